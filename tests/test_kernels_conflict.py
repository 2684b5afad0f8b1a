"""The conflict stage's compiled kernels (avionics/conflict/kernels.py) against their numpy references, on random
inputs and on the edge cases: compiled = reference to 1e-9 (absolute for probabilities, relative for geometry).

The public functions dispatch on avionics.base.jit.ready(); the references are called explicitly (the *_reference
functions, or the public function inside jit.reference() for the stage's curve), so both run in one process.
Under AVIONICS_COMPILED=0 there is nothing compiled to compare: the tests skip.
"""

from __future__ import annotations

import math
from unittest import mock

import numpy as np
import pytest
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st

from avionics.conflict import assess, kernels
from avionics.conflict import probability as prob
from avionics.conflict.cpa import pair_geometry, pair_geometry_reference
from avionics.conflict.params import ConflictConfig
from avionics.conflict.pc_at_cpa import pc_at_cpa, pc_at_cpa_reference
from avionics.conflict.scheduling import MinDistancePrefilter
from avionics.base import jit

pytestmark = pytest.mark.skipif(not jit.ENABLED, reason="compiled kernels are off (AVIONICS_COMPILED=0)")
TOL = 1e-9
SETTINGS = settings(max_examples=200, deadline=None, suppress_health_check=[HealthCheck.too_slow])


def same_probabilities(got, want, tol=TOL):
    got, want = np.asarray(got), np.asarray(want)
    assert got.shape == want.shape
    assert np.array_equal(np.isnan(got), np.isnan(want)), (got, want)
    ok = ~np.isnan(want)
    assert np.all(np.abs(got[ok] - want[ok]) <= tol), np.max(np.abs(got[ok] - want[ok]))


def covariance(sigma_major, axis_ratio, angle):
    c, s = math.cos(angle), math.sin(angle)
    rot = np.array([[c, -s], [s, c]])
    return rot @ np.diag([sigma_major**2, (sigma_major / axis_ratio) ** 2]) @ rot.T


@st.composite
def disk_case(draw):
    """Covariances from 1e-6 to 1e6 m of sigma (tiny and huge), axis ratios 1 to 1e8 (and exactly degenerate: a
    line, a point), any rotation; R from 0 to 1e4 sigma; the mean at the centre, inside, on the boundary exactly,
    just off it, far out."""
    sigma = 10 ** draw(st.floats(-6.0, 6.0))
    kind = draw(st.sampled_from(["general", "general", "general", "line", "point"]))
    ratio = 10 ** draw(st.floats(0.0, 8.0))
    angle = draw(st.floats(0.0, math.pi))
    cov = covariance(sigma, ratio, angle)
    if kind == "line":
        cov = covariance(sigma, 1.0, angle) * np.array([[1.0, 0.0], [0.0, 0.0]])
    elif kind == "point":
        cov = np.zeros((2, 2))
    r = draw(st.sampled_from([0.0, 1.0])) * sigma * 10 ** draw(st.floats(-3.0, 4.0))
    r = draw(st.one_of(st.just(r), st.floats(0.0, 1e4)))
    rho = draw(st.sampled_from([0.0, 0.3, 1.0, 1.0, 1.0 + 1e-12, 0.999, 1.5, 10.0]))
    phi = draw(st.floats(0.0, 2.0 * math.pi))
    jitter = draw(st.floats(-3.0, 3.0)) * sigma * draw(st.sampled_from([0.0, 0.0, 1.0]))
    mean = (rho * r + jitter) * np.array([math.cos(phi), math.sin(phi)])
    return mean, cov, r


@SETTINGS
@given(st.lists(disk_case(), min_size=1, max_size=8))
@example([(np.array([1.0, 0.0]), np.eye(2), 1.0)])  # on the boundary
@example([(np.zeros(2), np.zeros((2, 2)), 0.0)])  # radius 0, no covariance
@example([(np.array([0.5, 0.0]), np.zeros((2, 2)), 0.5)])  # a point mass exactly on the boundary
@example([(np.zeros(2), np.eye(2) * 1e-30, 1e-14)])
@example([(np.array([3e5, 0.0]), np.eye(2) * 1e12, 1e5)])
@example([(np.array([0.0, 0.0]), np.eye(2), 0.0), (np.array([0.0, 0.0]), np.eye(2), 0.0),
          (np.array([11.0, 0.0]), np.array([[1.07861331e-13, -2.95475680e-13], [-2.95475680e-13, 9.02138669e-13]]),
           11.0)])  # on the boundary, sigma/R ~ 1e-7: kernel and reference were 1.07e-9 apart (both off)
def test_pc_exact_kernel_equals_reference(cases):
    mean = np.array([c[0] for c in cases])
    cov = np.array([c[1] for c in cases])
    r = np.array([c[2] for c in cases])
    same_probabilities(prob.pc_exact(mean, cov, r), prob.pc_exact_reference(mean, cov, r))


def pc_mpmath(mean, cov, radius, dps=36):
    """P(|m + e| <= R), e ~ N(0, P), by mpmath at dps digits, independently of pc_exact's method: polar coordinates
    about the disk's centre, the radial integral along each ray in closed form (a Gaussian in rho times rho), the
    angle by mpmath.quad with break points across the narrow wedge where the mass is. The inputs are taken as the
    exact binary values they are (the symmetric part of P)."""
    import mpmath as mp

    with mp.workdps(dps):
        mx, my, r = mp.mpf(float(mean[0])), mp.mpf(float(mean[1])), mp.mpf(float(radius))
        a, d = mp.mpf(float(cov[0][0])), mp.mpf(float(cov[1][1]))
        b = (mp.mpf(float(cov[0][1])) + mp.mpf(float(cov[1][0]))) / 2
        det = a * d - b * b

        def ray(th):  # integral over rho in [0, R] of rho N2(rho (cos th, sin th); m, P), times 2 pi sqrt(det)
            ux, uy = mp.cos(th), mp.sin(th)
            big_a = (d * ux * ux - 2 * b * ux * uy + a * uy * uy) / det  # u' P^-1 u
            rho0 = (d * ux * mx - b * (ux * my + uy * mx) + a * uy * my) / det / big_a  # nearest point to m
            across = ux * my - uy * mx  # the mean's offset from the ray's line, and the variance across it:
            var_across = a * uy * uy - 2 * b * ux * uy + d * ux * ux  # m' P^-1 m - B^2/A without cancellation
            k = mp.sqrt(big_a / 2)
            radial = ((mp.exp(-(k * rho0) ** 2) - mp.exp(-(k * (r - rho0)) ** 2)) / big_a
                      + rho0 * mp.sqrt(mp.pi / (2 * big_a)) * (mp.erf(k * (r - rho0)) + mp.erf(k * rho0)))
            return mp.exp(-across * across / (2 * var_across)) * radial

        rm = mp.hypot(mx, my)
        th0 = mp.atan2(my, mx) if rm > 0 else mp.mpf(0)
        points = {th0 - mp.pi, th0 + mp.pi}
        disc = mp.sqrt(((a - d) / 2) ** 2 + b * b)
        for lam in ((a + d) / 2 + disc, det / ((a + d) / 2 + disc)):  # both sigmas, as angles seen from the centre
            if rm > 0 and mp.sqrt(lam) / rm < 0.05:
                points.update(th0 + k * mp.sqrt(lam) / rm for k in (-40, -12, -6, -3, -1, 0, 1, 3, 6, 12, 40))
        return mp.quad(ray, sorted(points)) / (2 * mp.pi * mp.sqrt(det))


def boundary_cases():
    """The mean on the circle R = 11 m (to the last bit of its coordinates), sigma/R 1e-9 to 1e-3, axis ratios 1 to
    1e8, three orientations (one with the minor axis along the boundary normal: the chord's square-root end inside
    the Gaussian), each met by every sigma and every ratio; and hypothesis' case."""
    r = 11.0
    turns = [(0.3, 1.1), (math.pi / 2, 0.0), (1.2, 2.5)]  # (covariance angle, mean's direction)
    cases = []
    for i, sigma_over_r in enumerate([1e-9, 1e-6, 1e-3]):
        for j, ratio in enumerate([1.0, 1e4, 1e8]):
            angle, phi = turns[(i - j) % 3]
            cases.append((r * np.array([math.cos(phi), math.sin(phi)]), covariance(sigma_over_r * r, ratio, angle), r))
    cases.append((np.array([11.0, 0.0]), np.array([[1.07861331e-13, -2.95475680e-13],
                                                    [-2.95475680e-13, 9.02138669e-13]]), 11.0))
    return cases


def test_pc_exact_on_the_boundary_agrees_with_mpmath():
    """On the boundary Pc is 0.5 minus a curvature term ~ var_tangential / (R sigma_normal), from 1e-8 to 0.36
    here: kernel and reference to 1e-12 of a 36-digit integration (they leave out the 3.2e-14 beyond 7.5 sigma).
    Before the thin path both were up to 0.48 off here (sigma/R 1e-9, ratio 1e8, minor axis along the normal),
    1.7e-7 (ratio 1e4), 5e-9 (isotropic), and 1.0e-10 (kernel), 4.5e-10 (reference) on hypothesis' case."""
    pytest.importorskip("mpmath")
    cases = boundary_cases()
    mean = np.array([c[0] for c in cases])
    cov = np.array([c[1] for c in cases])
    r = np.array([c[2] for c in cases])
    want = np.array([float(pc_mpmath(*c)) for c in cases])
    assert want.min() < 0.2  # not a vacuous grid: the curvature term is far from negligible on some
    for got in (prob.pc_exact(mean, cov, r), prob.pc_exact_reference(mean, cov, r)):
        np.testing.assert_allclose(got, want, rtol=0, atol=1e-12)


def test_pc_exact_kernel_non_finite_inputs_and_shapes():
    mean = np.array([[np.nan, 0.0], [0.0, 0.0], [0.0, 0.0], [np.inf, 0.0]])
    cov = np.broadcast_to(np.eye(2), (4, 2, 2))  # read-only, non-contiguous: copied for the kernel
    r = np.array([1.0, np.nan, -1.0, 1.0])
    got = prob.pc_exact(mean, cov, r)
    same_probabilities(got, prob.pc_exact_reference(mean, cov, r))
    assert np.isnan(got[[0, 1, 3]]).all() and got[2] == 0.0
    assert prob.pc_exact(np.zeros((0, 2)), np.zeros((0, 2, 2)), 1.0).shape == (0,)
    assert prob.pc_exact([0.0, 0.0], np.eye(2), 1.0).shape == (1,)


def test_pc_exact_kernel_many_random_pairs():
    """20,000 pairs over the acceptance grid of test_probability.py (ratios to 1000:1, R 0.01 to 100 sigma)."""
    rng = np.random.default_rng(11)
    n = 20_000
    sig = 10 ** rng.uniform(-1, 1, n)
    cov = np.array([covariance(s, 10 ** q, a) for s, q, a in zip(sig, rng.uniform(0, 3, n), rng.uniform(0, np.pi, n))])
    r = sig * 10 ** rng.uniform(-2, 2, n)
    phi = rng.uniform(0, 2 * np.pi, n)
    mean = (r * rng.uniform(0, 3, n))[:, None] * np.column_stack([np.cos(phi), np.sin(phi)])
    got, want = prob.pc_exact(mean, cov, r), prob.pc_exact_reference(mean, cov, r)
    same_probabilities(got, want)
    assert np.abs(got - want).max() < 1e-13  # the same formulas: they agree far below the 1e-9 asked


def test_pc_exact_dispatches_on_the_switch():
    assert type(kernels.pc_exact_pairs).__name__ == "CPUDispatcher" and kernels.pc_exact_pairs in jit.KERNELS
    mean, cov = np.array([[0.3, 0.2]]), np.eye(2)[None]
    with mock.patch.object(kernels, "pc_exact_pairs", side_effect=AssertionError("kernel called")):
        with pytest.raises(AssertionError, match="kernel called"):
            prob.pc_exact(mean, cov, 1.0)
        with jit.reference():
            prob.pc_exact(mean, cov, 1.0)  # the reference: no kernel (as the live loop before its switch)
        with mock.patch.object(jit, "ENABLED", False), mock.patch.object(jit, "_ready", False):
            prob.pc_exact(mean, cov, 1.0)  # compiled kernels off: the reference


# --- Pc at CPA -------------------------------------------------------------------------------------------


@st.composite
def cpa_case(draw):
    n = draw(st.integers(1, 6))
    seed = draw(st.integers(0, 2**32 - 1))
    rng = np.random.default_rng(seed)
    scale = 10 ** draw(st.floats(-4.0, 4.0))
    x = np.column_stack([rng.uniform(-3000, 3000, (n, 2)), rng.uniform(-300, 300, n),
                         rng.uniform(-60, 60, (n, 2)), rng.uniform(-3, 3, n)])
    if draw(st.booleans()):
        x[:, 3:6] = 0.0  # no relative motion
    a = rng.normal(size=(n, 6, 6)) * np.array([30, 30, 15, 2, 2, 1.0])[None, :, None] * scale
    p = a @ np.swapaxes(a, 1, 2) + np.diag([100, 100, 25, 1, 1, 0.25])[None] * scale**2
    t = rng.uniform(0, 60, n) * draw(st.sampled_from([0.0, 1.0, 1e3]))
    has_alt = rng.random(n) < 0.8
    volumes = draw(st.lists(st.tuples(st.sampled_from([0.0, 150.0, 1000.0, 1e5]),
                                      st.sampled_from([None, 0.0, 100.0, 250.0])), min_size=1, max_size=3))
    sigma_h, sigma_v = draw(st.sampled_from([(0.0, 0.0), (2.0, 1.0), (30.0, 10.0)]))
    return x, p, t, volumes, sigma_h, sigma_v, has_alt


@SETTINGS
@given(cpa_case())
def test_pc_at_cpa_kernel_equals_reference(case):
    same_probabilities(pc_at_cpa(*case), pc_at_cpa_reference(*case))


def test_pc_at_cpa_kernel_cpa_ages_away():
    """tests/test_pc_at_cpa.py's hovering pair closing at 7.5e-132 m/s: CPA 1e134 s ahead, propagation capped."""
    x = np.array([[0.0, 2000.0, 300.0, 0.0, -7.5e-132, 0.0]])
    p = np.diag([100.0, 100.0, 25.0, 1.0, 1.0, 0.25])[None]
    t = np.array([2000.0 * 7.5e-132 / 7.5e-132**2])
    args = (x, p, t, [(1000.0, 250.0), (300.0, None)], 2.0, 1.0, np.array([True]))
    got = pc_at_cpa(*args)
    same_probabilities(got, pc_at_cpa_reference(*args))
    assert np.isfinite(got).all() and got[0, 0] == pytest.approx(0.0, abs=1e-12)


# --- the conflict stage's curve ----------------------------------------------------------------------------


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(cpa_case(), st.sampled_from([0.5, 1.0, 2.0]), st.floats(0.0, 300.0))
def test_conflict_stage_curve_kernel_equals_reference(case, step_s, margin):
    x, p, _, _, sigma_h, sigma_v, has_alt = case
    cfg = ConflictConfig(step_s=step_s, lookahead_s=30.0 * step_s, accel_sigma_h_mps2=sigma_h,
                         accel_sigma_v_mps2=sigma_v, within_samples=0)
    margin = np.full(len(x), margin)
    got = assess.conflict_probabilities(x, p, cfg, has_alt=has_alt, z_margin_m=margin, return_curve=True)
    with jit.reference():
        want = assess.conflict_probabilities(x, p, cfg, has_alt=has_alt, z_margin_m=margin, return_curve=True)
    for key in ("pc_curve", "pc_now", "pc_max", "pc_pe"):
        same_probabilities(got[key], want[key])
    np.testing.assert_array_equal(got["t_s"], want["t_s"])
    # the time of the maximum: the same step unless two steps tie to within the tolerance
    curve = want["pc_curve"]
    at = lambda t: curve[np.arange(len(x)), np.searchsorted(want["t_s"], t)]  # noqa: E731
    np.testing.assert_allclose(at(got["t_pc_max_s"]), at(want["t_pc_max_s"]), atol=TOL, rtol=0)


def test_conflict_stage_curve_uses_the_kernel_only_for_the_exact_method():
    x = np.array([[500.0, 200.0, 30.0, -20.0, -5.0, 0.0]])
    p = np.diag([100.0, 100.0, 25.0, 1.0, 1.0, 0.25])[None]
    with mock.patch.object(kernels, "zone_pairs", side_effect=AssertionError("kernel called")):
        with pytest.raises(AssertionError, match="kernel called"):
            assess.conflict_probabilities(x, p, ConflictConfig(within_samples=0))
        assess.conflict_probabilities(x, p, ConflictConfig(within_samples=0), method=prob.OneBlockPc())


# --- geometry ----------------------------------------------------------------------------------------------

FIELDS = ("range_m", "s_dot_v", "closure_rate_mps", "t_cpa_s", "hmd_m", "sz_m", "vz_mps", "vmd_m", "range_tau_s",
          "vertical_tau_s", "s_xy_m", "v_xy_mps", "cpa_xy_m", "t_cpa3d_s", "cpa3d_xyz_m", "miss3d_m")
coord = st.one_of(st.floats(-1e5, 1e5), st.sampled_from([0.0, 1e-131, -7.5e-132, 1e-300]))


@SETTINGS
@given(st.lists(st.tuples(coord, coord, coord, coord, coord, coord), min_size=1, max_size=10))
@example([(0.0, 0.0, 0.0, 0.0, 0.0, 0.0)])  # co-located, no motion
@example([(0.0, 2000.0, 300.0, 0.0, -7.5e-132, 0.0)])  # CPA 1e134 s ahead
@example([(100.0, 0.0, 0.0, 0.0, 0.0, 0.0), (0.0, 0.0, 50.0, 0.0, 0.0, -1.0)])
def test_pair_geometry_kernel_equals_reference(rows):
    a = np.array(rows, float)
    args = (a[:, 0:2], a[:, 2:4], a[:, 4], a[:, 5])
    got, want = pair_geometry(*args), pair_geometry_reference(*args)
    for name in FIELDS:
        g, w = getattr(got, name), getattr(want, name)
        assert g.shape == w.shape, name
        np.testing.assert_allclose(g, w, rtol=TOL, atol=1e-300, err_msg=name)  # inf == inf; NaN == NaN


def test_pair_geometry_kernel_is_used():
    with mock.patch.object(kernels, "pair_geometry_pairs", side_effect=AssertionError("kernel called")):
        with pytest.raises(AssertionError, match="kernel called"):
            pair_geometry([[1.0, 2.0]], [[0.0, 1.0]], [0.0], [0.0])


# --- the alerter's TCAS3D tests --------------------------------------------------------------------------------


@SETTINGS
@given(st.lists(st.tuples(coord, coord, coord, coord, coord, coord, st.booleans(), st.booleans(),
                          st.sampled_from([0.0, 30.0, 1e4])), min_size=1, max_size=10),
       st.sampled_from([0.0, 500.0, 1500.0]), st.sampled_from([0.0, 100.0, 250.0]), st.sampled_from([0.0, 25.0, 48.0]),
       st.sampled_from([None, 0.0, 400.0]), st.booleans(), st.booleans(), st.booleans())
@example([(1000.0, 0.0, -20.0, 0.0, 100.0, -4.0, True, True, 0.0)], 1000.0, 100.0, 25.0, None, False, True, False)
def test_tcas3d_kernel_equals_reference(rows, dmod, zthr, tau, hmd, altitude_required, hmd_filter, scalar_flags):
    from avionics.advisory.alerting import TCAS3D, Encounter, TcasThresholds

    a = np.array([r[:6] for r in rows], float)
    g = pair_geometry_reference(a[:, 0:2], a[:, 2:4], a[:, 4], a[:, 5])
    has_alt = np.array([r[6] for r in rows])
    eligible = True if scalar_flags else np.array([r[7] for r in rows])
    margin = 0.0 if scalar_flags else np.array([r[8] for r in rows])
    enc = Encounter(g, has_alt, margin, eligible)
    det = TCAS3D(altitude_required=altitude_required, hmd_filter=hmd_filter)
    thr = TcasThresholds(tau, dmod, zthr, hmd)
    for time_s in (tau, 0.0):
        got = det.conflict(enc, thr, time_s)
        assert got.dtype == bool
        np.testing.assert_array_equal(got, det.conflict_reference(enc, thr, time_s))


def test_tcas3d_kernel_is_used():
    from avionics.advisory.alerting import TCAS3D, Encounter, TcasThresholds

    enc = Encounter(pair_geometry([[1.0, 2.0]], [[0.0, 1.0]], [0.0], [0.0]), np.array([True]))
    with mock.patch.object(kernels, "tcas3d_conflict_pairs", side_effect=AssertionError("kernel called")):
        with pytest.raises(AssertionError, match="kernel called"):
            TCAS3D().conflict(enc, TcasThresholds(25.0, 1000.0, 100.0), 25.0)


# --- the pc_within Monte Carlo ---------------------------------------------------------------------------------


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(cpa_case(), st.integers(0, 2**32 - 1), st.sampled_from([0.5, 1.0]), st.sampled_from([0, 1, 7, 30]),
       st.sampled_from([None, 100.0, "mixed"]), st.sampled_from([(2.0, 1.0), (0.0, 0.0), (30.0, 10.0)]))
def test_pc_within_kernel_equals_reference_sample_for_sample(case, seed, step_s, steps, half, sigmas):
    """The same random numbers from the same Generator: the same hits, exactly (a fraction of the samples)."""
    from avionics.conflict.prediction import pc_within_cv_mc, pc_within_cv_mc_reference

    x, p, _, volumes, _, _, _ = case
    x = x.copy()
    x[:, 0:2] *= 0.1  # within reach of the disk in a few steps
    hh = None if half is None else (np.where(np.arange(len(x)) % 2 == 0, 100.0, np.inf) if half == "mixed" else half)
    args = (x, p, volumes[0][0] or 300.0, steps * step_s, step_s, *sigmas, hh, 200)
    got = pc_within_cv_mc(*args, np.random.default_rng(seed))
    want = pc_within_cv_mc_reference(*args, np.random.default_rng(seed))
    np.testing.assert_array_equal(got, want)


def test_pc_within_kernel_agrees_on_the_conflict_stage_and_leaves_the_generator_where_the_reference_does():
    from avionics.conflict.prediction import pc_within_cv_mc, pc_within_cv_mc_reference

    rng = np.random.default_rng(5)
    n = 40
    x = np.column_stack([rng.uniform(-2000, 2000, (n, 2)), rng.uniform(-150, 150, n),
                         rng.uniform(-40, 40, (n, 2)), rng.uniform(-2, 2, n)])
    x[:, 3:5] -= x[:, 0:2] / 40.0  # converging
    p = np.broadcast_to(np.diag([400.0, 400.0, 100.0, 4.0, 4.0, 1.0]), (n, 6, 6))
    g1, g2 = np.random.default_rng(9), np.random.default_rng(9)
    got = pc_within_cv_mc(x, p, 300.0, 60.0, 1.0, 2.0, 1.0, np.full(n, 100.0), 500, g1)
    want = pc_within_cv_mc_reference(x, p, 300.0, 60.0, 1.0, 2.0, 1.0, np.full(n, 100.0), 500, g2)
    np.testing.assert_array_equal(got, want)
    assert 0.0 < got.max() and got.min() < 1.0  # not a vacuous comparison: some pairs hit, some do not
    assert g1.random() == g2.random()


# --- the pre-filter (Hwang condition 2(b)) -----------------------------------------------------------------


@SETTINGS
@given(cpa_case(), st.sampled_from([0.0, 1.0, 60.0]), st.sampled_from([1.0, 1.5, 3.0]),
       st.sampled_from([0.0, 30.0, 300.0]))
@example(case=(np.array([[1000.0, 0.0, 0.0, -10.0, 0.0, 0.0], [1000.0, 0.0, 50.0, -10.0, 0.0, -1.0],
                         [0.0, 0.0, -20.0, 0.0, 0.0, 1.0], [3000.0, 0.0, 10.0, 0.0, 0.0, 0.0]]),
               np.tile(np.diag([100.0, 100.0, 25.0, 1.0, 1.0, 0.25]), (4, 1, 1)), None, None, 2.0, 1.0,
               np.array([True, True, True, False])), lookahead_s=60.0, alpha=1.5, margin=0.0)
def test_prefilter_kernel_equals_reference(case, lookahead_s, alpha, margin):
    """MinDistancePrefilter.keep's kernel keeps exactly the pairs its numpy reference keeps (a co-altitude pair,
    one crossing the other's altitude, a pair at rest, one without altitude among them)."""
    x, p, _, _, sigma_h, sigma_v, has_alt = case
    prefilter = MinDistancePrefilter(zone_radius_m=150.0, zone_half_height_m=30.0, lookahead_s=lookahead_s,
                                     step_s=1.0, alpha=alpha, accel_sigma_h_mps2=sigma_h, accel_sigma_v_mps2=sigma_v)
    margins = np.full(len(x), margin)
    got = prefilter.keep(x, p, has_alt, margins)
    want = prefilter.keep_reference(x, p, has_alt, margins)
    assert got.dtype == bool and np.array_equal(got, want), (got, want)
