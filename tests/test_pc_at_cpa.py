"""Pc of a protected volume at the predicted CPA (conflict/pc_at_cpa.py), as alert gating uses it."""

import numpy as np
import pytest

from avionics.conflict.pc_at_cpa import pc_at_cpa


def _pairs(n, seed=0):
    rng = np.random.default_rng(seed)
    x = np.column_stack([rng.uniform(-3000, 3000, (n, 2)), rng.uniform(-200, 200, n),
                         rng.uniform(-60, 60, (n, 2)), rng.uniform(-3, 3, n)])
    a = rng.normal(size=(n, 6, 6)) * np.array([30, 30, 15, 2, 2, 1.0])[None, :, None]
    p = a @ np.swapaxes(a, 1, 2) + np.diag([100, 100, 25, 1, 1, 0.25])[None]
    t = rng.uniform(0, 40, n)
    return x, p, t


def test_several_volumes_in_one_call_equal_one_call_each():
    x, p, t = _pairs(50)
    has_alt = np.arange(50) % 5 != 0
    volumes = [(1000.0, 250.0), (300.0, 100.0), (600.0, None)]
    both = pc_at_cpa(x, p, t, volumes, 2.0, 1.0, has_alt)
    for k, volume in enumerate(volumes):
        np.testing.assert_allclose(both[k], pc_at_cpa(x, p, t, [volume], 2.0, 1.0, has_alt)[0], atol=1e-15)
    assert both.shape == (3, 50) and (both >= 0).all() and (both <= 1).all()


def test_matches_monte_carlo_of_the_straight_line_miss_with_process_noise():
    x, p, t = _pairs(4, seed=3)
    x[:, 0:2] = -t[:, None] * x[:, 3:5] + np.array([[200, 0], [0, -500], [900, 100], [50, 50]])  # misses near R
    sigma_h, sigma_v, n = 2.0, 1.0, 400_000
    rng = np.random.default_rng(7)
    got = pc_at_cpa(x, p, t, [(800.0, 150.0)], sigma_h, sigma_v, np.ones(4, bool))[0]
    for i in range(4):
        s = rng.multivariate_normal(x[i], p[i], n)
        # white-acceleration position noise over t: variance sigma^2 t^4 / 4 per axis (the tracks' CV model)
        noise = rng.normal(size=(n, 3)) * np.array([sigma_h, sigma_h, sigma_v]) * t[i] ** 2 / 2
        miss = s[:, 0:3] + t[i] * s[:, 3:6] + noise
        mc = np.mean((np.hypot(miss[:, 0], miss[:, 1]) <= 800.0) & (np.abs(miss[:, 2]) <= 150.0))
        assert got[i] == pytest.approx(mc, abs=4e-3), i


def test_a_cpa_ages_away_is_no_conflict_and_stays_finite():
    """Two hovering aircraft 2 km apart whose relative velocity is a rounding residue (found by hypothesis in
    tests/test_identity.py): the CPA lies 1e134 s ahead. Its Pc is 0, not a NaN that fails the pair."""
    x = np.array([[0.0, 2000.0, 300.0, 0.0, -7.5e-132, 0.0]])
    p = np.diag([100.0, 100.0, 25.0, 1.0, 1.0, 0.25])[None]
    t = np.array([2000.0 * 7.5e-132 / 7.5e-132**2])
    pc = pc_at_cpa(x, p, t, [(1000.0, 250.0)], 2.0, 1.0, np.array([True]))
    assert np.isfinite(t).all() and t[0] > 1e100
    assert pc.shape == (1, 1) and pc[0, 0] == pytest.approx(0.0, abs=1e-12)
