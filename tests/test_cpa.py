"""CPA and tau against brute-force sampling of the relative trajectory and hand-computed cases."""

import math

import numpy as np
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from avionics.conflict.cpa import modified_tau, pair_geometry

coord = st.floats(-20000, 20000, allow_nan=False, allow_subnormal=False)
speed = st.floats(-300, 300, allow_nan=False, allow_subnormal=False)


@settings(max_examples=200, deadline=None)
@given(sx=coord, sy=coord, vx=speed, vy=speed, sz=st.floats(-1000, 1000), vz=st.floats(-50, 50))
def test_cpa_is_the_minimum_of_the_sampled_future(sx, sy, vx, vy, sz, vz):
    g = pair_geometry([[sx, sy]], [[vx, vy]], [sz], [vz])
    t = np.linspace(0.0, 2000.0, 200001)
    d = np.hypot(sx + vx * t, sy + vy * t)
    assert g.hmd_m[0] <= d.min() + 1e-6
    assert g.hmd_m[0] == np.hypot(sx + vx * g.t_cpa_s[0], sy + vy * g.t_cpa_s[0])
    assert g.t_cpa_s[0] >= 0.0
    assert math.isclose(g.vmd_m[0], sz + vz * g.t_cpa_s[0], abs_tol=1e-9)
    assert math.isclose(g.range_m[0], math.hypot(sx, sy))


@settings(max_examples=200, deadline=None)
@given(sx=coord, sy=coord, vx=speed, vy=speed)
def test_range_tau_is_range_over_closure(sx, sy, vx, vy):
    g = pair_geometry([[sx, sy]], [[vx, vy]], [0.0], [0.0])
    r = math.hypot(sx, sy)
    if g.s_dot_v[0] < 0 and r > 0:
        assert g.range_tau_s[0] > 0.0
        if g.closure_rate_mps[0] > 1e-9:
            assert math.isclose(g.range_tau_s[0], r / g.closure_rate_mps[0], rel_tol=1e-9)
    elif r > 0:
        assert g.range_tau_s[0] == math.inf


def test_head_on_hand_numbers():
    # 10 km apart, closing at 200 m/s, co-altitude: tau 50 s, CPA at 50 s with zero miss.
    g = pair_geometry([[0.0, 10000.0]], [[0.0, -200.0]], [0.0], [0.0])
    assert g.range_tau_s[0] == 50.0 and g.t_cpa_s[0] == 50.0 and g.hmd_m[0] == 0.0
    assert g.closure_rate_mps[0] == 200.0 and g.vertical_tau_s[0] == 0.0
    # modified tau with DMOD 1000 m: (1000^2 - 10000^2) / (10000 * -200) = 49.5 s
    assert math.isclose(g.mod_tau(1000.0)[0], 49.5)


def test_degenerate_pairs():
    g = pair_geometry([[0.0, 0.0], [500.0, 0.0], [500.0, 0.0]], [[10.0, 0.0], [0.0, 0.0], [10.0, 0.0]],
                      [100.0, 100.0, -50.0], [-10.0, 0.0, -5.0])
    # co-located: range 0, tau 0, inside any DMOD
    assert g.range_m[0] == 0.0 and g.range_tau_s[0] == 0.0 and modified_tau(0.0, 0.0, 100.0) == 0.0
    # zero relative velocity: CPA now, miss = current range, never closing
    assert g.t_cpa_s[1] == 0.0 and g.hmd_m[1] == 500.0 and g.range_tau_s[1] == math.inf
    assert g.mod_tau(100.0)[1] == math.inf
    # diverging: CPA now
    assert g.t_cpa_s[2] == 0.0 and g.range_tau_s[2] == math.inf
    # vertical: converging pair -> time to co-altitude; diverging -> inf
    assert g.vertical_tau_s[0] == 10.0 and g.vertical_tau_s[2] == math.inf
    assert np.all(np.isfinite(g.hmd_m))


# --- issue 4: CPA position, 3D CPA, entry/exit intervals ----------------------------------------------------


@settings(max_examples=150, deadline=None)
@given(sx=coord, sy=coord, vx=speed, vy=speed, sz=st.floats(-1000, 1000), vz=st.floats(-50, 50))
def test_3d_cpa_is_the_minimum_of_the_sampled_slant_range(sx, sy, vx, vy, sz, vz):
    g = pair_geometry([[sx, sy]], [[vx, vy]], [sz], [vz])
    t = np.linspace(0.0, 2000.0, 200001)
    d = np.sqrt((sx + vx * t) ** 2 + (sy + vy * t) ** 2 + (sz + vz * t) ** 2)
    assert g.t_cpa3d_s[0] >= 0.0
    assert g.miss3d_m[0] <= d.min() + 1e-6
    assert np.allclose(g.cpa3d_xyz_m[0], [sx + vx * g.t_cpa3d_s[0], sy + vy * g.t_cpa3d_s[0], sz + vz * g.t_cpa3d_s[0]])
    assert np.allclose(g.cpa_xy_m[0], [sx + vx * g.t_cpa_s[0], sy + vy * g.t_cpa_s[0]])


def test_intervals_and_loss_of_separation():
    from avionics.conflict.cpa import disk_interval, slab_interval

    # head-on 10 km, 200 m/s closing, 500 m radius: inside from 47.5 s to 52.5 s
    g = pair_geometry([[0.0, 10000.0]], [[0.0, -200.0]], [300.0], [-10.0])
    a, b = g.horizontal_interval(500.0)
    assert math.isclose(a[0], 47.5) and math.isclose(b[0], 52.5)
    # slab |z| <= 100 m: 300 - 10 t in [-100, 100] for t in [20, 40] -> no overlap with [47.5, 52.5]
    c, d = g.vertical_interval(100.0)
    assert math.isclose(c[0], 20.0) and math.isclose(d[0], 40.0)
    lo, hi = g.conflict_interval(500.0, 100.0, 120.0)
    assert np.isnan(lo[0]) and np.isnan(hi[0])
    lo, hi = g.conflict_interval(500.0, 200.0, 120.0)  # |z| <= 200: t in [10, 50] -> [47.5, 50]
    assert math.isclose(lo[0], 47.5) and math.isclose(hi[0], 50.0)
    lo, hi = g.conflict_interval(500.0, 200.0, 48.0)  # clipped to the lookahead
    assert math.isclose(hi[0], 48.0)
    # already inside: time to loss of separation 0; never (miss 1000 m): NaN; no motion inside: all time
    a, b = disk_interval([[100.0, 0.0], [0.0, 1000.0], [10.0, 0.0]], [[5.0, 0.0], [100.0, 0.0], [0.0, 0.0]], 500.0)
    assert a[0] < 0.0 < b[0] and np.isnan(a[1]) and a[2] == -math.inf and b[2] == math.inf
    lo, _ = pair_geometry([[100.0, 0.0]], [[5.0, 0.0]], [0.0], [0.0]).conflict_interval(500.0)
    assert lo[0] == 0.0
    c, d = slab_interval([50.0, 500.0], [0.0, 0.0], 100.0)
    assert c[0] == -math.inf and d[0] == math.inf and np.isnan(c[1])
    # co-located, no relative motion: CPA now in 3D too
    g = pair_geometry([[0.0, 0.0]], [[0.0, 0.0]], [0.0], [0.0])
    assert g.t_cpa3d_s[0] == 0.0 and g.miss3d_m[0] == 0.0 and g.time_to_coaltitude_s[0] == 0.0


@settings(max_examples=40)
@given(st.floats(2000.0, 15000.0), st.floats(-math.pi, math.pi), st.floats(50.0, 250.0), st.floats(-0.5, 0.5),
       st.floats(1.0, 30.0), st.floats(0.05, 1.0), st.integers(0, 2**16))
def test_hmd_sigma_matches_a_monte_carlo_of_the_relative_state(rng_m, bearing, closing, offset, sigma_pos,
                                                              sigma_vel, seed):
    """hmd_sigma_m, the first-order spread of the horizontal miss distance (read by the alerter for a sensor-only
    track), against the spread of the miss distances of 20,000 relative states drawn from the covariance. The
    pair is closing (CPA ahead) and the errors small beside the miss, where first order holds."""
    from avionics.conflict.cpa import hmd_sigma_m, pair_geometry_reference

    s = rng_m * np.array([math.sin(bearing), math.cos(bearing)])
    heading = bearing + math.pi + offset  # towards the ownship, `offset` rad off
    v = closing * np.array([math.sin(heading), math.cos(heading)])
    g = pair_geometry_reference(s[None], v[None], np.zeros(1), np.zeros(1))
    p = np.diag([sigma_pos**2, sigma_pos**2, 1.0, sigma_vel**2, sigma_vel**2, 0.1])
    p[0, 3] = p[3, 0] = 0.5 * sigma_pos * sigma_vel  # a correlated pair, as a filter's
    draws = np.random.default_rng(seed).multivariate_normal(np.r_[s, 0.0, v, 0.0], p, 20000)
    mc = pair_geometry_reference(draws[:, 0:2], draws[:, 3:5], draws[:, 2], draws[:, 5])
    assume(g.hmd_m[0] > 5.0 * (sigma_pos + g.t_cpa_s[0] * sigma_vel))  # else folded at 0: not first order
    assert math.isclose(hmd_sigma_m(g, p[None])[0], mc.hmd_m.std(), rel_tol=0.05)
