import math
import re

import pytest

from avionics.advisory.tables import LevelSelector, ProfileError, load_profile, profile_text
from avionics.config import ConfigError, load_config
from avionics.base.units import FPM, FT, G0, NM


def test_builtin_profiles_load_with_their_documented_values():
    tcas, small, do365 = load_profile("tcas2"), load_profile("small-uas"), load_profile("do365")
    assert [lvl.sl for lvl in tcas.levels] == [2, 3, 4, 5, 6, 7, 7]
    assert tcas.response.delay_s == 5.0 and tcas.response.accel_mps2 == pytest.approx(0.25 * G0)
    assert tcas.response.rate_mps == pytest.approx(1500 * FPM)
    assert tcas.ra_inhibit_below_agl_m == pytest.approx(1000 * FT)
    assert tcas.descend_inhibit_below_agl_m == pytest.approx(1100 * FT)
    assert tcas.increase_descent_inhibit_below_agl_m == pytest.approx(1450 * FT)
    (s,) = small.levels
    assert (s.ra_dmod_m, s.ra_zthr_m) == pytest.approx((2000 * FT, 250 * FT))  # ASTM F3442 well clear
    (d,) = do365.levels
    assert math.isinf(s.ceiling_m) and math.isinf(d.ceiling_m)
    # DO-365B Phase I DWC as DAIDALUS v2.0.4 Configurations/DO_365B_no_SUM.conf states it (alerter DWC_Phase_I):
    # WCV_TAUMOD DTHR 0.66 nmi, TTHR 35 s, TCOA 0; ZTHR 700/450/450 ft; alerting 55/55/25 s, early 75/75/55 s
    for name in ("do365", "daidalus-do365b-no-sum"):
        a = load_profile(name).alerter
        assert [lv.name for lv in a.levels] == ["PREVENTIVE", "CORRECTIVE", "WARNING"]
        assert [lv.region for lv in a.levels] == ["NONE", "MID", "NEAR"]
        got = [(lv.thresholds.dthr_m, lv.thresholds.zthr_m, lv.thresholds.tthr_s, lv.thresholds.tcoa_s)
               for lv in a.levels]
        want = [(0.66 * NM, 700 * FT, 35, 0), (0.66 * NM, 450 * FT, 35, 0), (0.66 * NM, 450 * FT, 35, 0)]
        assert all(g == pytest.approx(w) for g, w in zip(got, want, strict=True))
        assert [(lv.alerting_time_s, lv.early_alerting_time_s) for lv in a.levels] == [(55, 75), (55, 75), (25, 55)]
        assert (a.hysteresis_time_s, a.persistence_time_s, a.alerting_m, a.alerting_n) == (5.0, 4.0, 2, 4)
    noncoop = load_profile("do365-non-coop").alerter  # DWC_Non_Coop: 2200 ft, 450 ft, no tau; early 110/110/90 s
    assert all((lv.thresholds.dthr_m, lv.thresholds.zthr_m, lv.thresholds.tthr_s) == pytest.approx((2200 * FT, 450 * FT, 0))
               for lv in noncoop.levels)
    assert [lv.early_alerting_time_s for lv in noncoop.levels] == [110, 110, 90]
    assert load_profile("tcas2").alerter is None


def test_a_do365_profile_refuses_the_pc_gates_it_has_no_levels_for():
    with pytest.raises(ConfigError, match="DO-365"):
        load_config(overrides=["advisory.profile=do365", "advisory.criterion=pc"])
    load_config(overrides=["advisory.profile=do365", "advisory.persistence=m-of-n"])


def test_any_value_can_be_overridden_in_any_unit():
    p = load_profile("tcas2", ["sl4.ra_tau_s=25", "sl4.ra_dmod_ft=2500", "response.delay_s=3",
                               "descend_inhibit_below_agl_ft=1200"])
    sl4 = next(lvl for lvl in p.levels if lvl.sl == 4)
    assert sl4.ra_tau_s == 25 and sl4.ra_dmod_m == pytest.approx(2500 * FT)
    assert sl4.ta_dmod_m == pytest.approx(0.48 * NM)  # untouched
    assert p.response.delay_s == 3 and p.descend_inhibit_below_agl_m == pytest.approx(1200 * FT)
    cfg = load_config(overrides=['advisory.profile_overrides=["sl4.ra_tau_s=25"]'])
    assert cfg.advisory.profile_overrides == ("sl4.ra_tau_s=25",)


@pytest.mark.parametrize("override, message", [
    ("sl9.ra_tau_s=25", "no sl9"), ("response.nope=1", "unknown response key"), ("bogus=1", "unknown key"),
    ("sl4.ra_tau_s=fast", "key=number"),
])
def test_bad_overrides_are_clear_errors(override, message):
    with pytest.raises(ProfileError, match=re.escape(message)):
        load_profile("tcas2", [override])


def test_unknown_profile_is_a_configuration_error(tmp_path):
    with pytest.raises(ConfigError, match="unknown profile"):
        load_config(overrides=['advisory.profile="tcas3"'])
    bad = tmp_path / "bad.toml"
    bad.write_text((load_profile.__globals__["profile_text"]("tcas2")[1]).replace("ta_tau_s = 30", "ta_tau_s = -1"))
    with pytest.raises(ConfigError, match="ta_tau_s"):
        load_config(overrides=[f'advisory.profile="{bad}"'])


def test_a_profile_file_by_path(tmp_path):
    text = load_profile.__globals__["profile_text"]("small-uas")[1].replace('name = "small-uas"', 'name = "mine"')
    path = tmp_path / "mine.toml"
    path.write_text(text)
    assert load_profile(str(path)).name == "mine"


def test_sensitivity_level_hysteresis_at_a_band_boundary():
    sel = LevelSelector(load_profile("tcas2"))  # 100 ft hysteresis; SL 4/5 boundary at 5000 ft
    assert sel.select(4900 * FT, 4900 * FT).sl == 4
    assert sel.select(5050 * FT, 5050 * FT).sl == 4  # within 100 ft above the boundary: stays
    assert sel.select(5150 * FT, 5150 * FT).sl == 5
    assert sel.select(4950 * FT, 4950 * FT).sl == 5  # within 100 ft below: stays
    assert sel.select(4850 * FT, 4850 * FT).sl == 4
    assert sel.select(800 * FT, 800 * FT).sl == 2  # a big step is taken at once


def test_daidalus_tcas3d_is_tcas3d_conf():
    # DAIDALUS Configurations/TCAS3D.conf (TCASTable): SL from altitude alone (SL N while alt <= its upper
    # bound, TCASTable.getSensitivityLevel), RA HMD = the RA DMOD values (TCASTable.RA_HMD_ in ft), no
    # hysteresis, no inhibits. The tcas2 profile keeps v7.1's own HMD filter table, which is not these.
    from avionics.advisory.tables import select_level

    p = load_profile("daidalus-tcas3d")
    ra_levels = [lvl for lvl in p.levels if lvl.ra_tau_s is not None]
    assert [lvl.ra_hmd_m / FT for lvl in ra_levels] == pytest.approx([1215, 2126, 3342, 4861, 6683, 6683])
    # 1215 ft = 0.2 nm to the foot
    assert [lvl.ra_hmd_m for lvl in ra_levels] == pytest.approx([lvl.ra_dmod_m for lvl in ra_levels], abs=0.25)
    assert [lvl.ra_tau_s for lvl in ra_levels] == [15, 20, 25, 30, 35, 35]
    assert p.sl_hysteresis_m == p.inhibit_hysteresis_m == p.descend_inhibit_below_agl_m == 0.0
    assert math.isinf(p.max_threat_vertical_rate_mps)
    for alt_ft, sl in ((-1, 1), (0, 1), (0.1, 2), (1000, 2), (1000.1, 3), (2350, 3), (5000, 4), (10000, 5),
                       (20000, 6), (42000, 7), (42000.1, 8)):
        assert select_level(0.0, alt_ft * FT, p.levels).sl == sl, alt_ft  # AGL is not used
    tcas = load_profile("tcas2")
    assert [lvl.ra_hmd_m / NM for lvl in tcas.levels if lvl.ra_hmd_m] == pytest.approx(
        [0.40, 0.57, 0.74, 0.82, 0.98, 0.98])
    assert tcas.inhibit_hysteresis_m == pytest.approx(100 * FT)
    assert tcas.max_threat_vertical_rate_mps == pytest.approx(10000 * FPM)


@pytest.mark.parametrize("text, message", [
    ('[alerter]\nkind = "wcv"\n', "no [[alerter.levels]]"),
    ('[alerter]\nkind = "tcas"\n', "expected \"wcv\""),
    ('[alerter]\nkind = "wcv"\n[[alerter.levels]]\nname = "X"\nadvisory = "ALERT"\n', "advisory: expected"),
    ('[alerter]\nkind = "wcv"\n[[alerter.levels]]\nname = "X"\nadvisory = "TA"\nregion = "ORANGE"\n', "region"),
    ('[alerter]\nkind = "wcv"\n[[alerter.levels]]\nname = "X"\nadvisory = "TA"\ndthr_ft = 4000\nzthr_ft = 450\n',
     "missing key 'tthr_s'"),
    ('[bands]\nturn_rate_deg_s = 3.0\n', "needs a DO-365 [alerter]"),
])
def test_a_bad_alerter_or_bands_table_names_what_is_wrong(tmp_path, text, message):
    base = profile_text("tcas2")[1]
    path = tmp_path / "mine.toml"
    path.write_text(base + "\n" + text)
    with pytest.raises(ProfileError, match=re.escape(message)):
        load_profile(str(path))


def test_bands_overrides_are_checked_against_the_bands_parameters():
    assert load_profile("do365", ["bands.turn_rate_deg_s=1.5"]).bands.turn_rate_deg_s == 1.5
    with pytest.raises(ProfileError, match="unknown key"):
        load_profile("do365", ["bands.turn_rate=1.5"])
    with pytest.raises(ProfileError, match="no DO-365 alerter"):
        load_profile("tcas2", ["bands.turn_rate_deg_s=1.5"])
