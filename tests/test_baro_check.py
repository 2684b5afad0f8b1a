"""Barometer cross-check (issue 10, deliverable 2): a stuck, glitched or out-of-range ownship pressure is detected,
counted, named in the status, and the co-altitude alert comes when it would with a good barometer.

Fast time at the core's level: ownship fixes and intruder reports go straight into DaaCore; SCALED_PRESSURE goes
through the real decoder (so an out-of-range press_abs is rejected where it is on the wire). Expected values come
from independent oracles: ICAO Doc 7488's tabulated pressures, the ISA formula worked by hand, and the TCAS onset
r(tau) = (tau*c + sqrt((tau*c)^2 + 4 DMOD^2)) / 2 of modified tau (r^2 - DMOD^2) / (r c) = tau.
"""

from __future__ import annotations

import math
import struct
from collections import Counter

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from pymavlink.dialects.v20 import common as m2

from avionics.config import AltitudeConfig, Config, load_config
from avionics.base import atmosphere
from avionics.base.atmosphere import MAX_VALID_HPA, MIN_VALID_HPA, pressure_altitude_m, pressure_hpa_at
from avionics.base.types import AddressSource, AdvisoryLevel, AltitudeDatum, IntruderKey, IntruderReport, OwnshipFix
from avionics.base.types import OwnshipPressure
from avionics.base.units import KT, NM
from avionics.io.decode import MessageDecoder
from harness import Harness
from avionics.tracking.baro_check import BaroCrossCheck
from synthetic import PLANE

# -- oracles --------------------------------------------------------------------------------------------------
# ICAO Doc 7488 (3rd ed.), Table of the standard atmosphere: pressure at geopotential altitude.
DOC7488_HPA = {0.0: 1013.25, 1000.0: 898.746, 11000.0: 226.321, 20000.0: 54.7489}


def isa_altitude_by_hand(p_hpa: float) -> float:
    """Troposphere only, written out: h = T0/L * (1 - (p/p0)^(R L / g0))."""
    return 288.15 / 0.0065 * (1.0 - (p_hpa / 1013.25) ** (287.05287 * 0.0065 / 9.80665))


H_STUCK = isa_altitude_by_hand(950.0)  # 540.34 m: where a static port frozen at 950 hPa reads right
ALT = 1000.0  # ownship and intruder cruise, pressure altitude = geometric altitude on an ISA day
CLIMB = 10.0  # m/s, ownship from H_STUCK to ALT, then level (t_level = 46 s)
T_LEVEL = (ALT - H_STUCK) / CLIMB
V = 125 * KT  # each, head-on: closing 250 kt
R0 = 7 * NM
KEY = IntruderKey(0xABC123, AddressSource.ES1090)


def onset(range0, closing, tau, dmod):
    """Time at which modified tau falls to tau on a straight closing course."""
    r = (tau * closing + math.sqrt((tau * closing) ** 2 + 4 * dmod**2)) / 2
    return (range0 - r) / closing


T_TA = onset(R0, 2 * V, 30, 0.48 * NM)  # SL 4 (3281 ft): TA tau 30 s, DMOD 0.48 nm -> 69.3 s
T_RA = onset(R0, 2 * V, 20, 0.35 * NM)  # RA tau 20 s, DMOD 0.35 nm -> 79.6 s
GLITCH = (T_RA - 2.0, T_RA - 1.0)  # 1 s, ending just before the RA is due
# 500 hPa: +4.6 km, an offset no atmosphere has (implausible); without the cross-check it pulls the learned
# offset by ~430 m and the RA comes 7.8 s late. 850 hPa: +457 m, a plausible offset but a jump.
GLITCHES = {"glitch_1s_500hpa": (500.0, "implausible"), "glitch_1s_850hpa": (850.0, "jump")}


# -- the encounter -------------------------------------------------------------------------------------------
def own_alt(t):
    return min(H_STUCK + CLIMB * t, ALT)


def true_hpa(t):
    return pressure_hpa_at(own_alt(t))


def scaled_pressure(t, press_abs):
    msg = m2.MAVLink_scaled_pressure_message(int(t * 1000), press_abs, 0.0, 1500)
    buf = msg.pack(m2.MAVLink(None, srcSystem=1, srcComponent=1))
    return m2.MAVLink(None).decode(bytearray(buf))


def fly(press_abs, until_s=90.0, overrides=(), status_every_s=1.0):
    """Ownship 5 Hz (fix + SCALED_PRESSURE press_abs(t)), intruder 1 Hz, steps at 10 Hz.
    Returns (node, [(t, advisory change)], {t: status})."""
    node = Harness(load_config(overrides=list(overrides)))
    core = node.core
    changes, statuses = [], {}
    for k in range(int(round(until_s * 10)) + 1):
        t = round(k * 0.1, 6)
        inputs = []
        if k % 2 == 0:
            lat, lon = PLANE.to_geodetic(0.0, V * t)
            vu = CLIMB if t < T_LEVEL else 0.0
            inputs.append(OwnshipFix(t, float(lat), float(lon), own_alt(t), own_alt(t), (V, 0.0, -vu)))
            item = node.decoder.decode(scaled_pressure(t, press_abs(t)), t)
            if item is not None:
                inputs.append(item)
        if k % 10 == 0:
            lat, lon = PLANE.to_geodetic(0.0, R0 - V * t)
            inputs.append(IntruderReport(KEY, t, t, float(lat), float(lon), ALT, AltitudeDatum.PRESSURE,
                                         (0.0, -V), 0.0))
        changes += [(t, c) for c in core.step(t, inputs).changes]
        if k % int(round(status_every_s * 10)) == 0:
            statuses[t] = node.status(t)
    return node, changes, statuses


def first(changes, level):
    return next((t for t, c in changes if c.level is level), None)


T_STICKS = 55.0  # level at 1000 m since 46 s, the encounter's TA at 69 s


def glitched(hpa):
    return lambda t: hpa if GLITCH[0] <= t < GLITCH[1] else true_hpa(t)


CASES = {
    "no_fault": true_hpa,
    "stuck_950": lambda t: 950.0,
    "stuck_950_when_level": lambda t: 950.0 if t >= T_STICKS else true_hpa(t),
    **{name: glitched(hpa) for name, (hpa, _) in GLITCHES.items()},
    "out_of_range_1hpa": lambda t: 1.0,
}


@pytest.fixture(scope="module")
def runs():
    return {name: fly(press) for name, press in CASES.items()}


def baro_counts(node) -> Counter:
    return +Counter({k: v for k, v in node.core.ownship.counters.items() if k.startswith("baro.")})


# -- ISA: the oracle, the bound, the round trip --------------------------------------------------------------
def test_isa_matches_doc_7488_and_the_hand_formula():
    for h, p in DOC7488_HPA.items():
        assert pressure_hpa_at(h) == pytest.approx(p, rel=2e-5)
        assert pressure_altitude_m(p) == pytest.approx(h, abs=0.5)
    assert pressure_altitude_m(950.0) == pytest.approx(H_STUCK, abs=1e-6) == pytest.approx(540.34, abs=0.01)
    # the valid range is what the two layers invert: up to 20 km (Doc 7488: 54.7489 hPa), not 1 hPa
    assert MIN_VALID_HPA == pytest.approx(54.7489, abs=1e-3)
    assert atmosphere.MAX_PRESSURE_ALTITUDE_M == 20000.0
    for bad in (1.0, 54.7, 1100.1, math.nan):
        with pytest.raises(ValueError):
            pressure_altitude_m(bad)
    with pytest.raises(ValueError):
        pressure_hpa_at(20000.1)  # the +1 K/km layer above 20 km is not modelled: no extrapolation


@given(st.floats(atmosphere.MIN_PRESSURE_ALTITUDE_M, atmosphere.MAX_PRESSURE_ALTITUDE_M))
def test_isa_round_trips_over_the_whole_valid_range(h):
    p = pressure_hpa_at(h)
    assert MIN_VALID_HPA * (1 - 1e-12) <= p <= MAX_VALID_HPA * (1 + 1e-12)
    assert pressure_altitude_m(min(max(p, MIN_VALID_HPA), MAX_VALID_HPA)) == pytest.approx(h, abs=1e-6)


@given(st.floats(width=32, allow_nan=True, allow_infinity=True).filter(
    lambda p: not MIN_VALID_HPA <= p <= MAX_VALID_HPA))
@settings(max_examples=200)
def test_any_pressure_outside_the_valid_range_is_a_counted_rejection_never_an_exception(press_abs):
    counters = Counter()
    decoder = MessageDecoder(Config(), counters)
    assert decoder.decode(scaled_pressure(1.0, press_abs), 1.0) is None
    wire = struct.unpack("<f", struct.pack("<f", press_abs))[0]
    reason = "pressure.invalid" if not math.isfinite(wire) else "pressure.out_of_range"
    assert +counters == {"rx.scaled_pressure": 1, reason: 1}
    assert decoder.pressure_rejection == (1.0, reason.split(".")[1])


@given(st.floats(width=32, min_value=55.0, max_value=MAX_VALID_HPA))
@settings(max_examples=100)
def test_any_pressure_inside_the_valid_range_decodes(press_abs):
    counters = Counter()
    item = MessageDecoder(Config(), counters).decode(scaled_pressure(1.0, press_abs), 1.0)
    assert isinstance(item, OwnshipPressure)
    assert item.pressure_altitude_m == pytest.approx(pressure_altitude_m(press_abs), abs=1e-6)
    assert +counters == {"rx.scaled_pressure": 1}


# -- the acceptance encounters -------------------------------------------------------------------------------
def test_no_fault_alerts_at_the_tcas_onsets(runs):
    node, changes, statuses = runs["no_fault"]
    assert first(changes, AdvisoryLevel.TA) == pytest.approx(T_TA, abs=0.11)
    assert first(changes, AdvisoryLevel.RA) == pytest.approx(T_RA, abs=0.11)
    assert not any(c.datum_mismatch for _, c in changes)
    assert baro_counts(node) == {}
    assert all(s["pressure_fault"] is None and s["pressure_altitude_available"] for s in statuses.values())
    assert node.status(90.0)["ownship"]["pressure_altitude_m"] == pytest.approx(ALT, abs=0.5)


@pytest.mark.parametrize("case", ["stuck_950", "stuck_950_when_level", *GLITCHES, "out_of_range_1hpa"])
def test_faulty_pressure_alerts_within_1_s_of_the_no_fault_onsets(runs, case):
    _, good, _ = runs["no_fault"]
    _, changes, _ = runs[case]
    for level in (AdvisoryLevel.TA, AdvisoryLevel.RA):
        assert first(changes, level) is not None, (case, level)
        assert abs(first(changes, level) - first(good, level)) <= 1.0, (case, level)


def test_stuck_pressure_is_detected_during_the_climb_and_never_recovers(runs):
    node, changes, statuses = runs["stuck_950"]
    counts = baro_counts(node)
    assert set(counts) == {"baro.stuck"}
    # detected once GNSS has climbed 5 sigma of a fix difference, 5 * sqrt(2) * 4 m = 28.3 m: at 10 m/s, 2.8 s
    t_detect = min(t for t, s in statuses.items() if s["pressure_fault"] == "stuck")
    assert t_detect <= 5.0
    assert all(s["pressure_fault"] == "stuck" for t, s in statuses.items() if t >= t_detect)
    status = statuses[85.0]
    assert not status["pressure_altitude_available"] and status["unavailable_reason"] == "no_pressure_altitude"
    assert any("ownship pressure stuck" in w for w in status["warnings"])
    assert status["datum_mismatch_intruders"] == [str(KEY)]
    assert all(c.datum_mismatch for _, c in changes)  # the alerts come from GNSS altitude, widened


def test_pressure_sticking_at_another_value_in_level_flight_is_a_jump_that_holds(runs):
    """Level at 1000 m (898.75 hPa), the reading freezes at 950 hPa: a -460 m step against the learned offset.
    Level flight cannot show it stuck (a frozen reading is what a live one looks like without noise), but the
    step is beyond the gate, and it holds until the drift allowance (0.1 m/s) could explain 460 m: over an hour."""
    node, changes, statuses = runs["stuck_950_when_level"]
    assert set(baro_counts(node)) == {"baro.jump"}
    assert statuses[55.0]["pressure_fault"] == "jump" and statuses[54.0]["pressure_fault"] is None
    assert all(s["pressure_fault"] == "jump" for t, s in statuses.items() if t >= T_STICKS)
    assert changes and all(c.datum_mismatch for t, c in changes if t >= T_STICKS)


@pytest.mark.parametrize("case", GLITCHES)
def test_glitch_is_rejected_without_pulling_the_offset_and_recovers_after_the_hold(runs, case):
    node, changes, statuses = runs[case]
    reason = GLITCHES[case][1]
    assert baro_counts(node) == {f"baro.{reason}": 5, "baro.recovered": 1}  # five 5-Hz samples in the second
    assert statuses[79.0]["pressure_fault"] == reason
    assert any(f"ownship pressure {reason}" in w for w in statuses[79.0]["warnings"])
    # hysteresis: altitude.baro_recovery_s = 5 s of good samples after the glitch (ends 78.6 s) -> back at 83.6 s
    back = min(t for t, s in statuses.items() if t > GLITCH[1] and s["pressure_fault"] is None)
    assert GLITCH[1] + 5.0 <= back <= GLITCH[1] + 6.0
    assert node.core.ownship.baro.learned.offset_m == pytest.approx(0.0, abs=0.5)  # not pulled by the glitch
    assert node.status(90.0)["ownship"]["pressure_altitude_m"] == pytest.approx(ALT, abs=0.5)
    assert [c.datum_mismatch for t, c in changes if t < GLITCH[0]] == [False]  # the TA, before the glitch


def test_out_of_range_pressure_is_rejected_by_the_decoder_and_named_in_the_status(runs):
    node, changes, statuses = runs["out_of_range_1hpa"]
    assert node.counters["pressure.out_of_range"] == 451  # every sample, 5 Hz over 90 s
    assert baro_counts(node) == {}  # never reached the cross-check
    status = statuses[85.0]
    assert status["pressure_fault"] == "implausible" and not status["pressure_altitude_available"]
    assert any("ownship pressure implausible" in w for w in status["warnings"])
    assert all(c.datum_mismatch for _, c in changes)


def test_without_the_cross_check_the_same_faults_lose_or_delay_the_alerts():
    """Control: the encounters are sensitive to the faults (gates opened wide, the old trusting behaviour)."""
    wide = ["altitude.baro_gate_sigmas=1e9", "altitude.baro_offset_drift_mps=1e9",
            "altitude.baro_offset_min_m=-1e9", "altitude.baro_offset_max_m=1e9"]
    _, stuck, _ = fly(CASES["stuck_950"], overrides=wide)
    assert first(stuck, AdvisoryLevel.TA) is None and first(stuck, AdvisoryLevel.RA) is None
    _, glitch, _ = fly(CASES["glitch_1s_500hpa"], overrides=wide)
    assert first(glitch, AdvisoryLevel.RA) is None or first(glitch, AdvisoryLevel.RA) > T_RA + 5.0


# -- core-level implausible and recovery ---------------------------------------------------------------------
def test_implausible_pressure_altitude_through_the_core_api_is_counted_and_recovers():
    """A core caller (not the decoder) handing over a pressure altitude above 20 km, then good ones again."""
    node = Harness(load_config())
    core = node.core
    for k in range(0, 151):
        t = k * 0.2
        lat, lon = PLANE.to_geodetic(0.0, V * t)
        alt = 45000.0 if 10.0 <= t < 11.0 else ALT
        core.step(t, [OwnshipFix(t, float(lat), float(lon), ALT, ALT, (V, 0.0, 0.0)), OwnshipPressure(t, alt)])
        if t == 10.6:
            assert node.status(t)["pressure_fault"] == "implausible"
            assert core.ownship.state_at(t).pressure_altitude_m is None
    assert baro_counts(node) == {"baro.implausible": 5, "baro.recovered": 1}
    assert node.status(30.0)["pressure_fault"] is None
    assert core.ownship.state_at(30.0).pressure_altitude_m == pytest.approx(ALT, abs=0.1)


def test_counters_reach_the_core_counters():
    """The cross-check counts into the core's counters (status.counters on zenoh, `avionics run --counters`):
    pipeline/intake.py must build OwnshipFilter(config.altitude, config.input, counters)."""
    node = Harness(load_config())
    assert node.core.ownship.counters is node.core.counters


# -- the monitor alone: properties of the gates --------------------------------------------------------------
CFG = AltitudeConfig()
GNSS_SIGMA = 4.0


def feed(check, samples):
    for t, hp, hg, vz in samples:
        check.update(t, hp, hg, vz)


@given(climb=st.floats(-10.0, 10.0), noise=st.lists(st.floats(-1.0, 1.0), min_size=100, max_size=100),
       drift=st.floats(-CFG.baro_offset_drift_mps, CFG.baro_offset_drift_mps), bias=st.floats(-500.0, 1200.0))
def test_a_healthy_barometer_is_never_faulted(climb, noise, drift, bias):
    """Noise within 2 sigma (2 * 3.5 m), any climb up to 10 m/s, offset drift within the configured rate and any
    plausible offset: no fault over 20 s. (The gate is 5 sigma plus the drift allowance.)"""
    check = BaroCrossCheck(CFG, GNSS_SIGMA, Counter())
    for i, n in enumerate(noise):
        t = i * 0.2
        hg = 1000.0 + climb * t
        check.update(t, hg + bias + drift * t + 2.0 * CFG.baro_noise_sigma_m * n, hg, climb)
        assert check.fault is None, (t, check.counters)


@given(size=st.one_of(st.floats(-1000.0, -40.0), st.floats(40.0, 1000.0)), samples=st.integers(1, 10))
def test_a_glitch_beyond_the_gate_never_moves_the_learned_offset(size, samples):
    check = BaroCrossCheck(CFG, GNSS_SIGMA, Counter())
    feed(check, [(i * 0.2, 1000.0, 1000.0, 0.0) for i in range(50)])  # 10 s level, offset 0 confirmed
    learned = check.learned.offset_m
    feed(check, [(10.0 + i * 0.2, 1000.0 + size, 1000.0, 0.0) for i in range(samples)])
    assert check.fault == "jump" and check.learned.offset_m == learned
    assert check.offset_at(10.0 + samples * 0.2, 3.0) is None
    # back to good: used again only after baro_recovery_s of consistent samples
    t0 = 10.0 + samples * 0.2
    feed(check, [(t0 + i * 0.2, 1000.0, 1000.0, 0.0) for i in range(25)])
    assert check.fault == "jump"
    feed(check, [(t0 + 5.0, 1000.0, 1000.0, 0.0)])
    assert check.fault is None and check.offset_at(t0 + 5.0, 3.0) == pytest.approx(learned, abs=1e-9)


def test_a_fault_during_the_hold_restarts_it():
    check = BaroCrossCheck(CFG, GNSS_SIGMA, Counter())
    feed(check, [(i * 0.2, 1000.0, 1000.0, 0.0) for i in range(50)])
    feed(check, [(10.0, 1500.0, 1000.0, 0.0)])  # jump
    feed(check, [(10.2 + i * 0.2, 1000.0, 1000.0, 0.0) for i in range(20)])  # 4 s good
    feed(check, [(14.2, 1500.0, 1000.0, 0.0)])  # another glitch: the hold starts again
    feed(check, [(14.4 + i * 0.2, 1000.0, 1000.0, 0.0) for i in range(25)])  # 4.8 s good
    assert check.fault == "jump"
    feed(check, [(19.4, 1000.0, 1000.0, 0.0)])
    assert check.fault is None and dict(check.counters) == {"baro.jump": 2, "baro.recovered": 1}


@given(offset=st.one_of(st.floats(-5000.0, CFG.baro_offset_min_m - 1e-6),
                        st.floats(CFG.baro_offset_max_m + 1e-6, 5000.0)))
def test_an_offset_no_atmosphere_produces_is_implausible(offset):
    check = BaroCrossCheck(CFG, GNSS_SIGMA, Counter())
    check.update(0.0, 1000.0 + offset, 1000.0, 0.0)
    assert check.fault == "implausible" and check.learned is None and check.offset_at(0.0, 3.0) is None


def test_a_stuck_barometer_in_level_flight_is_not_flagged_until_the_altitude_changes():
    """Frozen at the right value, the reading is right: nothing to detect until GNSS says we moved 28.3 m."""
    check = BaroCrossCheck(CFG, GNSS_SIGMA, Counter())
    feed(check, [(i * 0.2, 1000.0, 1000.0, 0.0) for i in range(100)])
    assert check.fault is None
    feed(check, [(20.0 + i * 0.2, 1000.0, 1000.0 - 2.0 * i * 0.2, -2.0) for i in range(1, 100)])
    assert check.fault == "stuck"
    assert 20.0 + 28.3 / 2.0 <= check.fault_since_s <= 20.0 + 28.3 / 2.0 + 0.4


def test_the_ownship_state_asked_twice_at_one_instant_sees_what_came_between():
    """OwnshipFilter.state_at keeps its last answer for the stages that ask at the same instant (issue 32): a fix or
    a pressure sample that arrives at that instant must still be seen by the next ask."""
    from avionics.config import InputConfig
    from avionics.tracking.ownship import OwnshipFilter

    own = OwnshipFilter(CFG, InputConfig())
    own.update_fix(OwnshipFix(0.0, 0.0, 0.0, 100.0, 100.0, (10.0, 0.0, 0.0)), 0.0, 0.0)
    assert own.state_at(1.0).x[1] == pytest.approx(10.0)  # predicted 1 s north at 10 m/s
    own.update_fix(OwnshipFix(1.0, 0.0, 0.0, 120.0, 120.0, (10.0, 0.0, 0.0)), 0.0, 50.0)
    after_fix = own.state_at(1.0)
    assert (after_fix.x[1], after_fix.x[2]) == (50.0, 120.0)
    assert after_fix.pressure_altitude_m is None
    own.update_pressure(OwnshipPressure(1.0, 150.0))  # the first sample sets the offset (30 m above GNSS)
    assert own.state_at(1.0).pressure_altitude_m == pytest.approx(150.0)
