"""Trajectory prediction (IMM, CV closed form, Paielli-Erzberger growth), Pc along it, and the pipeline stage."""

import math

import numpy as np
import pytest

from avionics.config import ConflictConfig
from avionics.conflict import prediction as pr
from avionics.compose import build_conflict_assessor
from avionics.conflict.assess import conflict_probabilities
from avionics.conflict.probability import pc_exact
from avionics.base.units import KT, NM
from avionics.tracking import models
from avionics.tracking.kalman_cv import cv_process_noise, cv_transition


class cv4:
    """Minimal [x, y, vx, vy] CV motion model (piecewise-constant white acceleration), a models.MotionModel."""

    name, dim, accelerates, estimates_turn = "cv4", 4, True, False

    def __init__(self, sigma):
        self.sigma = sigma

    def F(self, dt):
        f = np.eye(4)
        f[0, 2] = f[1, 3] = dt
        return f

    def Q(self, dt, x=None, heading=None):
        g = np.array([[dt * dt / 2, 0], [0, dt * dt / 2], [dt, 0], [0, dt]])
        return g @ g.T * self.sigma**2

    def matrices(self, dt, x=None, heading=None):
        return self.F(dt), self.F(dt), self.Q(dt)


def ca_like(sigma):
    """A second model on the same state: CV dynamics with 3x the noise (a 'manoeuvre' mode)."""
    return cv4(3.0 * sigma)


def random_spd(rng, n, k):
    a = rng.normal(size=(k, n, n))
    return a @ np.swapaxes(a, 1, 2) + 0.1 * np.eye(n)


def test_single_model_is_the_kalman_prediction():
    rng = np.random.default_rng(0)
    x = rng.normal(size=(3, 4))
    p = random_spd(rng, 4, 3)
    model = cv4(1.5)
    pred = pr.model_predict(x, p, model, 10.0, 1.0)
    xk, pk = x.copy(), p.copy()
    for k in range(1, 11):
        f, q = model.F(1.0), model.Q(1.0)
        xk = xk @ f.T
        pk = f @ pk @ f.T + q
        assert np.allclose(pred.x[:, k], xk) and np.allclose(pred.p[:, k], pk)
    assert np.all(pred.mu == 1.0)


def test_imm_mode_probabilities_follow_the_markov_chain():
    rng = np.random.default_rng(1)
    trans = np.array([[0.9, 0.1], [0.3, 0.7]])
    x = rng.normal(size=(2, 2, 4))
    p = np.stack([random_spd(rng, 4, 2), random_spd(rng, 4, 2)], axis=1)
    mu = np.array([[0.2, 0.8], [1.0, 0.0]])
    pred = pr.imm_predict(x, p, mu, pr.ModeSet((cv4(1.0), ca_like(1.0)), trans), 5.0, 1.0)
    for k in range(6):
        assert np.allclose(pred.mu[:, k], mu @ np.linalg.matrix_power(trans, k))  # Baek & Bang eq 20
    # combination (eqs 16-17)
    xc, pc = pr.combine(pred.x_modes[:, 3], pred.p_modes[:, 3], pred.mu[:, 3])
    assert np.allclose(pred.x[:, 3], xc) and np.allclose(pred.p[:, 3], pc)
    assert np.allclose(pred.x[:, 3], np.einsum("nm,nmi->ni", pred.mu[:, 3], pred.x_modes[:, 3]))


def test_identical_modes_reduce_to_one_model():
    rng = np.random.default_rng(2)
    x = rng.normal(size=(4, 4))
    p = random_spd(rng, 4, 4)
    one = pr.model_predict(x, p, cv4(1.0), 20.0, 1.0)
    two = pr.imm_predict(np.stack([x, x], 1), np.stack([p, p], 1), np.full((4, 2), 0.5),
                         pr.ModeSet((cv4(1.0), cv4(1.0)), np.array([[0.95, 0.05], [0.05, 0.95]])), 20.0, 1.0)
    assert np.allclose(one.x, two.x) and np.allclose(one.p, two.p)


def test_one_step_matches_filterpy_imm_predict():
    """The interaction and mode-matched prediction of one step equal filterpy's IMMEstimator.predict (its mode
    probabilities stay at mu until an update; ours move to Pi mu, eq 20, so only per-mode values compare)."""
    from filterpy.kalman import IMMEstimator, KalmanFilter

    rng = np.random.default_rng(3)
    trans = np.array([[0.95, 0.05], [0.05, 0.95]])
    models = (cv4(0.5), ca_like(0.5))
    filters = []
    xs, ps = rng.normal(size=(2, 4)), random_spd(rng, 4, 2)
    for j, model in enumerate(models):
        kf = KalmanFilter(dim_x=4, dim_z=2)
        kf.F, kf.Q = model.F(1.0), model.Q(1.0)
        kf.x, kf.P = xs[j].copy(), ps[j].copy()
        filters.append(kf)
    mu = np.array([0.3, 0.7])
    imm = IMMEstimator(filters, mu, trans)
    imm.predict()
    pred = pr.imm_predict(xs[None], ps[None], mu[None], pr.ModeSet(models, trans), 1.0, 1.0)
    for j, kf in enumerate(filters):
        assert np.allclose(pred.x_modes[0, 1, j], kf.x.ravel(), atol=1e-12)
        assert np.allclose(pred.p_modes[0, 1, j], kf.P, atol=1e-12)
    assert np.allclose(pred.mu[0, 1], imm.cbar)  # Pi mu


def test_tracking_models_plug_in():
    # avionics/tracking/models.py returns (F_mean, F_cov, Q) in batches; heading-noise CA (eq 31) too.
    cv, ca = models.ConstantVelocity(0.5), models.ConstantAcceleration(2.0, heading_noise=True)
    x = np.zeros((2, 2, 6))
    x[:, :, 2] = 100.0  # eastbound
    p = np.broadcast_to(np.eye(6), (2, 2, 6, 6)).copy()
    pred = pr.imm_predict(x, p, np.full((2, 2), 0.5), pr.ModeSet((cv, ca), np.array([[0.95, 0.05], [0.05, 0.95]])),
                          20.0, 1.0)
    assert np.allclose(pred.x[:, 20, 0], 2000.0)
    # eq 31 for heading east (psi = 90 deg): CA noise is across track (y), so y spreads more than x in CA
    assert pred.p_modes[0, 20, 1, 1, 1] > pred.p_modes[0, 20, 1, 0, 0]


def test_cv_closed_form_equals_the_step_recursion():
    rng = np.random.default_rng(4)
    rel_x = rng.normal(0, 100, (3, 6))
    rel_p = random_spd(rng, 6, 3) * 10
    t = pr.lookahead_times(60.0, 1.0)
    mxy, cxy, mz, vz = pr.cv_relative_prediction(rel_x, rel_p, t, 1.0, 2.0, 0.7)
    f, q = cv_transition(1.0), cv_process_noise(1.0, 2.0, 0.7)
    x, p = rel_x.copy(), rel_p.copy()
    for k in range(61):
        assert np.allclose(mxy[:, k], x[:, 0:2]) and np.allclose(mz[:, k], x[:, 2])
        assert np.allclose(cxy[:, k], p[:, 0:2, 0:2], rtol=1e-10) and np.allclose(vz[:, k], p[:, 2, 2], rtol=1e-10)
        x, p = x @ f.T, f @ p @ f.T + q
    with pytest.raises(ValueError):
        pr.lookahead_times(60.5, 1.0)


def test_paielli_erzberger_growth_model():
    v = np.array([[480 * KT, 0.0], [0.0, 0.0]])  # eastbound at 480 kn; a hovering aircraft
    p0 = np.broadcast_to(np.eye(2) * 15.0**2, (2, 2, 2))  # Hwang: 15 m initial
    t = np.array([0.0, 60.0, 600.0, 3600.0])
    q = pr.pe_track_covariance(t, v, p0)
    along, cross = np.sqrt(q[0, :, 0, 0]), np.sqrt(q[0, :, 1, 1])
    assert np.allclose(along, 15.0 + 15 * KT * t)  # 15 kn = 0.25 nm/min
    rate = 480 * KT / 57.0  # v/57: a 1 deg heading error
    assert np.allclose(cross[:2], 15.0 + rate * t[:2])
    assert np.allclose(cross[2:], NM)  # saturates at 1 nm
    assert np.allclose(q[0, :, 0, 1], 0.0)  # principal axes along and across the track (eq 22)
    assert np.allclose(q[1, :, 0, 0], q[1, :, 1, 1])  # no track: isotropic growth
    # rotated track: eigenvectors follow the heading
    q45 = pr.pe_track_covariance(t, np.array([[1.0, 1.0]]) * 100.0, p0[:1])
    w, vec = np.linalg.eigh(q45[0, 2])
    assert abs(abs(vec[:, 1] @ np.array([1, 1]) / math.sqrt(2)) - 1.0) < 1e-12  # major axis along track
    # eq 23: the pair covariance is the sum
    m = pr.pe_pair_covariance(t, v[:1], p0[:1], v[1:], p0[1:])
    assert np.allclose(m, pr.pe_track_covariance(t, v[:1], p0[:1]) + pr.pe_track_covariance(t, v[1:], p0[1:]))


def test_pe_pair_probability_at_minimum_separation():
    # head-on at 480 kn each, 40 nm apart with 2 nm lateral offset: eq 24 with M(t_md), t_md = 150 s
    v_own, v_int = np.array([[480 * KT, 0.0]]), np.array([[-480 * KT, 0.0]])
    p0 = np.eye(2)[None] * 15.0**2
    rel_pos, rel_vel = np.array([[40 * NM, 2 * NM]]), v_int - v_own
    pc, t_md = pr.pe_conflict_probability(rel_pos, rel_vel, v_own, p0, v_int, p0, 5 * NM, lookahead_s=1200.0)
    assert t_md[0] == pytest.approx(150.0)
    m = pr.pe_pair_covariance(np.array([150.0]), v_own, p0, v_int, p0)[0, 0]
    from scipy.special import ndtr
    s = math.sqrt(m[1, 1])
    assert pc[0] == pytest.approx(ndtr((5 * NM - 2 * NM) / s) - ndtr((-5 * NM - 2 * NM) / s), abs=1e-12)
    pc_d, _ = pr.pe_conflict_probability(rel_pos, rel_vel, v_own, p0, v_int, p0, 5 * NM, 1200.0, delta_s=5.0)
    assert pc_d[0] >= pc[0] - 1e-15


def test_curve_max_and_ties():
    pc = np.array([[0.1, 0.3, 0.3, 0.2], [np.nan] * 4, [0.0, 0.0, 0.0, 0.0]])
    best, t = pr.max_over_lookahead(pc, np.array([0.0, 1.0, 2.0, 3.0]))
    assert best[0] == 0.3 and t[0] == 1.0
    assert np.isnan(best[1]) and np.isnan(t[1])
    assert best[2] == 0.0 and t[2] == 0.0


def test_within_lookahead_sees_crossings_between_steps():
    # Deterministic (no uncertainty, no noise): a 50 m zone crossed at 200 m/s between two 1 s grid points.
    rel_x = np.array([[-1100.0, 30.0, 0.0, 200.0, 0.0, 0.0], [-1100.0, 80.0, 0.0, 200.0, 0.0, 0.0]])
    rel_p = np.zeros((2, 6, 6))
    within = pr.pc_within_cv_mc(rel_x, rel_p, 50.0, 60.0, 1.0, 0.0, 0.0, half_height=10.0, samples=10, rng=0)
    assert list(within) == [1.0, 0.0]
    t = pr.lookahead_times(60.0, 1.0)
    mxy, cxy, _, _ = pr.cv_relative_prediction(rel_x, rel_p + np.eye(6) * 1e-12, t, 1.0, 0.0, 0.0)
    assert np.all(np.hypot(mxy[0, :, 0], mxy[0, :, 1]) > 50.0)  # no grid point is inside
    # a vertical pass outside the slab at the moment of the horizontal crossing is no conflict
    rel_x2 = rel_x[:1].copy()
    rel_x2[0, 2], rel_x2[0, 5] = 300.0, -5.0  # at 5.5 s it is 272 m above
    assert pr.pc_within_cv_mc(rel_x2, rel_p[:1], 50.0, 60.0, 1.0, 0.0, 0.0, 10.0, 10, 0)[0] == 0.0


def test_within_is_at_least_the_max_over_time():
    rng = np.random.default_rng(5)
    rel_x = np.column_stack([rng.uniform(-3000, 3000, (6, 2)), rng.uniform(-50, 50, 6),
                             rng.uniform(-60, 60, (6, 2)), rng.uniform(-2, 2, 6)])
    rel_p = np.broadcast_to(np.diag([900.0, 900.0, 64.0, 4.0, 4.0, 1.0]), (6, 6, 6))
    cfg = ConflictConfig(zone_radius_m=800.0, within_samples=4000)
    out = conflict_probabilities(rel_x, rel_p, cfg)
    se = np.sqrt(0.25 / 4000)
    assert np.all(out["pc_within"] >= out["pc_max"] - 4 * se)
    assert np.all(out["pc_max"] >= out["pc_now"])


def test_imm_trajectory_monte_carlo():
    # One CV mode without noise and a point estimate: deterministic like the CV Monte Carlo.
    x = np.array([[[-1100.0, 30.0, 200.0, 0.0]], [[-1100.0, 80.0, 200.0, 0.0]]])
    p = np.zeros((2, 1, 4, 4))
    ms = pr.ModeSet((cv4(0.0),), np.ones((1, 1)))
    got = pr.pc_within_imm_mc(x, p, np.ones((2, 1)), ms, 50.0, 60.0, 1.0, samples=20, rng=0)
    assert list(got) == [1.0, 0.0]
    # Two modes: agrees with the CV-model Monte Carlo when both modes are the same CV model.
    ms2 = pr.ModeSet((cv4(1.0), cv4(1.0)), np.array([[0.9, 0.1], [0.1, 0.9]]))
    x2 = np.repeat(np.array([[[-2000.0, 300.0, 60.0, 0.0]]]), 2, axis=1)
    p2 = np.broadcast_to(np.diag([400.0, 400.0, 4.0, 4.0]), (1, 2, 4, 4))
    a = pr.pc_within_imm_mc(x2, p2, np.full((1, 2), 0.5), ms2, 500.0, 60.0, 1.0, samples=6000, rng=1)[0]
    rel_x = np.array([[-2000.0, 300.0, 0.0, 60.0, 0.0, 0.0]])
    rel_p = np.diag([400.0, 400.0, 0.0, 4.0, 4.0, 0.0])[None]
    b = pr.pc_within_cv_mc(rel_x, rel_p, 500.0, 60.0, 1.0, 1.0, 0.0, None, 6000, 2)[0]
    assert abs(a - b) < 5 * math.sqrt(0.25 / 3000)


def test_pipeline_function_outputs():
    rel_x = np.array([[6000.0, 0.0, 0.0, -100.0, 0.0, 0.0],      # head-on, co-altitude
                      [6000.0, 0.0, 0.0, -100.0, 0.0, 0.0],      # same, altitude unknown
                      [-6000.0, 0.0, 0.0, -100.0, 0.0, 0.0],     # receding
                      [500.0, 0.0, 20.0, 0.0, 0.0, 0.0]])        # inside now, no relative motion
    rel_p = np.broadcast_to(np.diag([1800.0, 1800.0, 128.0, 8.0, 8.0, 2.0]), (4, 6, 6))
    cfg = ConflictConfig()
    out = conflict_probabilities(rel_x, rel_p, cfg, has_alt=[True, False, True, True], return_curve=True)
    for k in ("pc_now", "pc_max", "t_pc_max_s", "pc_within", "pc_pe"):
        assert out[k].shape == (4,)
    assert out["pc_curve"].shape == (4, 61) and out["t_s"][-1] == 60.0
    assert out["pc_max"][1] > out["pc_max"][0]  # no vertical factor without altitude
    assert 50.0 < out["t_pc_max_s"][0] <= 60.0
    assert out["pc_max"][2] == 0.0 and out["pc_pe"][2] == 0.0  # receding: eq 24 suppressed by condition 2(b)
    want_now = pc_exact(rel_x[3:, 0:2], rel_p[3:, 0:2, 0:2], cfg.zone_radius_m)[0]
    from avionics.conflict.probability import vertical_probability
    want_now *= vertical_probability(20.0, 128.0, cfg.zone_half_height_m)
    assert out["pc_now"][3] == pytest.approx(want_now, abs=1e-12)
    # reproducible with the configured seed; a datum margin widens the slab
    again = conflict_probabilities(rel_x, rel_p, cfg, has_alt=[True, False, True, True])
    assert np.array_equal(again["pc_within"], out["pc_within"])
    wide = conflict_probabilities(rel_x[:1], rel_p[:1], cfg, z_margin_m=[60.0])
    assert wide["pc_max"][0] > out["pc_max"][0]
    empty = conflict_probabilities(np.zeros((0, 6)), np.zeros((0, 6, 6)), cfg)
    assert all(v.shape == (0,) for v in empty.values())


def test_assessor_applies_hwang_conditions():
    cfg = ConflictConfig(within_samples=0, schedule_period_s=1.0, schedule_fast_period_s=0.2, schedule_threshold=0.1)
    a = build_conflict_assessor(cfg)
    rel_x = np.array([[3000.0, 0.0, 0.0, -100.0, 0.0, 0.0], [-30000.0, 0.0, 0.0, -100.0, 0.0, 0.0]])
    rel_p = np.broadcast_to(np.diag([1800.0, 1800.0, 128.0, 8.0, 8.0, 2.0]), (2, 6, 6))
    keys = ["near", "far"]
    o = a.assess(0.0, keys, rel_x, rel_p)
    assert list(o["computed"]) == [True, False] and list(o["filtered"]) == [False, True]
    assert o["pc_max"][1] == 0.0 and o["pc_max"][0] > cfg.schedule_threshold
    o2 = a.assess(0.1, keys, rel_x, rel_p)  # not due: last values kept
    assert not o2["computed"][0] and o2["pc_max"][0] == o["pc_max"][0]
    o3 = a.assess(0.2, keys, rel_x, rel_p)  # above the threshold: tau_c
    assert o3["computed"][0]
    o4 = a.assess(0.25, keys, rel_x, rel_p, modes=["turn", "cv"])  # a mode change: at once
    assert o4["computed"][0]


def test_assessor_refreshes_the_monte_carlo_within_probability_on_the_slow_period_only():
    cfg = ConflictConfig(within_samples=400, schedule_period_s=1.0, schedule_fast_period_s=0.2, schedule_threshold=0.1)
    a = build_conflict_assessor(cfg)
    rel_x = np.array([[3000.0, 0.0, 0.0, -100.0, 0.0, 0.0]])
    rel_p = np.diag([1800.0, 1800.0, 128.0, 8.0, 8.0, 2.0])[None]
    first = a.assess(0.0, ["near"], rel_x, rel_p)
    closer = rel_x + [[-20.0, 1200.0, 0, 0, 0, 0]]  # the miss moves to the zone edge: every output changes
    fast = a.assess(0.2, ["near"], closer, rel_p)  # Pc above the threshold: recomputed at the fast rate ...
    assert fast["computed"][0] and fast["pc_max"][0] != first["pc_max"][0]
    assert fast["pc_within"][0] == first["pc_within"][0]  # ... but the Monte Carlo part waits for the period
    slow = a.assess(1.0, ["near"], closer, rel_p)
    assert slow["computed"][0] and slow["pc_within"][0] < first["pc_within"][0] - 0.2
    assert slow["pc_within"][0] >= slow["pc_max"][0] - 0.1


def test_assessor_bounds_the_monte_carlo_cost_and_refreshes_the_stalest_pairs_first():
    cfg = ConflictConfig(within_samples=50, within_max_pairs_per_s=4.0, within_burst_pairs=4, schedule_period_s=1.0)
    a = build_conflict_assessor(cfg)
    keys = [f"k{i}" for i in range(10)]
    rel_x = np.tile([3000.0, 0.0, 0.0, -100.0, 0.0, 0.0], (10, 1))
    rel_p = np.broadcast_to(np.diag([1800.0, 1800.0, 128.0, 8.0, 8.0, 2.0]), (10, 6, 6))
    fresh, first = [], None
    for t in (0.0, 1.0, 2.0):
        o = a.assess(t, keys, rel_x, rel_p)
        assert o["computed"].all()  # Pc now and max for every pair, every time
        first = o["pc_within"] if first is None else first
        fresh.append({k for k, age in zip(keys, a.within_age(t, keys)) if age == 0.0})
    assert [len(f) for f in fresh] == [4, 4, 4]  # the bucket holds one second: 4 pairs
    assert fresh[0] == set(keys[:4]) and fresh[1] == set(keys[4:8])  # never-computed first ...
    assert fresh[2] == set(keys[8:] + keys[:2])  # ... then the stalest
    assert np.isnan(first[4:]).all() and (first[:4] > 0.5).all()  # no value before a pair's first turn
    assert a.last(keys)["pc_within"].min() > 0.5  # every pair has one by now
    np.testing.assert_allclose(a.within_age(2.5, keys), [0.5, 0.5, 2.5, 2.5] + [1.5] * 4 + [0.5, 0.5])  # its age
    assert np.isnan(a.within_age(2.5, ["never"]))[0]


def test_assessor_budget_below_one_pair_per_second_and_the_monte_carlo_off():
    rel_x = np.array([[3000.0, 0.0, 0.0, -100.0, 0.0, 0.0]])
    rel_p = np.diag([1800.0, 1800.0, 128.0, 8.0, 8.0, 2.0])[None]
    slow = build_conflict_assessor(ConflictConfig(within_samples=50, within_max_pairs_per_s=0.5))
    ages = [slow.assess(t, ["a"], rel_x, rel_p) and slow.within_age(t, ["a"])[0] for t in (0.0, 1.0, 2.0)]
    assert ages == [0.0, 1.0, 0.0]  # one pair every 2 s
    off = build_conflict_assessor(ConflictConfig(within_samples=0))
    o = off.assess(0.0, ["a"], rel_x, rel_p)
    assert np.isnan(o["pc_within"][0]) and np.isnan(off.within_age(0.5, ["a"])[0])  # no value, no age


def test_one_call_runs_at_most_a_burst_of_the_monte_carlo_and_frequent_calls_reach_the_budget():
    """conflict.within_burst_pairs: after a long idle (a full bucket) one call refreshes at most the burst; called
    at 10 Hz, as the pipeline calls it at least, the stage still refreshes within_max_pairs_per_s pairs a second
    (the oracle: the budget's own arithmetic, 20 pairs over 1 s at 20 per second, every pair once)."""
    rel_x = np.tile([3000.0, 0.0, 0.0, -100.0, 0.0, 0.0], (40, 1))
    rel_p = np.broadcast_to(np.diag([1800.0, 1800.0, 128.0, 8.0, 8.0, 2.0]), (40, 6, 6))
    keys = [f"k{i}" for i in range(40)]
    a = build_conflict_assessor(ConflictConfig(within_samples=20, within_max_pairs_per_s=20.0, within_burst_pairs=2,
                                               schedule_period_s=1.0))
    a.assess(0.0, keys, rel_x, rel_p)
    assert (a.within_age(0.0, keys) == 0.0).sum() == 2  # a full bucket is two pairs, not a second's twenty
    refreshed = set()
    for k in range(1, 11):  # 10 Hz for one second
        t = 100.0 + 0.1 * k
        a.assess(t, keys, rel_x, rel_p)
        fresh = {key for key, age in zip(keys, a.within_age(t, keys)) if age == 0.0}
        assert len(fresh) <= 2
        refreshed |= fresh
    assert len(refreshed) == 20  # 20 per second: the budget


@pytest.mark.parametrize("override, message", [
    ("conflict.method=nope", "conflict.method"),
    ("conflict.prefilter=nope", "conflict.prefilter"),
    ("conflict.lookahead_s=60.5", "multiple"),
    ("conflict.zone_radius_m=0", "must be > 0"),
    ("conflict.n_blocks=0", "n_blocks"),
    ("conflict.schedule_fast_period_s=2", "schedule_fast_period_s"),
    ("conflict.schedule_threshold=1.5", "probability"),
    ("conflict.prefilter_alpha=0.5", "alpha"),
    ("conflict.within_max_pairs_per_s=0", "within_max_pairs_per_s"),
    ("conflict.within_burst_pairs=0", "within_burst_pairs"),
])
def test_conflict_config_validation(override, message):
    from avionics.config import ConfigError, load_config

    with pytest.raises(ConfigError, match=message):
        load_config(overrides=[override])
    assert load_config(overrides=["conflict.method=blocks", "conflict.n_blocks=20"]).conflict.n_blocks == 20


def test_pc_methods_as_objects_are_the_named_methods():
    import dataclasses

    from avionics.compose import build_pc_method
    from avionics.conflict.params import CONFLICT_METHODS
    from avionics.conflict.probability import conflict_probability

    rng = np.random.default_rng(3)
    mean = rng.uniform(-2000, 2000, (7, 2))
    a = rng.uniform(100, 900, 7)
    cov = np.stack([np.diag([x * x, (x / 3) ** 2]) for x in a])
    vel = rng.uniform(-100, 100, (7, 2))
    for name in CONFLICT_METHODS:
        cfg = ConflictConfig(method=name, n_blocks=6, mc_samples=3000)
        method = build_pc_method(cfg)
        assert method.name == name
        got = method.probability(mean, cov, 1219.2, rel_vel=vel, rng=np.random.default_rng(1))
        want = conflict_probability(mean, cov, 1219.2, name, rel_vel=vel, n_blocks=6, samples=3000,
                                    rng=np.random.default_rng(1))
        np.testing.assert_array_equal(got, want)
        # through the assessor: the configured method decides pc_now
        out = conflict_probabilities(np.column_stack([mean, np.zeros(7), vel, np.zeros(7)]),
                                     np.broadcast_to(np.diag([1e4, 1e4, 1.0, 1.0, 1.0, 1.0]), (7, 6, 6)),
                                     dataclasses.replace(cfg, within_samples=0), method=method)
        assert out["pc_now"].shape == (7,)
