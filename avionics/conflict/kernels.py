"""Compiled kernels of the conflict stage (issue 13 item 1): one call over every pair.

Each kernel is the numpy reference beside it written as a loop over pairs, with the same formulas in the same
order (the equations cited are the reference's):

  pc_exact_pairs        probability.pc_exact_reference / _exact_general / _gl_panels (and _exact_thin /
                        _thin_panels, _line_mass, disk_margin for a Gaussian narrow across the disk): the disk
                        probability of a 2-D Gaussian, 1D Gauss-Legendre along the minor principal axis with the
                        major axis in closed form (Baek & Bang eq 24 over the disk), N pairs
  pc_at_cpa_pairs       pc_at_cpa.pc_at_cpa_reference: straight-line propagation to the CPA time with the white-
                        acceleration term, the disk (as above) and the vertical slab, every volume in one call
  pc_curve_cv_pairs     assess.conflict_probabilities' curve: prediction.cv_relative_prediction (closed form CV)
                        at every step, the exact disk and the slab factor, (N, K) in one call
  zone_pairs            assess.conflict_probabilities without Monte Carlo, fused: the curve, its maximum and
                        Hwang eq 24 at the CPA step behind condition 2(b), one call (issue 32 item 1)
  min_distance_keep_pairs  scheduling.MinDistancePrefilter.keep: Hwang condition 2(b) widened by 3 sigma
  pair_geometry_pairs   cpa.pair_geometry_reference: range, s.v, closure, t_cpa, hmd, vmd, taus, 3D CPA
  pc_within_paths       prediction.pc_within_cv_mc_reference's arithmetic on random numbers drawn by numpy

`avionics.base.jit.kernel` compiles them with numba at import (explicit signatures, disk cache); with
AVIONICS_COMPILED=0 they stay plain Python and the public functions call the numpy references instead.

Numerics: `ndtr` is cephes' (scipy.special.ndtr) structure on the C library's erf/erfc (1 ulp apart from scipy's);
sums are taken in the reference's order where numpy's is sequential (cumsum), so the kernels agree with the
references to ~1e-15, well inside the 1e-9 of tests/test_kernels_conflict.py.
"""

from __future__ import annotations

import math

import numpy as np

from avionics.base.jit import kernel

SQRT1_2 = math.sqrt(0.5)
SQRT_2PI = math.sqrt(2.0 * math.pi)
K_SIGMA = 7.5  # = probability.K_SIGMA
GAUSS_CORE = 3.0  # = probability.GAUSS_CORE
TAU_WIDTH_FEW_NODES = 0.5  # = probability.TAU_WIDTH_FEW_NODES
TAU_SPLIT = 1.0  # = probability.TAU_SPLIT
SPAN_16, SPAN_24 = 4.0, 6.5  # = probability.GL_RULES: 16 nodes up to 4 sigmas, 24 up to 6.5, 32 beyond
THIN = 1e-3  # = probability.THIN
EDGE_NEAR = 2.0  # = probability.EDGE_NEAR
SPLIT = 134217729.0  # = probability._SPLIT (Veltkamp)


def _gl_table():
    x = np.zeros((3, 32))
    w = np.zeros((3, 32))
    for row, n in enumerate((16, 24, 32)):
        gx, gw = np.polynomial.legendre.leggauss(n)  # the reference's rules (probability._GL), same values
        x[row, :n], w[row, :n] = gx, gw
    return x, w


GL_X, GL_W = _gl_table()
GL_NODES = np.array([16, 24, 32], np.int64)

# --- scalar helpers -------------------------------------------------------------------------------------


@kernel("float64(float64)")
def ndtr(a):
    """Standard normal CDF, cephes ndtr (scipy.special.ndtr): 0.5 + 0.5 erf(a/sqrt 2) near 0, else the erfc
    tail (no 1 - 1e-17 cancellation)."""
    if a != a:
        return a
    x = a * SQRT1_2
    z = abs(x)
    if z < SQRT1_2:
        return 0.5 + 0.5 * math.erf(x)
    y = 0.5 * math.erfc(z)
    if x > 0.0:
        y = 1.0 - y
    return y


@kernel("float64(float64, float64, float64, float64)")
def interval_mass(lo, hi, mean, sigma):
    """probability._interval_mass: P(lo <= N(mean, sigma^2) <= hi), sigma = 0 a point mass (boundary inclusive);
    the difference taken in the tail where the CDF is small."""
    if sigma > 0.0:
        za = (lo - mean) / sigma
        zb = (hi - mean) / sigma
        if za > 0.0:
            p = ndtr(-za) - ndtr(-zb)
        else:
            p = ndtr(zb) - ndtr(za)
        return max(p, 0.0) if p == p else p
    if hi >= lo:
        return 1.0 if (lo <= mean and mean <= hi) else 0.0
    return 0.0


@kernel("float64(float64, float64, float64)")
def prod_err(x, y, p):
    """probability._prod_err: x y - p exactly, p = fl(x y) (Dekker)."""
    c = SPLIT * x
    xh = c - (c - x)
    xl = x - xh
    c = SPLIT * y
    yh = c - (c - y)
    yl = y - yh
    return ((xh * yh - p) + xh * yl + xl * yh) + xl * yl


@kernel("float64(float64, float64, float64, float64)")
def diff_of_products(a, b, c, d):
    """probability._diff_of_products: a b - c d to ~1 ulp of the result."""
    p = a * b
    q = c * d
    out = (p - q) + (prod_err(a, b, p) - prod_err(c, d, q))
    return out if np.isfinite(out) else p - q


@kernel("float64(float64, float64, float64)")
def disk_margin(mx, my, r):
    """probability.disk_margin for one pair: D = R^2 - |m|^2 to ~1 ulp of D."""
    pr = r * r
    px = mx * mx
    py = my * my
    s1 = pr - px
    bb = s1 - pr
    e1 = (pr - (s1 - bb)) + (-px - bb)
    s2 = s1 - py
    bb = s2 - s1
    e2 = (s1 - (s2 - bb)) + (-py - bb)
    out = s2 + (((e1 + e2) + prod_err(r, r, pr)) - (prod_err(mx, mx, px) + prod_err(my, my, py)))
    return out if np.isfinite(out) else pr - px - py


@kernel("void(float64[::1], int64, float64, float64)")
def clip_sort(knots, end, lo, hi):
    """knots[1:end] clipped to [lo, hi], then sorted in place (insertion sort: ten candidates at most); knots[0]
    is the window's start and is left as it is."""
    for i in range(1, end):
        knots[i] = min(max(knots[i], lo), hi)
    for i in range(2, end):
        v = knots[i]
        j = i - 1
        while j >= 1 and knots[j] > v:
            knots[j + 1] = knots[j]
            j -= 1
        knots[j + 1] = v


@kernel("float64(float64, float64, float64, float64, float64, float64, float64)")
def thin_a1(p, q, mu, mv, s_b, e_m, dm):
    """probability._thin_args' a1 = (h - |m_v|)/s_b = (D - 2|m_u| p - p^2) / ((h + |m_v|) s_b),
    h = sqrt(q (e_m + p))."""
    h = math.sqrt(max(q * (e_m + p), 0.0))
    den = (h + mv) * s_b
    return (dm - p * (2.0 * mu + p)) / den if den > 0.0 else 0.0


@kernel("float64(float64, float64, float64, float64, float64, float64)")
def thin_a2(p, q, mv, s_b, e_m, dm):
    """probability._thin_args' a2 = -(h + |m_v|)/s_b."""
    h = math.sqrt(max(q * (e_m + p), 0.0))
    return -(h + mv) / s_b


@kernel("float64(float64, float64, float64, float64, float64, float64, float64, float64, float64, float64, int64, "
        "boolean)")
def thin_panel(a, b, s_a, s_b, mu, mv, e_p, e_m, dm, z_e, rule, sqrt_map):
    """probability._thin_panels for one panel: Gauss-Legendre (rule 0, 1, 2: 16, 24, 32 nodes) of phi(z) bracket
    over z in [a, b], in z or (sqrt_map) in s = sqrt(z_e - z), R - u = s_a s^2."""
    if sqrt_map:
        s_lo = math.sqrt(z_e - b)
        s_hi = math.sqrt(z_e - a)
        half = 0.5 * (s_hi - s_lo)
    else:
        s_lo = 0.0
        half = 0.5 * (b - a)
    acc = 0.0
    for j in range(GL_NODES[rule]):
        x = 1.0 + GL_X[rule, j]
        if sqrt_map:
            s = s_lo + half * x
            z = z_e - s * s
            q = s_a * (s * s)
            p = e_p - q
            jac = 2.0 * s
        else:
            z = a + half * x
            p = s_a * z
            q = e_p - p
            jac = 1.0
        h = math.sqrt(max(q * (e_m + p), 0.0))
        den = (h + mv) * s_b
        a1 = (dm - p * (2.0 * mu + p)) / den if den > 0.0 else 0.0
        a2 = -(h + mv) / s_b
        acc += math.exp(-0.5 * z * z) * (ndtr(a1) - ndtr(a2)) * jac * GL_W[rule, j]
    return acc * half / SQRT_2PI


@kernel("float64(float64, float64, float64, float64, float64, float64)")
def exact_thin(m_u, m_v, s_a, s_b, r, dm):
    """probability._exact_thin for one pair (0 < s_a < THIN R): in the Gaussian's coordinate z = (u - m_u)/s_a with
    every distance to the circle from the margin D; break points at z = +-3, the top of the chord and the zone ends
    h = |m_v| +- 7.5 s_b; closed-form masses outside the zones, Gauss-Legendre in z or in sqrt(z_e - z) inside."""
    mu = abs(m_u)
    mv = abs(m_v)
    e_m = r + mu
    e_p = (dm + mv * mv) / e_m
    z_e = e_p / s_a
    if not z_e > -K_SIGMA:  # beyond the chord's end, or NaN (as the reference's empty window)
        return 0.0
    z_hi = min(K_SIGMA, z_e)
    kb = K_SIGMA * s_b
    knots = np.empty(9)
    knots[0] = -K_SIGMA
    knots[1] = -GAUSS_CORE
    knots[2] = GAUSS_CORE
    knots[3] = -mu / s_a
    k = 4
    for j in range(2):  # h = |m_v| + kb, h = ||m_v| - kb|
        delta = dm - kb * (2.0 * mv + kb) if j == 0 else dm + kb * (2.0 * mv - kb)
        u2 = delta + mu * mu
        if u2 > 0.0:
            uh = math.sqrt(u2)
            knots[k] = delta / (uh + mu) / s_a
            knots[k + 1] = -(uh + mu) / s_a
        else:
            knots[k] = -K_SIGMA
            knots[k + 1] = -K_SIGMA
        k += 2
    clip_sort(knots, 8, -K_SIGMA, z_hi)
    knots[8] = z_hi
    total = 0.0
    zone = 0.0
    for i in range(8):
        a = knots[i]
        b = knots[i + 1]
        if not b - a > 0.0:
            continue
        zm = 0.5 * (a + b)
        pm = s_a * zm
        a1 = thin_a1(pm, e_p - pm, mu, mv, s_b, e_m, dm)
        a2 = thin_a2(pm, e_p - pm, mv, s_b, e_m, dm)
        act1 = abs(a1) < K_SIGMA
        act2 = a2 > -K_SIGMA
        if act1 or act2:
            pa = s_a * a
            pb = s_a * b
            span = b - a
            if act1:
                span = max(span, abs(thin_a1(pb, e_p - pb, mu, mv, s_b, e_m, dm)
                                     - thin_a1(pa, e_p - pa, mu, mv, s_b, e_m, dm)))
            if act2:
                span = max(span, abs(thin_a2(pb, e_p - pb, mv, s_b, e_m, dm) - thin_a2(pa, e_p - pa, mv, s_b, e_m, dm)))
            edge = z_e - b < EDGE_NEAR * (b - a)
            if edge or span > SPAN_24:
                rule = 2
            elif span > SPAN_16:
                rule = 1
            else:
                rule = 0
            zone += thin_panel(a, b, s_a, s_b, mu, mv, e_p, e_m, dm, z_e, rule, edge)
        elif a1 >= K_SIGMA:
            if a > 0.0:
                total += ndtr(-a) - ndtr(-b)
            else:
                total += ndtr(b) - ndtr(a)
    total += zone
    return min(max(total, 0.0), 1.0)


@kernel("float64(float64, float64)")
def tau_of_u(u, r):
    """probability._tau_of_u: u = R sin t -> tau = tan(t/2) = (u/R) / (1 + sqrt(1 - (u/R)^2))."""
    w = min(max(u / r, -1.0), 1.0)
    return w / (1.0 + math.sqrt(max(1.0 - w * w, 0.0)))


@kernel("float64(float64, float64, float64, float64, float64, float64, float64, int64, float64, float64, boolean)")
def gl_panel(a, b, r, z_a, s_a, s_b, m_v, rule, offset, sign, both):
    """probability._gl_panels for one panel: Gauss-Legendre (rule 0, 1, 2: 16, 24, 32 nodes) over tau in [a, b]
    of phi(z(u)) bracket(h) du/dtau, u = 2R tau / (1 + tau^2), h = R (1 - tau^2) / (1 + tau^2); bracket =
    offset + sign Phi(sign h/s_b - m_v/s_b) with one term constant, both terms when `both`."""
    half = 0.5 * (b - a)
    c_u = 2.0 * r / s_a
    inv_a = 1.0 + a * a
    hz_scale = r / s_b
    mvz = m_v / s_b
    acc = 0.0
    for j in range(GL_NODES[rule]):
        d = half * (1.0 + GL_X[rule, j])  # t - a, without cancellation
        t = a + d
        t2 = t * t
        den = 1.0 / (1.0 + t2)
        q = (1.0 - t2) * den  # h / R
        zu = z_a + c_u * d * (1.0 - t * a) * den / inv_a
        f = math.exp(-0.5 * zu * zu)
        hz = q * hz_scale
        if both:
            brk = ndtr(hz - mvz) - ndtr(-hz - mvz)
        else:
            brk = offset + sign * ndtr(sign * hz - mvz)
        f *= brk
        f *= q * den  # du/dtau = 2 R (1 - t^2) / (1 + t^2)^2
        acc += f * GL_W[rule, j]
    return acc * half * (2.0 / SQRT_2PI) * r / s_a


@kernel("float64(float64, float64, float64, float64, float64, float64, float64, float64, float64)")
def zone_piece(a, b, za, hm, r, s_a, s_b, m_v, kb):
    """One zone panel (or half of a wide one) of probability._exact_general: which bracket terms vary (from the
    panel's midpoint h), the sigmas the panel spans, the Gauss-Legendre rule by GL_RULES, the integral."""
    act1 = abs(hm - m_v) < kb  # upper term Phi((h - m_v)/s_b) varies
    act2 = abs(hm + m_v) < kb  # lower term Phi((-h - m_v)/s_b) varies
    c1 = 1.0 if hm > m_v else 0.0  # constant value of a term that does not vary
    c2 = 1.0 if -hm - m_v > 0.0 else 0.0
    dzp = 2.0 * r * (b - a) * (1.0 - a * b) / ((1.0 + a * a) * (1.0 + b * b)) / s_a
    ha = r * (1 - a * a) / (1 + a * a)
    hb = r * (1 - b * b) / (1 + b * b)
    hmax = r if (a < 0.0 and b > 0.0) else max(ha, hb)
    span = max(dzp, (hmax - min(ha, hb)) / s_b)
    if b - a > TAU_WIDTH_FEW_NODES:  # the rational tau map needs more nodes on wide panels
        span = SPAN_24 if span <= SPAN_16 else np.inf
    if span <= SPAN_16:
        rule = 0
    elif span <= SPAN_24:
        rule = 1
    else:
        rule = 2
    both = act1 and act2
    sign = 1.0 if act1 else -1.0
    offset = 0.0 if both else (-c2 if act1 else c1)
    return gl_panel(a, b, r, za, s_a, s_b, m_v, rule, offset, sign, both)


@kernel("float64(float64, float64, float64, float64, float64)")
def exact_general(m_u, m_v, s_a, s_b, r):
    """probability._exact_general for one pair (s_a > 0, R > 0): the window m_u +- 7.5 s_a clipped to the disk,
    in tau; break points at the zone ends (h within 7.5 s_b of +-m_v) and at m_u +- 3 s_a; closed-form Gaussian
    mass on the panels outside every zone, Gauss-Legendre on the zone panels."""
    lo = max(-r, m_u - K_SIGMA * s_a)
    hi = min(r, m_u + K_SIGMA * s_a)
    if lo >= hi:
        return 0.0
    t_lo = tau_of_u(lo, r)
    t_hi = tau_of_u(hi, r)
    kb = K_SIGMA * s_b
    knots = np.empty(12)
    knots[0] = t_lo
    k = 1
    for sgn in (1.0, -1.0):
        c = sgn * m_v
        for h_end in (c + kb, c - kb):
            if h_end > 0.0 and h_end < r:
                tb = math.sqrt(abs((r - h_end) / (r + h_end)))
                knots[k] = tb
                knots[k + 1] = -tb
            else:
                knots[k] = t_lo
                knots[k + 1] = t_lo
            k += 2
    knots[9] = tau_of_u(m_u - GAUSS_CORE * s_a, r)
    knots[10] = tau_of_u(m_u + GAUSS_CORE * s_a, r)
    clip_sort(knots, 11, t_lo, t_hi)  # the ten candidates in the window, in order
    knots[11] = t_hi

    # standardised u of every knot, chained from the window start by exact differences
    # u(b) - u(a) = 2R (b - a)(1 - ab) / ((1 + a^2)(1 + b^2)) (as numpy: z0 + cumsum of the differences)
    z0 = max((-r - m_u) / s_a, -K_SIGMA)
    z = np.empty(12)
    z[0] = z0
    cum = 0.0
    for p in range(11):
        ta = knots[p]
        tb = knots[p + 1]
        cum += 2.0 * r * (tb - ta) * (1.0 - ta * tb) / ((1.0 + ta * ta) * (1.0 + tb * tb)) / s_a
        z[p + 1] = z0 + cum
    total = 0.0
    zone = 0.0
    cdf = np.empty(12)  # Phi(z) of the knots, evaluated only where a closed-form panel needs it
    have = -1  # cdf[have] is known
    for p in range(11):
        ta = knots[p]
        tb = knots[p + 1]
        width = tb - ta
        tm = 0.5 * (ta + tb)
        h_mid = r * (1.0 - tm * tm) / (1.0 + tm * tm)
        in_zone = ((abs(h_mid - m_v) < kb) or (abs(h_mid + m_v) < kb)) and width > 0.0
        if in_zone:
            if width > TAU_SPLIT:  # a zone panel covering most of the disk: two halves
                mid = 0.5 * (ta + tb)
                z_mid = z[p] + 2.0 * r * (mid - ta) * (1.0 - ta * mid) / ((1.0 + ta * ta) * (1.0 + mid * mid)) / s_a
                zone += zone_piece(ta, mid, z[p], h_mid, r, s_a, s_b, m_v, kb)
                zone += zone_piece(mid, tb, z_mid, h_mid, r, s_a, s_b, m_v, kb)
            else:
                zone += zone_piece(ta, tb, z[p], h_mid, r, s_a, s_b, m_v, kb)
        elif h_mid > m_v + kb and h_mid > -m_v + kb:  # inside the disk on the whole panel: bracket 1
            if have != p:
                cdf[p] = ndtr(z[p])
            cdf[p + 1] = ndtr(z[p + 1])
            have = p + 1
            total += cdf[p + 1] - cdf[p]
    total += zone
    return min(max(total, 0.0), 1.0)


@kernel("float64(float64, float64, float64, float64, float64, float64, float64)")
def disk_pc(mx, my, c00, c01, c10, c11, r):
    """probability.pc_exact_reference for one pair: the principal frame of the covariance (principal_frame, the
    small eigenvalue as det / large one), then the line case (s_a = 0) or the general one; NaN for non-finite
    inputs, 0 for R <= 0."""
    b = 0.5 * (c01 + c10)
    half_tr = 0.5 * (c00 + c11)
    disc = math.hypot(0.5 * (c00 - c11), b)
    lam_b = half_tr + disc
    skew = 0.5 * (c01 - c10)
    det = max(diff_of_products(c00, c11, c01, c10) - skew * skew, 0.0)  # of the exact symmetric part
    lam_a = det / lam_b if lam_b > 0.0 else 0.0
    lam_a = min(lam_a, lam_b)
    theta = 0.5 * math.atan2(2.0 * b, c00 - c11)  # direction of the major axis
    c = math.cos(theta)
    s = math.sin(theta)
    if b == 0.0 and c00 < c11:  # the major axis along y exactly (probability.principal_frame)
        c = 0.0
        s = 1.0
    m_u = mx * -s + my * c
    m_v = mx * c + my * s
    s_a = np.sqrt(lam_a)
    s_b = np.sqrt(max(lam_b, 0.0))
    if not (np.isfinite(m_u) and np.isfinite(m_v) and np.isfinite(s_a) and np.isfinite(s_b) and np.isfinite(r)):
        return np.nan
    if not r > 0.0:
        return 0.0
    if s_a > 0.0 and s_a >= THIN * r:
        return exact_general(m_u, m_v, s_a, s_b, r)
    dm = disk_margin(mx, my, r)  # the line and the thin paths only
    if s_a == 0.0:  # all the mass on the line u = m_u (or a point when s_b = 0 too): probability._line_mass
        mv = abs(m_v)
        w2 = dm + mv * mv
        if not w2 >= 0.0:
            return 0.0
        if not s_b > 0.0:
            return 1.0 if dm >= 0.0 else 0.0
        h = math.sqrt(w2)
        den = (h + mv) * s_b
        a1 = dm / den if den > 0.0 else 0.0
        return max(ndtr(a1) - ndtr(-(h + mv) / s_b), 0.0)
    if s_a > 0.0:
        return exact_thin(m_u, m_v, s_a, s_b, r, dm)
    return 0.0


# --- over pairs ------------------------------------------------------------------------------------------


@kernel("float64[::1](float64[:, ::1], float64[:, :, ::1], float64[::1])")
def pc_exact_pairs(mean, cov, radius):
    """probability.pc_exact for N pairs: mean (N, 2), cov (N, 2, 2), radius (N,) -> (N,)."""
    n = mean.shape[0]
    out = np.empty(n)
    for i in range(n):
        out[i] = disk_pc(mean[i, 0], mean[i, 1], cov[i, 0, 0], cov[i, 0, 1], cov[i, 1, 0], cov[i, 1, 1], radius[i])
    return out


@kernel("float64[:, ::1](float64[:, ::1], float64[:, :, ::1], float64[::1], float64[::1], float64[::1], "
        "boolean[::1], float64, float64, float64)")
def pc_at_cpa_pairs(rel_x, rel_p, t_s, radii, half_heights, has_alt, sigma_h, sigma_v, max_t):
    """pc_at_cpa.pc_at_cpa_reference: rel_x (N, 6), rel_p (N, 6, 6), t_s (N,), volumes radii (V,) and half heights
    (V,) (NaN: no slab) -> (V, N). Propagation to t = min(t_s, max_t):

        m(t) = m_pos + t m_vel,   P_pos(t) = P_pp + t (P_pv + P_vp) + t^2 P_vv + (t^4 / 4) diag(s_h^2, s_h^2, s_v^2)

    then Pc = P(|x_h(t)| <= R) * P(|z(t)| <= H) (the slab factor 1 without altitude or half height)."""
    n = rel_x.shape[0]
    nv = radii.shape[0]
    out = np.empty((nv, n))
    qh = sigma_h * sigma_h
    qv = sigma_v * sigma_v
    for i in range(n):
        t = max_t if t_s[i] > max_t else t_s[i]  # np.minimum: a NaN stays NaN
        q = t ** 4 / 4.0
        mx = rel_x[i, 0] + t * rel_x[i, 3]
        my = rel_x[i, 1] + t * rel_x[i, 4]
        mz = rel_x[i, 2] + t * rel_x[i, 5]
        p = rel_p[i]
        tt = t * t
        # P_pv + P_pv^T as the reference forms it (pv + swapaxes(pv)), then the noise on the diagonal
        c00 = p[0, 0] + t * (p[0, 3] + p[0, 3]) + tt * p[3, 3] + q * qh
        c01 = p[0, 1] + t * (p[0, 4] + p[1, 3]) + tt * p[3, 4]
        c10 = p[1, 0] + t * (p[1, 3] + p[0, 4]) + tt * p[4, 3]
        c11 = p[1, 1] + t * (p[1, 4] + p[1, 4]) + tt * p[4, 4] + q * qh
        czz = p[2, 2] + t * (p[2, 5] + p[2, 5]) + tt * p[5, 5] + q * qv
        for k in range(nv):
            pc = disk_pc(mx, my, c00, c01, c10, c11, radii[k])
            hh = half_heights[k]
            if hh == hh and has_alt[i]:
                pc *= interval_mass(-hh, hh, mz, np.sqrt(max(czz, 0.0)))
            out[k, i] = pc
    return out


@kernel("UniTuple(float64, 8)(float64[::1], float64[:, ::1], float64, float64, float64, float64)")
def cv_at(x, p, t, step_s, sh2, sv2):
    """prediction.cv_relative_prediction for one pair at t = k step: (mean x, y, covariance xx, xy, yx, yy, mean z,
    variance z), the white-acceleration term sigma^2 step^4 (k^3/3 - k/12) on the diagonal (sh2, sv2: sigma^2)."""
    k = np.rint(t / step_s)
    qpos = step_s ** 4 * (k ** 3 / 3.0 - k / 12.0)  # per unit sigma^2
    tt = t * t
    return (x[0] + t * x[3], x[1] + t * x[4],
            p[0, 0] + t * (p[0, 3] + p[0, 3]) + tt * p[3, 3] + sh2 * qpos,
            p[0, 1] + t * (p[0, 4] + p[1, 3]) + tt * p[3, 4],
            p[1, 0] + t * (p[1, 3] + p[0, 4]) + tt * p[4, 3],
            p[1, 1] + t * (p[1, 4] + p[1, 4]) + tt * p[4, 4] + sh2 * qpos,
            x[2] + t * x[5],
            p[2, 2] + t * (p[2, 5] + p[2, 5]) + tt * p[5, 5] + sv2 * qpos)


@kernel("float64[:, ::1](float64[:, ::1], float64[:, :, ::1], float64[::1], float64, float64, float64, float64, "
        "float64[::1], boolean[::1])")
def pc_curve_cv_pairs(rel_x, rel_p, t_s, step_s, sigma_h, sigma_v, radius, half_heights, has_alt):
    """The conflict stage's Pc curve (assess.conflict_probabilities with the exact method): the closed-form CV
    prediction of prediction.cv_relative_prediction at every t = k step,

        m(t) = m_pos + t m_vel
        P_pos(t) = P_pp + t (P_pv + P_vp) + t^2 P_vv + sigma^2 step^4 (k^3/3 - k/12) I

    the exact disk probability and the slab factor P(|z| <= H_i) where the altitude is known: (N, K)."""
    n = rel_x.shape[0]
    nk = t_s.shape[0]
    out = np.empty((n, nk))
    sh2 = sigma_h * sigma_h
    sv2 = sigma_v * sigma_v
    for i in range(n):
        p = rel_p[i]
        x = rel_x[i]
        hh = half_heights[i]
        for j in range(nk):
            mx, my, c00, c01, c10, c11, mz, vz = cv_at(x, p, t_s[j], step_s, sh2, sv2)
            pc = disk_pc(mx, my, c00, c01, c10, c11, radius)
            if has_alt[i]:
                pc *= interval_mass(-hh, hh, mz, np.sqrt(max(vz, 0.0)))
            out[i, j] = pc
    return out


@kernel("float64(float64[::1])")
def cpa_time(x):
    """The horizontal CPA time of the relative state x, -s.v / |v|^2 (0 without relative motion), unclamped."""
    v2 = x[3] * x[3] + x[4] * x[4]
    return -(x[0] * x[3] + x[1] * x[4]) / v2 if v2 > 0.0 else 0.0


@kernel("float64(float64[::1], float64, float64)")
def min_distance(x, t_cpa, lookahead_s):
    """scheduling.predicted_min_distance: |s + v t| at the CPA time clamped to [0, lookahead]."""
    t = min(max(t_cpa, 0.0), lookahead_s)
    return math.hypot(x[0] + x[3] * t, x[1] + x[4] * t)


@kernel("void(float64[:, ::1], float64[:, :, ::1], float64[::1], float64, float64, float64, float64, float64[::1], "
        "boolean[::1], float64, float64, float64[:, ::1], float64[:, ::1])")
def zone_pairs(rel_x, rel_p, t_s, step_s, sigma_h, sigma_v, radius, half_heights, has_alt, lookahead_s, alpha,
               curve, out):
    """assess.conflict_probabilities with the exact method and no Monte Carlo, fused (issue 32 item 1): the curve
    of pc_curve_cv_pairs into `curve` (N, K), then per pair into `out` (N, 4) its columns ZONE_COLUMNS:

        pc_now = curve[0], pc_max and its time (prediction.max_over_lookahead: the earliest on ties, NaN rows NaN),
        pc_pe  = Hwang eq 24 (probability.pc_paielli_erzberger) with the CV prediction at the mean's CPA time on the
                 step grid (clamped to the lookahead), times the slab factor there where the altitude is known;
                 0 unless the predicted minimum distance within the lookahead is below alpha R + 3 sigma of that
                 prediction (scheduling.min_distance_filter: Hwang condition 2(b))."""
    n = rel_x.shape[0]
    nk = t_s.shape[0]
    curve[:, :] = pc_curve_cv_pairs(rel_x, rel_p, t_s, step_s, sigma_h, sigma_v, radius, half_heights, has_alt)
    sh2 = sigma_h * sigma_h
    sv2 = sigma_v * sigma_v
    for i in range(n):
        x = rel_x[i]
        p = rel_p[i]
        best = 0
        top = -1.0
        for j in range(nk):  # np.argmax over the row with NaN as -1: the first maximum
            v = curve[i, j]
            if v != v:
                v = -1.0
            if v > top:
                top = v
                best = j
        out[i, 0] = curve[i, 0]
        out[i, 1] = curve[i, best]
        out[i, 2] = np.nan if curve[i, best] != curve[i, best] else t_s[best]
        # the (clamped) CPA time of the mean on the step grid, and the prediction there
        t_cpa = cpa_time(x)
        k = min(max(np.rint(t_cpa / step_s), 0.0), nk - 1.0)
        mx, my, c00, c01, c10, c11, mz, vz = cv_at(x, p, t_s[int(k)], step_s, sh2, sv2)
        speed = math.hypot(x[3], x[4])
        if speed > 0.0:  # the strip |n . x| <= R across the relative velocity
            nx = -x[4] / speed
            ny = x[3] / speed
            d = nx * mx + ny * my
            s2 = nx * (c00 * nx + c01 * ny) + ny * (c10 * nx + c11 * ny)
            pe = interval_mass(-radius, radius, d, np.sqrt(max(s2, 0.0)))
        else:  # no relative motion: the exact instantaneous value
            pe = disk_pc(mx, my, c00, c01, c10, c11, radius)
        # Hwang condition 2(b): the straight-line minimum distance within the lookahead
        if not min_distance(x, t_cpa, lookahead_s) < alpha * radius + 3.0 * np.sqrt(c00 + c11):
            out[i, 3] = 0.0
            continue
        if has_alt[i]:
            pe *= interval_mass(-half_heights[i], half_heights[i], mz, np.sqrt(max(vz, 0.0)))
        out[i, 3] = pe


@kernel("boolean[::1](float64[:, ::1], float64[:, :, ::1], boolean[::1], float64[::1], float64, float64, float64, "
        "float64, float64, float64, float64)")
def min_distance_keep_pairs(rel_x, rel_p, has_alt, z_margin_m, radius, half_height, lookahead_s, step_s, alpha,
                            sigma_h, sigma_v):
    """scheduling.MinDistancePrefilter.keep for N pairs (Hwang condition 2(b), widened by 3 sigma of the CV
    prediction at the horizon): the straight-line minimum distance within the lookahead < alpha R + 3 sqrt(tr
    P_xy(T)), and where the altitude is known the minimum vertical separation < alpha (H + margin) + 3 sigma_z(T)."""
    n = rel_x.shape[0]
    keep = np.empty(n, np.bool_)
    for i in range(n):
        x = rel_x[i]
        _, _, c00, _, _, c11, _, vz = cv_at(x, rel_p[i], lookahead_s, step_s, sigma_h * sigma_h, sigma_v * sigma_v)
        ok = min_distance(x, cpa_time(x), lookahead_s) < alpha * radius + 3.0 * np.sqrt(c00 + c11)
        if ok and has_alt[i]:
            zmax = alpha * (half_height + z_margin_m[i]) + 3.0 * np.sqrt(vz)
            end = x[2] + x[5] * lookahead_s
            if np.sign(x[2]) != np.sign(end):  # scheduling.predicted_min_vertical: crosses (NaN too)
                mv = 0.0
            else:
                mv = min(abs(x[2]), abs(end))
            ok = mv < zmax
        keep[i] = ok
    return keep


GEOMETRY_COLUMNS = ("range_m", "s_dot_v", "closure_rate_mps", "t_cpa_s", "hmd_m", "vmd_m", "range_tau_s",
                    "vertical_tau_s", "cpa_x", "cpa_y", "t_cpa3d_s", "cpa3d_x", "cpa3d_y", "cpa3d_z", "miss3d_m")


@kernel("float64[:, ::1](float64[:, ::1], float64[:, ::1], float64[::1], float64[::1])")
def pair_geometry_pairs(s_xy, v_xy, sz, vz):
    """cpa.pair_geometry_reference for N pairs, the columns GEOMETRY_COLUMNS (N, 15):
    t_cpa = max(0, -s.v / |v|^2) (0 when v = 0), hmd = |s + v t_cpa|, vmd = sz + vz t_cpa, range tau = r / closure
    when closing (0 at r = 0, else inf), vertical tau = -sz / vz when converging (0 at co-altitude, else inf),
    3D CPA time max(0, -(s.v + sz vz) / (|v|^2 + vz^2)) and the relative position and slant distance there."""
    n = s_xy.shape[0]
    out = np.empty((n, 15))
    for i in range(n):
        sx = s_xy[i, 0]
        sy = s_xy[i, 1]
        vx = v_xy[i, 0]
        vy = v_xy[i, 1]
        z = sz[i]
        w = vz[i]
        r = math.hypot(sx, sy)
        sv = sx * vx + sy * vy
        v2 = vx * vx + vy * vy
        t_cpa = max(0.0, -sv / v2) if v2 > 0.0 else 0.0
        closure = -sv / r if r > 0.0 else 0.0
        range_tau = r / closure if closure > 0.0 else np.inf
        if r == 0.0:
            range_tau = 0.0
        vtau = -z / w if z * w < 0.0 else np.inf
        if z == 0.0:
            vtau = 0.0
        cx = sx + vx * t_cpa
        cy = sy + vy * t_cpa
        v3 = v2 + w * w
        t3 = max(0.0, -(sv + z * w) / v3) if v3 > 0.0 else 0.0
        px = sx + vx * t3
        py = sy + vy * t3
        pz = z + w * t3
        out[i, 0] = r
        out[i, 1] = sv
        out[i, 2] = closure
        out[i, 3] = t_cpa
        out[i, 4] = math.hypot(cx, cy)
        out[i, 5] = z + w * t_cpa
        out[i, 6] = range_tau
        out[i, 7] = vtau
        out[i, 8] = cx
        out[i, 9] = cy
        out[i, 10] = t3
        out[i, 11] = px
        out[i, 12] = py
        out[i, 13] = pz
        out[i, 14] = np.sqrt(px * px + py * py + pz * pz)
    return out


@kernel("boolean[::1](float64[::1], float64[::1], float64[::1], float64[::1], float64[::1], boolean[::1], "
        "float64[::1], boolean[::1], float64, float64, float64, float64, boolean)")
def tcas3d_conflict_pairs(range_m, s_dot_v, hmd_m, sz_m, vz_mps, has_alt, margin_m, eligible, dmod_m, zthr_m, tau_s,
                          hmd_thr_m, altitude_required):
    """advisory/alerting.py TCAS3D.conflict (its numpy code is the reference) for N pairs ([B71] Table 3 thresholds;
    DAIDALUS TCAS2D.horizontal_RA, TCAS3D.vertical_RA; HMD filter where hmd_thr_m is not NaN):

      horizontal: r <= DMOD, or closing (s.v < 0) with modified tau (DMOD^2 - r^2) / (s.v) <= TAU
      vertical:   |sz'| <= ZTHR, or converging with time to co-altitude -sz'/vz <= TAU,
                  sz' = sign(sz) max(|sz| - margin, 0) (the datum margin taken off)
      out:        altitude_required: has_alt & eligible & horizontal & vertical; else horizontal & (!has_alt | vertical)
    """
    n = range_m.shape[0]
    out = np.empty(n, np.bool_)
    d2 = dmod_m ** 2
    for i in range(n):
        r = range_m[i]
        sv = s_dot_v[i]
        if r <= dmod_m:
            horizontal = True
        elif sv < 0.0:
            horizontal = (d2 - r ** 2) / sv <= tau_s
        else:
            horizontal = False
        z = sz_m[i]
        sep = np.sign(z) * max(abs(z) - margin_m[i], 0.0)
        w = vz_mps[i]
        converging = sep * w < 0.0
        vertical = abs(sep) <= zthr_m or (converging and -sep / w <= tau_s)
        if altitude_required:
            fire = has_alt[i] and eligible[i] and horizontal and vertical
        else:
            fire = horizontal and ((not has_alt[i]) or vertical)
        if hmd_thr_m == hmd_thr_m:
            fire = fire and hmd_m[i] <= hmd_thr_m
        out[i] = fire
    return out


@kernel("boolean(float64, float64, float64, float64, float64, float64, float64, float64, boolean)")
def segment_hits(p0x, p0y, p1x, p1y, z0, z1, radius, half_height, vertical):
    """prediction._segment_hits for one segment: the straight segment p0 -> p1 (with z0 -> z1 when vertical) passes
    inside the disk |p| <= R (and the slab |z| <= H) at the same instant: the roots of |d|^2 s^2 + 2 (p0.d) s +
    |p0|^2 - R^2 = 0 and of |z0 + dz s| = H intersected with s in [0, 1]."""
    dx = p1x - p0x
    dy = p1y - p0y
    a = dx * dx + dy * dy
    b = p0x * dx + p0y * dy
    c = (p0x * p0x + p0y * p0y) - radius ** 2
    disc = b * b - a * c
    sq = math.sqrt(max(disc, 0.0))
    if a > 0.0:
        ta = (-b - sq) / a
        tb = (-b + sq) / a
    else:
        ta = 0.0 if c <= 0.0 else np.inf
        tb = 1.0 if c <= 0.0 else -np.inf
    ok = disc >= 0.0 or a == 0.0
    lo = max(ta, 0.0)
    hi = min(tb, 1.0)
    if vertical:
        dz = z1 - z0
        level_in = abs(z0) <= half_height
        if dz != 0.0:
            u1 = (-half_height - z0) / dz
            u2 = (half_height - z0) / dz
            za = min(u1, u2)
            zb = max(u1, u2)
        else:
            za = 0.0 if level_in else np.inf
            zb = 1.0 if level_in else -np.inf
        lo = max(lo, za)
        hi = min(hi, zb)
    return ok and lo <= hi


@kernel("int64(float32[:, ::1], float32[:, ::1], float32[:, ::1], int64[::1], float64[::1], float32[::1], "
        "float64[::1], boolean, float32[::1], float32, float32, boolean, float64, float64[::1], int64)")
def within_step(pos, vel, accel, owner, radius, reach0, half_height, vertical, sig32, h32, half_h2, drop, v_min, hits,
                m):
    """One step of prediction.pc_within_cv_mc_reference over its m undecided samples (the first m rows), with the
    step's standard normals `accel` (m, 3) drawn by numpy: the float32 propagation pos1 = pos + vel h + a h^2/2,
    vel += a h (a = sigma * normal); the exact float64 segment test on the samples that can reach the disk during
    the step (start range - step length <= R + 1 m); a hit counted for its pair (hits[owner] += 1) and the sample
    removed; when `drop`, the samples outside the disk receding faster than v_min removed too. Arrays are
    compacted in place, in order (as the reference's boolean indexing); returns the samples left."""
    w = 0
    for i in range(m):
        ax = accel[i, 0] * sig32[0]
        ay = accel[i, 1] * sig32[1]
        az = accel[i, 2] * sig32[2]
        p0x = pos[i, 0]
        p0y = pos[i, 1]
        p0z = pos[i, 2]
        p1x = p0x + vel[i, 0] * h32 + ax * half_h2
        p1y = p0y + vel[i, 1] * h32 + ay * half_h2
        p1z = p0z + vel[i, 2] * h32 + az * half_h2
        dx = p1x - p0x
        dy = p1y - p0y
        reach = reach0[i] + np.sqrt(dx * dx + dy * dy)
        vx = vel[i, 0] + ax * h32
        vy = vel[i, 1] + ay * h32
        vz = vel[i, 2] + az * h32
        done = False
        if p0x * p0x + p0y * p0y <= reach * reach:
            if segment_hits(np.float64(p0x), np.float64(p0y), np.float64(p1x), np.float64(p1y), np.float64(p0z),
                            np.float64(p1z), radius[i], half_height[i], vertical):
                hits[owner[i]] += 1.0
                done = True
        if drop and not done:  # outside the disk and receding at v_r > v_min: it cannot come back
            range2 = p1x * p1x + p1y * p1y
            radial = p1x * vx + p1y * vy  # v_r |r|
            # as numpy promotes: range2 against the float64 R^2; v_min (a float64 scalar) times sqrt(range2) (float32)
            done = (np.float64(range2) > radius[i] * radius[i]) and \
                (np.float64(radial) > v_min * np.float64(np.sqrt(range2)))
        if not done:
            pos[w, 0] = p1x
            pos[w, 1] = p1y
            pos[w, 2] = p1z
            vel[w, 0] = vx
            vel[w, 1] = vy
            vel[w, 2] = vz
            owner[w] = owner[i]
            radius[w] = radius[i]
            reach0[w] = reach0[i]
            half_height[w] = half_height[i]
            w += 1
    return w
