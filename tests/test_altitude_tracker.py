"""Active surveillance's Mode C altitude track (avionics/tracking/altitude_tracker.py): the vertical rate from the
times of 100 ft level transitions, against hand bounds over random climbs, descents and level flights replied to
at 1 Hz, and what the sensor tracker publishes with it."""

from __future__ import annotations

import math

import numpy as np
from hypothesis import given, settings, strategies as st

from avionics.tracking.altitude_tracker import (GUESRATE_MPS, MODE_C_QUANTUM_M, QuantisedAltitudeTrack,
                                                mode_c_quantum)
from avionics.tracking.measurement import PolarMeasurement
from avionics.tracking.sensor_tracker import SensorTracker
from avionics_sitl.sensors import ACTIVE_MODE_C
from tests.test_polar_tracking import h_modes, own_at, straight, v_modes

Q = MODE_C_QUANTUM_M


def mode_c(altitude_m: float) -> float:
    """The reply's altitude: the 100 ft level the aircraft is in (the simulator's sitl/avionics_sitl/sensors.py)."""
    return round(altitude_m / Q) * Q


def fly(z0: float, rate: float, seconds: int, phase: float = 0.0):
    """Replies at 1 Hz from t = phase to a track started at the first; yields (t, true altitude, track)."""
    track = None
    for k in range(seconds + 1):
        t = phase + k
        z = z0 + rate * t
        if track is None:
            track = QuantisedAltitudeTrack.start(t, mode_c(z), Q)
        else:
            track.update(t, mode_c(z))
        yield t, z, track


def test_the_mode_c_quantum_is_read_from_the_declared_sigma():
    """DEGAS and the simulator declare a Mode C altitude's error as the quantum's uniform q / sqrt(12); a Mode S
    25 ft reply (2.2 m) and an altimeter's own sigma are not a 100 ft quantum, and keep the Kalman filter."""
    assert mode_c_quantum(Q / math.sqrt(12.0)) == Q
    assert mode_c_quantum(ACTIVE_MODE_C.altitude_quantum_m / math.sqrt(12.0)) == Q
    assert mode_c_quantum(25 * 0.3048 / math.sqrt(12.0)) is None
    assert mode_c_quantum(9.0) is None and mode_c_quantum(None) is None


@settings(max_examples=60, deadline=None)
@given(st.floats(-300.0, 12000.0), st.floats(0.0, 0.99))
def test_a_level_aircraft_reads_level(z0, phase):
    """No transition, ever: the rate is 0 and the altitude the reply's level, within half a level of the truth."""
    for _, z, track in fly(z0, 0.0, 60, phase):
        alt, rate, var_z, var_zd = track.predicted(track.t_last)
        assert rate == 0.0 and abs(alt - z) <= Q / 2 + 1e-9
        assert var_z > 0.0 and var_zd > 0.0


@settings(max_examples=80, deadline=None)
@given(st.floats(-300.0, 12000.0), st.floats(1.7, 12.0), st.sampled_from([1, -1]), st.floats(0.0, 0.99))
def test_a_steady_climb_or_descent_is_read_from_its_level_transitions(z0, speed, sign, phase):
    """A constant rate v (1-12 m/s, 200-2400 ft/min) replied to at 1 Hz. Hand bounds:
    - the altitude estimate stays within one level of the truth at every reply (both lie in the reported level or
      at its edge);
    - from the first transition on, the rate has the climb's sign;
    - at every transition of a confirmed trend, the rate is q / t_bin with t_bin the time per level between
      transitions, each seen up to one reply late: t_bin within q/|v| +- 1 s, so |rate| within
      [q / (q/|v| + 1), q / (q/|v| - 1)] (q/|v| is at least 2.5 s here); and the true rate lies within the
      bounds the tracker publishes its variance from."""
    rate = sign * speed
    lo, hi = Q / (Q / speed + 1.0), Q / (Q / speed - 1.0)
    levels = mode_c(z0 + rate * phase)
    trends = 0
    for _, z, track in fly(z0, rate, 90, phase):
        assert abs(track.z - z) <= Q + 1e-9, (track.z, z)
        if track.level != levels:
            levels = track.level
            assert track.zd * sign > 0.0, track
            if track.state == "trend":
                trends += 1
                assert lo - 1e-9 <= abs(track.zd) <= hi + 1e-9, (track.zd, lo, hi)
                assert track.zd_lo - 1e-9 <= rate <= track.zd_hi + 1e-9, (rate, track.zd_lo, track.zd_hi)
    assert trends >= 2


def test_a_young_track_of_a_slow_climb_reads_the_guess_not_a_fast_climb():
    """NASA's scenario_6 in small: an intruder climbing at 2.4 m/s (about 480 ft/min), its first reply 10.8 m below
    a level boundary. The first transition shows 5 s later; a Kalman filter taking the 100 ft step as white noise
    read 10.2 m/s there (docs/tracking.md). TCAS II's tracker reads GUESRATE (480 ft/min) after one transition, and
    q / t_bin after the second, 12.7 s on."""
    start = 3.5 * Q - 10.8  # 10.8 m below the boundary between levels 3 and 4: crossed at 4.5 s, seen at 5 s
    seen = {round(t): (track.zd, track.state) for t, _, track in fly(start, 2.4, 20)}
    assert seen[4] == (0.0, "new")
    assert seen[5] == (GUESRATE_MPS, "guess")
    assert all(abs(seen[t][0] - GUESRATE_MPS) < 1e-9 for t in range(5, 18))
    assert seen[18][1] == "trend" and abs(seen[18][0] - Q / 13.0) < 1e-9


def test_an_aircraft_on_a_level_boundary_reads_level():
    """Replies that alternate between two levels (an aircraft holding an altitude on the boundary between them):
    after the first reversal the track is oscillating, its rate 0 and its altitude within a level of the
    boundary."""
    boundary = 40.5 * Q
    track = QuantisedAltitudeTrack.start(0.0, boundary - Q / 2, Q)
    for k in range(1, 30):
        track.update(float(k), boundary + (Q / 2 if k % 3 == 1 else -Q / 2))
    assert track.state == "oscillating" and track.zd == 0.0
    assert abs(track.z - boundary) <= Q


def test_the_sensor_tracker_publishes_the_mode_c_track_s_vertical():
    """An intruder 270 m below climbing at 2.4 m/s, seen by active surveillance (Mode C altitudes, the declared
    q / sqrt(12)): the published vertical rate is the Mode C track's, never above GUESRATE before the second
    transition, and the altitude within a level of the truth; with the declared sigma of an altimeter instead
    (no quantum), the Kalman filter's bank is published as before."""
    mount = ACTIVE_MODE_C.mount("1")
    target = lambda t: straight([300.0, 4000.0, 730.0], [0.0, -20.0, 2.4], t)  # noqa: E731
    published = {}
    for sigma in (Q / math.sqrt(12.0), 9.0):
        tracker = SensorTracker(h_modes(), v_modes())
        rates = []
        for t in np.arange(1.0, 12.0 + 1e-9, 1.0):
            own, tgt = own_at(t), target(t)
            rel = tgt[:3] - own[:3]
            meas = PolarMeasurement(mount, float(t), float(np.linalg.norm(rel)), math.atan2(rel[0], rel[1]), 15.24,
                                    math.radians(9.0), altitude_m=mode_c(float(tgt[2])), altitude_sigma_m=sigma)
            tracker.scan(float(t), [meas], own[:3], 0.0, own[3:6])
            if tracker.confirmed:
                (trk,) = tracker.confirmed
                x, p = tracker.predict([trk.track_id], float(t))
                rates.append(x[0, 5])
                if sigma != 9.0:
                    assert abs(x[0, 2] - tgt[2]) <= Q
                    assert p[0, 2, 5] == 0.0 and p[0, 5, 5] > 0.0
        published[sigma] = (trk.vertical is not None, max(rates))
    assert published[Q / math.sqrt(12.0)][0] and published[Q / math.sqrt(12.0)][1] <= GUESRATE_MPS + 1e-9
    assert not published[9.0][0]


def test_a_detection_with_an_elevation_instead_of_an_altitude_leaves_the_mode_c_track_as_it_was():
    """A scan source may mix kinds (a zenoh client sending one sensor id's returns with elevations after Mode C
    replies): the detection updates the banks and leaves the Mode C track, which has no altitude to take, as it
    was; nothing raises."""
    mount = ACTIVE_MODE_C.mount("1")
    tracker = SensorTracker(h_modes(), v_modes())
    target = lambda t: straight([300.0, 4000.0, 730.0], [0.0, -20.0, 0.0], t)  # noqa: E731
    for t in np.arange(1.0, 8.0 + 1e-9, 1.0):
        own, tgt = own_at(t), target(t)
        rel = tgt[:3] - own[:3]
        common = dict(range_m=float(np.linalg.norm(rel)), azimuth_rad=math.atan2(rel[0], rel[1]),
                      range_sigma_m=15.24, azimuth_sigma_rad=math.radians(9.0))
        if t < 6.0:
            meas = PolarMeasurement(mount, float(t), **common, altitude_m=mode_c(float(tgt[2])),
                                    altitude_sigma_m=Q / math.sqrt(12.0))
        else:
            meas = PolarMeasurement(mount, float(t), **common, elevation_rad=math.asin(rel[2] / np.linalg.norm(rel)),
                                    elevation_sigma_rad=math.radians(1.0))
        tracker.scan(float(t), [meas], own[:3], 0.0, own[3:6])
        if t == 5.0:
            (trk,) = tracker.confirmed
            before = (trk.vertical.t_last, trk.vertical.z, trk.vertical.zd)
    (trk,) = tracker.confirmed
    assert (trk.vertical.t_last, trk.vertical.z, trk.vertical.zd) == before
