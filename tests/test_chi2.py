"""The gates' chi-square quantile (avionics/base/chi2.py) against scipy.stats, the reference it replaces."""

import math

from hypothesis import given, strategies as st
from scipy.stats import chi2

from avionics.base.chi2 import chi2_quantile


@given(p=st.floats(1e-6, 1 - 1e-12), dof=st.integers(1, 12))
def test_equals_scipy_stats_chi2_ppf_bit_for_bit(p, dof):
    assert chi2_quantile(p, dof) == chi2.ppf(p, dof)


def test_the_textbook_values():
    # chi-square tables (e.g. NIST/SEMATECH e-Handbook 1.3.6.7.4): 95 % with 1 and 2 dof; 2 dof in closed form
    assert round(chi2_quantile(0.95, 1), 3) == 3.841 and round(chi2_quantile(0.95, 2), 3) == 5.991
    assert abs(chi2_quantile(0.9999, 2) - (-2.0 * math.log(1e-4))) < 1e-9
