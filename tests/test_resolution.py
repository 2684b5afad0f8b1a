"""RA sense and strength (TCAS II v7.1 rules, docs/advisories.md) against hand-projected vertical separations.

The standard response (tcas2): 5 s, 0.25 g (2.4517 m/s^2) to 1500 fpm (7.62 m/s); strengthening and reversal
2.5 s, 0.35 g to 2500 fpm. Closed-loop expectations are flown by tests/ra_sim.py, a point-mass vertical
simulation written apart from advisory/resolution.py.
"""

import numpy as np
import pytest

from avionics.advisory.inhibits import HysteresisInhibit, Inhibits, LowAltitudeInhibits
from avionics.advisory.alerting import Encounter as Pairs, tcas2_alerter
from avionics.advisory.resolution import ResolutionLogic, Sense, Strength, Threat, own_displacement
from avionics.advisory.tables import load_profile, select_level
from avionics.conflict.cpa import pair_geometry
from avionics.base.types import AdvisoryLevel
from avionics.base.units import FPM, FT, G0, NM
from ra_sim import Encounter, Intruder, fly

TCAS = load_profile("tcas2")
ALIM = 300 * FT  # SL 3 and SL 4
LOW = Inhibits(ra=False, descend=True, increase_descent=True)  # 1000 to 1100 ft AGL


def logic():
    return ResolutionLogic(TCAS)


def head_on(agl_ft, sz_ft, vz_own_fpm=0.0, vz_intruder_fpm=0.0):
    """Head-on at 100 m/s closure from 5 km, the intruder sz_ft above ownship."""
    return Encounter(agl_ft * FT, vz_own_fpm * FPM, (Intruder(5000.0, 0.0, -100.0, 0.0, sz_ft * FT,
                                                              vz_intruder_fpm * FPM),))


def test_standard_response_by_hand():
    # 5 s delay, 0.25 g (2.452 m/s^2) to 1500 fpm (7.62 m/s): reached 3.107 s after the delay.
    assert own_displacement(5.0, 0.0, 7.62, 2.4517, 5.0) == 0.0
    ta = 7.62 / 2.4517
    assert own_displacement(5.0 + ta, 0.0, 7.62, 2.4517, 5.0) == pytest.approx(0.5 * 2.4517 * ta**2)
    assert own_displacement(25.0, 0.0, 7.62, 2.4517, 5.0) == pytest.approx(0.5 * 2.4517 * ta**2 + 7.62 * (20 - ta))
    assert own_displacement(10.0, -2.0, -2.0, 2.4517, 5.0) == pytest.approx(-20.0)  # already at target


def test_level_intruder_above_gives_descend_below_gives_climb():
    above = logic().resolve(0.0, [Threat(200 * FT, 0.0, 25.0)], 0.0, ALIM)
    below = logic().resolve(0.0, [Threat(-200 * FT, 0.0, 25.0)], 0.0, ALIM)
    assert (above.sense, above.strength, above.words()) == (Sense.DESCEND, Strength.CORRECTIVE, "DESCEND")
    assert (below.sense, below.strength, below.words()) == (Sense.CLIMB, Strength.CORRECTIVE, "CLIMB")
    assert above.target_rate_mps == pytest.approx(-1500 * FPM) and not above.crossing
    assert above.separation_m >= ALIM and below.separation_m >= ALIM


def test_separation_already_assured_gives_a_preventive_ra():
    ra = logic().resolve(0.0, [Threat(500 * FT, 0.0, 20.0)], 0.0, ALIM)
    assert (ra.sense, ra.strength, ra.words(), ra.target_rate_mps) == (Sense.DESCEND, Strength.PREVENTIVE,
                                                                       "DONT CLIMB", None)


def test_climbing_ownship_that_can_level_off_is_told_to():
    # Intruder 600 ft above, level; we climb at 2000 fpm toward it: levelling off keeps > ALIM.
    ra = logic().resolve(0.0, [Threat(600 * FT, 0.0, 20.0)], 2000 * FPM, ALIM)
    assert (ra.sense, ra.strength, ra.words()) == (Sense.DESCEND, Strength.LEVEL_OFF, "LEVEL OFF")
    assert ra.target_rate_mps == 0.0


def test_intruder_climbing_through_our_altitude_non_crossing_when_it_achieves_alim():
    # From 300 ft below at 1000 fpm, CPA in 20 s: climbing 1500 fpm stays above it by ALIM without crossing.
    threat = Threat(-300 * FT, 1000 * FPM, 20.0)
    ra = logic().resolve(0.0, [threat], 0.0, ALIM)
    climb = logic().separation([threat], Sense.CLIMB, Strength.CORRECTIVE, 0.0)
    assert ra.sense is Sense.CLIMB and not ra.crossing and climb >= ALIM


def test_fast_climber_makes_the_crossing_sense_the_choice():
    # 3000 fpm from 300 ft below, CPA in 25 s: it will be far above by CPA; climbing (non-crossing) cannot
    # stay above it, descending (through its current altitude) leaves it above us by > ALIM.
    threat = Threat(-300 * FT, 3000 * FPM, 25.0)
    ra = logic().resolve(0.0, [threat], 0.0, ALIM)
    assert logic().separation([threat], Sense.CLIMB, Strength.CORRECTIVE, 0.0) < ALIM
    assert ra.sense is Sense.DESCEND and ra.crossing and ra.separation_m >= ALIM


def test_reversal_when_the_intruder_reverses_its_vertical_rate():
    lg = logic()
    first = lg.resolve(0.0, [Threat(400 * FT, 0.0, 30.0)], 0.0, ALIM)
    assert first.sense is Sense.DESCEND
    # The intruder now dives at 3000 fpm at us: descending can no longer reach ALIM; climbing can.
    for k in range(1, 40):
        t = k * 0.5
        ra = lg.resolve(t, [Threat(400 * FT - 3000 * FPM * t, -3000 * FPM, 30.0 - t)], 0.0, ALIM)
        if ra.reversed:
            break
    assert ra.reversed and ra.sense is Sense.CLIMB and ra.words() == "CLIMB NOW"


# -- item 1: low altitude ------------------------------------------------------------------------------------

def test_at_1050_ft_agl_a_threat_400_ft_above_gets_dont_climb_and_keeps_its_400_ft():
    # The case: the descend inhibit used to remove DON'T CLIMB too, and CLIMB, INCREASE CLIMB took
    # ownship from 400 ft below the intruder to about 20 ft. Flown, the preventive RA keeps all 400 ft.
    out = fly(head_on(1050, 400), TCAS)
    assert out.words == ["DONT CLIMB"]
    assert out.vmd_flown_m[0] == pytest.approx(400 * FT, abs=0.5)
    ra = out.first_ra[1]
    assert ra.sense is Sense.DESCEND and ra.strength is Strength.PREVENTIVE and "inhibited" in ra.reason


def _descending_onto_a_dont_climb(descent_fpm: float, t_cpa_s: float):
    """1050 ft AGL (descend inhibited), a level threat 400 ft above, CPA t_cpa_s away: DON'T CLIMB. From 2 s it
    descends at descent_fpm; the first RA at or after that (0.5 s steps)."""
    lg = logic()
    assert lg.resolve(0.0, [Threat(400 * FT, 0.0, t_cpa_s)], 0.0, ALIM, LOW).words() == "DONT CLIMB"
    for k in range(1, int(2 * t_cpa_s)):
        t = k * 0.5
        sz = 400 * FT - descent_fpm * FPM * max(0.0, t - 2.0)
        ra = lg.resolve(t, [Threat(sz, -descent_fpm * FPM if t >= 2.0 else 0.0, t_cpa_s - t)], 0.0, ALIM, LOW)
        if t >= 2.0:
            return t, ra


# The reversal (2.5 s, 0.35 g = 3.432 m/s^2 to 1500 fpm = 7.62 m/s) climbs 7.62^2 / (2 * 3.432) = 8.459 m while
# accelerating (2.220 s) and 7.62 m/s after: by CPA T s away, 8.459 + 7.62 (T - 2.5 - 2.220) m.

def test_a_dont_climb_below_the_descend_inhibit_reverses_as_soon_as_the_threat_descends_onto_it():
    # 800 fpm from 2 s, CPA at 30 s: at CPA the threat is 400 - 800 * 28 / 60 = 26.7 ft above a level ownship,
    # short of ALIM, and no descent may be given. The reversal: 8.459 + 7.62 * 23.28 = 185.9 m (609.9 ft), 583.2
    # ft above it. Judged by the corrective descent it may not fly, the DON'T CLIMB used to wait until the
    # descent's projection fell short too (13 s, 308 ft).
    t, ra = _descending_onto_a_dont_climb(800.0, 30.0)
    assert (t, ra.reversed, ra.sense, ra.words()) == (2.0, True, Sense.CLIMB, "CLIMB NOW")
    assert ra.separation_m == pytest.approx(583.2 * FT, abs=0.3 * FT)


def test_a_reversal_short_of_alim_is_given_when_it_leaves_more_than_the_ra_being_flown():
    # 1900 fpm from 2 s, CPA at 14 s: the threat ends 400 - 1900 * 12 / 60 = 20 ft above a level ownship. The
    # reversal climbs 8.459 + 7.62 * 7.280 = 63.93 m (209.7 ft) by CPA: 189.7 ft above it, short of ALIM 300 ft
    # but 170 ft more than the DON'T CLIMB (the sense of most separation, v7.1 booklet); it used to be refused
    # for missing ALIM and the DON'T CLIMB kept to 20 ft (Lincoln v2.1 encounter 1769: 39 ft at CPA, an NMAC
    # the RA caused).
    t, ra = _descending_onto_a_dont_climb(1900.0, 14.0)
    assert (t, ra.reversed, ra.sense, ra.words()) == (2.0, True, Sense.CLIMB, "CLIMB NOW")
    assert ra.separation_m == pytest.approx(189.7 * FT, abs=0.3 * FT)


def test_below_1100_ft_no_corrective_descent_above_1200_ft_one():
    # 200 ft below a level intruder at SL 3 (RA tau 15 s). Above the inhibit: DESCEND (200 ft + ~211 ft of
    # descent by CPA > ALIM). Below it: DESCEND is inhibited and CLIMB would cross to ~11 ft above
    # (211 - 200 ft), worse than the 200 ft of doing nothing: DON'T CLIMB, and the 200 ft are kept.
    high = fly(head_on(1300, 200), TCAS)
    assert high.words[0] == "DESCEND" and high.vmd_flown_m[0] >= ALIM
    low = fly(head_on(1050, 200), TCAS)
    assert low.words == ["DONT CLIMB"] and low.vmd_flown_m[0] == pytest.approx(200 * FT, abs=0.5)


def test_climbing_toward_a_threat_below_the_inhibit_is_told_to_level_off():
    # At 1050 ft AGL climbing 1000 fpm, a level threat 400 ft above, CPA in 15 s: doing nothing leaves
    # 400 - 250 = 150 ft. Level Off (not a descent, so allowed): 5.08 m/s for 5 s then 0.25 g to 0 gives
    # 25.40 + 5.08^2 / (2 * 2.4517) = 30.66 m of climb, 121.92 - 30.66 = 91.26 m (299 ft) below it.
    # CLIMB would pass ~68 ft above it (worse than doing nothing): never issued.
    ra = logic().resolve(0.0, [Threat(400 * FT, 0.0, 15.0)], 1000 * FPM, ALIM, LOW)
    assert (ra.sense, ra.strength, ra.words()) == (Sense.DESCEND, Strength.LEVEL_OFF, "LEVEL OFF")
    assert ra.separation_m == pytest.approx(400 * FT - (5.08 * 5 + 5.08**2 / (2 * 0.25 * G0)), abs=0.01)


def test_inhibits_have_100_ft_hysteresis():
    descend = HysteresisInhibit(1100 * FT, 100 * FT)
    heights = [1050, 1150, 1199, 1201, 1150, 1050, 1001, 999, 1100]
    assert [descend.update(h * FT) for h in heights] == [True, True, True, False, False, False, False, True, True]
    assert descend.update(None) is False  # no AGL: no inhibit can apply
    now = LowAltitudeInhibits(TCAS).update(1050 * FT)
    assert (now.ra, now.descend, now.increase_descent) == (False, True, True)


def test_no_increase_descent_below_1450_ft_agl():
    lg = logic()
    low = Inhibits(increase_descent=True)
    lg.resolve(0.0, [Threat(100 * FT, 0.0, 30.0)], 0.0, ALIM, low)
    # Nothing is flown (open loop): the descend RA would be strengthened to INCREASE DESCENT, but not here.
    strengths = {lg.resolve(t, [Threat(100 * FT, 0.0, 30.0 - t)], 0.0, ALIM, low).strength
                 for t in (3.0, 6.0, 9.0, 12.0)}
    assert Strength.INCREASE not in strengths


# -- item 2: inside DMOD, diverging --------------------------------------------------------------------------

@pytest.mark.parametrize("range_nm, expected", [(0.30, AdvisoryLevel.RA), (0.40, AdvisoryLevel.TA),
                                                (0.50, AdvisoryLevel.NONE)])
def test_a_slowly_diverging_pair_inside_dmod_is_a_threat(range_nm, expected):
    # SL 4: RA DMOD 0.35 nm, TA DMOD 0.48 nm. Co-altitude, opening at 1 m/s: TCAS2D.horizontal_RA alerts
    # on range <= DMOD, closing or not; outside DMOD a diverging pair is clear.
    level = select_level(None, 3000 * FT, TCAS.levels)
    g = pair_geometry(np.array([[range_nm * NM, 0.0]]), np.array([[1.0, 0.0]]), np.array([0.0]), np.array([0.0]))
    assert tcas2_alerter().alert(Pairs(g, np.array([True])), level)[0] == int(expected)


# -- item 3: multi-threat -----------------------------------------------------------------------------------

def test_threats_above_and_below_get_a_composite_ra_that_level_flight_satisfies():
    above, below = Threat(400 * FT, 0.0, 20.0), Threat(-400 * FT, 0.0, 20.0)
    ra = logic().resolve(0.0, [above, below], 0.0, ALIM)
    assert ra.composite and ra.words() == "DONT CLIMB DONT DESCEND" and ra.target_rate_mps == 0.0
    assert ra.sense_against(above) is Sense.DESCEND and ra.sense_against(below) is Sense.CLIMB
    assert ra.separation_m == pytest.approx(400 * FT) and not ra.crossing
    climbing = logic().resolve(0.0, [above, below], 500 * FPM, ALIM)
    assert climbing.composite and climbing.strength is Strength.LEVEL_OFF and climbing.words() == "LEVEL OFF"
    # Flown: both vertical misses stay 400 ft (the old logic climbed at 2500 fpm through the upper one).
    enc = Encounter(3000 * FT, 0.0, (Intruder(5000.0, 0.0, -100.0, 0.0, 400 * FT, 0.0),
                                     Intruder(-5000.0, 0.0, 100.0, 0.0, -400 * FT, 0.0)))
    out = fly(enc, TCAS)
    assert out.words == ["DONT CLIMB DONT DESCEND"]
    assert min(out.vmd_flown_m) == pytest.approx(400 * FT, abs=0.5)


def test_several_threats_on_one_side_share_one_sense():
    both_above = [Threat(250 * FT, 0.0, 25.0), Threat(600 * FT, -500 * FPM, 22.0)]
    ra = logic().resolve(0.0, both_above, 0.0, ALIM)
    assert ra.sense is Sense.DESCEND and not ra.crossing
    assert ra.separation_m == pytest.approx(min(
        logic().separation([th], Sense.DESCEND, ra.strength, 0.0) for th in both_above))


# -- item 4: strength sequence ------------------------------------------------------------------------------

def test_a_corrective_ra_weakens_to_level_off():
    out = fly(head_on(3000, 0), TCAS)  # co-altitude head-on at SL 4
    assert out.words == ["DESCEND", "LEVEL OFF"]  # v7.1; v7.0 weakened to DON'T CLIMB
    assert out.vmd_flown_m[0] >= ALIM


def test_strengthening_goes_preventive_corrective_increase():
    # Open loop (nothing flown): DON'T CLIMB against a level intruder 350 ft above (> ALIM), then the intruder
    # descends at 1100 fpm toward us (to 17 ft below our altitude by CPA): the RA strengthens one step at a
    # time, never preventive -> increase. (At 1500 fpm it would end 150 ft below us, a DESCEND would leave
    # only ~136 ft, worse than doing nothing, and the RA reverses to CLIMB instead.)
    lg = logic()
    first = lg.resolve(0.0, [Threat(350 * FT, 0.0, 20.0)], 0.0, ALIM)
    assert first.strength is Strength.PREVENTIVE
    seen = [first.strength]
    for k in range(1, 13):
        t = k * 1.0
        ra = lg.resolve(t, [Threat(350 * FT - 1100 * FPM * t, -1100 * FPM, 20.0 - t)], 0.0, ALIM)
        if ra.strength is not seen[-1]:
            seen.append(ra.strength)
    assert seen == [Strength.PREVENTIVE, Strength.CORRECTIVE, Strength.INCREASE]


# Strengthening is judged against the RA being flown, not the path of the RA's start (evaluation 2026-12-03,
# seed 1 encounters 16492 and 2860). Standard response by hand: 5 s, 2.4517 m/s^2 to 7.62 m/s, reached after
# 3.108 s; after 5 + 3.108 s, 0.5 * 2.4517 * 3.108^2 = 11.84 m.

def test_dont_climb_strengthens_to_descend_after_ownship_levels_off_under_a_descending_threat():
    # Ownship descends at 2000 fpm; a threat 300 ft above descends at 1500 fpm, CPA in 36 s: keeping the
    # descent passes 600 ft below it (>= ALIM): DON'T CLIMB. 18 s later ownship has levelled off (DON'T CLIMB
    # allows it), 600 ft lower; the threat is 450 ft above and reaches our altitude at CPA (18 s): the RA flown
    # leaves 0 ft. DESCEND leaves 11.84 + 7.62 * (18 - 8.108) = 87.2 m (286 ft) > 0: the RA strengthens (v7.1
    # booklet: an RA no longer predicted to give ALIM is strengthened). Against the 2000 fpm descent ownship no
    # longer flies (600 ft) it was held, and the evaluation flew it to an NMAC.
    lg = logic()
    first = lg.resolve(0.0, [Threat(300 * FT, -1500 * FPM, 36.0)], -2000 * FPM, ALIM, own_altitude_m=0.0)
    assert first.words() == "DONT CLIMB" and first.separation_m == pytest.approx(600 * FT)
    ra = lg.resolve(18.0, [Threat(450 * FT, -1500 * FPM, 18.0)], 0.0, ALIM, own_altitude_m=-600 * FT)
    assert (ra.sense, ra.strength, ra.words()) == (Sense.DESCEND, Strength.CORRECTIVE, "DESCEND")
    assert ra.separation_m == pytest.approx(11.84 + 7.62 * (18 - 5 - 7.62 / 2.4517), abs=0.05)


def test_level_off_strengthens_to_climb_when_the_threat_below_starts_climbing():
    # Ownship descends at 800 fpm, a threat 120 ft below at the same rate, CPA in 33 s: LEVEL OFF (66.7 ft in the
    # 5 s delay, 11.1 ft more to stop at 0.25 g) keeps us 482 ft above it (>= ALIM). Ownship levels (100 ft
    # lower); at CPA - 8 s the threat, 220 ft below, climbs at
    # 1500 fpm and would be 20 ft below us at CPA with LEVEL OFF. CLIMB: 0.5 * 2.4517 * 3^2 = 11.03 m (36 ft)
    # in the 3 s after the delay, 56 ft > 20 ft: CLIMB. The 800 fpm descent that LEVEL OFF stopped (320 ft
    # below it at CPA) must not hold it back.
    lg = logic()
    first = lg.resolve(0.0, [Threat(-120 * FT, -800 * FPM, 33.0)], -800 * FPM, ALIM, own_altitude_m=0.0)
    assert first.words() == "LEVEL OFF" and first.sense is Sense.CLIMB
    assert first.separation_m == pytest.approx(560 * FT - 800 * FPM * 5 - 4.064**2 / (2 * 2.4517), abs=0.05)
    ra = lg.resolve(25.0, [Threat(-220 * FT, 1500 * FPM, 8.0)], 0.0, ALIM, own_altitude_m=-100 * FT)
    assert (ra.sense, ra.strength, ra.words()) == (Sense.CLIMB, Strength.CORRECTIVE, "CLIMB")
    assert ra.separation_m == pytest.approx(0.5 * 2.4517 * 3.0**2 + 20 * FT, abs=0.05)


def test_a_first_ra_is_never_an_increase():
    ra = logic().resolve(0.0, [Threat(0.0, 0.0, 8.0)], 0.0, ALIM)  # too late for ALIM with any RA
    assert ra.strength is Strength.CORRECTIVE


# -- item 5: co-altitude ------------------------------------------------------------------------------------

@pytest.mark.parametrize("sz_m", [1e-4, -1e-4, 0.0, 0.4, -0.4])
def test_exact_co_altitude_is_a_tie_that_goes_to_descend(sz_m):
    # Within 10 ft neither sense crosses, and separations within 1 m tie: descend (DO-185B sense selection,
    # as publicly described), climb where descend is inhibited. Sub-millimetre noise no longer decides.
    assert logic().resolve(0.0, [Threat(sz_m, 0.0, 25.0)], 0.0, ALIM).sense is Sense.DESCEND
    assert logic().resolve(0.0, [Threat(sz_m, 0.0, 25.0)], 0.0, ALIM, LOW).sense is Sense.CLIMB


def test_within_10_ft_the_larger_separation_decides_without_a_crossing():
    # 2.9 m below us: climbing gains 5.8 m over descending (> the 1 m tie) and crosses nothing.
    ra = logic().resolve(0.0, [Threat(-2.9, 0.0, 25.0)], 0.0, ALIM)
    assert ra.sense is Sense.CLIMB and not ra.crossing


def test_mirrored_co_altitude_head_ons_get_the_same_sense():
    east = fly(Encounter(3000 * FT, 0.0, (Intruder(5000.0, 0.0, -100.0, 0.0, 0.0, 0.0),)), TCAS)
    west = fly(Encounter(3000 * FT, 0.0, (Intruder(-5000.0, 0.0, 100.0, 0.0, 0.0, 0.0),)), TCAS)
    assert east.words[0] == west.words[0] == "DESCEND"


# -- item 6: no threat above 10,000 fpm ---------------------------------------------------------------------

@pytest.mark.parametrize("rate_fpm, ra", [(11000, False), (9000, True)])
def test_no_threat_declared_against_an_intruder_above_10000_fpm(rate_fpm, ra):
    # Diving onto ownship: co-altitude at the CPA, 50 s away at the start.
    out = fly(head_on(5000, rate_fpm * 50 / 60, vz_intruder_fpm=-rate_fpm), TCAS)
    assert bool(out.words) is ra
