"""TA and RA onsets at every TCAS II sensitivity level, noise-free, against a direct evaluation of the
TCAS II v7.1 tests on the exact relative motion (an independent reference: plain math, 0.01 s scan)."""

import math
from dataclasses import dataclass

import pytest

from avionics.advisory.tables import load_profile
from avionics.base.types import AdvisoryLevel
from avionics.base.units import FPM, FT, KT, NM
from synthetic import Encounter, Mover

TCAS = load_profile("tcas2")
ROWS = {2: TCAS.levels[0], 3: TCAS.levels[1], 4: TCAS.levels[2], 5: TCAS.levels[3], 6: TCAS.levels[4],
        7: TCAS.levels[5], 8: TCAS.levels[6]}  # 8: SL 7 above FL420
ALTITUDE_FT = {2: 500, 3: 1500, 4: 3000, 5: 7000, 6: 15000, 7: 30000, 8: 43000}
SPEEDS_KT = {2: (90, 120), 3: (100, 140), 4: (150, 200), 5: (200, 250), 6: (250, 300), 7: (300, 350),
             8: (300, 350)}


@dataclass
class Geometry:
    name: str
    ownship: Mover
    intruder: Mover


def geometries(key: int) -> list[Geometry]:
    alt = ALTITUDE_FT[key] * FT
    v_own, v_int = (v * KT for v in SPEEDS_KT[key])
    row = ROWS[key]
    lead = (row.ta_tau_s + 30.0)  # start well before any alert
    closing = v_own + v_int
    r0 = closing * lead + row.ta_dmod_m
    own = Mover((0.0, 0.0, alt), (0.0, v_own, 0.0))
    t_meet = r0 / closing
    climb = 1500 * FPM
    return [
        Geometry("head-on", own, Mover((0.0, r0, alt), (0.0, -v_int, 0.0))),
        # crossing from the right on a collision course: both reach (0, v_own t_meet) together
        Geometry("crossing", own, Mover((v_int * t_meet, v_own * t_meet, alt), (-v_int, 0.0, 0.0))),
        Geometry("overtaking", Mover((0.0, 0.0, alt), (0.0, v_own * 0.5, 0.0)),
                 Mover((100.0, -(v_own * 0.5) * lead * 1.5, alt), (0.0, v_own * 1.5, 0.0))),
        Geometry("climbing", own, Mover((0.0, r0, alt - climb * t_meet), (0.0, -v_int, climb))),
        Geometry("descending", own, Mover((0.0, r0, alt + climb * t_meet), (0.0, -v_int, -climb))),
    ]


def reference_onsets(g: Geometry, key: int, duration: float):
    """First times the TA and RA tests hold (TCAS II v7.1 definitions, straight-line motion)."""
    row = ROWS[key]
    ta = ra = None
    for k in range(int(duration * 100)):
        t = k / 100
        (oe, on, oz), (ie, in_, iz) = g.ownship.at(t), g.intruder.at(t)
        sx, sy, sz = ie - oe, in_ - on, iz - oz
        vx, vy, vz = (a - b for a, b in zip(g.intruder.v, g.ownship.v))
        r, sv = math.hypot(sx, sy), sx * vx + sy * vy
        if sv > 0:
            continue  # diverging: clear of conflict

        def horizontal(dmod, tau):
            return r <= dmod or (sv < 0 and (dmod**2 - r**2) / sv <= tau)

        def vertical(zthr, tau):
            return abs(sz) <= zthr or (sz * vz < 0 and -sz / vz <= tau)

        if ta is None and horizontal(row.ta_dmod_m, row.ta_tau_s) and vertical(row.ta_zthr_m, row.ta_tau_s):
            ta = t
        if ra is None and row.ra_tau_s is not None and horizontal(row.ra_dmod_m, row.ra_tau_s) \
                and vertical(row.ra_zthr_m, row.ra_tau_s):
            tc = max(0.0, -sv / (vx * vx + vy * vy))
            if math.hypot(sx + vx * tc, sy + vy * tc) <= row.ra_hmd_m:
                ra = t
    return ta, ra


def onsets(changes):
    first = {}
    for t, c in changes:
        first.setdefault(c.level, t)
    return first.get(AdvisoryLevel.TA), first.get(AdvisoryLevel.RA)


CASES = [(key, i) for key in ROWS for i in range(5)]


@pytest.mark.parametrize("key, index", CASES, ids=[f"SL{min(k, 7)}{'+' if k == 8 else ''}-"
                                                   f"{geometries(k)[i].name}" for k, i in CASES])
def test_onsets_within_1_s_of_the_tcas_tests(key, index):
    g = geometries(key)[index]
    duration = ROWS[key].ta_tau_s + 45.0 + (40.0 if g.name == "overtaking" else 0.0)
    core, changes = Encounter(g.ownship, g.intruder).run(duration)
    assert core.level.sl == min(key, 7)
    ta_ref, ra_ref = reference_onsets(g, key, duration)
    ta, ra = onsets(changes)
    assert ta_ref is not None and ta == pytest.approx(ta_ref, abs=1.0), (ta, ta_ref)
    if ra_ref is None:
        assert ra is None
    else:
        assert ra == pytest.approx(ra_ref, abs=1.0), (ra, ra_ref)
    if key == 2:
        assert ra is None  # TCAS: TA only below 1000 ft AGL


def test_hmd_filter_excludes_the_ra_of_a_wide_miss_but_not_the_ta():
    alt, v = 3000 * FT, 200 * KT  # SL 4: RA HMD 0.57 nm
    own = Mover((0.0, 0.0, alt), (0.0, v, 0.0))
    intruder = Mover((0.7 * NM, 8 * NM, alt), (0.0, -v, 0.0))  # passes 0.7 nm abeam
    _, changes = Encounter(own, intruder).run(100)
    levels = {c.level for _, c in changes}
    assert AdvisoryLevel.TA in levels and AdvisoryLevel.RA not in levels
    _, changes = Encounter(own, intruder, overrides=["advisory.hmd_filter=false"]).run(100)
    assert AdvisoryLevel.RA in {c.level for _, c in changes}


def test_vertical_test_excludes_the_ra_700_ft_above_but_not_the_ta():
    alt, v = 3000 * FT, 200 * KT  # SL 4: TA ZTHR 850 ft, RA ZTHR 600 ft
    own = Mover((0.0, 0.0, alt), (0.0, v, 0.0))
    _, changes = Encounter(own, Mover((0.0, 8 * NM, alt + 700 * FT), (0.0, -v, 0.0))).run(100)
    assert {c.level for _, c in changes} == {AdvisoryLevel.TA, AdvisoryLevel.NONE}


def test_small_uas_profile_issues_ras_low_down():
    alt = 300 * FT  # TCAS would be SL 2 here: TA only
    own = Mover((0.0, 0.0, alt), (0.0, 30 * KT, 0.0))
    intruder = Mover((0.0, 3 * NM, alt + 50 * FT), (0.0, -90 * KT, 0.0))
    _, tcas = Encounter(own, intruder).run(100)
    _, small = Encounter(own, intruder, overrides=['advisory.profile="small-uas"']).run(100)
    assert AdvisoryLevel.RA not in {c.level for _, c in tcas}
    ras = [c for _, c in small if c.level is AdvisoryLevel.RA]
    assert ras and ras[0].ra_sense == "descend" and ras[0].ra_words == "DESCEND"  # intruder 50 ft above
    assert ras[0].target_vertical_rate_mps == pytest.approx(-500 * FPM)  # the autopilot's response rate
