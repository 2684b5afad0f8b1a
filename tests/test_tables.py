import pytest

from avionics.advisory.tables import TCAS_II_V71, select_level
from avionics.base.units import FT, NM


@pytest.mark.parametrize("agl_ft, alt_ft, sl", [
    (500, 500, 2), (999, 999, 2), (1000, 1000, 3), (2350, 2350, 3), (2351, 2351, 4), (3000, 3000, 4),
    (4000, 5000, 4), (4000, 5001, 5), (9000, 10000, 5), (15000, 15000, 6), (30000, 30000, 7),
    (42000, 42000, 7), (43000, 43000, 7),
])
def test_sensitivity_level_by_altitude_band(agl_ft, alt_ft, sl):
    assert select_level(agl_ft * FT, alt_ft * FT).sl == sl


def test_above_fl420_row_widens_zthr():
    low, high = select_level(40000 * FT, 42000 * FT), select_level(43000 * FT, 43000 * FT)
    assert low.ta_zthr_m == pytest.approx(850 * FT) and high.ta_zthr_m == pytest.approx(1200 * FT)
    assert high.ra_zthr_m == pytest.approx(800 * FT) and high.alim_m == pytest.approx(700 * FT)


def test_sl4_values_from_tcas_ii_v71():
    sl4 = select_level(3000 * FT, 3000 * FT)
    assert (sl4.ta_tau_s, sl4.ra_tau_s) == (30, 20)
    assert sl4.ta_dmod_m == pytest.approx(0.48 * NM) and sl4.ra_dmod_m == pytest.approx(0.35 * NM)
    assert sl4.ra_hmd_m == pytest.approx(0.57 * NM) and sl4.ra_zthr_m == pytest.approx(600 * FT)


def test_sl2_has_no_ra():
    assert TCAS_II_V71[0].ra_tau_s is None
