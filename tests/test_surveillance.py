"""One surveillance picture in the pipeline (tracking/surveillance.py, issue 30): ADS-B reports and radar scans go
through DaaCore.step as the live process takes them (OwnshipFix with its heading, IntruderReport, SensorScan), and
what the assessment reads is one track per aircraft. The oracles are the parts' own, tested apart in
test_polar_tracking.py: fusion.fuse (Dai eqs 41-42 / covariance intersection) for the fused state, and the radar's
declared 3-sigma for an ADS-B fault."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from avionics.config import load_config
from avionics.base.types import AddressSource, IntruderKey, OwnshipFix, SensorScan
from avionics.pipeline.daa_core import DaaCore
from avionics.tracking import fusion
from avionics_sitl.sensors import RADAR, SimulatedSensor
from tests.test_polar_tracking import PLANE, adsb_reports, fault_target, own_at, straight, two_aircraft_03_nm_apart


def fix(t: float) -> OwnshipFix:
    s = own_at(t)
    lat, lon = PLANE.to_geodetic(s[0], s[1])
    return OwnshipFix(t, float(lat), float(lon), float(s[2]), float(s[2]) - 200.0, (float(s[4]), float(s[3]),
                      -float(s[5])), heading_deg=math.degrees(math.atan2(s[3], s[4])) % 360.0)


def fly(targets, duration_s, seed, adsb_target=None, fault=None, probe=None):
    """Step a DaaCore at 10 Hz: ownship fixes at 5 Hz, radar scans of `targets` at its 10 Hz (Appendix Q errors),
    ADS-B reports of adsb_target at 1 Hz (with `fault`); probe(core, t) after each step. Returns the core."""
    core = DaaCore(load_config(overrides=["advisory.profile=do365"]))
    sensor = SimulatedSensor(RADAR, "0", seed=seed)
    reports = []
    if adsb_target is not None:
        reports = adsb_reports(adsb_target, np.arange(0.5, duration_s, 1.0), np.random.default_rng(seed),
                               fault=fault)[1]
    k = 0
    for t in np.round(np.arange(0.1, duration_s + 1e-9, 0.1), 6):
        inputs = [fix(t)] if abs(t * 5 - round(t * 5)) < 1e-6 else []
        while k < len(reports) and reports[k][0].time_s <= t:
            inputs.append(reports[k][0])
            k += 1
        meas, _ = sensor.scan(t, own_at(t), 0.0, np.array([f(t) for f in targets]))
        if meas:
            inputs.append(SensorScan(float(t), "0", tuple(meas)))
        core.step(float(t), inputs)
        if probe is not None:
            probe(core, float(t))
    return core


def test_radar_only_aircraft_are_tracks_of_their_own_and_two_at_03_nm_are_two():
    a, b = two_aircraft_03_nm_apart()
    core = fly([a, b], 20.0, seed=3)
    keys = sorted(core.tracker.tracks)
    assert len(keys) == 2 and all(k.source is AddressSource.SENSOR for k in keys)
    x, _ = core.tracker.predict(keys, 20.0)
    truth = np.array([a(20.0)[:2], b(20.0)[:2]])
    # positions in the pipeline's plane are the test's plane shifted by where the ownship's first fix put it
    origin = np.array(core.frame.to_plane(*PLANE.to_geodetic(0.0, 0.0), (0.0, 0.0))[:2], float)
    err = np.linalg.norm(x[:, None, :2] - origin - truth[None], axis=2)
    # each aircraft its own track, within 60 m (the radar's 1.1 deg at 3.5 km: 60 m cross-range 1-sigma)
    assert (err.min(axis=0) < 60.0).all() and (err.min(axis=1) < 60.0).all()


def test_the_same_aircraft_on_adsb_and_radar_is_one_track_with_the_fused_state():
    target = lambda t: straight([500.0, 4000.0, 1050.0], [0.0, -30.0, 0.0], t)  # noqa: E731
    core = fly([target], 12.0, seed=5, adsb_target=target)
    key = IntruderKey(0xABC123, AddressSource.ES1090)
    assert list(core.tracker.tracks) == [key]
    assert core.counters["sensor.paired_with_adsb"] == 1
    sensor_key = core.tracker.paired[key]
    x, p = core.tracker.predict([key], 12.0)
    xa, pa = core.tracker.adsb.predict([key], 12.0)
    # the radar track as fusion reads it: its bias considered (SensorTracker.predict)
    xs, ps = core.tracker.sensors["radar"].predict([sensor_key.address], 12.0, consider_bias=True)
    xf, pf, _, _ = fusion.fuse(xa, pa, xs, ps, [False], cross="ci")
    np.testing.assert_allclose(x, xf, rtol=0, atol=1e-9)
    np.testing.assert_allclose(p, pf, rtol=0, atol=1e-9)


@pytest.mark.parametrize("size_m", [1852.0, 370.4])
def test_an_adsb_step_leaves_the_fused_track_within_the_radars_3_sigma(size_m):
    """The step of test_polar_tracking's fault cases (1 NM; NIC 7's containment radius) at 30 s, through the
    pipeline: the fused track (what the assessment reads) stays within the radar's 3-sigma at every second, as
    the ADS-B track alone does not."""
    u = np.array([math.cos(0.7), math.sin(0.7)])
    key = IntruderKey(0xABC123, AddressSource.ES1090)
    rows = []

    def probe(core, t):
        if t >= 10.0 and abs(t - round(t)) < 1e-6 and key in core.tracker.paired:
            origin = np.array(core.frame.to_plane(*PLANE.to_geodetic(0.0, 0.0), (0.0, 0.0))[:2], float)
            truth = fault_target(t)
            x, _ = core.tracker.predict([key], t)
            xa, _ = core.tracker.adsb.predict([key], t)
            rel = truth[:3] - own_at(t)[:3]
            rng_m = float(np.linalg.norm(rel))
            # the radar's declared horizontal 1-sigma: range and azimuth (random and bias in quadrature, DEGAS)
            sigma = max(math.hypot(21.34, 15.24), rng_m * math.radians(math.hypot(1.0, 0.5)))
            rows.append((t, float(np.linalg.norm(x[0, :2] - origin - truth[:2])),
                         float(np.linalg.norm(xa[0, :2] - origin - truth[:2])), 3.0 * sigma))

    fly([fault_target], 60.0, seed=7, adsb_target=fault_target,
        fault=lambda t: (size_m if t >= 30.0 else 0.0) * u, probe=probe)
    res = np.array(rows)
    assert len(res) >= 45, "paired with the ADS-B track for the whole run"
    t, fused, adsb, three_sigma = res.T
    assert (fused <= three_sigma).all(), res[fused > three_sigma]
    assert (adsb > three_sigma).any()


@settings(max_examples=25)
@given(steps=st.integers(1, 50))
def test_a_sensor_s_tracks_take_the_noise_per_second_the_1_s_values_were_set_for(steps):
    """compose.motion_models at a period of 1/steps s: `steps` predictions add to the state each model drives
    (CV's and CAD's velocity, CT's and CA's acceleration, CH's vertical speed) exactly the variance one 1 s
    prediction adds at [tracking]'s per-step values (by hand: those states evolve as a random walk, F's row is
    the identity on them, so their variances add)."""
    from avionics.compose import motion_models
    from avionics.tracking.params import TrackingConfig

    config = TrackingConfig(imm_horizontal_modes=("cv", "ct", "ca"))
    period = 1.0 / steps
    driven = {"cv": [2, 3], "ct": [4, 5], "ca": [4, 5], "ch": [1], "cad": [1]}
    for one_s, fast in zip(*(sum(motion_models(config, p), []) for p in (1.0, period))):
        idx = driven[one_s.name]
        f, _, q = fast.matrices(np.array([period]))
        p = np.zeros_like(q[0])
        for _ in range(steps):
            p = f[0] @ p @ f[0].T + q[0]
        expected = one_s.matrices(np.array([1.0]))[2][0]
        assert np.allclose(np.diag(p)[idx], np.diag(expected)[idx], rtol=1e-9), one_s.name


def test_the_radar_tracks_have_the_turn_modes_and_active_surveillance_the_adsb_modes():
    """[tracking] radar_horizontal_modes for a radar's tracks, with a turn left at imm_turn_exit_probability and
    the other modes, vertical ones too, at radar_switch_probability (models.mode_switching); active
    surveillance's keep the ADS-B tracks' imm_horizontal_modes and imm_switch_probability (docs/tracking.md,
    "Turns seen by a radar")."""
    from collections import Counter

    from avionics.compose import build_surveillance

    config = load_config().tracking
    surveillance = build_surveillance(config, Counter())
    radar_tracker, active_tracker = surveillance._tracker("radar", 0.1), surveillance._tracker("active", 1.0)
    radar, active = radar_tracker.bank_h, active_tracker.bank_h
    assert radar.names == list(config.radar_horizontal_modes) == ["cv", "ct", "turn_left", "turn_right"]
    np.testing.assert_allclose(np.diag(radar.chain.at(1.0)[0]), [0.99, 0.99, 0.8, 0.8], atol=1e-12)
    np.testing.assert_allclose(np.diag(radar_tracker.bank_v.chain.at(1.0)[0]), 0.99, atol=1e-12)
    assert active.names == list(config.imm_horizontal_modes)
    for bank in (active, active_tracker.bank_v):
        np.testing.assert_allclose(np.diag(bank.chain.at(1.0)[0]), 1.0 - config.imm_switch_probability, atol=1e-12)
