"""Ties decided as DAIDALUS decides them (issue 29 item 3).

DAIDALUS compares with gov.nasa.larcfm.Util's almost_equals (16348 ULPs at PRECISION13; 2^40 at the bands'
PRECISION5; and a zero special case: when one side is exactly 0, both below 1e-13 / 1e-5 are equal) and its
almost_less / almost_leq / almost_geq. A loss interval is a conflict when time_in is almost-less than time_out
(LossData.conflict), so a loss that begins at 0 and lasts 1e-14 s is none; the bands' samples ask for a loss
on the line through the sample within [tsk, tsk + tstep] (DaidalusIntegerBands LOS_at_coast) or beginning at the
sample (violationAtWithTrafficState = conflictWithTrafficState(t, t)), not for the instantaneous test.

The cases here follow by hand from those definitions: ADS-B altitudes on a 25 ft grid put two aircraft exactly
450 ft apart, which in floating point is ZTHR to about 1e-13 m (17450 ft - 17000 ft = 137.15999999999985 m,
ZTHR = 137.16 m).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from avionics.advisory.bands import BandsEngine, BandsParams
from avionics.advisory.bands_kinematics import Cylinder, cylinder_interval
from avionics.advisory.wcv import WCV_TAUMOD, conflict, wcv_interval
from avionics.advisory.tables import load_profile
from avionics.base import jit
from avionics.base.almost import (
    PRECISION5, almost_equals, almost_geq, almost_greater, almost_leq, almost_less,
)
from avionics.base.units import FPM, FT, KT, NM

DO365B_LEVELS = load_profile("daidalus-do365b-no-sum").alerter.levels  # DO_365B_no_SUM.conf DWC_Phase_I, the data
DO365_PHASE_I = DO365B_LEVELS[-1].thresholds  # its det_3

OWN_FT, INTRUDER_FT = 17000.0, 17450.0  # both on the 25 ft grid, 450 ft apart
SEP_M = INTRUDER_FT * FT - OWN_FT * FT


def test_almost_equals_is_utils():
    assert SEP_M != DO365_PHASE_I.zthr_m and almost_equals(SEP_M, DO365_PHASE_I.zthr_m)  # a few ULPs apart
    assert almost_equals(1.0, 1.0 + 16348 * 2.0**-52) and not almost_equals(1.0, 1.0 + 16349 * 2.0**-52)
    assert almost_equals(0.0, 9e-14) and not almost_equals(0.0, 2e-13)  # the zero special case ...
    assert not almost_equals(1e-14, 9e-14)  # ... only when one side is exactly 0
    assert almost_equals(0.0, 9e-6, PRECISION5) and not almost_equals(0.0, 2e-5, PRECISION5)
    assert almost_equals(1.0, 1.0 + 1e-12, PRECISION5) and not almost_equals(1.0, 1.0 + 1e-3, PRECISION5)
    assert not almost_equals(math.nan, math.nan) and almost_equals(math.inf, math.inf)
    assert not almost_equals(-1e-300, 1e300)  # far apart: no integer wrap makes them equal
    assert not almost_less(0.0, 5e-14) and almost_less(0.0, 5e-13)
    assert almost_leq(SEP_M, DO365_PHASE_I.zthr_m) and almost_leq(DO365_PHASE_I.zthr_m, SEP_M)
    assert almost_geq(SEP_M, DO365_PHASE_I.zthr_m) and not almost_greater(DO365_PHASE_I.zthr_m, SEP_M)
    a = np.array([0.0, 1.0, 2.0])
    assert almost_equals(a, a + np.array([5e-14, 1e-17, 1.0])).tolist() == [True, True, False]


def _pair(sz, vz):
    s = np.array([[0.0, 0.5 * NM]])  # head-on, inside the horizontal volume now
    v = np.array([[0.0, -270 * KT]])
    return s, v, np.array([sz]), np.array([vz])


def test_separation_at_zthr_and_diverging_is_no_conflict():
    # the intruder 450 ft above (to 1e-13 m) climbing away at 1000 fpm: the vertical loss lasts
    # (ZTHR - sz) / vz ~ 3e-14 s from 0, almost equal to no time at all (LossData.conflict, zero special case)
    t_in, t_out = wcv_interval(*_pair(SEP_M, 1000 * FPM), DO365_PHASE_I, 0.0, 180.0)
    assert t_in[0] == 0.0 and 0.0 < t_out[0] < 1e-13
    assert not conflict(t_in, t_out)[0]
    # 1e-9 m further inside: a loss of 1e-12 s, a conflict (no longer almost equal)
    t_in, t_out = wcv_interval(*_pair(DO365_PHASE_I.zthr_m - 1e-9, 1000 * FPM), DO365_PHASE_I, 0.0, 180.0)
    assert conflict(t_in, t_out)[0]
    # the same geometry level: inside ZTHR (|sz| <= ZTHR, WCV_TCOA's own comparison) for the whole lookahead
    t_in, t_out = wcv_interval(*_pair(SEP_M, 0.0), DO365_PHASE_I, 0.0, 180.0)
    assert conflict(t_in, t_out)[0]


def test_no_relative_vertical_motion_is_almost_zero():
    # WCV_TCOA: "level" is Util.almost_equals(vz, 0), i.e. |vz| < 1e-13 m/s. 1e-11 m outside ZTHR and closing at
    # 1e-12 m/s enters the slab in 10 s (a conflict); closing at 5e-14 m/s counts as level, outside: none.
    s, v, _, _ = _pair(0.0, 0.0)
    sz = np.array([DO365_PHASE_I.zthr_m + 1e-11])
    moving = wcv_interval(s, v, sz, np.array([-1e-12]), DO365_PHASE_I, 0.0, 180.0)
    assert conflict(*moving)[0] and moving[0][0] == pytest.approx(10.0, rel=1e-3)
    assert not conflict(*wcv_interval(s, v, sz, np.array([-5e-14]), DO365_PHASE_I, 0.0, 180.0))[0]


def test_cylinder_at_its_height_is_clear():
    # CD3D.detection: level flight at |sz| almost equal to H is not inside (Vertical.almost_vertical_los)
    cyl = Cylinder(500 * FT, 100 * FT)
    s, v = np.array([[0.0, 100.0]]), np.array([[0.0, -50.0]])
    sz = np.array([(OWN_FT + 100.0) * FT - OWN_FT * FT])
    t_in, t_out = cylinder_interval(s, v, sz, np.array([0.0]), cyl, 180.0)
    assert not conflict(t_in, t_out)[0]
    t_in, t_out = cylinder_interval(s, v, sz - 1e-6, np.array([0.0]), cyl, 180.0)
    assert conflict(t_in, t_out)[0]


def _bands(intruder_ft, intruder_vs_fpm):
    own = [0.0, 0.0, OWN_FT * FT]
    intruder = [[0.0, 0.5 * NM, intruder_ft * FT]]
    return BandsEngine(BandsParams(), DO365B_LEVELS).compute(0.0, own, [0.0, 150 * KT, 0.0], intruder,
                                 [[0.0, -120 * KT, intruder_vs_fpm * FPM]], ["tie"], [1])


@pytest.mark.parametrize("intruder_ft, intruder_vs_fpm", [(17450.0, 1000.0), (16550.0, -1000.0)])
def test_bands_at_450_ft_diverging(intruder_ft, intruder_vs_fpm):
    """Head-on 0.5 nmi, the intruder exactly 450 ft above (below) climbing (descending) away at 1000 fpm, the
    ownship level. By hand: a vertical speed on the intruder's side beyond its 1000 fpm closes the 450 ft and is
    a loss (NEAR: within 25 s); one of at most 1000 fpm toward it keeps >= 450 ft and is clear. Now is no loss
    (the tie above), so no region is saturated and there are no RECOVERY bands; altitude targets are all clear
    (the level-out climbs at 500 fpm, slower than the intruder's 1000 fpm). DAIDALUS v2.0.4 gives these bands."""
    b = _bands(intruder_ft, intruder_vs_fpm)
    up = intruder_vs_fpm > 0
    vs = [(round(iv.lower / FPM), round(iv.upper / FPM), iv.region) for iv in b.vertical_rate_mps]
    assert vs == ([(-6000, 1000, "NONE"), (1000, 6000, "NEAR")] if up else
                  [(-6000, -1000, "NEAR"), (-1000, 6000, "NONE")])
    assert [iv.region for iv in b.altitude_m] == ["NONE"]
    assert not any(iv.region == "RECOVERY" for kind in ("track_deg", "ground_speed_mps")
                   for iv in b.intervals(kind))


def test_wcv_taumod_alerts_no_tie():
    # the detector as the alerter sees it: the same diverging tie raises nothing within 55 s
    from avionics.advisory.alerting import Encounter
    from avionics.conflict.cpa import pair_geometry

    s, v, sz, vz = _pair(SEP_M, 1000 * FPM)
    enc = Encounter(pair_geometry(s, v, sz, vz), np.array([True]))
    assert not WCV_TAUMOD().conflict(enc, DO365_PHASE_I, 55.0)[0]


def test_vertical_speed_recovery_with_both_descending_450_ft_apart():
    """Ownship at 28 875 ft descending at 1000 fpm, the intruder 450 ft above (to 1e-13 m) descending at 1000 fpm,
    1190 m away (inside DTHR): in loss now, every region saturated, so recovery bands. By hand: a descent faster
    than 1000 fpm opens the vertical gap and recovers (RECOVERY); any vertical speed at or above -1000 fpm keeps
    the gap at or below 450 ft while the intruder is horizontally inside, and never recovers (NEAR). A strict
    comparison at the recovery cylinder's 450 ft made the whole range RECOVERY; DAIDALUS v2.0.4 gives these."""
    own = [0.0, 0.0, 28875.0 * FT]
    intruder = [[-1000.0, -650.0, 29325.0 * FT]]
    b = BandsEngine(BandsParams(), DO365B_LEVELS).compute(0.0, own, [0.0, 54.0, -1000 * FPM], intruder,
                                                          [[-88.0, 86.0, -1000 * FPM]], ["tie"], [3])
    vs = [(round(iv.lower / FPM), round(iv.upper / FPM), iv.region) for iv in b.vertical_rate_mps]
    assert vs == [(-6000, -1000, "RECOVERY"), (-1000, 6000, "NEAR")]


def test_a_recovery_that_no_value_finds_reports_minus_infinity_as_daidalus():
    """Ownship descending at 1000 fpm, an intruder 111 m away and 100 ft below climbing at 2070 fpm: every value of
    every kind passes through the NMAC cylinder, so the bands stay NEAR and the recovery search finds nothing.
    DAIDALUS v2.0.4 (its Java on the same state, 2026-12-05) reports timeToRecovery() = -infinity then (recovery
    attempted, DaidalusRealBands.compute_recovery_bands' NEGATIVE_INFINITY), not NaN (no recovery attempted);
    so does recovery_information (here before it was None, found in 11 of 1,800 states compared)."""
    own, own_v = [0.0, 0.0, 8610.6], [-54.52165583582027, -1.196130881102894, -5.08]
    engine = BandsEngine(BandsParams(), DO365B_LEVELS)
    b = engine.compute(0.0, own, own_v, [[45.70357936898783, 101.32584984923422, 8580.12]],
                       [[-67.55153694518366, -41.99613362734122, 10.522457442253392]], ["nmac"], [0])
    assert [(round(iv.lower / FPM), round(iv.upper / FPM), iv.region) for iv in b.vertical_rate_mps] == \
        [(-6000, 6000, "NEAR")]
    assert b.recovery["vertical_rate_mps"]
    assert engine.recovery_information["vertical_rate_mps"] == (-math.inf, -math.inf, -math.inf, 0)


def _ulps_away(x: float, ulps: int) -> float:
    """The double `ulps` units in the last place from x (negative: below), across 0; NaN past the largest."""
    bits = int(np.array(x).view(np.int64))
    ordered = -(2**63) - bits if bits < 0 else bits  # the doubles' order as integers (Util.almost_equals)
    ordered += ulps
    bits = -(2**63) - ordered if ordered < 0 else ordered
    return float(np.array(bits, np.int64).view(np.float64)) if -(2**63) <= bits < 2**63 else math.nan


DOUBLES = st.one_of(
    st.floats(allow_nan=True, allow_infinity=True),
    st.sampled_from([0.0, -0.0, 1e-13, -1e-13, 9.99e-14, 1e-5, 137.16, SEP_M, 1.7976931348623157e308, 5e-324]),
    st.integers(-2**60, 2**60))


@settings(max_examples=500, deadline=None)
@given(DOUBLES, st.one_of(DOUBLES, st.tuples(st.integers(-1, 1), st.integers(-2, 2))),
       st.sampled_from([16348, 1 << 27, 1 << 40, 5]))
def test_one_pair_compares_as_the_arrays_do(a, b, precision):
    """The comparisons of two numbers (Python floats, the bands' and the alerter's one-pair path) decide as the
    array path does, element for element: ULP neighbours at every precision, the zero special case, signed
    zeros, NaN, infinities, the largest doubles (whose ordered bit patterns wrap int64 in the array path)."""
    if type(b) is tuple:  # b at the precision's edge from a: precision - 2 to precision + 2 ULPs above or below
        b = _ulps_away(float(a), b[0] * (precision + b[1])) if math.isfinite(a) else a
    # as arrays too, broadcast against each other ((2, 1) against a read-only (1, 3)), compiled and not
    arrays = np.array([[a], [b]], float), np.broadcast_to(np.array([[b, a, 0.0]], float), (1, 3))
    for compare in (almost_equals, almost_less, almost_greater, almost_leq, almost_geq):
        one, many = compare(a, b, precision), compare(*arrays, precision)
        with jit.reference():
            reference = compare(*arrays, precision)
        assert bool(one) == bool(many[0, 0]), (compare.__name__, a, b, precision)
        assert type(one) is (bool if compare is almost_equals else np.bool_)
        assert many.shape == (2, 3) and np.array_equal(many, reference), (compare.__name__, a, b, precision)
        for x, y in ((arrays[0], b), (a, arrays[1])):  # an array against a number, either way round
            with jit.reference():
                reference = compare(x, y, precision)
            assert np.array_equal(compare(x, y, precision), reference), (compare.__name__, a, b, precision)
        assert compare(np.empty(0), np.array([b]), precision).shape == (0,)  # none against one: none
