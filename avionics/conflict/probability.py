"""Conflict probability of a Gaussian relative position over a conflict zone, for N pairs at once.

The relative position x = intruder - ownship is N(m, P) (Baek & Bang eq 23: m = m_A - m_B, P = P_A + P_B for
independent estimates). A conflict is x inside the zone D: the horizontal disk |x| <= R, and in 3D the disk
times the vertical slab |z| <= H. The probability is (Baek & Bang eq 24)

    Pc = integral over D of N2(x; m, P) dx.

With the vertical axis independent of the horizontal one (as in every tracker of this project: no filter
couples them), the 3D probability is the product of the disk probability and the slab probability
Phi((H - m_z)/s_z) - Phi((-H - m_z)/s_z).

Methods (one interface, `conflict_probability`, every array over N pairs):

exact       1D integral along the minor principal axis of P with the other axis in closed form, Gauss-Legendre
            on panels placed where the integrand has structure (see `pc_exact`); agrees with scipy dblquad to
            better than 1e-12 over covariance axis ratios up to 1000:1 and R from 0.01 to 100 sigma, and with a
            50-digit mpmath integration to 1e-13 with the mean on the boundary, sigma/R from 1e-9 to 1e-3 and axis
            ratios to 1e8 (tests/test_kernels_conflict.py): where the Gaussian is narrow across the disk every
            distance to the circle comes from D = R^2 - |m|^2 computed to the last bit (`disk_margin`).
one_block   Hwang & Seah (2008) as given by Baek & Bang eqs 25-28: whiten (Cholesky, eqs 25-26), rotate to the
            axes of the (now elliptic) zone, integrate over the circumscribing rectangle: a product of two 1D
            Gaussian CDF differences (eq 27-28). An upper bound.
blocks      Baek & Bang eq 29: the elliptic zone covered by n_blocks rectangles (a staircase), each as eq 27,
            summed. An upper bound that decreases to the exact value as n_blocks grows.
pe          Paielli & Erzberger (1997) as given by Hwang, Hwang & Tomlin eq 24: with the relative velocity held
            constant the zone, swept along the relative velocity, becomes an infinite strip; Pc is the Gaussian
            mass of the strip, Phi(R - d) - Phi(-R - d) in units of the cross-velocity sigma. This is the
            probability of a conflict at any time of the straight-line encounter (past or future: Hwang's
            condition 2(b) exists because of that), an upper bound of the instantaneous value.
mc          Monte Carlo over a Gaussian mixture (the IMM mode mixture: per-mode means and covariances, weights
            = mode probabilities), or over the single Gaussian.

Whitening and rotating as in eqs 25-26 and rotating to the ellipse axes is the same as working in the principal
axes of P scaled by their sigmas, which is what the code does: in that frame the zone is the disk, the Gaussian
factorises into N(u; m_u, s_a) N(v; m_v, s_b), and a rectangle aligned with (u, v) has the probability of eq 27.

Units: any consistent length unit (metres in the pipeline, nautical miles in the paper reports).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Protocol

import numpy as np
from scipy import special

from avionics.base import jit

kernels = jit.lazy(__name__, "avionics.conflict.kernels")  # the module, once jit.load() ran (jit.py)

METHODS = ("exact", "one_block", "blocks", "pe", "mc")

SQRT_2PI = math.sqrt(2.0 * math.pi)
K_SIGMA = 7.5  # Gaussian mass beyond 7.5 sigma: 3.2e-14 per side
# Gauss-Legendre rules by how many sigmas (of either factor's own argument) a panel spans: 32 nodes integrate a
# Gaussian or a CDF ramp over 15 sigmas to ~1e-13, 24 nodes over 6.5 sigmas and 16 nodes over 4 to ~1e-13.
GL_RULES = ((4.0, 16), (6.5, 24), (np.inf, 32))
_GL = {n: np.polynomial.legendre.leggauss(n) for _, n in GL_RULES}
TAU_WIDTH_FEW_NODES = 0.5  # 16 nodes only on panels at most this wide in tau (of 2)
TAU_SPLIT = 1.0  # zone panels wider than this in tau (of 2) are integrated as two halves
CHUNK = 1024  # pairs per block in pc_exact
GAUSS_CORE = 3.0  # extra break points at m_u +- 3 s_a
THIN = 1e-3  # s_a below THIN R: the thin path (_exact_thin), integrated in the Gaussian's own coordinate
EDGE_NEAR = 2.0  # thin path: a zone panel within EDGE_NEAR widths of the chord's end u = R is integrated in sqrt

ndtr = special.ndtr


# --- helpers ---------------------------------------------------------------------------------------------


def _as_pairs(mean, cov, radius):
    mean = np.asarray(mean, float)
    cov = np.asarray(cov, float)
    if mean.ndim == 1:
        mean = mean[None, :]
    if cov.ndim == 2:
        cov = np.broadcast_to(cov, (mean.shape[0], 2, 2))
    if mean.shape[-1] != 2 or cov.shape[-2:] != (2, 2) or cov.shape[0] != mean.shape[0]:
        raise ValueError(f"mean (N, 2) and cov (N, 2, 2) expected, got {mean.shape} and {cov.shape}")
    radius = np.broadcast_to(np.asarray(radius, float), (mean.shape[0],))
    return mean, cov, radius


_SPLIT = 134217729.0  # 2^27 + 1: Veltkamp's split of a double into two 26-bit halves


def _prod_err(x, y, p):
    """x y - p exactly, p = fl(x y) (Dekker's product: no fused multiply-add needed)."""
    c = _SPLIT * x
    xh = c - (c - x)
    xl = x - xh
    c = _SPLIT * y
    yh = c - (c - y)
    yl = y - yh
    return ((xh * yh - p) + xh * yl + xl * yh) + xl * yl


def _diff_of_products(a, b, c, d):
    """a b - c d to ~1 ulp of the result however much the two products cancel (the determinant of a covariance
    with axis ratio 1e8 is 1e-16 of a d); the plain difference where the split overflows (|x| > 1e300)."""
    with np.errstate(over="ignore", invalid="ignore"):
        p, q = a * b, c * d
        out = (p - q) + (_prod_err(a, b, p) - _prod_err(c, d, q))
        return np.where(np.isfinite(out), out, p - q)


def disk_margin(mean, radius):
    """D = R^2 - |m|^2 for every pair, to ~1 ulp of D itself (Dekker's products and exact two-sums): how far the
    mean is inside the disk. Pc is as sensitive to the mean's distance to the circle as the Gaussian is narrow across
    it, and a mean on the boundary with sigma ~1e-7 R turns a rounding of |m| (1e-16 R) into 1e-9 of Pc; the
    paths that need it (the line and the thin paths of pc_exact) take this distance from D, never from |m| - R or
    from the rotated mean."""
    mx, my, r = mean[:, 0], mean[:, 1], radius
    with np.errstate(over="ignore", invalid="ignore"):
        pr, px, py = r * r, mx * mx, my * my
        s1 = pr - px  # two-sum: s1 + e1 = pr - px exactly
        bb = s1 - pr
        e1 = (pr - (s1 - bb)) + (-px - bb)
        s2 = s1 - py
        bb = s2 - s1
        e2 = (s1 - (s2 - bb)) + (-py - bb)
        out = s2 + (((e1 + e2) + _prod_err(r, r, pr)) - (_prod_err(mx, mx, px) + _prod_err(my, my, py)))
        return np.where(np.isfinite(out), out, pr - px - py)


def principal_frame(mean, cov):
    """Principal axes of each 2x2 covariance: (m_u, m_v, s_a, s_b, e_a, e_b) with s_a <= s_b the sigmas
    along the minor (e_a) and major (e_b) axes, and m_u, m_v the mean in that frame. Closed form; the small
    eigenvalue is det / large one, det from Dekker's exact products, so it stays accurate to ~1e-16 for axis ratios
    up to 1e8 and beyond (the plain a d - b^2 loses all of it at 1e8), and it is the determinant of the exact symmetric
    part (a d - c01 c10 - ((c01 - c10)/2)^2), not of the rounded average b, whose last bit is 1e-8 of s_a at 1e8."""
    a = cov[:, 0, 0]
    d = cov[:, 1, 1]
    b = 0.5 * (cov[:, 0, 1] + cov[:, 1, 0])
    half_tr = 0.5 * (a + d)
    disc = np.hypot(0.5 * (a - d), b)
    lam_b = half_tr + disc
    skew = 0.5 * (cov[:, 0, 1] - cov[:, 1, 0])  # exact for a nearly symmetric cov (R @ D @ R.T is, to an ulp)
    det = np.maximum(_diff_of_products(a, d, cov[:, 0, 1], cov[:, 1, 0]) - skew * skew, 0.0)  # of the symmetric part
    with np.errstate(divide="ignore", invalid="ignore"):
        lam_a = np.where(lam_b > 0.0, det / np.where(lam_b > 0.0, lam_b, 1.0), 0.0)
    lam_a = np.minimum(lam_a, lam_b)
    theta = 0.5 * np.arctan2(2.0 * b, a - d)  # direction of the major axis
    c, s = np.cos(theta), np.sin(theta)
    axis_y = (b == 0.0) & (a < d)  # the major axis along y: exactly, not cos(pi/2) = 6e-17 (a tilt a line feels)
    c, s = np.where(axis_y, 0.0, c), np.where(axis_y, 1.0, s)
    e_b = np.stack([c, s], axis=-1)
    e_a = np.stack([-s, c], axis=-1)
    m_u = np.einsum("ij,ij->i", mean, e_a)
    m_v = np.einsum("ij,ij->i", mean, e_b)
    return m_u, m_v, np.sqrt(lam_a), np.sqrt(np.maximum(lam_b, 0.0)), e_a, e_b


def _interval_mass(lo, hi, mean, sigma):
    """P(lo <= N(mean, sigma^2) <= hi), exact also for sigma = 0 (a point mass, boundary inclusive)."""
    lo, hi, mean, sigma = np.broadcast_arrays(lo, hi, mean, sigma)
    with np.errstate(divide="ignore", invalid="ignore"):
        safe = np.where(sigma > 0.0, sigma, 1.0)
        za, zb = (lo - mean) / safe, (hi - mean) / safe
        # Take the difference in the tail where the CDF is small, so that 1 - 1e-17 never cancels.
        upper = za > 0.0
        p = np.where(upper, ndtr(-za) - ndtr(-zb), ndtr(zb) - ndtr(za))
    point = ((lo <= mean) & (mean <= hi)).astype(float)
    return np.where(sigma > 0.0, np.maximum(p, 0.0), np.where(hi >= lo, point, 0.0))


def vertical_probability(mean_z, var_z, half_height):
    """P(|z| <= H) for z ~ N(mean_z, var_z): the slab factor of the 3D zone."""
    mean_z = np.asarray(mean_z, float)
    h = np.asarray(half_height, float)
    return _interval_mass(-h, h, mean_z, np.sqrt(np.maximum(np.asarray(var_z, float), 0.0)))


# --- exact ---------------------------------------------------------------------------------------------


def _tau_of_u(u, r):
    """u = R sin t -> tau = tan(t/2) = (u/R) / (1 + sqrt(1 - (u/R)^2)), in [-1, 1]."""
    with np.errstate(over="ignore"):  # a tiny radius: u / r overflows to +-inf, which the clip makes +-1 (exact)
        w = np.clip(u / r, -1.0, 1.0)
    return w / (1.0 + np.sqrt(np.maximum(1.0 - w * w, 0.0)))


def pc_exact(mean, cov, radius) -> np.ndarray:
    """Exact Pc over the disk |x| <= R for N pairs: mean (N, 2), cov (N, 2, 2), radius scalar or (N,): the
    compiled kernel (conflict/kernels.py pc_exact_pairs, every pair in one call) when the compiled kernels
    are ready (avionics.base.jit.ready), else the numpy reference `pc_exact_reference` (the method is described there)."""
    if not jit.ready():
        return pc_exact_reference(mean, cov, radius)
    mean, cov, radius = _as_pairs(mean, cov, radius)
    return kernels.pc_exact_pairs(as_c(mean), as_c(cov), as_c(radius))


def as_c(a, dtype=np.float64) -> np.ndarray:
    """a as the compiled kernels take it: float64 (or dtype), C-contiguous, writable (numba types a read-only
    array apart); a copy only when it is not already (np.require costs six times more on the one-report path)."""
    a = np.ascontiguousarray(a, dtype=dtype)
    return a if a.flags.writeable else a.copy()


def pc_exact_reference(mean, cov, radius) -> np.ndarray:
    """Exact Pc over the disk |x| <= R for N pairs: mean (N, 2), cov (N, 2, 2), radius scalar or (N,).

    In the principal frame (u along the minor axis, sigma s_a <= s_b) the inner integral over v is closed form:

        Pc = int_{-R}^{R} phi((u - m_u)/s_a)/s_a [Phi((h(u) - m_v)/s_b) - Phi((-h(u) - m_v)/s_b)] du,
        h(u) = sqrt(R^2 - u^2).

    The remaining 1D integral is taken over u in [m_u - 7.5 s_a, m_u + 7.5 s_a] (clipped to [-R, R]) with the
    substitution u = 2R tau / (1 + tau^2) (tau = tan(t/2), u = R sin t): the square-root edge of h(u) at u = +-R
    becomes a rational, analytic integrand, with no trigonometric calls. The bracket is exactly 0 or 1 (to
    1e-14) except where h(u) is within 7.5 s_b of +-m_v; those 'zones' end at tau = sqrt((R - h)/(R + h)),
    which split the window into panels, as do m_u +- 3 s_a. On a panel without a zone the bracket is a constant
    and the integral is the closed-form Gaussian mass of the panel; on a panel inside a zone both factors span
    at most 15 sigmas of their own argument, and 16-, 24- or 32-point Gauss-Legendre (by the span) is exact to
    ~1e-13. Knots are chained by exact differences of u (no digits lost when s_a << |m_u|). Along the minor axis the
    bracket never varies faster than the Gaussian factor except near u = +-R, exactly where the zone panels
    put the break points, so no adaptive refinement is needed: cost is fixed per pair (plus 16-32 nodes per
    zone panel, typically 1-3). Degenerate covariances are exact too: s_a = 0 (a line) and P = 0 (a point).

    That holds while s_a >= THIN R. A Gaussian narrower across the disk is integrated by `_exact_thin`, in its own
    coordinate: Pc moves by ~0.4 / s_a per metre of the mean's distance to the circle, and the tau grid, the rotated
    mean and the circle all carry 1e-16 R of rounding in absolute position (a mean on the boundary with s_a = 1e-7 R
    came out 1e-9 off, and the compiled kernel, whose sin/cos differ from numpy's by an ulp, disagreed with this
    reference by as much); below s_a ~ 1e-13 R tau cannot even resolve the window. The thin path, the line case
    and the principal frame's determinant take every cancelling difference from exact products (disk_margin,
    _diff_of_products), so they are good to ~1e-16 of the Gaussian's own scale.
    """
    mean, cov, radius = _as_pairs(mean, cov, radius)
    n = mean.shape[0]
    out = np.zeros(n)
    if n == 0:
        return out
    m_u, m_v, s_a, s_b, _, _ = principal_frame(mean, cov)
    r = radius
    finite = np.isfinite(m_u) & np.isfinite(m_v) & np.isfinite(s_a) & np.isfinite(s_b) & np.isfinite(r)
    ok = finite & (r > 0.0)
    line = ok & (s_a == 0.0)  # all the mass on the line u = m_u (or a point when s_b = 0 too)
    gen = ok & (s_a > 0.0) & (s_a >= THIN * r)
    thin = ok & (s_a > 0.0) & (s_a < THIN * r)
    dm = disk_margin(mean, r) if (line | thin).any() else None  # the line and the thin paths only

    if line.any():
        i = np.flatnonzero(line)
        out[i] = _line_mass(m_v[i], s_b[i], dm[i])

    for sel, path in ((gen, _exact_general), (thin, _exact_thin)):
        idx = np.flatnonzero(sel)
        for k in range(0, idx.size, CHUNK):  # blocks that keep the temporaries in cache (2-3x faster)
            i = idx[k:k + CHUNK]
            args = (m_u[i], m_v[i], s_a[i], s_b[i], r[i])
            with np.errstate(over="ignore"):  # a knot's z far beyond the window (tiny s_a): +-inf, then clipped
                out[i] = path(*args) if path is _exact_general else path(*args, dm[i])
    out[~finite] = np.nan
    return out


def _line_mass(m_v, s_b, dm):
    """All the mass on the line u = m_u: P(|v| <= h) for v ~ N(m_v, s_b^2), h = sqrt(R^2 - m_u^2), with the
    near-zero end h - |m_v| = D / (h + |m_v|) from the accurate margin D (a point, s_b = 0: inside iff D >= 0)."""
    mv = np.abs(m_v)
    w2 = dm + mv * mv  # R^2 - m_u^2
    h = np.sqrt(np.maximum(w2, 0.0))
    den = (h + mv) * s_b
    with np.errstate(divide="ignore", invalid="ignore"):
        a1 = np.where(den > 0.0, dm / np.where(den > 0.0, den, 1.0), 0.0)
        a2 = -(h + mv) / np.where(s_b > 0.0, s_b, 1.0)
    mass = np.maximum(ndtr(a1) - ndtr(a2), 0.0)
    return np.where(w2 >= 0.0, np.where(s_b > 0.0, mass, (dm >= 0.0).astype(float)), 0.0)


def _col(x):
    return x[:, None]


def _thin_args(p, q, mu, mv, s_b, e_m, dm):
    """The bracket's arguments at offsets p from the mean along u (q = R - |m_u| - p, the distance to the chord's end
    given as computed by the caller): a1 = (h - |m_v|)/s_b = (D - 2|m_u| p - p^2) / ((h + |m_v|) s_b), no digits lost
    when h ~ |m_v| however far the disk is; a2 = -(h + |m_v|)/s_b."""
    h = np.sqrt(np.maximum(q * (e_m + p), 0.0))
    den = (h + mv) * s_b
    g = dm - p * (2.0 * mu + p)
    with np.errstate(divide="ignore", invalid="ignore"):
        a1 = np.where(den > 0.0, g / np.where(den > 0.0, den, 1.0), 0.0)
    return a1, -(h + mv) / s_b


def _gl_nodes(span):
    """Gauss-Legendre points by the sigmas a panel spans (GL_RULES)."""
    return np.where(span <= GL_RULES[0][0], GL_RULES[0][1], np.where(span <= GL_RULES[1][0], GL_RULES[1][1],
                                                                     GL_RULES[2][1]))


def _exact_thin(m_u, m_v, s_a, s_b, r, dm):
    """The Gaussian narrow across the disk (s_a < THIN R): the same integral as _exact_general, in the Gaussian's own
    coordinate z = (u - m_u)/s_a instead of the circle's tau. With s_a below ~1e-13 R the tau grid cannot even place
    the window (tau carries 1e-16 R in u), and above it every absolute position (the rotated mean, the circle) holds
    1e-16 R, which is 1e-16 R / s_a of the Gaussian: a mean on the boundary with s_a = 1e-7 R was 1e-9 off. Here no
    quantity is absolute: u = |m_u| + p (by symmetry m_u, m_v >= 0), the chord's end is at p = e_p = R - |m_u| =
    (D + m_v^2) / (R + |m_u|) and the upper chord edge relative to the mean is h - |m_v| = (D - 2|m_u| p - p^2) /
    (h + |m_v|), all from the margin D = R^2 - |m|^2 (disk_margin). The window z in [-7.5, min(7.5, e_p/s_a)] (the
    far end, R/s_a > 1000 away, never in it) is split at z = +-3, at the top of the chord (u = 0) and where h =
    |m_v| +- 7.5 s_b (the zone ends: u^2 = D + m_u^2 - (h^2 - m_v^2), the root near the mean as a quotient); panels
    outside the zones are closed-form Gaussian masses, zone panels Gauss-Legendre in z, or in s = sqrt(z_e - z) when
    the chord's end z_e is near (h ~ sqrt(z_e - z) is analytic in s)."""
    n = m_u.shape[0]
    mu, mv = np.abs(m_u), np.abs(m_v)
    e_m = r + mu
    e_p = (dm + mv * mv) / e_m
    z_e = e_p / s_a
    z_hi = np.minimum(K_SIGMA, z_e)
    empty = ~(z_hi > -K_SIGMA)
    z_hi = np.where(empty, -K_SIGMA, z_hi)
    kb = K_SIGMA * s_b
    cand = np.empty((n, 7))
    cand[:, 0] = -GAUSS_CORE
    cand[:, 1] = GAUSS_CORE
    cand[:, 2] = -mu / s_a
    k = 3
    for delta in (dm - kb * (2.0 * mv + kb), dm + kb * (2.0 * mv - kb)):  # h = |m_v| + kb, h = ||m_v| - kb|
        u2 = delta + mu * mu  # R^2 - h^2: the roots u = +-sqrt(u2)
        root = u2 > 0.0
        uh = np.sqrt(np.where(root, u2, 0.0))
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            cand[:, k] = np.where(root, delta / np.where(root, uh + mu, 1.0) / s_a, -K_SIGMA)  # uh - mu, stably
            cand[:, k + 1] = np.where(root, -(uh + mu) / s_a, -K_SIGMA)
        k += 2
    cand = np.minimum(np.maximum(cand, -K_SIGMA), z_hi[:, None])
    knots = np.empty((n, 9))
    knots[:, 0] = -K_SIGMA
    knots[:, 1:8] = np.sort(cand, axis=1)
    knots[:, 8] = z_hi
    za, zb = knots[:, :-1], knots[:, 1:]  # 8 panels, some of zero width
    width = zb - za
    zm = 0.5 * (za + zb)
    pm = _col(s_a) * zm
    a1, a2 = _thin_args(pm, _col(e_p) - pm, _col(mu), _col(mv), _col(s_b), _col(e_m), _col(dm))
    act1 = np.abs(a1) < K_SIGMA
    act2 = a2 > -K_SIGMA
    in_zone = (act1 | act2) & (width > 0.0)
    inside = (a1 >= K_SIGMA) & ~act2 & (width > 0.0)
    upper = za > 0.0  # the Gaussian mass of a panel, taken in the tail where it is small
    mass = np.where(upper, ndtr(-za) - ndtr(-zb), ndtr(zb) - ndtr(za))
    total = np.where(inside, mass, 0.0).sum(axis=1)

    pi_, pj = np.nonzero(in_zone)
    if pi_.size:
        a, b = za[pi_, pj], zb[pi_, pj]
        sap, sbp, mup, mvp = s_a[pi_], s_b[pi_], mu[pi_], mv[pi_]
        epp, emp, dmp, zep = e_p[pi_], e_m[pi_], dm[pi_], z_e[pi_]
        # the span in sigmas of the Gaussian and of each varying bracket term (monotone on a panel: u = 0 is a knot)
        pa, pb = sap * a, sap * b
        a1a, a2a = _thin_args(pa, epp - pa, mup, mvp, sbp, emp, dmp)
        a1b, a2b = _thin_args(pb, epp - pb, mup, mvp, sbp, emp, dmp)
        span = np.maximum(b - a, np.maximum(np.where(act1[pi_, pj], np.abs(a1b - a1a), 0.0),
                                            np.where(act2[pi_, pj], np.abs(a2b - a2a), 0.0)))
        edge = zep - b < EDGE_NEAR * (b - a)
        nodes = np.where(edge, GL_RULES[-1][1], _gl_nodes(span))
        vals = np.empty(pi_.size)
        for _, nn in GL_RULES:
            for sq in (False, True):
                sel = np.flatnonzero((nodes == nn) & (edge == sq))
                if sel.size:
                    vals[sel] = _thin_panels(a[sel], b[sel], sap[sel], sbp[sel], mup[sel], mvp[sel], epp[sel],
                                             emp[sel], dmp[sel], zep[sel], nn, sq)
        total += np.bincount(pi_, weights=vals, minlength=n)
    total = np.where(empty, 0.0, total)
    return np.clip(total, 0.0, 1.0)


def _thin_panels(a, b, s_a, s_b, mu, mv, e_p, e_m, dm, z_e, nodes, sqrt_map):
    """Gauss-Legendre (nodes points) of phi(z) bracket over z in [a, b], one row per panel, in z or (sqrt_map) in
    s = sqrt(z_e - z), where q = R - u = s_a s^2 exactly."""
    gx, gw = _GL[nodes]
    if sqrt_map:
        s_lo, s_hi = np.sqrt(z_e - b), np.sqrt(z_e - a)
        half = 0.5 * (s_hi - s_lo)
        s = _col(s_lo) + _col(half) * (1.0 + gx[None, :])
        z = _col(z_e) - s * s
        q = _col(s_a) * (s * s)
        p = _col(e_p) - q
        jac = 2.0 * s
    else:
        half = 0.5 * (b - a)
        z = _col(a) + _col(half) * (1.0 + gx[None, :])
        p = _col(s_a) * z
        q = _col(e_p) - p
        jac = 1.0
    a1, a2 = _thin_args(p, q, _col(mu), _col(mv), _col(s_b), _col(e_m), _col(dm))
    f = np.exp(-0.5 * z * z) * (ndtr(a1) - ndtr(a2)) * jac
    return (f @ gw) * half / SQRT_2PI


def _exact_general(m_u, m_v, s_a, s_b, r):
    n = m_u.shape[0]
    lo = np.maximum(-r, m_u - K_SIGMA * s_a)
    hi = np.minimum(r, m_u + K_SIGMA * s_a)
    empty = lo >= hi
    hi = np.where(empty, lo, hi)
    t_lo, t_hi = _tau_of_u(lo, r), _tau_of_u(hi, r)
    kb = K_SIGMA * s_b

    # Break points (tau). Zone ends: the two bracket terms change only where h is within K s_b of c = m_v
    # (upper edge of the chord) or c = -m_v (lower edge); h(tau) = R (1 - tau^2)/(1 + tau^2) falls with |tau|.
    # Gaussian core: m_u +- 3 s_a, so that no panel holds the Gaussian in a small fraction of its width.
    cand = np.empty((n, 10))
    k = 0
    for c in (m_v, -m_v):
        for h_end in (c + kb, c - kb):
            with np.errstate(divide="ignore", invalid="ignore"):
                tb = np.sqrt(np.abs((r - h_end) / (r + h_end)))  # used only where 0 < h_end < r
            inner = (h_end > 0.0) & (h_end < r)
            cand[:, k] = np.where(inner, tb, t_lo)
            cand[:, k + 1] = np.where(inner, -tb, t_lo)
            k += 2
    cand[:, 8] = _tau_of_u(m_u - GAUSS_CORE * s_a, r)
    cand[:, 9] = _tau_of_u(m_u + GAUSS_CORE * s_a, r)
    cand = np.clip(cand, t_lo[:, None], t_hi[:, None])
    knots = np.empty((n, 12))
    knots[:, 0] = t_lo
    knots[:, 1:11] = np.sort(cand, axis=1)
    knots[:, 11] = t_hi
    ta, tb = knots[:, :-1], knots[:, 1:]  # 11 panels, some of zero width
    width = tb - ta

    # Bracket at panel midpoints: outside the zones it is the indicator h > m_v + K s_b (the lower term is then
    # 0: h > -m_v + K s_b cannot fail while the upper one holds unless both are saturated, bracket 0 either way).
    tm = 0.5 * (ta + tb)
    h_mid = r[:, None] * (1.0 - tm * tm) / (1.0 + tm * tm)
    mv = m_v[:, None]
    kb2 = kb[:, None]
    in_zone = ((np.abs(h_mid - mv) < kb2) | (np.abs(h_mid + mv) < kb2)) & (width > 0.0)
    inside = (h_mid > mv + kb2) & (h_mid > -mv + kb2)

    # Panels outside every zone: bracket 0 or 1, Gaussian mass of the panel in closed form (absolute error
    # 1e-16 per panel is all that is needed), from the standardised u of every knot, chained from the window
    # start by exact differences u(b) - u(a) = 2R (b - a)(1 - ab) / ((1 + a^2)(1 + b^2)): knots never lose
    # digits to u - m_u even when s_a << |m_u| (absolute positions near R carry only 1e-16 R), and the
    # closed-form and Gauss-Legendre panels see the same knot positions, so their masses add up exactly.
    z0 = np.maximum((-r - m_u) / s_a, -K_SIGMA)
    dz = 2.0 * r[:, None] * width * (1.0 - ta * tb) / ((1.0 + ta * ta) * (1.0 + tb * tb)) / s_a[:, None]
    z_knots = np.concatenate([z0[:, None], z0[:, None] + np.cumsum(dz, axis=1)], axis=1)
    cdf = ndtr(z_knots)
    mass = cdf[:, 1:] - cdf[:, :-1]
    total = np.where(inside & ~in_zone, mass, 0.0).sum(axis=1)

    # Zone panels: Gauss-Legendre in tau, 16, 24 or 32 nodes by the sigmas the panel spans (GL_RULES). Where only
    # one bracket term varies on a panel (the usual case) the other is the constant 0 or 1 and one CDF per
    # node is enough: bracket = offset + sign Phi(sign h/s_b - m_v/s_b).
    pi_, pj = np.nonzero(in_zone)
    if pi_.size:
        a, b = ta[pi_, pj], tb[pi_, pj]
        za = z_knots[pi_, pj]
        hm = h_mid[pi_, pj]
        wide = np.flatnonzero(b - a > TAU_SPLIT)  # a zone panel covering most of the disk: two halves
        if wide.size:
            aw, bw = a[wide], b[wide]
            mid = 0.5 * (aw + bw)
            z_mid = za[wide] + 2.0 * r[pi_[wide]] * (mid - aw) * (1.0 - aw * mid) / (
                (1.0 + aw * aw) * (1.0 + mid * mid)) / s_a[pi_[wide]]
            b = b.copy()
            b[wide] = mid  # first halves in place, second halves appended
            pi_ = np.concatenate([pi_, pi_[wide]])
            a = np.concatenate([a, mid])
            b = np.concatenate([b, bw])
            za = np.concatenate([za, z_mid])
            hm = np.concatenate([hm, hm[wide]])  # the zone flags hold on the whole panel
        mvp, kbp = m_v[pi_], kb[pi_]
        act1 = np.abs(hm - mvp) < kbp  # upper term Phi((h - m_v)/s_b) varies
        act2 = np.abs(hm + mvp) < kbp  # lower term Phi((-h - m_v)/s_b) varies
        c1 = (hm > mvp).astype(float)  # constant value of a term that does not vary
        c2 = (-hm - mvp > 0.0).astype(float)
        rp, sap, sbp = r[pi_], s_a[pi_], s_b[pi_]
        # sigmas spanned on the panel by the Gaussian factor (u monotone in tau) and by the bracket (h is
        # monotone on either side of tau = 0, maximal there)
        dzp = 2.0 * rp * (b - a) * (1.0 - a * b) / ((1.0 + a * a) * (1.0 + b * b)) / sap
        ha, hb = rp * (1 - a * a) / (1 + a * a), rp * (1 - b * b) / (1 + b * b)
        hmax = np.where((a < 0.0) & (b > 0.0), rp, np.maximum(ha, hb))
        span = np.maximum(dzp, (hmax - np.minimum(ha, hb)) / sbp)
        # the rational tau map needs more nodes on wide panels: 24 at most up to 1 wide (after TAU_SPLIT)
        span = np.where(b - a > TAU_WIDTH_FEW_NODES, np.where(span <= GL_RULES[0][0], GL_RULES[1][0], np.inf), span)
        both = act1 & act2
        sign = np.where(act1, 1.0, -1.0)
        offset = np.where(both, 0.0, np.where(act1, -c2, c1))
        vals = np.empty(pi_.size)
        lo_span = 0.0
        for hi_span, nodes in GL_RULES:
            grp = (span > lo_span) & (span <= hi_span) if lo_span > 0.0 else span <= hi_span
            lo_span = hi_span
            for two in (False, True):
                sel = np.flatnonzero(grp & (both == two))
                if sel.size:
                    vals[sel] = _gl_panels(a[sel], b[sel], rp[sel], za[sel], sap[sel], sbp[sel], mvp[sel], nodes,
                                           None if two else offset[sel], None if two else sign[sel])
        total += np.bincount(pi_, weights=vals, minlength=n)
    total = np.where(empty, 0.0, total)
    return np.clip(total, 0.0, 1.0)


def _gl_panels(a, b, r, z_a, s_a, s_b, m_v, nodes, offset=None, sign=None):
    """Gauss-Legendre (nodes points) over tau in [a, b] of the exact integrand, one row per panel; z_a is the
    standardised u at tau = a. With offset and sign: bracket = offset + sign Phi(sign h/s_b - m_v/s_b) (one
    bracket term constant on the panel); without: both terms."""
    gx, gw = _GL[nodes]
    half = 0.5 * (b - a)
    d = half[:, None] * (1.0 + gx[None, :])  # t - a, without cancellation
    t = a[:, None] + d
    t2 = t * t
    den = 1.0 / (1.0 + t2)
    q = (1.0 - t2) * den  # h / R
    zu = z_a[:, None] + (2.0 * r / s_a)[:, None] * d * (1.0 - t * a[:, None]) * den / (1.0 + a * a)[:, None]
    f = np.exp(-0.5 * zu * zu)
    hz = q * (r / s_b)[:, None]
    mvz = (m_v / s_b)[:, None]
    if offset is None:
        brk = ndtr(hz - mvz) - ndtr(-hz - mvz)
    else:
        brk = offset[:, None] + sign[:, None] * ndtr(sign[:, None] * hz - mvz)
    f *= brk
    f *= q * den  # du/dtau = 2 R (1 - t^2) / (1 + t^2)^2
    return (f @ gw) * half * (2.0 / SQRT_2PI) * r / s_a


# --- approximations ------------------------------------------------------------------------------------


def pc_one_block(mean, cov, radius) -> np.ndarray:
    """Hwang & Seah one block (Baek & Bang eqs 25-28): the circumscribing rectangle of the whitened elliptic
    zone, i.e. the square |u| <= R, |v| <= R in the principal axes; an upper bound of the exact value."""
    mean, cov, radius = _as_pairs(mean, cov, radius)
    m_u, m_v, s_a, s_b, _, _ = principal_frame(mean, cov)
    return _interval_mass(-radius, radius, m_u, s_a) * _interval_mass(-radius, radius, m_v, s_b)


def pc_blocks(mean, cov, radius, n_blocks: int = 10) -> np.ndarray:
    """Baek & Bang set of blocks (eq 29): the whitened elliptic zone covered by n_blocks rectangles, cut along
    its long axis (the minor principal axis u of P, where the ellipse is R/s_a long) into equal widths; each
    block's half-height is the ellipse's half-height at the block edge nearer the centre, so the blocks cover
    the zone and the sum (eq 29 of eq 27 terms) is an upper bound. n_blocks = 1 is the one-block method; a
    cover with 2k blocks refines the one with k, so the bound tightens monotonically along k, 2k, 4k..."""
    if n_blocks < 1:
        raise ValueError("n_blocks must be >= 1")
    mean, cov, radius = _as_pairs(mean, cov, radius)
    m_u, m_v, s_a, s_b, _, _ = principal_frame(mean, cov)
    k = np.arange(n_blocks + 1)
    edges = radius[:, None] * (-1.0 + 2.0 * k[None, :] / n_blocks)  # (N, nb + 1)
    ua, ub = edges[:, :-1], edges[:, 1:]
    straddles = (ua < 0.0) & (ub > 0.0)
    near = np.where(straddles, 0.0, np.minimum(np.abs(ua), np.abs(ub)))
    half_h = np.sqrt(np.maximum(radius[:, None] ** 2 - near**2, 0.0))
    pu = _interval_mass(ua, ub, m_u[:, None], s_a[:, None])
    pv = _interval_mass(-half_h, half_h, m_v[:, None], s_b[:, None])
    return np.minimum((pu * pv).sum(axis=1), 1.0)


def pc_paielli_erzberger(mean, cov, radius, rel_vel) -> np.ndarray:
    """Hwang, Hwang & Tomlin eq 24 (Paielli & Erzberger 1997): the zone swept along the relative velocity is the
    strip |n . x| <= R (n the unit normal of the relative velocity); Pc = Phi((R - n.m)/s) - Phi((-R - n.m)/s),
    s^2 = n^T P n. In the whitened frame of eq 24 this is the strip of half-width Delta y_c around the offset
    Delta y; the strip is frame-independent, so no Cholesky is needed. Zero relative velocity: the pair stays
    where it is and the exact instantaneous value is returned."""
    mean, cov, radius = _as_pairs(mean, cov, radius)
    v = np.broadcast_to(np.asarray(rel_vel, float), mean.shape)
    speed = np.hypot(v[:, 0], v[:, 1])
    moving = speed > 0.0
    with np.errstate(divide="ignore", invalid="ignore"):
        nrm = np.stack([-v[:, 1], v[:, 0]], axis=-1) / np.where(moving, speed, 1.0)[:, None]
    d = np.einsum("ij,ij->i", nrm, mean)
    s = np.sqrt(np.maximum(np.einsum("ij,ijk,ik->i", nrm, cov, nrm), 0.0))
    out = _interval_mass(-radius, radius, d, s)
    if (~moving).any():
        i = np.flatnonzero(~moving)
        out[i] = pc_exact(mean[i], cov[i], radius[i])
    return out


def pc_monte_carlo(means, covs, radius, weights=None, samples: int = 10000, rng=None,
                   half_height=None, mean_z=None, var_z=None) -> np.ndarray:
    """Monte Carlo Pc over a Gaussian mixture: means (N, M, 2), covs (N, M, 2, 2), weights (N, M) (mode
    probabilities; None: equal), or a single Gaussian (N, 2), (N, 2, 2). Vertical (optional): per-pair slab
    |z| <= half_height with z ~ N(mean_z, var_z) independent of the horizontal position (per-mode (N, M)
    arrays allowed). Standard error sqrt(Pc (1 - Pc) / samples)."""
    rng = np.random.default_rng(rng)
    means = np.asarray(means, float)
    covs = np.asarray(covs, float)
    if means.ndim == 2:
        means, covs = means[:, None, :], covs[:, None, :, :]
    n, m = means.shape[:2]
    w = np.full((n, m), 1.0 / m) if weights is None else np.asarray(weights, float).reshape(n, m)
    w = w / w.sum(axis=1, keepdims=True)
    radius = np.broadcast_to(np.asarray(radius, float), (n,))
    step = max(1, 200_000 // max(samples, 1))  # pairs per block: bounded memory
    if n > step:
        hh = None if half_height is None else np.broadcast_to(np.asarray(half_height, float), (n,))
        mz = None if mean_z is None else np.broadcast_to(np.asarray(mean_z, float).reshape(n, -1), (n, m))
        vz = None if var_z is None else np.broadcast_to(np.asarray(var_z, float).reshape(n, -1), (n, m))
        return np.concatenate([
            pc_monte_carlo(means[k:k + step], covs[k:k + step], radius[k:k + step], w[k:k + step], samples, rng,
                           None if hh is None else hh[k:k + step], None if mz is None else mz[k:k + step],
                           None if vz is None else vz[k:k + step])
            for k in range(0, n, step)])
    cdf = np.cumsum(w, axis=1)
    mode = (rng.random((n, samples))[:, :, None] > cdf[:, None, :]).sum(axis=2)
    mode = np.minimum(mode, m - 1)  # (n, S)
    chol = _safe_cholesky(covs)  # (n, m, 2, 2)
    z = rng.standard_normal((n, samples, 2))
    rows = np.arange(n)[:, None]
    mu = means[rows, mode]  # (n, S, 2)
    lc = chol[rows, mode]  # (n, S, 2, 2)
    x = mu + np.einsum("nsij,nsj->nsi", lc, z)
    hit = np.einsum("nsi,nsi->ns", x, x) <= radius[:, None] ** 2
    if half_height is not None:
        mz = np.broadcast_to(np.asarray(mean_z, float).reshape(n, -1), (n, m))[rows, mode]
        vz = np.broadcast_to(np.asarray(var_z, float).reshape(n, -1), (n, m))[rows, mode]
        zz = mz + np.sqrt(np.maximum(vz, 0.0)) * rng.standard_normal((n, samples))
        hit &= np.abs(zz) <= np.broadcast_to(np.asarray(half_height, float), (n,))[:, None]
    return hit.mean(axis=1)


def _safe_cholesky(p: np.ndarray) -> np.ndarray:
    """Lower Cholesky factor of 2x2 covariances in closed form; semi-definite (even zero) covariances allowed."""
    a = np.maximum(p[..., 0, 0], 0.0)
    b = 0.5 * (p[..., 0, 1] + p[..., 1, 0])
    c = p[..., 1, 1]
    l11 = np.sqrt(a)
    with np.errstate(divide="ignore", invalid="ignore"):
        l21 = np.where(l11 > 0.0, b / np.where(l11 > 0.0, l11, 1.0), 0.0)
    l22 = np.sqrt(np.maximum(c - l21 * l21, 0.0))
    out = np.zeros(p.shape)
    out[..., 0, 0] = l11
    out[..., 1, 0] = l21
    out[..., 1, 1] = l22
    return out


def pc_direct_grid(mean, cov, radius, n_points: int = 1_000_000) -> np.ndarray:
    """Baek & Bang's reference: direct numerical integration of eq 24 with about n_points uniformly spaced
    points in the circular zone (midpoint rule on a square grid of spacing R sqrt(pi / n_points)). Slow by
    design (one pair at a time); its error is the staircase of the grid along the circle."""
    mean, cov, radius = _as_pairs(mean, cov, radius)
    out = np.empty(mean.shape[0])
    for i in range(mean.shape[0]):
        r = radius[i]
        hstep = r * math.sqrt(math.pi / n_points)
        k = int(math.ceil(r / hstep))
        g = (np.arange(-k, k) + 0.5) * hstep
        gx, gy = np.meshgrid(g, g, indexing="ij")
        inside = gx * gx + gy * gy <= r * r
        pts = np.stack([gx[inside], gy[inside]], axis=-1) - mean[i]
        pinv = np.linalg.inv(cov[i])
        q = np.einsum("ki,ij,kj->k", pts, pinv, pts)
        dens = np.exp(-0.5 * q) / (2.0 * math.pi * math.sqrt(np.linalg.det(cov[i])))
        out[i] = dens.sum() * hstep * hstep
    return out


# --- the methods as objects (conflict.method; built in avionics/compose.py, build_pc_method) ----------------


class PcMethod(Protocol):
    """The horizontal Pc of N Gaussian relative positions over disks: probability(mean (N, 2), cov (N, 2, 2),
    radius scalar or (N,), rel_vel (N, 2), rng) -> (N,). rel_vel is read by 'pe' only, rng by 'mc' only."""

    @property
    def name(self) -> str: ...  # read-only: the methods are frozen dataclasses

    def probability(self, mean, cov, radius, rel_vel=None, rng=None) -> np.ndarray: ...


@dataclass(frozen=True, slots=True)
class ExactPc:
    """conflict.method = "exact": `pc_exact`."""

    name: str = "exact"

    def probability(self, mean, cov, radius, rel_vel=None, rng=None) -> np.ndarray:
        return pc_exact(mean, cov, radius)


@dataclass(frozen=True, slots=True)
class OneBlockPc:
    """conflict.method = "one_block": Hwang & Seah (Baek & Bang eqs 25-28), `pc_one_block`."""

    name: str = "one_block"

    def probability(self, mean, cov, radius, rel_vel=None, rng=None) -> np.ndarray:
        return pc_one_block(mean, cov, radius)


@dataclass(frozen=True, slots=True)
class BlocksPc:
    """conflict.method = "blocks": Baek & Bang eq 29 with n_blocks blocks, `pc_blocks`."""

    n_blocks: int = 10
    name: str = "blocks"

    def probability(self, mean, cov, radius, rel_vel=None, rng=None) -> np.ndarray:
        return pc_blocks(mean, cov, radius, self.n_blocks)


@dataclass(frozen=True, slots=True)
class PaielliErzbergerPc:
    """conflict.method = "pe": Hwang, Hwang & Tomlin eq 24 (needs the relative velocity), `pc_paielli_erzberger`."""

    name: str = "pe"

    def probability(self, mean, cov, radius, rel_vel=None, rng=None) -> np.ndarray:
        if rel_vel is None:
            raise ValueError("method 'pe' needs rel_vel")
        return pc_paielli_erzberger(mean, cov, radius, rel_vel)


@dataclass(frozen=True, slots=True)
class MonteCarloPc:
    """conflict.method = "mc": `pc_monte_carlo` with `samples` samples per pair and time."""

    samples: int = 10000
    name: str = "mc"

    def probability(self, mean, cov, radius, rel_vel=None, rng=None) -> np.ndarray:
        return pc_monte_carlo(mean, cov, radius, None, self.samples, rng)


# --- one interface ---------------------------------------------------------------------------------------


def conflict_probability(mean, cov, radius, method: str = "exact", *, weights=None, rel_vel=None,
                         half_height=None, mean_z=None, var_z=None, n_blocks: int = 10,
                         samples: int = 10000, rng=None) -> np.ndarray:
    """Pc for N pairs by any method, horizontal or 3D.

    mean (N, 2), cov (N, 2, 2): relative horizontal position intruder - ownship and its covariance; or a mode
    mixture: mean (N, M, 2), cov (N, M, 2, 2), weights (N, M). radius: R, scalar or (N,).
    rel_vel (N, 2): relative velocity (method 'pe' only).
    half_height (scalar or (N,)), mean_z and var_z ((N,) or (N, M) for a mixture): the slab |z| <= H; omitted:
    horizontal only. With a mixture, the analytic methods return sum_j w_j Pc(mode j) (exact for 'exact').
    Returns (N,) probabilities in [0, 1] (NaN for non-finite inputs with the analytic methods).
    """
    if method not in METHODS:
        raise ValueError(f"method must be one of {METHODS}, got {method!r}")
    mean = np.asarray(mean, float)
    cov = np.asarray(cov, float)
    if method == "mc":
        return pc_monte_carlo(mean, cov, radius, weights, samples, rng, half_height, mean_z, var_z)
    if mean.ndim == 3:  # mixture: weighted sum over modes
        n, m = mean.shape[:2]
        w = np.full((n, m), 1.0 / m) if weights is None else np.asarray(weights, float).reshape(n, m)
        w = w / w.sum(axis=1, keepdims=True)
        rad = np.repeat(np.broadcast_to(np.asarray(radius, float), (n,)), m)
        rv = None if rel_vel is None else np.repeat(np.broadcast_to(np.asarray(rel_vel, float), (n, 2)), m, axis=0)
        p = _horizontal(mean.reshape(n * m, 2), cov.reshape(n * m, 2, 2), rad, method, rv, n_blocks).reshape(n, m)
        if half_height is not None:
            hh = np.broadcast_to(np.asarray(half_height, float).reshape(n, -1), (n, m))
            mz = np.broadcast_to(np.asarray(mean_z, float).reshape(n, -1), (n, m))
            vz = np.broadcast_to(np.asarray(var_z, float).reshape(n, -1), (n, m))
            p = p * vertical_probability(mz, vz, hh)
        return (w * p).sum(axis=1)
    p = _horizontal(mean, cov, radius, method, rel_vel, n_blocks)
    if half_height is not None:
        p = p * vertical_probability(mean_z, var_z, half_height)
    return p


def _horizontal(mean, cov, radius, method, rel_vel, n_blocks):
    if method == "exact":
        return pc_exact(mean, cov, radius)
    if method == "one_block":
        return pc_one_block(mean, cov, radius)
    if method == "blocks":
        return pc_blocks(mean, cov, radius, n_blocks)
    if rel_vel is None:
        raise ValueError("method 'pe' needs rel_vel")
    return pc_paielli_erzberger(mean, cov, radius, rel_vel)
