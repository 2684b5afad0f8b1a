"""ADS-B integrity monitor (avionics/tracking/integrity.py): each failure mode detected on a synthetic track, clean
tracks never flagged, the flag on zenoh and DAA_ADVISORY, the frozen position no longer restarting the track, and
the TA floor for a degraded track inside DMOD and ZTHR by its reported position."""

import math
from collections import Counter

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st
from scipy.stats import chi2

from avionics.compose import build_tracker
from avionics.config import load_config
from avionics.base.types import AddressSource, Advisory, AdvisoryLevel, AltitudeDatum, IntruderKey, IntruderReport, \
    TrackView
from avionics.base.units import KT
from avionics.io import encode
from avionics.io.dialect import daa
from avionics.io.framing import FrameScanner
from avionics.io.payloads import advisory_payload, track_payload
from avionics.monitor.schema import clean_sample
from avionics.tracking import integrity as im

KEY = IntruderKey(0xA1B2C3, AddressSource.ES1090)
M_PER_DEG = 111_195.0  # only for the lat/lon the monitor uses across a plane change (none here)


def _tracker(filter_name="imm"):
    counters = Counter()
    return build_tracker(load_config(overrides=[f"tracking.filter={filter_name}"]).tracking, counters), counters


def _fly(fault=None, filter_name="imm", seed=0, duration=300, onset=140.0, speed=150 * KT, turn_dps=0.0,
         noise=(12.3, 1.2)):
    """A 1 Hz track (straight, or turning at turn_dps) with white noise; fault from onset. Returns per second the
    track's integrity label, and the counters."""
    tracker, counters = _tracker(filter_name)
    rng = np.random.default_rng(seed)
    e = n = 0.0
    psi = math.radians(30.0)
    frozen = None
    labels = []
    for k in range(duration):
        t = float(k)
        if k:
            psi += math.radians(turn_dps)
            e, n = e + speed * math.sin(psi), n + speed * math.cos(psi)
        ze, zn = e + rng.normal(0, noise[0]), n + rng.normal(0, noise[0])
        tau = t - onset
        if fault == "step" and tau >= 0:
            ze += 500.0
        elif fault == "ramp" and tau >= 0:
            zn += 10.0 * tau
        elif fault == "oscillation" and tau >= 0:
            ze += 500.0 * math.sin(2 * math.pi * tau / 20.0)
        elif fault == "frozen" and tau >= 0:
            frozen = frozen or (ze, zn)
            ze, zn = frozen
        if not (fault == "loss" and tau >= 0):
            v = (speed * math.sin(psi) + rng.normal(0, noise[1]), speed * math.cos(psi) + rng.normal(0, noise[1]))
            rep = IntruderReport(KEY, t, t, zn / M_PER_DEG, ze / M_PER_DEG, 1500.0, AltitudeDatum.PRESSURE, v, 0.0)
            tracker.ingest(rep, ze, zn)
        for sub in range(10):  # the pipeline's 10 Hz assessments
            tracker.prune(t + 0.1 * sub)
        labels.append(tracker.tracks[KEY].integrity.label if KEY in tracker.tracks else "deleted")
    return labels, counters


def test_the_window_threshold_is_the_chi_square_quantile():
    assert im.Q_THRESHOLD == pytest.approx(chi2.ppf(1 - im.ALPHA, 2))
    assert im.Q_THRESHOLD == pytest.approx(-2 * math.log(im.ALPHA))  # chi2 with 2 dof: exponential tail


@pytest.mark.parametrize("filter_name", ["imm", "cv"])
@pytest.mark.parametrize("fault, mode, within_s", [
    ("loss", "position_loss", 5), ("step", "step", 2), ("ramp", "ramp", 40), ("oscillation", "oscillation", 20),
    ("frozen", "inconsistent", 4)])
def test_each_failure_mode_is_detected_and_named(filter_name, fault, mode, within_s):
    labels, _ = _fly(fault, filter_name)
    assert set(labels[:140]) == {"ok"}
    after = labels[140:140 + within_s + 1]
    assert f"degraded:{mode}" in after, after
    if fault == "step":  # a one-time jump: held while the longest window holds it, then ok again
        assert labels[140 + 2:140 + int(im.WINDOWS[-1])] == [f"degraded:{mode}"] * (int(im.WINDOWS[-1]) - 2)
        assert labels[-1] == "ok"
    elif fault != "loss":  # a persisting fault stays flagged (a lost track is deleted after delete_after_s)
        assert labels[-1] == f"degraded:{mode}"


def test_a_ramp_is_flagged_before_its_error_reaches_the_nic7_containment_radius():
    labels, _ = _fly("ramp")  # 10 m/s: 370.4 m after 37 s
    first = next(k for k, lab in enumerate(labels) if lab != "ok")
    assert 140 < first < 140 + im.RC_NIC7_M / 10.0


def test_the_consistency_statistic_by_hand():
    """Two reports: the residual is the displacement minus the trapezoid of the velocities (hand-computed), and
    q its normalised square with the documented covariance."""
    mon = im.IntegrityMonitor(velocity_sigma_mps=2.0)
    key = "k"
    mon.observe([key], [0.0], [0.0], [0.0], [0.0], [(100.0, 0.0)], [30.0])
    # displacement 100 m east + 600 m north step; trapezoid (100 + 100)/2 * 1 s = 100 m east
    mon.observe([key], [1.0], [1.0], [100.0], [600.0], [(100.0, 0.0)], [30.0])
    status = mon.status(key)
    assert status.mode == "step"
    u = np.array([0.0, 600.0])  # hand: (100, 600) - (100, 0)
    iso = 2 * 30.0**2 + 2.0**2 * 0.5 + (im.VELOCITY_BIAS_MPS * 1.0) ** 2
    jitter_e = im.TIME_JITTER_S**2 * (100.0**2 * 2)  # along-track (east) only
    q = u[0] ** 2 / (iso + jitter_e) + u[1] ** 2 / iso
    assert q > im.Q_THRESHOLD
    assert status.fault_m == pytest.approx(max(600.0, im.RC_NIC7_M))


def test_widening_adds_the_fault_size_to_the_position_variance():
    mon = im.IntegrityMonitor(velocity_sigma_mps=2.0)
    mon.observe(["a", "b"], [0.0, 0.0], [0.0, 0.0], [0.0, 0.0], [0.0, 0.0], [(50.0, 0.0), (50.0, 0.0)], [30.0, 30.0])
    mon.observe(["a", "b"], [1.0, 1.0], [1.0, 1.0], [50.0, 1050.0], [0.0, 0.0], [(50.0, 0.0), (50.0, 0.0)], [30.0, 30.0])
    p = np.tile(np.eye(6), (2, 1, 1))
    wide = mon.widen(["a", "b"], p)
    assert np.array_equal(wide[0], p[0])
    assert wide[1, 0, 0] == pytest.approx(1 + 1000.0**2) and wide[1, 2, 2] == 1.0


@settings(max_examples=12, deadline=None)
@given(seed=st.integers(0, 2**31 - 1), turn=st.sampled_from([0.0, 1.5, -3.0]),
       speed=st.floats(40.0, 250.0), filter_name=st.sampled_from(["imm", "cv"]))
def test_a_clean_track_is_never_flagged(seed, turn, speed, filter_name):
    labels, _ = _fly(None, filter_name, seed=seed, duration=600, speed=speed, turn_dps=turn)
    assert set(labels) == {"ok"}


def test_the_frozen_position_no_longer_restarts_the_track_and_is_flagged():
    """The OpenSky case of issue 10: frozen position, velocity 150 kt, 300 s: it restarted 19 times unflagged."""
    labels, counters = _fly("frozen", duration=60 + 300, onset=60.0)
    assert counters["track.restarted"] == 0
    assert labels[60 + 3:] == ["degraded:inconsistent"] * (300 - 3)


def _advisory(integrity="ok"):
    return Advisory(intruder=KEY, level=AdvisoryLevel.TA, time_s=10.0, reason="range", sensitivity_level=4,
                    range_m=900.0, closure_rate_mps=10.0, t_cpa_s=30.0, hmd_m=100.0, vmd_m=50.0, range_tau_s=40.0,
                    mod_tau_s=30.0, vertical_tau_s=60.0, altitude_datum=AltitudeDatum.PRESSURE,
                    datum_mismatch=False, integrity=integrity)


@pytest.mark.parametrize("label, code", [("ok", daa.DAA_INTEGRITY_OK),
                                         ("degraded:inconsistent", daa.DAA_INTEGRITY_INCONSISTENT),
                                         ("degraded:step", daa.DAA_INTEGRITY_STEP)])
def test_the_flag_reaches_daa_advisory(label, code):
    mav = daa.MAVLink(None, 1, 191)
    (msg,) = FrameScanner(Counter()).feed(bytes(encode.daa_advisory(_advisory(label), "ABC").pack(mav)), True)
    assert msg.get_type() == "DAA_ADVISORY" and msg.integrity == code
    assert bool(msg.flags & daa.DAA_ADVISORY_FLAGS_INTEGRITY_DEGRADED) == (label != "ok")


def test_the_flag_reaches_the_zenoh_payloads_and_the_monitor_accepts_them():
    track_tracker, _ = _tracker()
    for k in range(20):  # 77 m/s east, the position frozen from k = 10 on
        east = 77.0 * min(k, 9)
        rep = IntruderReport(KEY, float(k), float(k), 0.0, east / M_PER_DEG, 1500.0, AltitudeDatum.PRESSURE,
                             (77.0, 0.0), 0.0)
        track_tracker.ingest(rep, east, 0.0)
    track = track_tracker.tracks[KEY]
    assert track.integrity.label == "degraded:inconsistent"
    x, p = track_tracker.predict([KEY], 20.0)
    payload = track_payload("uav1", TrackView.of(track, 20.0, x[0], p[0], 0.0, 0.0, True,
                                                 _advisory(track.integrity.label)))
    assert payload["integrity"] == "degraded:inconsistent" and payload["integrity_fault_m"] >= im.RC_NIC7_M
    assert clean_sample("tracks", payload)["integrity"] == "degraded:inconsistent"
    adv = advisory_payload("uav1", _advisory("degraded:inconsistent"))
    assert clean_sample("advisories", adv)["integrity"] == "degraded:inconsistent"


def _core_with_degraded_intruder(stale_position_m):
    """An intruder whose reported position froze `stale_position_m` north of the ownship (co-altitude), while its
    velocity says it flies away at 150 kt: the track dead-reckons away, the reported position stays close."""
    from avionics.base.geodesy import LocalTangentPlane
    from avionics.base.types import OwnshipFix, OwnshipPressure
    from avionics.pipeline.daa_core import DaaCore

    core = DaaCore(load_config(overrides=["zenoh.enabled=false"]))
    plane = LocalTangentPlane(47.0, 8.0)
    out = []
    for k in range(40):
        t = float(k)
        fix = OwnshipFix(t, 47.0, 8.0, 1000.0, 1000.0, (0.0, 0.0, 0.0))
        north = stale_position_m if k >= 20 else stale_position_m - 77.0 * (20 - k)
        lat, lon = plane.to_geodetic(0.0, north)
        rep = IntruderReport(KEY, t, t, float(lat), float(lon), 1000.0, AltitudeDatum.PRESSURE, (0.0, 77.0), 0.0)
        for sub in range(10):
            res = core.step(t + 0.1 * sub, [fix, OwnshipPressure(t, 1000.0), rep] if sub == 0 else [])
            out += [a for a in res.assessed if a.intruder == KEY]
    return core, out


def test_a_degraded_intruder_inside_dmod_and_zthr_by_its_reported_position_gets_at_least_a_ta():
    core, assessed = _core_with_degraded_intruder(300.0)
    track = core.tracker.tracks[KEY]
    assert track.integrity.label == "degraded:inconsistent"
    last = assessed[-1]
    assert last.range_m > 1500.0  # the track itself has flown away on the reported velocity ...
    assert last.level >= AdvisoryLevel.TA  # ... but the reported position is inside DMOD and ZTHR


def test_the_ta_floor_needs_the_reported_position_inside_dmod():
    core, assessed = _core_with_degraded_intruder(20_000.0)
    assert core.tracker.tracks[KEY].integrity.degraded
    assert assessed[-1].level is AdvisoryLevel.NONE


def test_the_core_advisory_carries_the_integrity_label():
    _, assessed = _core_with_degraded_intruder(300.0)
    assert assessed[-1].integrity == "degraded:inconsistent"


def test_the_report_runs_small():
    from avionics_eval.reports.tracking import integrity

    res = integrity(encounters=2, clean_tracks=2, clean_duration_s=300.0)
    assert set(res["modes"]) == {"loss", "step", "ramp", "oscillation", "frozen"}
    assert all(m["detected"] == 2 for m in res["modes"].values())
    assert res["clean"]["false_detections"] == 0


def test_a_recentred_plane_is_not_a_step():
    """The trackers' reframe carries the monitor's last positions (avionics/base/frame.py): no false step."""
    from avionics.base.frame import FrameChange
    from avionics.base.geodesy import LocalTangentPlane

    old, new = LocalTangentPlane(47.0, 8.0), LocalTangentPlane(47.0, 8.0133)  # ~1 km east
    mon = im.IntegrityMonitor(velocity_sigma_mps=2.0)
    for k in range(20):
        plane = old if k < 10 else new
        if k == 10:
            mon.reframe(FrameChange(old, new))
        lat, lon = old.to_geodetic(100.0 * k, 0.0)
        e, n = plane.to_en(lat, lon)
        mon.observe(["k"], [float(k)], [float(k)], [float(e)], [float(n)], [(100.0, 0.0)], [30.0])
    assert mon.status("k") is im.OK


@settings(max_examples=60, deadline=None)
@given(st.lists(st.tuples(st.floats(0.2, 3.0), st.floats(-50.0, 50.0), st.floats(-50.0, 50.0),
                          st.booleans(), st.booleans(), st.floats(0.0, 0.5), st.sampled_from([0.0, 3.0, 30.0])),
                min_size=1, max_size=40),
       st.floats(-200.0, 200.0), st.floats(-200.0, 200.0))
def test_a_lone_report_gives_what_the_vectorised_path_gives(steps, ve, vn):
    """observe() on one report takes a path of its own on Python floats (the usual step); the oracle is the
    vectorised path, reached by observing the same key beside a second, unrelated key. Stale flags, the status and
    the widening agree exactly, step after step, through jumps, frozen positions, missing velocities, zero sigmas."""
    lone, batched = im.IntegrityMonitor(2.0), im.IntegrityMonitor(2.0)
    key, other = IntruderKey(1, AddressSource.ES1090), IntruderKey(2, AddressSource.ES1090)
    t, e, n = 0.0, 0.0, 0.0
    for k, (dt, jump_e, jump_n, frozen, no_velocity, latency, sigma) in enumerate(steps):
        t += dt
        if not frozen:
            e, n = e + ve * dt + jump_e, n + vn * dt + jump_n
        v = (math.nan, math.nan) if no_velocity else (ve, vn)
        a = lone.observe([key], [t], [t + latency], np.array([e]), np.array([n]), [v], [sigma])
        b = batched.observe([key, other], [t, t], [t + latency, t], np.array([e, 5e4 + k]), np.array([n, 0.0]),
                            [v, (0.0, 0.0)], [sigma, 30.0])
        assert bool(a[0]) == bool(b[0])
        assert lone.status(key) == batched.status(key)
        p = np.repeat(np.eye(6)[None], 1, axis=0)
        np.testing.assert_array_equal(lone.widen([key], p.copy()), batched.widen([key], p.copy()))
