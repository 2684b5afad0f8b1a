"""Conflict probability: the exact method against scipy dblquad, the approximations bracketed, degenerate cases."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import special

from avionics.conflict import probability as prob
from avionics_eval.reports.conflict import dblquad_pc  # the dblquad reference, shared with the report


def covariance(sigma_major, axis_ratio, angle):
    c, s = math.cos(angle), math.sin(angle)
    rot = np.array([[c, -s], [s, c]])
    return rot @ np.diag([sigma_major**2, (sigma_major / axis_ratio) ** 2]) @ rot.T


@st.composite
def pair_case(draw):
    """Axis ratio (of sigmas) 1 to 1000 (variances to 1e6), any rotation, R from 0.01 to 100 sigma_major; the
    mean anywhere from the centre to 3 R out, plus up to 3 sigma of offset (so on and near the boundary too)."""
    ratio = 10 ** draw(st.floats(0.0, 3.0))
    angle = draw(st.floats(0.0, math.pi))
    sigma = 10 ** draw(st.floats(-1.0, 1.0))
    r = sigma * 10 ** draw(st.floats(-2.0, 2.0))
    rho = draw(st.sampled_from([0.0, 0.5, 0.95, 1.0, 1.05, 2.0, 3.0])) * draw(st.floats(0.8, 1.0))
    offset = draw(st.floats(-3.0, 3.0)) * sigma * draw(st.sampled_from([0.0, 1.0 / ratio, 1.0]))
    phi = draw(st.floats(0.0, 2.0 * math.pi))
    mean = (rho * r + offset) * np.array([math.cos(phi), math.sin(phi)])
    return mean, covariance(sigma, ratio, angle), r


@settings(max_examples=150, deadline=None)
@given(pair_case())
def test_exact_agrees_with_dblquad(case):
    mean, cov, r = case
    got = prob.pc_exact(mean[None], cov[None], r)[0]
    assert abs(got - dblquad_pc(mean, cov, r)) <= 1e-9


@pytest.mark.parametrize("ratio", [1.0, 10.0, 1000.0])
@pytest.mark.parametrize("r_over_sigma", [0.01, 1.0, 100.0])
@pytest.mark.parametrize("where", [0.0, 0.999, 1.0, 1.001, 2.0])
def test_exact_grid_corners(ratio, r_over_sigma, where):
    """The corners of the acceptance grid, with a rotated covariance and the mean on, just inside and outside
    the boundary."""
    cov = covariance(1.0, ratio, 0.7)
    r = r_over_sigma
    mean = where * r * np.array([math.cos(2.0), math.sin(2.0)])
    assert abs(prob.pc_exact(mean[None], cov[None], r)[0] - dblquad_pc(mean, cov, r)) <= 1e-9


def test_isotropic_centred_closed_form():
    # Rayleigh: P(|x| <= R) = 1 - exp(-R^2 / 2 sigma^2) for a centred isotropic Gaussian.
    r = np.array([0.01, 0.5, 1.0, 2.0, 5.0, 100.0])
    got = prob.pc_exact(np.zeros((6, 2)), np.broadcast_to(np.eye(2), (6, 2, 2)), r)
    assert np.allclose(got, -np.expm1(-r * r / 2.0), atol=5e-13, rtol=0)


def test_offset_isotropic_is_noncentral_chi2():
    # |x|^2 / sigma^2 is non-central chi-square with 2 degrees of freedom and non-centrality |m|^2 / sigma^2.
    from scipy.stats import ncx2

    rng = np.random.default_rng(3)
    m = rng.normal(0, 2, (50, 2))
    sig = 10 ** rng.uniform(-1, 1, 50)
    r = 10 ** rng.uniform(-1, 1, 50)
    cov = np.eye(2)[None] * (sig**2)[:, None, None]
    want = ncx2.cdf((r / sig) ** 2, 2, np.einsum("ij,ij->i", m, m) / sig**2)
    assert np.allclose(prob.pc_exact(m, cov, r), want, atol=1e-10, rtol=0)


def _random_cases(n, seed):
    rng = np.random.default_rng(seed)
    ratio = 10 ** rng.uniform(0, 3, n)
    ang = rng.uniform(0, math.pi, n)
    cov = np.array([covariance(1.0, q, a) for q, a in zip(ratio, ang)])
    r = 10 ** rng.uniform(-2, 2, n)
    phi = rng.uniform(0, 2 * math.pi, n)
    mean = (r * rng.uniform(0, 2, n) + rng.normal(0, 1, n))[:, None] * np.stack([np.cos(phi), np.sin(phi)], -1)
    return mean, cov, r


def test_approximations_are_upper_bounds_that_tighten():
    mean, cov, r = _random_cases(3000, 1)
    exact = prob.pc_exact(mean, cov, r)
    one = prob.pc_one_block(mean, cov, r)
    assert np.array_equal(prob.pc_blocks(mean, cov, r, 1), one)
    prev = one
    for k in (2, 4, 8, 16, 32, 64):  # covers with 2k blocks refine those with k
        cur = prob.pc_blocks(mean, cov, r, k)
        assert np.all(cur <= prev + 1e-15) and np.all(cur >= exact - 1e-12)
        prev = cur
    fine = prob.pc_blocks(mean, cov, r, 4000)
    assert np.max(fine - exact) < 0.01  # converges to the exact value
    # Paielli-Erzberger's strip contains the disk, whatever the direction of the relative velocity
    vel = np.random.default_rng(2).normal(size=mean.shape)
    assert np.all(prob.pc_paielli_erzberger(mean, cov, r, vel) >= exact - 1e-12)


def test_paielli_erzberger_is_the_strip_probability():
    # Relative velocity along +x, mean offset d across it: Pc = Phi((R - d)/s) - Phi((-R - d)/s), s = sigma_y.
    cov = np.array([[4.0, 1.5], [1.5, 0.25]])
    got = prob.pc_paielli_erzberger([[-7.0, 0.3]], cov[None], 1.0, [[2.0, 0.0]])[0]
    s = math.sqrt(cov[1, 1])
    assert got == pytest.approx(special.ndtr((1.0 - 0.3) / s) - special.ndtr((-1.0 - 0.3) / s), abs=1e-15)
    # the direction of motion along the line does not matter (Hwang's condition 2(b) exists for that)
    assert prob.pc_paielli_erzberger([[-7.0, 0.3]], cov[None], 1.0, [[-2.0, 0.0]])[0] == pytest.approx(got)
    # no relative motion: the instantaneous probability
    assert prob.pc_paielli_erzberger([[0.5, 0.3]], cov[None], 1.0, [[0.0, 0.0]])[0] == pytest.approx(
        prob.pc_exact([[0.5, 0.3]], cov[None], 1.0)[0], abs=1e-15)


def test_monte_carlo_and_mixtures():
    mean, cov, r = _random_cases(40, 5)
    exact = prob.pc_exact(mean, cov, r)
    mc = prob.pc_monte_carlo(mean, cov, r, samples=20000, rng=1)
    se = np.sqrt(np.maximum(exact * (1 - exact), 1e-4) / 20000)
    assert np.all(np.abs(mc - exact) <= 5 * se)
    # a two-mode mixture: exact is the weighted sum, MC samples the mixture
    means = np.stack([mean, mean + 0.5], axis=1)
    covs = np.stack([cov, 2.0 * cov], axis=1)
    w = np.column_stack([np.full(40, 0.3), np.full(40, 0.7)])
    want = 0.3 * exact + 0.7 * prob.pc_exact(mean + 0.5, 2.0 * cov, r)
    got = prob.conflict_probability(means, covs, r, "exact", weights=w)
    assert np.allclose(got, want, atol=1e-15)
    mcm = prob.conflict_probability(means, covs, r, "mc", weights=w, samples=20000, rng=2)
    assert np.all(np.abs(mcm - want) <= 5 * np.sqrt(np.maximum(want * (1 - want), 1e-4) / 20000))


def test_three_dimensional_zone_is_disk_times_slab():
    mean, cov, r = _random_cases(20, 9)
    mz = np.linspace(-3, 3, 20)
    vz = np.linspace(0.1, 4, 20)
    got = prob.conflict_probability(mean, cov, r, half_height=1.0, mean_z=mz, var_z=vz)
    slab = special.ndtr((1.0 - mz) / np.sqrt(vz)) - special.ndtr((-1.0 - mz) / np.sqrt(vz))
    assert np.allclose(got, prob.pc_exact(mean, cov, r) * slab, atol=1e-15)
    mc = prob.conflict_probability(mean, cov, r, "mc", half_height=1.0, mean_z=mz, var_z=vz, samples=20000, rng=4)
    assert np.all(np.abs(mc - got) <= 5 * np.sqrt(np.maximum(got * (1 - got), 1e-4) / 20000))


def test_degenerate_cases():
    zero = np.zeros((2, 2))
    # point masses: inside (boundary inclusive) and outside
    pts = np.array([[0.5, 0.0], [1.0, 0.0], [1.0 + 1e-12, 0.0]])
    assert list(prob.pc_exact(pts, np.broadcast_to(zero, (3, 2, 2)), 1.0)) == [1.0, 1.0, 0.0]
    assert list(prob.pc_one_block(pts, np.broadcast_to(zero, (3, 2, 2)), 1.0)) == [1.0, 1.0, 0.0]
    # a line (rank-1 covariance along y at x = 0.6): the chord |y| <= 0.8
    line = np.array([[0.0, 0.0], [0.0, 4.0]])
    want = special.ndtr((0.8 - 0.1) / 2.0) - special.ndtr((-0.8 - 0.1) / 2.0)
    assert prob.pc_exact([[0.6, 0.1]], line[None], 1.0)[0] == pytest.approx(want, abs=1e-15)
    assert prob.pc_exact([[1.6, 0.1]], line[None], 1.0)[0] == 0.0
    # nearly singular: continuous with the line
    near = np.array([[1e-20, 0.0], [0.0, 4.0]])
    assert prob.pc_exact([[0.6, 0.1]], near[None], 1.0)[0] == pytest.approx(want, abs=1e-12)
    # zero radius, far away, huge radius
    assert prob.pc_exact([[0.0, 0.0]], np.eye(2)[None], 0.0)[0] == 0.0
    assert prob.pc_exact([[1e6, 0.0]], np.eye(2)[None], 1.0)[0] == 0.0
    assert prob.pc_exact([[0.0, 0.0]], np.eye(2)[None], 1e6)[0] == pytest.approx(1.0, abs=1e-13)  # 7.5 sigma window
    # non-finite input propagates as NaN, the others are unaffected
    got = prob.pc_exact([[np.nan, 0.0], [0.0, 0.0]], np.broadcast_to(np.eye(2), (2, 2, 2)), 1.0)
    assert np.isnan(got[0]) and got[1] == pytest.approx(-math.expm1(-0.5))
    # empty batches and a single pair given without the batch axis
    assert prob.pc_exact(np.zeros((0, 2)), np.zeros((0, 2, 2)), 1.0).shape == (0,)
    assert prob.pc_exact([0.0, 0.0], np.eye(2), 1.0).shape == (1,)
    # vertical slab with zero variance: an indicator
    assert list(prob.vertical_probability([0.0, 2.0], [0.0, 0.0], 1.0)) == [1.0, 0.0]
    with pytest.raises(ValueError):
        prob.conflict_probability([[0.0, 0.0]], np.eye(2)[None], 1.0, "nope")
    with pytest.raises(ValueError):
        prob.conflict_probability([[0.0, 0.0]], np.eye(2)[None], 1.0, "pe")  # needs rel_vel


def test_direct_grid_reference_is_close():
    # Baek & Bang's 10^6-point direct integration: a staircase error of order 1e-5 here
    m, cov = np.array([[0.0, 2.0]]), np.eye(2)[None]
    assert abs(prob.pc_direct_grid(m, cov, 2.0)[0] - prob.pc_exact(m, cov, 2.0)[0]) < 1e-4


def test_scenario2_abeam_values():
    # Baek & Bang scenario 2 abeam: relative position (0, 2) nm, R = 2 nm on the boundary.
    for var, one_block in ((1.0, 0.47722), (0.1, 0.5)):
        cov = np.eye(2)[None] * var
        exact = prob.pc_exact([[0.0, 2.0]], cov, 2.0)[0]
        assert exact == pytest.approx(dblquad_pc(np.array([0.0, 2.0]), cov[0], 2.0), abs=1e-12)
        assert prob.pc_one_block([[0.0, 2.0]], cov, 2.0)[0] == pytest.approx(one_block, abs=1e-5)
        assert exact < 0.5  # the boundary curves away from the mean
