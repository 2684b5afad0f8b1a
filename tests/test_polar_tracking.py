"""Range/bearing sensors (issue 30 items 2-4): the converted measurement against a Monte Carlo of its error, the
sensor tracks (M-of-N, gate + GNN), one track per aircraft across ADS-B and radar, and the fusion under ADS-B
faults (Dai et al. 2017 Sec. 2.3 and 3.7)."""

from __future__ import annotations

import math
from collections import Counter

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings, strategies as st

from avionics.config import load_config
from avionics.core.geodesy import LocalTangentPlane
from avionics.core.types import AddressSource, AltitudeDatum, IntruderKey, IntruderReport
from avionics.core.units import NM
from avionics.tracking import fusion, models
from avionics.tracking.imm import ImmBank
from avionics.tracking.imm_tracker import ImmTracker
from avionics.tracking.measurement import PolarMeasurement, SensorMount, convert
from avionics.tracking.sensor_tracker import SensorTracker
from avionics_sitl.sensors import ACTIVE_MODE_C, RADAR, SimulatedSensor

CFG = load_config().tracking
PLANE = LocalTangentPlane(47.4, 8.5)


def h_modes():
    return [models.ConstantVelocity(CFG.imm_cv_sigma_mps2), models.CoordinatedTurn(CFG.imm_ct_sigma_mps2)]


def v_modes():
    return [models.ConstantHeight(CFG.imm_ch_sigma_mps), models.ConstantAltitudeChange(CFG.imm_cad_sigma_mps2)]


# -- the converted measurement ----------------------------------------------------------------------------

@settings(max_examples=12, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(r=st.floats(500.0, 40000.0), b=st.floats(-math.pi, math.pi), e=st.floats(-0.4, 0.4),
       sr=st.floats(5.0, 80.0), sb_deg=st.floats(0.5, 15.0), se_deg=st.floats(0.0, 5.0), seed=st.integers(0, 2**16))
def test_converted_measurement_is_unbiased_and_its_covariance_matches_a_monte_carlo(r, b, e, sr, sb_deg, se_deg, seed):
    n = 40000
    rng = np.random.default_rng(seed)
    sb, se = math.radians(sb_deg), math.radians(se_deg)
    z, cov = convert(r + rng.normal(0, sr, n), b + rng.normal(0, sb, n), e + rng.normal(0, se, n), sr, sb, se)
    truth = r * np.array([math.cos(e) * math.sin(b), math.cos(e) * math.cos(b), math.sin(e)])
    err = z - truth
    mc = np.cov(err.T)
    mean_r = cov.mean(axis=0)
    keep = np.diag(mean_r) > 1e-6  # no elevation error: the vertical is exact up to range noise
    sd = np.sqrt(np.diag(mc))
    # unbiased: the mean error within 5 standard errors
    assert (np.abs(err.mean(axis=0))[keep] <= 5 * sd[keep] / math.sqrt(n) + 1e-9).all()
    # the covariance: the mean R against the Monte Carlo's, whitened (eigenvalues of R^-1/2 C R^-1/2 near 1)
    idx = np.flatnonzero(keep)
    w = np.linalg.cholesky(mean_r[np.ix_(idx, idx)])
    whitened = np.linalg.solve(w, np.linalg.solve(w, mc[np.ix_(idx, idx)]).T)
    eig = np.linalg.eigvalsh(0.5 * (whitened + whitened.T))
    assert eig.min() > 0.9 and eig.max() < 1.1, eig


def test_a_bad_measurement_is_named_and_counted_not_tracked():
    mount = RADAR.mount("radar0")
    bad = [PolarMeasurement(mount, 1.0, float("nan"), 0.1, 20.0, 0.02, elevation_rad=0.0, elevation_sigma_rad=0.02),
           PolarMeasurement(mount, 1.0, 3000.0, 0.1, 20.0, 0.02),  # neither elevation nor altitude
           PolarMeasurement(mount, 1.0, -5.0, 0.1, 20.0, 0.02, altitude_m=100.0, altitude_sigma_m=9.0)]
    assert all(m.problem() for m in bad)
    counters = Counter()
    tracker = SensorTracker(h_modes(), v_modes(), counters=counters)
    assert tracker.scan(1.0, bad, np.zeros(3), 0.0) == [None] * 3
    assert counters["sensor.rejected"] == 3 and not tracker.tracks
    with pytest.raises(ValueError):
        SensorMount("x", "sonar")


# -- scenario helpers -------------------------------------------------------------------------------------

def straight(p0, v, t):
    """[e, n, alt, ve, vn, vu] at times t of a straight, level-or-climbing flight."""
    t = np.asarray(t, float)[..., None]
    return np.concatenate([np.asarray(p0) + np.asarray(v) * t, np.broadcast_to(v, t.shape[:-1] + (3,))], axis=-1)


OWN_V = np.array([0.0, 40.0, 0.0])  # the ownship flies north at 40 m/s, 1000 m


def own_at(t):
    return straight([0.0, 0.0, 1000.0], OWN_V, t)


def run_radar(targets, duration_s, seed, errors=RADAR):
    """Scan the targets (callables t -> state) with a simulated radar; returns the tracker at the end."""
    sensor = SimulatedSensor(errors, "radar0", seed=seed)
    tracker = SensorTracker(h_modes(), v_modes())
    for t in np.arange(0.1, duration_s + 1e-9, 1.0 / errors.rate_hz):
        own = own_at(t)
        meas, _ = sensor.scan(t, own, 0.0, np.array([f(t) for f in targets]))
        tracker.scan(t, meas, own[:3], 0.0)
    return tracker


def test_two_aircraft_03_nm_apart_on_radar_only_are_two_tracks():
    sep = 0.3 * NM
    a = lambda t: straight([-sep / 2, 3500.0, 1050.0], [0.0, -30.0, 0.0], t)  # noqa: E731
    b = lambda t: straight([sep / 2, 3500.0, 1050.0], [0.0, -30.0, 0.0], t)  # noqa: E731
    tracker = run_radar([a, b], 20.0, seed=3)
    confirmed = tracker.confirmed
    assert len(confirmed) == 2
    x, _ = tracker.predict([t.track_id for t in confirmed], 20.0)
    truth = np.array([a(20.0)[:2], b(20.0)[:2]])
    # each aircraft has its own track, within 60 m (the radar's 1.1 deg at 3 km: 60 m cross-range 1-sigma)
    err = np.linalg.norm(x[:, None, :2] - truth[None], axis=2)
    assert (err.min(axis=0) < 60.0).all() and (err.min(axis=1) < 60.0).all()


def test_a_track_needs_m_of_n_detections_and_a_false_return_makes_none():
    lone = SimulatedSensor(RADAR, seed=1)
    tracker = SensorTracker(h_modes(), v_modes(), confirm=(3, 5))
    target = lambda t: straight([500.0, 4000.0, 1000.0], [0.0, -30.0, 0.0], t)  # noqa: E731
    for k, t in enumerate(np.arange(0.1, 0.45, 0.1)):
        meas, _ = lone.scan(t, own_at(t), 0.0, target(t)[None])
        tracker.scan(t, meas, own_at(t)[:3], 0.0)
        assert len(tracker.confirmed) == (1 if k >= 2 else 0)
    # a single return far from anything starts a tentative track that dies unconfirmed
    stray = PolarMeasurement(lone.mount, 0.5, 6000.0, 1.0, 25.0, 0.02, elevation_rad=0.0, elevation_sigma_rad=0.02)
    tracker.scan(0.5, [stray], own_at(0.5)[:3], 0.0)
    for t in (0.6, 0.7, 0.8):
        tracker.scan(t, [], own_at(t)[:3], 0.0)
    assert len(tracker.tracks) == 1 and len(tracker.confirmed) == 1


# -- ADS-B and radar: one aircraft ------------------------------------------------------------------------

def adsb_reports(state_at, times, rng, sigma_m=12.0, fault=None):
    """ADS-B reports (NACp 9 noise, 1 kt-ish velocity noise) at `times`, with an optional position fault f(t)."""
    key = IntruderKey(0xABC123, AddressSource.ES1090)
    out = []
    for t in times:
        s = state_at(t)
        pos = s[:2] + rng.normal(0, sigma_m, 2) + (fault(t) if fault else 0.0)
        lat, lon = PLANE.to_geodetic(pos[0], pos[1])
        vel = s[3:5] + rng.normal(0, 0.5, 2)
        out.append((IntruderReport(key, t, t, float(lat), float(lon), float(s[2]), AltitudeDatum.PRESSURE,
                                   (float(vel[0]), float(vel[1])), float(s[5]), position_sigma_m=sigma_m), pos))
    return key, out


@settings(max_examples=8, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(rng_m=st.floats(2500.0, 8000.0), az_deg=st.floats(-90.0, 90.0), dalt=st.floats(-200.0, 200.0),
       heading_deg=st.floats(0.0, 360.0), speed=st.floats(20.0, 60.0), seed=st.integers(0, 2**16))
def test_the_same_aircraft_on_adsb_and_radar_is_one_track(rng_m, az_deg, dalt, heading_deg, speed, seed):
    """Any geometry inside the radar's field of regard for the 8 s (range >= 2500 m, |azimuth| <= 90 deg, at most
    7.6 deg of elevation, at most 800 m flown by both): one radar track, paired with the ADS-B track."""
    a = math.radians(az_deg)
    p0 = [rng_m * math.sin(a), rng_m * math.cos(a), 1000.0 + dalt]
    v = [speed * math.sin(math.radians(heading_deg)), speed * math.cos(math.radians(heading_deg)), 0.0]
    target = lambda t: straight(p0, v, t)  # noqa: E731
    radar = run_radar([target], 8.0, seed)
    adsb = ImmTracker(CFG, Counter(), h_modes(), v_modes(), compiled=False)
    key, reps = adsb_reports(target, np.arange(0.5, 8.0, 1.0), np.random.default_rng(seed))
    for rep, pos in reps:
        adsb.ingest(rep, pos[0], pos[1])
    xa, pa = adsb.predict([key], 8.0)
    ids = [t.track_id for t in radar.confirmed]
    xs, ps = radar.predict(ids, 8.0)
    assert len(ids) == 1
    assert fusion.pair_tracks(xa, pa, xs, ps) == [(0, 0)]
