"""The chi-square quantile of the validation gates, without importing scipy.stats (about 0.55 s of start-up for
this one function): scipy's own chi2._ppf is 2 * gammaincinv(k / 2, p), so the value is bit for bit the same
(tests/test_chi2.py checks it against scipy.stats)."""

from __future__ import annotations

from scipy.special import gammaincinv


def chi2_quantile(probability: float, dof: int) -> float:
    """x such that P(chi-square with dof degrees of freedom <= x) = probability."""
    return 2.0 * float(gammaincinv(dof / 2.0, probability))
