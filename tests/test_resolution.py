"""RA sense and strength against hand-projected vertical separations (TCAS II standard response)."""

import pytest

from avionics.advisory.resolution import ResolutionLogic, Sense, Strength, Threat, own_displacement
from avionics.advisory.tables import load_profile
from avionics.core.units import FPM, FT

TCAS = load_profile("tcas2")
ALIM = 300 * FT  # SL 4


def logic():
    return ResolutionLogic(TCAS)


def test_standard_response_by_hand():
    # 5 s delay, 0.25 g (2.452 m/s^2) to 1500 fpm (7.62 m/s): reached 3.107 s after the delay.
    assert own_displacement(5.0, 0.0, 7.62, 2.4517, 5.0) == 0.0
    ta = 7.62 / 2.4517
    assert own_displacement(5.0 + ta, 0.0, 7.62, 2.4517, 5.0) == pytest.approx(0.5 * 2.4517 * ta**2)
    assert own_displacement(25.0, 0.0, 7.62, 2.4517, 5.0) == pytest.approx(0.5 * 2.4517 * ta**2 + 7.62 * (20 - ta))
    assert own_displacement(10.0, -2.0, -2.0, 2.4517, 5.0) == pytest.approx(-20.0)  # already at target


def test_level_intruder_above_gives_descend_below_gives_climb():
    above = logic().resolve(0.0, [Threat(200 * FT, 0.0, 25.0)], 0.0, None, ALIM)
    below = logic().resolve(0.0, [Threat(-200 * FT, 0.0, 25.0)], 0.0, None, ALIM)
    assert (above.sense, above.strength, above.words()) == (Sense.DESCEND, Strength.CORRECTIVE, "DESCEND")
    assert (below.sense, below.strength, below.words()) == (Sense.CLIMB, Strength.CORRECTIVE, "CLIMB")
    assert above.target_rate_mps == pytest.approx(-1500 * FPM) and not above.crossing
    assert above.separation_m >= ALIM and below.separation_m >= ALIM


def test_separation_already_assured_gives_a_preventive_ra():
    ra = logic().resolve(0.0, [Threat(500 * FT, 0.0, 20.0)], 0.0, None, ALIM)
    assert (ra.sense, ra.strength, ra.words(), ra.target_rate_mps) == (Sense.DESCEND, Strength.PREVENTIVE,
                                                                       "DONT CLIMB", None)


def test_climbing_ownship_that_can_level_off_is_told_to():
    # Intruder 600 ft above, level; we climb at 2000 fpm toward it: levelling off keeps > ALIM.
    ra = logic().resolve(0.0, [Threat(600 * FT, 0.0, 20.0)], 2000 * FPM, None, ALIM)
    assert (ra.sense, ra.strength, ra.words()) == (Sense.DESCEND, Strength.LEVEL_OFF, "LEVEL OFF")
    assert ra.target_rate_mps == 0.0


def test_intruder_climbing_through_our_altitude_non_crossing_when_it_achieves_alim():
    # From 300 ft below at 1000 fpm, co-altitude in 18 s, CPA in 20 s: staying above needs the climb
    # to beat the intruder's climb; climb 1500 fpm achieves ALIM without crossing.
    threat = Threat(-300 * FT, 1000 * FPM, 20.0)
    ra = logic().resolve(0.0, [threat], 0.0, None, ALIM)
    climb = logic().separation([threat], Sense.CLIMB, Strength.CORRECTIVE, 0.0)
    assert ra.sense is Sense.CLIMB and not ra.crossing and climb >= ALIM


def test_fast_climber_makes_the_crossing_sense_the_choice():
    # 3000 fpm from 300 ft below, CPA in 25 s: it will be far above by CPA; climbing (non-crossing) cannot
    # stay above it, descending (through its current altitude) leaves it above us by > ALIM.
    threat = Threat(-300 * FT, 3000 * FPM, 25.0)
    ra = logic().resolve(0.0, [threat], 0.0, None, ALIM)
    assert logic().separation([threat], Sense.CLIMB, Strength.CORRECTIVE, 0.0) < ALIM
    assert ra.sense is Sense.DESCEND and ra.crossing and ra.separation_m >= ALIM


def test_reversal_when_the_intruder_reverses_its_vertical_rate():
    lg = logic()
    first = lg.resolve(0.0, [Threat(400 * FT, 0.0, 30.0)], 0.0, None, ALIM)
    assert first.sense is Sense.DESCEND
    # The intruder now dives at 3000 fpm at us: descending can no longer reach ALIM; climbing can.
    t = 0.0
    for k in range(1, 40):
        t = k * 0.5
        ra = lg.resolve(t, [Threat(400 * FT - 3000 * FPM * t, -3000 * FPM, 30.0 - t)], 0.0, None, ALIM)
        if ra.reversed:
            break
    assert ra.reversed and ra.sense is Sense.CLIMB and ra.words() == "CLIMB NOW"


def test_descend_is_inhibited_below_1100_ft_agl():
    ra = logic().resolve(0.0, [Threat(200 * FT, 0.0, 25.0)], 0.0, 1050 * FT, ALIM)
    assert ra.sense is Sense.CLIMB  # would have been DESCEND (test above) higher up
    high = logic().resolve(0.0, [Threat(200 * FT, 0.0, 25.0)], 0.0, 1200 * FT, ALIM)
    assert high.sense is Sense.DESCEND


def test_no_increase_descent_below_1450_ft_agl():
    lg = logic()
    lg.resolve(0.0, [Threat(100 * FT, 0.0, 30.0)], 0.0, 1400 * FT, ALIM)
    # Nothing is flown (open loop): the descend RA would be strengthened to INCREASE DESCENT, but not here.
    strengths = {lg.resolve(t, [Threat(100 * FT, 0.0, 30.0 - t)], 0.0, 1400 * FT, ALIM).strength
                 for t in (3.0, 6.0, 9.0, 12.0)}
    assert Strength.INCREASE not in strengths


def test_one_sense_for_several_threats():
    both_above = [Threat(250 * FT, 0.0, 25.0), Threat(600 * FT, -500 * FPM, 22.0)]
    ra = logic().resolve(0.0, both_above, 0.0, None, ALIM)
    assert ra.sense is Sense.DESCEND and not ra.crossing
    assert ra.separation_m == pytest.approx(min(
        logic().separation([th], Sense.DESCEND, ra.strength, 0.0) for th in both_above))
    # One above, one below: the sense with the larger least separation (climbing keeps above the lower one
    # and gets above the upper one; descending would pass through the lower one).
    split = [Threat(250 * FT, 0.0, 25.0), Threat(-900 * FT, 0.0, 22.0)]
    ra = logic().resolve(0.0, split, 0.0, None, ALIM)
    seps = {s: logic().separation(split, s, Strength.CORRECTIVE, 0.0) for s in Sense}
    assert ra.sense is max(seps, key=seps.get) is Sense.CLIMB and ra.crossing


def test_strengthening_when_the_response_is_not_flown():
    lg = logic()
    assert lg.resolve(0.0, [Threat(0.0, 0.0, 22.0)], 0.0, None, ALIM).strength is Strength.CORRECTIVE
    strengths = [lg.resolve(t, [Threat(0.0, 0.0, 22.0 - t)], 0.0, None, ALIM).strength for t in (2.0, 4.0, 6.0, 8.0, 10.0, 12.0, 14.0)]
    assert Strength.INCREASE in strengths
