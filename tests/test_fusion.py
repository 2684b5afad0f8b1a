"""Dai et al.'s optimal information fusion (eqs 41-42), covariance intersection, the variable sampling period
(Dai Table 1) and the full-covariance measurement update of the IMM bank."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from avionics.tracking import fusion, models
from avionics.tracking.imm import ImmBank


def spd(rng, n, scale=1.0):
    a = rng.normal(size=(n, n)) * scale
    return a @ a.T + n * scale**2 * np.eye(n)


@settings(max_examples=30, deadline=None)
@given(seed=st.integers(0, 2**16))
def test_eqs_41_42_are_the_information_fusion_without_cross_covariance_and_bar_shalom_campo_with_it(seed):
    rng = np.random.default_rng(seed)
    n = 3
    p1, p2 = spd(rng, n), spd(rng, n, 2.0)
    x1, x2 = rng.normal(size=n), rng.normal(size=n)
    x, p, a = fusion.fuse_pair(x1[None], p1[None], x2[None], p2[None])
    info = np.linalg.inv(p1) + np.linalg.inv(p2)
    assert np.allclose(p[0], np.linalg.inv(info))
    assert np.allclose(x[0], np.linalg.solve(info, np.linalg.solve(p1, x1) + np.linalg.solve(p2, x2)))
    assert np.allclose(a[0, 0] + a[0, 1], np.eye(n))  # the weights sum to I (unbiased)
    # with a cross-covariance: Bar-Shalom & Campo's two-sensor formula
    p12 = 0.3 * np.linalg.cholesky(p1) @ np.linalg.cholesky(p2).T
    x, p, _ = fusion.fuse_pair(x1[None], p1[None], x2[None], p2[None], p12[None])
    s = p1 + p2 - p12 - p12.T
    gain = (p1 - p12) @ np.linalg.inv(s)
    assert np.allclose(x[0], x1 + gain @ (x2 - x1))
    assert np.allclose(p[0], p1 - gain @ (p1 - p12).T)


@settings(max_examples=30, deadline=None)
@given(seed=st.integers(0, 2**16))
def test_covariance_intersection_is_consistent_for_any_correlation(seed):
    rng = np.random.default_rng(seed)
    p1, p2 = spd(rng, 2), spd(rng, 2, 3.0)
    x, p, w = fusion.covariance_intersection(np.zeros((1, 2)), p1[None], np.ones((1, 2)), p2[None])
    assert 0.0 <= w[0] <= 1.0
    # consistent for every cross-correlation: P_ci >= the true covariance of the CI estimate (ρ in [-1, 1] grid)
    i1, i2 = np.linalg.inv(p1), np.linalg.inv(p2)
    k1, k2 = p[0] @ (w[0] * i1), p[0] @ ((1 - w[0]) * i2)
    for rho in np.linspace(-1, 1, 9):
        p12 = rho * np.linalg.cholesky(p1) @ np.linalg.cholesky(p2).T
        true = k1 @ p1 @ k1.T + k2 @ p2 @ k2.T + k1 @ p12 @ k2.T + k2 @ p12.T @ k1.T
        assert np.linalg.eigvalsh(p[0] - true).min() >= -1e-9
    assert np.trace(p[0]) <= min(np.trace(p1), np.trace(p2)) * (1 + 1e-5)  # never worse than the better one


def test_variable_sampling_period_follows_dai_table_1():
    from avionics.tracking.integrity import position_sigma_per_axis

    sigma = [position_sigma_per_axis(epu) * 0.99 for epu in (3.0, 10.0, 30.0, 92.6, 185.2, 555.6, 926.0, 1852.0)]
    # NACp 11, 10, 9, 8, 7, 6, 5, 4: Table 1's 1, 1, 0.8, 0.6, 0.6, 0.6, 0.8, 1 s while near
    assert fusion.sampling_period(sigma, 30.0).tolist() == [1.0, 1.0, 0.8, 0.6, 0.6, 0.6, 0.8, 1.0]
    assert fusion.nacp(sigma).tolist() == [11, 10, 9, 8, 7, 6, 5, 4]
    assert (fusion.sampling_period(sigma, 90.0) == 1.0).all()  # far: 1 s
    assert (fusion.sampling_period(sigma, np.inf) == 1.0).all()  # not closing


def test_a_full_measurement_covariance_with_zero_correlation_is_the_diagonal_update():
    rng = np.random.default_rng(0)
    modes = [models.ConstantVelocity(0.3), models.CoordinatedTurn(2.0)]
    banks = [ImmBank(modes, 4, models.switching_matrix(2, 0.05), capacity=4, compiled=False) for _ in range(2)]
    x0 = rng.normal(size=(4, 6)) * 100
    for b in banks:
        b.init(np.arange(4), x0, np.eye(6) * 400.0)
    z = x0[:, :4] + rng.normal(size=(4, 4)) * 10
    mask = np.ones((4, 4), bool)
    mask[1, 2:] = False
    r_var = rng.uniform(50, 200, (4, 4))
    r_cov = r_var[:, :, None] * np.eye(4)
    a = banks[0].update(np.arange(4), 1.0, z, mask, r_var)
    b = banks[1].update(np.arange(4), 1.0, z, mask, np.ones((4, 4)), r_cov=r_cov)
    assert np.allclose(a.x, b.x) and np.allclose(a.p, b.p) and np.allclose(a.mu, b.mu)
    # a correlated covariance changes the update (the conversion's correlation is used)
    r_cov[:, 0, 1] = r_cov[:, 1, 0] = 0.8 * np.sqrt(r_cov[:, 0, 0] * r_cov[:, 1, 1])
    c = banks[1].update(np.arange(4), 1.0, z, mask, np.ones((4, 4)), r_cov=r_cov)
    assert not np.allclose(a.x, c.x)
    with pytest.raises(ValueError):
        ImmBank(modes, 4, models.switching_matrix(2, 0.05), vb=__import__("avionics.tracking.imm",
                fromlist=["VbParams"]).VbParams()).update(np.arange(1), 1.0, z[:1], mask[:1], r_var[:1], r_cov[:1])
