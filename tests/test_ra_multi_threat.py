"""The RA logic against several threats at once (issue 24), flown closed loop by the point-mass pilot of
tests/ra_sim.py (written apart from advisory/resolution.py), with exact states.

The oracle is the TCAS II v7.1 booklet's multi-threat rule ("Multiple threat encounters": one RA that provides
the separation from every threat; a composite RA, Don't Climb + Don't Descend, keeps ownship between threats
above and below) read as two properties over random geometries of two to four threats:

1. No climb or descend word (first, strengthened, reversed) issued against two or more threats points toward a
   threat that level flight clears by ALIM (in force when the word was issued): the threat is on that side at its CPA with at least ALIM of vertical
   miss when ownship levels off (the response model's delay and acceleration, closed form in
   ra_sim.level_off_dz).
2. Flying the RAs never leaves a threat a smaller true vertical miss at its horizontal CPA than not flying
   them, or, where the threats pull apart, never less than ALIM (15 ft tolerance for the 0.1 s grid). A threat
   that joins an RA in progress is judged against the path ownship flew when it joined; ALIM is the least of the
   sensitivity levels in force while it was a threat (the level follows ownship's altitude). Not asked where a
   floor levelled the RA off, or of a threat whose reference goes below the descend floor: the ground ranks
   first (tests/test_ra_floors.py). The geometries the search once found against it stay as examples
   (FOUND_BY_SEARCH).

The hand-computed cases check the three shapes of issue 24: threats above and below (composite), two threats on
the same side (one sense), and a second threat joining after a CLIMB (no climb into it).
"""

from __future__ import annotations

import math

import pytest
from hypothesis import HealthCheck, given, settings, strategies as st

from avionics.advisory.resolution import ResolutionLogic, Sense, Strength, Threat
from avionics.advisory.tables import load_profile
from avionics.base.units import FPM, FT
from ra_sim import Encounter, Intruder, fly, level_off_dz

PROFILES = {name: load_profile(name) for name in ("tcas2", "f3442", "do365")}
TOLERANCE_M = 15 * FT
POINTING = (Strength.CORRECTIVE, Strength.INCREASE)


def intruder(t_cpa, closure, bearing, hmd, side, vmd, vz, vz_own) -> Intruder:
    """An intruder at horizontal CPA after t_cpa with the given HMD and unflown VMD (traced back from CPA)."""
    vx, vy = -closure * math.cos(bearing), -closure * math.sin(bearing)
    cx, cy = side * hmd * math.sin(bearing), -side * hmd * math.cos(bearing)
    return Intruder(cx - vx * t_cpa, cy - vy * t_cpa, vx, vy, vmd - (vz - vz_own) * t_cpa, vz)


@st.composite
def multi_threat(draw):
    """Two to four intruders within 1000 ft of ownship's altitude, CPAs 20-50 s ahead (often together), HMD
    0-600 m, rates within +-2000 fpm; ownship at 1500-30,000 ft (several SLs), level or at +-1500 fpm."""
    agl = draw(st.floats(1500 * FT, 30000 * FT))
    vz_own = draw(st.one_of(st.just(0.0), st.floats(-1500 * FPM, 1500 * FPM)))
    n = draw(st.integers(2, 4))
    t_common = draw(st.floats(20.0, 50.0))
    out = []
    for _ in range(n):
        t_cpa = draw(st.one_of(st.just(t_common), st.floats(20.0, 50.0)))
        vz = draw(st.one_of(st.just(0.0), st.floats(-2000 * FPM, 2000 * FPM)))
        sz_now = draw(st.floats(-1000 * FT, 1000 * FT))
        vmd = sz_now + (vz - vz_own) * t_cpa  # the unflown miss of an intruder now sz_now away
        out.append(intruder(t_cpa, draw(st.floats(40.0, 200.0)), draw(st.floats(0.0, 2 * math.pi)),
                            draw(st.floats(0.0, 600.0)), draw(st.sampled_from([-1.0, 1.0])), vmd, vz, vz_own))
    return Encounter(agl, vz_own, tuple(out), duration_s=55.0)


def check(enc: Encounter, profile_name: str, misses: bool = True) -> None:
    """Property 1, and property 2 where misses is True."""
    profile = PROFILES[profile_name]
    out = fly(enc, profile)
    if not out.threats or out.hmd_filter_ended is not None:
        return  # the HMD filter's early end: tests/test_ra_properties.py says why the vertical miss is not the RA's
    r = profile.response
    for t, ra, ra_now, own_z, vz, alim in out.issued:  # property 1, with the ALIM in force when it was issued
        if len(ra_now) < 2 or ra.sense is None or ra.strength not in POINTING:
            continue
        for j in ra_now:
            i = enc.intruders[j]
            t_cpa = max(0.0, -((i.x_m + i.vx_mps * t) * i.vx_mps + (i.y_m + i.vy_mps * t) * i.vy_mps)
                        / (i.vx_mps**2 + i.vy_mps**2))
            intruder_z = enc.agl_m + i.sz_m + i.vz_mps * (t + t_cpa)
            miss = own_z + level_off_dz(t_cpa, vz, r.delay_s, r.accel_mps2) - intruder_z
            toward = -ra.sense.sign * miss > 0.0  # the threat on the word's side at its CPA
            assert not (toward and abs(miss) >= alim + 1.0), (profile_name, t, ra.words(), j, miss / FT)
    floored = any("floor" in ra.reason for _, ra, *_ in out.issued)  # the ground first: test_ra_floors.py's case
    for j in out.threats - out.reference_below_floor if misses and not floored else ():  # property 2
        reference = out.joined_miss_m[j]
        floor = reference if len(out.threats) == 1 else min(reference, out.alim_m[j])
        assert out.vmd_flown_m[j] >= floor - TOLERANCE_M, (profile_name, j, out.words, out.vmd_flown_m[j] / FT,
                                                           reference / FT)


# Found by the search while property 2 did not hold (CI 2026-12-04; seeds 1-5 x 2000, 2026-12-05): a composite RA
# re-selected with its full response delay each second judged itself worse than doing nothing and ended with three
# threats 9 s from CPA (do365); a LEVEL OFF decided with SL 6's ALIM after descending through 20,000 ft was judged
# with SL 7's (tcas2: the oracle's error); a threat joining an INCREASE DESCENT was owed a descent below the
# increase-descent height (do365); a DESCEND turned composite was projected as if levelling off with no response
# delay, so a third threat's reference was one ownship could not fly (tcas2); a composite RA ended (TA kept) when a
# threat passing through ownship's altitude left no threat both above and below, 6 s before its CPA (tcas2). And
# two of the oracle's own: a CLIMB strengthened with SL 7's ALIM after climbing through 20,000 ft was judged with
# SL 6's (tcas2), and a threat joining just after an RA ended was owed the pilot's return to its earlier rate,
# which no logic can see (f3442: the reference is now the present rate held).
FOUND_BY_SEARCH = [
    ("tcas2", Encounter(6000.0, 6.0, (Intruder(2610.0, 0.0, -58.0, 0.0, 6.0, 0.0),
                                      Intruder(1800.0, 0.0, -40.0, 0.0, 0.0, 0.0),
                                      Intruder(1800.0, 0.0, -40.0, 0.0, 257.0, 0.0)), duration_s=55.0)),
    ("f3442", Encounter(458.0, -6.0, (Intruder(3901.0, 0.0, -83.0, 0.0, -122.0, 0.0),
                                      Intruder(1000.0, 0.0, -40.0, 0.0, -165.0, -2.0)), duration_s=55.0)),
    ("tcas2", Encounter(1588.0, -2.0, (Intruder(940.0, 0.0, -47.0, 0.0, -183.0, 0.0),
                                       Intruder(800.0, 0.0, -40.0, 0.0, 0.0, 0.0),
                                       Intruder(1920.0, 0.0, -40.0, 0.0, 186.0, -6.0)), duration_s=55.0)),
    ("do365", Encounter(538.0, 0.0, (Intruder(800.0, 0.0, -40.0, 0.0, 0.0, 0.0),
                                     Intruder(1000.0, 0.0, -40.0, 0.0, -138.0, 0.0)), duration_s=55.0)),
    ("tcas2", Encounter(1587.0, -1.96875, (Intruder(800.0, 0.0, -40.0, 0.0, -183.0, 0.0),
                                           Intruder(800.0, 0.0, -40.0, 0.0, 0.0, 0.0),
                                           Intruder(1960.0, 0.0, -40.0, 0.0, 189.0, -6.0)), duration_s=55.0)),
    ("tcas2", Encounter(6097.0, 0.0, (Intruder(3936.0, 0.0, -82.0, 0.0, 0.0, 0.0),
                                      Intruder(1920.0, 0.0, -40.0, 0.0, 0.0, 0.0)), duration_s=55.0)),
    ("do365", Encounter(458.0, 0.0, (Intruder(800.0, 0.0, -40.0, 0.0, 102.0, 0.0),
                                     Intruder(800.0, 0.0, -40.0, 0.0, -217.0, 0.0),
                                     Intruder(3510.0, 0.0, -90.0, 0.0, 0.0, 0.0)), duration_s=55.0)),
]


@pytest.mark.parametrize("profile_name", sorted(PROFILES))
@settings(max_examples=400, deadline=None, derandomize=True, database=None,
          suppress_health_check=[HealthCheck.too_slow])
@given(enc=multi_threat())
def test_multi_threat_properties(enc, profile_name):
    check(enc, profile_name)


@pytest.mark.parametrize("profile_name, enc", FOUND_BY_SEARCH)
def test_geometries_found_by_search(profile_name, enc):
    check(enc, profile_name)


# --- hand-computed cases (tcas2: 5 s, 0.25 g to 1500 fpm; SL 5 at 5000-10,000 ft: ALIM 350 ft) ----------------

TCAS = PROFILES["tcas2"]
ALIM5 = 350 * FT


def test_threats_above_and_below_get_the_composite_not_a_climb():
    # 400 ft above and 400 ft below, level, both at CPA in 20 s: level flight keeps 400 ft > ALIM from both.
    # Any climb or descend closes on one of them; the composite keeps both at 400 ft.
    threats = [Threat(400 * FT, 0.0, 20.0, "above"), Threat(-400 * FT, 0.0, 20.0, "below")]
    logic = ResolutionLogic(TCAS)
    for t in range(16):  # to 4 s before CPA, as the issue's replay strengthened then
        ra = logic.resolve(float(t), [Threat(th.sz_m, 0.0, 20.0 - t, th.key) for th in threats], 0.0, ALIM5)
        assert ra.composite and ra.words() == "DONT CLIMB DONT DESCEND", (t, ra)
        assert ra.separation_against(threats[0]) == pytest.approx(400 * FT)
        assert ra.separation_against(threats[1]) == pytest.approx(400 * FT)
    assert (ra.sense_against(threats[0]), ra.sense_against(threats[1])) == (Sense.DESCEND, Sense.CLIMB)


def test_the_issue_replay_threat_below_first_then_above_never_climbs():
    # The lower threat becomes an RA threat first (DONT DESCEND: level flight complies), the upper one joins
    # 3 s later; then the RA is the composite and nothing points up at the threat above, to CPA.
    logic = ResolutionLogic(TCAS)
    below, above = Threat(-400 * FT, 0.0, 25.0, "below"), Threat(400 * FT, 0.0, 25.0, "above")
    words = []
    for t in range(22):
        threats = [Threat(below.sz_m, 0.0, 25.0 - t, "below")] + \
            ([Threat(above.sz_m, 0.0, 25.0 - t, "above")] if t >= 3 else [])
        ra = logic.resolve(float(t), threats, 0.0, ALIM5)
        words.append(ra.words())
    assert words[0] == "DONT DESCEND"
    assert set(words[3:]) == {"DONT CLIMB DONT DESCEND"}, words
    assert ra.separation_against(above) == pytest.approx(400 * FT)  # not -121.9 m: the sense away from it


def test_two_threats_on_the_same_side_get_one_sense():
    # Both above (200 ft and 500 ft), level, CPA in 20 and 25 s: DESCEND keeps clear of both, never crossing.
    # By hand, 15 s after the RA: 64.3 m (211 ft) down; at 20 s: 0.5 a 3.107^2 + 7.62 (20 - 5 - 3.107) = 102.5 m.
    threats = [Threat(200 * FT, 0.0, 20.0, 1), Threat(500 * FT, 0.0, 25.0, 2)]
    ra = ResolutionLogic(TCAS).resolve(0.0, threats, 0.0, ALIM5)
    assert (ra.sense, ra.strength, ra.crossing, ra.composite) == (Sense.DESCEND, Strength.CORRECTIVE, False, False)
    down_20 = 0.5 * TCAS.response.accel_mps2 * (7.62 / TCAS.response.accel_mps2) ** 2 + 7.62 * (15 - 7.62 / TCAS.response.accel_mps2)
    assert ra.separation_against(threats[0]) == pytest.approx(200 * FT + down_20, abs=0.05)


def test_a_threat_joining_above_after_a_climb_stops_the_climb():
    # CLIMB against a level threat 100 ft below (CPA 25 s). 10 s later ownship climbs at 1500 fpm (7.62 m/s),
    # 0.5 a 3.107^2 + 7.62 x 1.893 = 26.3 m (86 ft) up, and a level threat 600 ft above its start (514 ft above
    # it now) joins, CPA in 15 s like the lower one's. Climbing on: 7.62 m/s x 15 s = 375 ft more, 139 ft below
    # the upper one (toward it). Levelling off (5 s at 1500 fpm, then 3.107 s to stop: 38.1 + 11.8 = 49.9 m =
    # 164 ft): 514 - 164 = 350 ft below the upper one (>= ALIM 300 ft: level flight clears it, so no climb word
    # may point at it) and 186 + 164 = 350 ft above the lower one. The RA turns composite: LEVEL OFF.
    alim, a = 300 * FT, TCAS.response.accel_mps2
    logic = ResolutionLogic(TCAS)
    first = logic.resolve(0.0, [Threat(-100 * FT, 0.0, 25.0, "below")], 0.0, alim)
    assert first.words() == "CLIMB"
    for t in (10.0, 11.0):
        up = 0.5 * a * (7.62 / a) ** 2 + 7.62 * (t - 5.0 - 7.62 / a)
        ra = logic.resolve(t, [Threat(-100 * FT - up, 0.0, 25.0 - t, "below"),
                               Threat(600 * FT - up, 0.0, 25.0 - t, "above")], 7.62, alim, own_altitude_m=up)
        assert ra.composite and ra.words() == "LEVEL OFF", (t, ra)
    assert ra.separation_against(Threat(0, 0, 0, "above")) >= alim - 1.0
    assert ra.sense_against(Threat(600 * FT - up, 0, 0, "above")) is Sense.DESCEND
