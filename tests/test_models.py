"""Motion models against the papers' matrices, for any dt."""

import math

import numpy as np
import pytest
from hypothesis import given, strategies as st

from avionics.tracking import models

T = 1.7


def hwang_to_ours(m_hwang: np.ndarray) -> np.ndarray:
    """Hwang's state [x, vx, ax, y, vy, ay] -> ours [x, y, vx, vy, ax, ay]."""
    perm = [0, 3, 1, 4, 2, 5]
    return m_hwang[np.ix_(perm, perm)]


def test_cv_is_hwang_eq_16_and_baek_bang_eq_5():
    a = np.array([[1, T, 0], [0, 1, 0], [0, 0, 0]], float)
    g = np.array([T**2 / 2, T, 0.0])
    f_h = np.kron(np.eye(2), a)
    q_h = np.kron(np.eye(2), np.outer(g, g)) * 0.4**2
    f, f_cov, q = models.cv(T, 0.4)
    assert np.array_equal(f, f_cov)
    np.testing.assert_allclose(f[0], hwang_to_ours(f_h), atol=1e-15)
    expected = hwang_to_ours(q_h)
    expected[4, 4] = expected[5, 5] = models.CV_ACCEL_FLOOR_MPS2**2  # the documented numerical floor
    np.testing.assert_allclose(q[0], expected, atol=1e-15)


def test_ct_is_hwang_eq_18_wiener_sequence_acceleration():
    a = np.array([[1, T, T**2 / 2], [0, 1, T], [0, 0, 1]])
    g = np.array([T**2 / 2, T, 1.0])
    f, _, q = models.ct(T, 2.5)
    np.testing.assert_allclose(f[0], hwang_to_ours(np.kron(np.eye(2), a)), atol=1e-15)
    np.testing.assert_allclose(q[0], hwang_to_ours(np.kron(np.eye(2), np.outer(g, g))) * 2.5**2, atol=1e-12)


def test_constant_acceleration_transition_composes_over_any_split_of_dt():
    f = models.constant_acceleration_f(np.array([0.3, 1.4, 1.7]))
    np.testing.assert_allclose(f[1] @ f[0], f[2], atol=1e-13)


def test_ca_noise_is_baek_bang_eq_31_heading_rotated():
    sigma = 3.0
    g = np.array([T**2 / 2, T, 1.0])
    for heading_deg, var_x, var_y in ((90.0, 0.0, 9.0), (0.0, 9.0, 0.0), (30.0, 9 * 0.75, 9 * 0.25)):
        _, _, q = models.ca(T, sigma, math.radians(heading_deg))
        np.testing.assert_allclose(q[0][0::2, 0::2], np.outer(g, g) * var_x, atol=1e-12)  # x axis
        np.testing.assert_allclose(q[0][1::2, 1::2], np.outer(g, g) * var_y, atol=1e-12)  # y axis
    _, _, q_iso = models.ca(T, sigma)  # eq 6 without the rotation: isotropic
    np.testing.assert_allclose(q_iso[0], models.ct(T, sigma)[2][0], atol=1e-12)


def test_cs_transition_is_dai_eq_10_and_its_mean_is_constant_acceleration():
    alpha = 0.2
    e = math.exp(-alpha * T)
    phi = np.array([[1, T, (-1 + alpha * T + e) / alpha**2], [0, 1, (1 - e) / alpha], [0, 0, e]])
    gamma = np.array([(-T + alpha * T**2 / 2 + (1 - e) / alpha) / alpha, T - (1 - e) / alpha, 1 - e])
    f_mean, f_cov, _ = models.cs(T, alpha, 20.0, np.zeros((1, 2)))
    np.testing.assert_allclose(f_cov[0][0::2, 0::2], phi, atol=1e-12)
    # eq 8 with a-bar = the state's own acceleration: Phi + Gamma e_a^T, which is the CA transition
    np.testing.assert_allclose(f_mean[0][0::2, 0::2], phi + np.outer(gamma, [0, 0, 1]), atol=1e-12)


def test_cs_process_noise_matches_singer_closed_form_and_small_dt_limit():
    alpha, t = 0.5, 2.0
    a, e1, e2 = alpha, math.exp(-alpha * t), math.exp(-2 * alpha * t)
    q11 = (1 - e2 + 2 * a * t + 2 * a**3 * t**3 / 3 - 2 * a**2 * t**2 - 4 * a * t * e1) / (2 * a**5)
    q12 = (e2 + 1 - 2 * e1 + 2 * a * t * e1 - 2 * a * t + a**2 * t**2) / (2 * a**4)
    q13 = (1 - e2 - 2 * a * t * e1) / (2 * a**3)
    q22 = (4 * e1 - 3 - e2 + 2 * a * t) / (2 * a**3)
    q23 = (e2 + 1 - 2 * e1) / (2 * a**2)
    q33 = (1 - e2) / (2 * a)
    singer = np.array([[q11, q12, q13], [q12, q22, q23], [q13, q23, q33]])
    np.testing.assert_allclose(models.cs_q_unit(t, alpha)[0], singer, rtol=1e-10)
    tiny = 1e-3  # no cancellation for alpha T -> 0: q -> [[T^5/20, T^4/8, T^3/6], [., T^3/3, T^2/2], [., ., T]]
    np.testing.assert_allclose(models.cs_q_unit(tiny, alpha)[0, 0, 0], tiny**5 / 20, rtol=1e-3)


def test_cs_acceleration_variance_is_zhou_eq_12():
    k = (4 - math.pi) / math.pi
    var = models.cs_accel_variance(np.array([0.0, 5.0, -5.0, 30.0]), 20.0)
    np.testing.assert_allclose(var, [k * 400, k * 225, k * 225, k * (0.05 * 20) ** 2])


def test_vertical_ch_and_cad_are_baek_bang_eqs_7_and_8():
    f, _, q = models.ch(T, 0.2)
    np.testing.assert_allclose(f[0], [[1, T], [0, 1]])
    np.testing.assert_allclose(q[0], 0.04 * np.outer([T, 1], [T, 1]), atol=1e-15)
    _, _, q = models.cad(T, 1.5)
    np.testing.assert_allclose(q[0], 2.25 * np.outer([T**2, T], [T**2, T]), atol=1e-12)


def test_yaw_rate_eq_20_and_its_low_pass():
    omega = math.radians(3.0)  # counter-clockwise
    v = np.array([200.0, 50.0])
    a = omega * np.array([-v[1], v[0]])  # centripetal acceleration of a left turn
    state = np.array([0.0, 0.0, v[0], v[1], a[0], a[1]])
    assert models.yaw_rate(state) == pytest.approx(omega, rel=1e-12)
    state[4:] *= -1
    assert models.yaw_rate(state) == pytest.approx(-omega, rel=1e-12)
    # 1/(11.9 s + 1): one time constant of a unit step reaches 1 - 1/e, however it is split into steps
    y = 0.0
    for dt in (0.5, 3.0, 2.4, 6.0):
        y = models.smooth_yaw_rate(y, 1.0, dt, 11.9)
    assert y == pytest.approx(1 - math.exp(-1), rel=1e-12)


def test_markov_chain_for_any_interval():
    m1 = models.switching_matrix(2, 0.05)
    chain = models.MarkovChain(m1)
    m = chain.at(np.array([0.0, 1.0, 2.0, 3.5]))
    np.testing.assert_allclose(m[0], np.eye(2), atol=1e-14)
    np.testing.assert_allclose(m[1], m1, atol=1e-14)
    np.testing.assert_allclose(m[2], m1 @ m1, atol=1e-14)
    np.testing.assert_allclose(m[3] @ chain.at(0.5)[0], np.linalg.matrix_power(m1, 4), atol=1e-14)
    np.testing.assert_allclose(models.MarkovChain(models.switching_matrix(3, 0.1)).at(2.0)[0],
                               np.linalg.matrix_power(models.switching_matrix(3, 0.1), 2), atol=1e-14)
    with pytest.raises(ValueError):
        models.MarkovChain(np.array([[0.4, 0.6], [0.6, 0.4]]))  # negative eigenvalue: no real generator


@given(n=st.integers(2, 4), p=st.floats(0.001, 0.5 * 3 / 4))
def test_markov_chain_of_every_mode_count_and_switch_probability(n, p):
    """Every configurable chain (2-4 modes, uniform switching below the embeddable limit) builds, and its
    whole-period steps are powers of M1 (the exact reference); 4 modes at 0.23 raised "Singular matrix"."""
    m1 = models.switching_matrix(n, p)
    if (np.linalg.eigvals(m1).real <= 0).any():
        return  # no real logarithm: refused by design (tested above)
    chain = models.MarkovChain(m1)
    for k in (1, 2, 5):
        np.testing.assert_allclose(chain.at(float(k))[0], np.linalg.matrix_power(m1, k), atol=1e-12)


def test_model_objects_are_the_model_functions():
    """The MotionModel objects the IMM bank and the trajectory prediction are given: F, Q and matrices are the
    builders above (CA's eq 31 heading from the given heading, else from each state's own velocity)."""
    dt = np.array([0.7, 2.0, 5.0])
    x = np.zeros((3, 6))
    x[:, 2:6] = [[100.0, 0.0, 0.5, -1.0], [0.0, 80.0, 2.0, 0.0], [-50.0, 50.0, 0.0, 3.0]]
    heading = np.array([0.3, 1.2, -2.0])
    cases = [(models.ConstantVelocity(0.3), models.cv(dt, 0.3)),
             (models.ConstantAcceleration(3.0), models.ca(dt, 3.0, heading)),
             (models.ConstantAcceleration(3.0, heading_noise=False), models.ca(dt, 3.0)),
             (models.CoordinatedTurn(2.0), models.ct(dt, 2.0)),
             (models.CurrentStatistical(0.1, 20.0), models.cs(dt, 0.1, 20.0, x[:, 4:6]))]
    for model, want in cases:
        assert isinstance(model, models.MotionModel) and model.dim == models.H_DIM
        for got, ref in zip(model.matrices(dt, x, heading), want):
            assert np.array_equal(got, ref)
        assert np.array_equal(model.F(dt), want[0]) and np.array_equal(model.Q(dt, x, heading), want[2])
    own = models.ca(np.full(3, 1.0), 3.0, models.heading_rad(x[:, 2], x[:, 3]))
    assert np.array_equal(models.ConstantAcceleration(3.0).Q(1.0, x), own[2])
    for model, want in ((models.ConstantHeight(0.1), models.ch(dt, 0.1)),
                        (models.ConstantAltitudeChange(1.0), models.cad(dt, 1.0))):
        assert model.dim == models.V_DIM and all(np.array_equal(g, r) for g, r in zip(model.matrices(dt, None), want))
    assert [m.name for m in (models.ConstantVelocity(1.0), models.CurrentStatistical(0.1, 20.0))] == ["cv", "cs"]
    assert not models.ConstantVelocity(1.0).accelerates and models.CoordinatedTurn(1.0).estimates_turn


@given(rate_dps=st.floats(0.5, 25.0), left=st.booleans(), dt=st.floats(0.01, 30.0),
       heading=st.floats(-math.pi, math.pi), speed=st.floats(1.0, 300.0))
def test_known_rate_turn_flies_the_circle_exactly(rate_dps, left, dt, heading, speed):
    """The turn at a known rate (Bar-Shalom, Li & Kirubarajan eq 11.7.1-4) against the circle written in complex
    numbers, an independent form: the velocity v = vx + i vy turns to v e^{i w T}, the position moves by
    v (e^{i w T} - 1) / (i w), and the acceleration is i w v'. The noise is CV's (Baek & Bang eq 5)."""
    w = math.radians(rate_dps) * (1.0 if left else -1.0)
    v0 = speed * complex(math.sin(heading), math.cos(heading))  # heading clockwise from north, x east
    p0 = complex(120.0, -40.0)
    v1 = v0 * complex(math.cos(w * dt), math.sin(w * dt))
    p1 = p0 + v0 * (complex(math.cos(w * dt), math.sin(w * dt)) - 1.0) / complex(0.0, w)
    a1 = complex(0.0, w) * v1
    f, f_cov, q = models.known_rate_turn(dt, w, 0.3)
    got = f[0] @ np.array([p0.real, p0.imag, v0.real, v0.imag, 0.0, 0.0])
    want = np.array([p1.real, p1.imag, v1.real, v1.imag, a1.real, a1.imag])
    np.testing.assert_allclose(got, want, rtol=1e-9, atol=1e-9 * (1.0 + speed * dt))
    assert np.array_equal(f, f_cov)
    assert np.array_equal(q, models.cv(dt, 0.3)[2])


def test_known_rate_turn_composes_and_names_its_side():
    f = models.known_rate_turn(np.array([0.3, 1.4, 1.7]), math.radians(3.0), 0.3)[0]
    np.testing.assert_allclose(f[1] @ f[0], f[2], atol=1e-12)
    left, right = models.KnownRateTurn(0.05, 0.3), models.KnownRateTurn(-0.05, 0.3)
    assert (left.name, right.name, left.dim) == ("turn_left", "turn_right", models.H_DIM)
    assert isinstance(left, models.MotionModel)
    assert np.array_equal(left.matrices(2.0)[0], models.known_rate_turn(2.0, 0.05, 0.3)[0])
    with pytest.raises(ValueError):
        models.known_rate_turn(1.0, 0.0, 0.3)


def test_a_turn_mode_is_left_at_its_exit_probability_and_a_long_coast_drifts_to_straight_flight():
    """models.mode_switching: CV and CT leave at p = 0.01 a second, each turn at e = 0.2, evenly to the others.
    Hand computation of the stationary distribution: a turn's inflow (2 a p/3 + b e/3) equals its outflow (b e),
    so b/a = p/e, and 2a + 2b = 1: a = 1/(2 (1 + p/e)) = 0.4762, b = 0.0238. A track that coasts long enough
    (a radar's blind zone) ends there, whatever mode it was in."""
    modes = [models.ConstantVelocity(0.3), models.CoordinatedTurn(2.0), models.KnownRateTurn(0.05, 0.3),
             models.KnownRateTurn(-0.05, 0.3)]
    m1 = models.mode_switching(modes, 0.01, 0.2)
    np.testing.assert_allclose(m1.sum(axis=1), 1.0, atol=1e-15)
    np.testing.assert_allclose(np.diag(m1), [0.99, 0.99, 0.8, 0.8])
    np.testing.assert_allclose(m1[2], [0.2 / 3, 0.2 / 3, 0.8, 0.2 / 3])
    a = 1.0 / (2.0 * (1.0 + 0.01 / 0.2))
    far = models.MarkovChain(m1).at(2000.0)[0]
    np.testing.assert_allclose(far, np.full((4, 1), 1.0) * [a, a, 0.5 - a, 0.5 - a], atol=1e-9)
    assert np.array_equal(models.mode_switching(modes[:2], 0.05, 0.2), models.switching_matrix(2, 0.05))
