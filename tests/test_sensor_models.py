"""The simulated range/bearing sensors (sitl sensors.py): DO-365 Appendix Q as DEGAS codes them, and `noise none`."""

from __future__ import annotations

import math

import numpy as np
import pytest

from avionics.base.units import FT, NM
from avionics_sitl.sensors import ACTIVE_MODE_C, RADAR, SimulatedSensor

OWN = np.array([0.0, 0.0, 1000.0, 0.0, 40.0, 0.0])


def target(east, north, up, v=(0.0, -50.0, 0.0)):
    return np.array([east, north, 1000.0 + up, *v])


def test_radar_field_of_regard_and_minimum_range():
    radar = SimulatedSensor(RADAR, seed=1)
    inside = target(2000.0, 3000.0, 100.0)
    behind = target(0.0, -3000.0, 0.0)  # 180 deg off the nose: outside +-110
    high = target(0.0, 3000.0, 1000.0)  # 18 deg up: outside +-15
    close = target(0.0, 1000.0, 0.0)  # inside RCPR's 4000 ft
    seen = radar.in_view(OWN, 0.0, np.array([inside, behind, high, close]))
    assert seen.tolist() == [True, False, False, False]
    assert 4000 * FT > 1000.0  # the close target is inside the minimum range


def test_radar_errors_have_the_appendix_q_spread_and_a_bounded_bias():
    radar = SimulatedSensor(RADAR, seed=2)
    tgt = target(3000.0, 4000.0, 0.0)
    rel = tgt[:3] - OWN[:3]
    r_true, az_true = np.linalg.norm(rel), math.atan2(rel[0], rel[1])
    meas = [radar.scan(0.1 * k, OWN, 0.0, tgt[None])[0][0] for k in range(1, 2001)]
    r_err = np.array([m.range_m for m in meas]) - r_true
    az_err = np.degrees(np.array([m.azimuth_rad for m in meas]) - az_true)
    assert r_err.std() == pytest.approx(21.34, rel=0.08)
    assert abs(r_err.mean()) <= 15.24 + 3.0  # the bias: uniform in +-15.24 m
    assert az_err.std() == pytest.approx(1.0, rel=0.08)
    assert abs(az_err.mean()) <= 0.5 + 0.1
    m = meas[0]
    assert m.range_sigma_m == pytest.approx(math.hypot(21.34, 15.24))  # declared: random and bias (DEGAS)
    assert m.range_rate_mps is not None and m.elevation_rad is not None and m.altitude_m is None


def test_active_surveillance_reports_mode_c_altitude_misses_a_tenth_and_slows_when_far():
    active = SimulatedSensor(ACTIVE_MODE_C, seed=3)
    tgt = target(1000.0, 5000.0, 137.0)
    got = [active.scan(float(k), OWN, 0.0, tgt[None])[0] for k in range(2000)]
    detected = np.array([len(g) for g in got])
    assert detected.mean() == pytest.approx(0.90, abs=0.02)  # 1 - 0.10^(1/10) per 0.1 s over 1 s
    alt = {g[0].altitude_m for g in got if g}
    assert alt == {round((1000.0 + 137.0) / (100 * FT)) * 100 * FT}  # 100 ft steps
    behind = target(0.0, -9.0 * NM, 0.0)
    assert not active.in_view(OWN, 0.0, behind[None])[0]  # 8.0 NM behind (Mode C)
    assert active.in_view(OWN, 0.0, target(0.0, 19.0 * NM, 0.0)[None])[0]  # 20.6 NM ahead
    assert ACTIVE_MODE_C.period_s(30.0) == 1.0 and ACTIVE_MODE_C.period_s(90.0) == 5.0


def test_false_returns_come_at_the_configured_rate_and_name_no_aircraft():
    from dataclasses import replace

    noisy = SimulatedSensor(replace(RADAR, false_returns_per_scan=0.5, detection_probability=0.8), seed=4)
    truths = [noisy.scan(0.1 * k, OWN, 0.0, target(0.0, 3000.0, 0.0)[None])[1] for k in range(1, 2001)]
    n_false = sum(t.count(None) for t in truths)
    n_true = sum(t.count(0) for t in truths)
    assert n_false / 2000 == pytest.approx(0.5, rel=0.1)
    assert n_true / 2000 == pytest.approx(0.8, abs=0.03)


@pytest.mark.parametrize("model", [RADAR, ACTIVE_MODE_C], ids=["radar", "active"])
def test_noise_none_measures_exactly_and_sees_all_round(model):
    exact = SimulatedSensor(model.exact_model(), seed=5)
    tgt = target(-300.0, -700.0, 600.0)  # behind, 37 deg up, 1 km: outside every limit of the noisy models
    (m,), (who,) = exact.scan(1.0, OWN, 0.0, tgt[None])
    rel = tgt[:3] - OWN[:3]
    assert who == 0
    assert m.range_m == pytest.approx(np.linalg.norm(rel), abs=1e-9)
    assert m.azimuth_rad == pytest.approx(math.atan2(rel[0], rel[1]), abs=1e-12)
    if m.elevation_rad is not None:
        assert m.elevation_rad == pytest.approx(math.asin(rel[2] / np.linalg.norm(rel)), abs=1e-12)
    else:
        assert m.altitude_m == pytest.approx(tgt[2])
