"""Compiled IMM kernels (numba, issue 13 item 1): the IMM cycle of tracking/imm.py written out per track, one call
for a whole batch.

The numpy code of imm.py and models.py is the reference and stays the path when the compiled kernels are not ready
(`avionics.base.jit.ready()` false: `AVIONICS_COMPILED=0`, or the live loop while they compile) or when a bank's
configuration is not covered here.
Each kernel below follows the reference equation by equation, in the same order of operations where it matters
(the mixing and the combination about mode 0's state, the Cholesky inverse of S written out entry by entry, the
log-domain likelihoods), so that both agree to rounding (tests/test_kernels_imm.py: 1e-9).

Covered: the standard likelihood (Baek & Bang eq 14) without variational-Bayes noise, horizontal modes CV, CA
and CT, vertical modes CH and CAD; that is `tracking.filter = "imm"` with any of those modes, the default
configuration (cv + ct, ch + cad) included. Not covered (the reference runs): the CS mode (Dai eqs 8-12), the
RMIMM likelihoods (Hwang eqs 11-14) and VB noise (Dai eqs 17-25).

Kernels (every one with an explicit signature: compiled, or loaded from numba's disk cache, at import):

    bank_update      one IMM cycle of one bank for a batch, nothing stored (ImmBank.update)
    bank_predict     the IMM trajectory prediction of one bank (ImmBank.predict)
    bank_combine     combination of the stored posteriors (ImmBank.posterior)
    tracker_update   the fused step of ImmTracker._update: both banks, the plausibility test, the chi-square
                     gate (Radosavljevic eq 17) and the commit of the accepted tracks, in place
    tracker_predict  ImmTracker.predict's two bank predictions, assembled into the pipeline's 6-state
    tracker_posterior  ImmTracker._posterior (both banks' combined posteriors, assembled)

A mode is passed as a code (tracking/bank_spec.py, with BankSpec and arr: what the banks need without numba)
and its noise parameter; the mode-transition matrix M(dt) is evaluated from
the eigendecomposition of models.MarkovChain (v, v^-1, generator eigenvalues) as MarkovChain.at does.
"""

from __future__ import annotations

import math

import numpy as np

from avionics.base.jit import kernel
from avionics.tracking import models
from avionics.tracking.bank_spec import CA, CA_ISO, CAD, CH, CT, CV, BankSpec, arr, mode_code  # noqa: F401

LOG_2PI = math.log(2.0 * math.pi)
TINY = 1e-300
CV_FLOOR_VAR = models.CV_ACCEL_FLOOR_MPS2**2
OK, NOT_PD = 0, 1


# --- per-track building blocks ------------------------------------------------------------------------------


@kernel("void(float64, float64[:, ::1], float64[:, ::1], float64[::1], float64[:, ::1])")
def transition(dt, v, vinv, lam, out):
    """Mode transition matrix M(dt)[from, to] = expm(|dt| / T0 logm(M1)) through the generator's eigen-
    decomposition, clipped to [0, 1] and rows normalised: models.MarkovChain.at."""
    m = lam.shape[0]
    t = abs(dt)
    e = np.empty(m)
    for l in range(m):
        e[l] = math.exp(lam[l] * t)
    for i in range(m):
        for k in range(m):
            acc = 0.0
            for l in range(m):
                acc += v[i, l] * e[l] * vinv[l, k]
            out[i, k] = min(max(acc, 0.0), 1.0)
    for i in range(m):
        s = 0.0
        for k in range(m):
            s += out[i, k]
        for k in range(m):
            out[i, k] = out[i, k] / s


@kernel("void(int64, float64, float64, float64, float64[:, ::1], float64[:, ::1])")
def motion_matrices(code, sigma, dt, heading, f, q):
    """F and Q of one mode for a step dt (models.py; the same polynomials in T):

    CV   Baek & Bang eq 5 (= Hwang eq 16): per axis F = [[1, T, 0], [0, 1, 0], [0, 0, 0]], Q = sigma^2 B B^T,
         B = [T^2/2, T, 0], plus the CV_ACCEL_FLOOR variance on the zeroed accelerations
    CA   Baek & Bang eq 6 with eq 31: F = [[1, T, T^2/2], [0, 1, T], [0, 0, 1]], Q = B Q_CA B^T, B = [T^2/2, T, 1],
         Q_CA = diag(sigma^2 cos^2 psi, sigma^2 sin^2 psi) (CA_ISO: eq 6's sigma^2 I)
    CT   Hwang eq 18: F as CA, Q = G G^T sigma^2, G = [T^2/2, T, 1]
    CH   Baek & Bang eq 7: F = [[1, T], [0, 1]], Q = sigma^2 [T, 1][T, 1]^T
    CAD  Baek & Bang eq 8: F = [[1, T], [0, 1]], Q = sigma^2 [T^2, T][T^2, T]^T (as printed)

    Horizontal states are interleaved [x, y, vx, vy, ax, ay]."""
    n = f.shape[0]
    for i in range(n):
        for j in range(n):
            f[i, j] = 0.0
            q[i, j] = 0.0
    t = dt
    t2 = t**2
    t3 = t**3
    t4 = t**4
    var = sigma**2
    if code == CH or code == CAD:
        f[0, 0] = 1.0
        f[0, 1] = t
        f[1, 1] = 1.0
        if code == CH:
            q[0, 0] = var * t2
            q[0, 1] = var * t
            q[1, 0] = var * t
            q[1, 1] = var
        else:
            q[0, 0] = var * t4
            q[0, 1] = var * t3
            q[1, 0] = var * t3
            q[1, 1] = var * t2
        return
    # horizontal, per axis a: position a, velocity 2 + a, acceleration 4 + a
    for a in range(2):
        p_, v_, c_ = a, 2 + a, 4 + a
        f[p_, p_] = 1.0
        f[p_, v_] = t
        f[v_, v_] = 1.0
        if code != CV:
            f[p_, c_] = 0.5 * t2
            f[v_, c_] = t
            f[c_, c_] = 1.0
        if code == CA:
            va = var * math.cos(heading) ** 2 if a == 0 else var * math.sin(heading) ** 2  # Baek & Bang eq 31
        else:
            va = var
        # g g^T with the polynomial coefficients of models._gain_outer: T^4/4, T^3/2, T^2/2, T^2, T, 1
        q[p_, p_] = va * (0.25 * t4)
        q[p_, v_] = q[v_, p_] = va * (0.5 * t3)
        q[v_, v_] = va * t2
        if code != CV:
            q[p_, c_] = q[c_, p_] = va * (0.5 * t2)
            q[v_, c_] = q[c_, v_] = va * t
            q[c_, c_] = va
        else:
            q[c_, c_] = CV_FLOOR_VAR  # the floor keeps P positive definite


@kernel("boolean(float64[:, ::1], float64[:, ::1], float64[::1], float64[:, ::1], float64[:, ::1])")
def spd_inverse(s, out, logdet, low, inv_l):
    """Inverse and log-determinant (logdet[0]) of a small SPD matrix by the written-out Cholesky factorisation of
    imm.spd_inverse (same order of sums). False if s is not positive definite (the reference raises). low, inv_l:
    (d, d) scratch."""
    d = s.shape[0]
    for i in range(d):
        for j in range(d):
            low[i, j] = 0.0
            inv_l[i, j] = 0.0
    for j in range(d):
        v = s[j, j]
        if j:
            acc = 0.0
            for k in range(j):
                acc += low[j, k] * low[j, k]
            v = s[j, j] - acc
        if not v > 0.0:
            return False
        low[j, j] = math.sqrt(v)
        for i in range(j + 1, d):
            a = s[i, j]
            if j:
                acc = 0.0
                for k in range(j):
                    acc += low[i, k] * low[j, k]
                a = s[i, j] - acc
            low[i, j] = a / low[j, j]
    for i in range(d):
        inv_l[i, i] = 1.0 / low[i, i]
        for j in range(i):
            acc = 0.0
            for k in range(j, i):
                acc += low[i, k] * inv_l[k, j]
            inv_l[i, j] = -acc * inv_l[i, i]
    for i in range(d):
        for j in range(i + 1):
            acc = 0.0
            for k in range(i, d):
                acc += inv_l[k, i] * inv_l[k, j]
            out[i, j] = acc
            out[j, i] = acc
    ld = 0.0
    for i in range(d):
        ld += math.log(low[i, i])
    logdet[0] = 2.0 * ld
    return True


@kernel("void(float64[:, ::1], float64[:, :, ::1], float64[::1], float64[::1], float64[:, ::1])")
def combine_row(x, p, mu, xo, po):
    """Combination, Baek & Bang eqs 16-17, of one track's modes x (M, n), p (M, n, n) with weights mu, about
    mode 0's state as imm.combine: x = sum mu_j x_j, P = sum mu_j (P_j + dx dx^T), symmetrised."""
    m, n = x.shape
    xr = np.zeros(n)
    for j in range(m):
        for a in range(n):
            xr[a] += mu[j] * (x[j, a] - x[0, a])
    for a in range(n):
        for b in range(n):
            acc = 0.0
            for j in range(m):
                acc += mu[j] * (p[j, a, b] + (x[j, a] - x[0, a]) * (x[j, b] - x[0, b]))
            po[a, b] = acc - xr[a] * xr[b]
    for a in range(n):
        for b in range(a + 1, n):
            s = 0.5 * (po[a, b] + po[b, a])
            po[a, b] = s
            po[b, a] = s
    for a in range(n):
        xo[a] = xr[a] + x[0, a]


@kernel("void(float64[:, ::1], float64[:, :, ::1], float64[::1], float64, int64[::1], float64[::1], "
        "float64[:, ::1], float64[:, ::1], float64[::1], boolean, "
        "float64[::1], float64[:, ::1], float64[:, :, ::1], float64[:, ::1], float64[:, ::1], float64[:, ::1], "
        "float64[::1], float64[:, ::1], float64[:, ::1])")
def interact_predict(x, p, mu, dt, codes, sigma, v, vinv, lam, horizontal, cbar, xp, pp, f, q, trans, x0r, p0, tmp):
    """Interaction (Baek & Bang eqs 11-13) and mode-matched prediction (eqs 18-19) of one track, as
    ImmBank._interact_predict: predicted mode probabilities cbar (M,), mode priors xp (M, n), pp (M, n, n).
    f, q, p0, tmp: (n, n), trans (M, M), x0r (n,) scratch."""
    m, n = x.shape
    transition(dt, v, vinv, lam, trans)
    for j in range(m):  # c_j = sum_i M_ij mu_i (eq 11's normaliser, Hwang eq 5 mu-hat)
        acc = 0.0
        for i in range(m):
            acc += mu[i] * trans[i, j]
        cbar[j] = acc
    heading = 0.0
    if horizontal:  # eq 31's psi from the combined velocity at the last update
        ve = 0.0
        vn = 0.0
        for i in range(m):
            ve += mu[i] * x[i, 2]
            vn += mu[i] * x[i, 3]
        heading = math.atan2(ve, vn)
    for j in range(m):
        # eq 11: omega_ij = M_ij mu_i / c_j; eqs 12-13 about mode 0's state
        cj = max(cbar[j], TINY)
        for a in range(n):
            acc = 0.0
            for i in range(m):
                acc += (trans[i, j] * mu[i] / cj) * (x[i, a] - x[0, a])
            x0r[a] = acc
        for a in range(n):
            for b in range(n):
                acc = 0.0
                for i in range(m):
                    acc += (trans[i, j] * mu[i] / cj) * (p[i, a, b] + (x[i, a] - x[0, a]) * (x[i, b] - x[0, b]))
                p0[a, b] = acc - x0r[a] * x0r[b]
        # eqs 18-19: x_j- = F_j x_0j, P_j- = F_j P_0j F_j^T + Q_j, symmetrised
        motion_matrices(codes[j], sigma[j], dt, heading, f, q)
        for a in range(n):
            acc = 0.0
            for b in range(n):
                acc += f[a, b] * (x0r[b] + x[0, b])
            xp[j, a] = acc
        for a in range(n):  # F P0 F^T over F's non-zero entries (at most 3 a row: the zeros add exact zeros)
            for b in range(n):
                acc = 0.0
                for c in range(n):
                    if f[a, c] != 0.0:
                        acc += f[a, c] * p0[c, b]
                tmp[a, b] = acc
        for a in range(n):
            for b in range(n):
                acc = 0.0
                for c in range(n):
                    if f[b, c] != 0.0:
                        acc += tmp[a, c] * f[b, c]
                pp[j, a, b] = acc + q[a, b]
        for a in range(n):
            for b in range(a + 1, n):
                s = 0.5 * (pp[j, a, b] + pp[j, b, a])
                pp[j, a, b] = s
                pp[j, b, a] = s


@kernel("boolean(float64[:, ::1], float64[:, :, ::1], float64[::1], float64[::1], boolean[::1], float64[::1], "
        "float64[:, ::1], float64[:, :, ::1], float64[::1], float64[::1], float64[::1], float64[::1], float64[::1], "
        "float64[:, ::1])")
def update_row(xp, pp, cbar, z, mask, r_var, xu, pu, mu_new, loglik, x_prior, var2, d2, work):
    """The update of one track (Dai eqs 30-36, Baek & Bang eqs 14-15) after interact_predict, as ImmBank.update:
    mode posteriors xu (M, n), pu (M, n, n), mode probabilities mu_new, log-likelihoods, the combined prior's
    mean x_prior (n,) and the variance var2 (2,) of its first two components (for the plausibility test), and
    d2[0] = min over modes of r^T S^-1 r (Radosavljevic eq 17). A masked component: zero residual, unit
    innovation variance, no gain. False if an S is not positive definite. work: (4 d + 3 + n, d) scratch."""
    m, n = xp.shape
    d = z.shape[0]
    for a in range(n):  # combined prediction, eqs 16-17 on the priors
        acc = 0.0
        for j in range(m):
            acc += cbar[j] * xp[j, a]
        x_prior[a] = acc
    for a in range(2):
        acc = 0.0
        for j in range(m):
            sp = xp[j, a] - x_prior[a]
            acc += cbar[j] * (pp[j, a, a] + sp**2)
        var2[a] = acc
    dof = 0
    for a in range(d):
        if mask[a]:
            dof += 1
    s = work[0:d]  # views into the scratch rows: (d, d) matrices, d-vectors, (n, d)
    s_inv = work[d:2 * d]
    low = work[2 * d:3 * d]
    inv_l = work[3 * d:4 * d]
    r = work[4 * d]
    w = work[4 * d + 1]
    ld = work[4 * d + 2, 0:1]
    k = work[4 * d + 3:4 * d + 3 + n]
    best = 0.0
    for j in range(m):
        for a in range(d):
            r[a] = z[a] - xp[j, a] if mask[a] else 0.0  # eq 30
            for b in range(d):
                if mask[a] and mask[b]:
                    s[a, b] = pp[j, a, b] + (r_var[a] if a == b else 0.0)  # eq 32
                else:
                    s[a, b] = 1.0 if a == b else 0.0
        if not spd_inverse(s, s_inv, ld, low, inv_l):
            return False
        for a in range(n):  # eq 33: K = P H^T S^-1, masked columns of P H^T zeroed
            for b in range(d):
                acc = 0.0
                for c in range(d):
                    if mask[c]:
                        acc += pp[j, a, c] * s_inv[c, b]
                k[a, b] = acc
        maha = 0.0
        for a in range(d):
            acc = 0.0
            for b in range(d):
                acc += s_inv[a, b] * r[b]
            w[a] = acc
            maha += r[a] * w[a]
        for a in range(n):  # eq 35
            acc = 0.0
            for b in range(d):
                acc += k[a, b] * r[b]
            xu[j, a] = xp[j, a] + acc
        for a in range(n):  # eq 36: P - K H P, symmetrised
            for b in range(n):
                acc = 0.0
                for c in range(d):
                    if mask[c]:
                        acc += k[a, c] * pp[j, b, c]
                pu[j, a, b] = pp[j, a, b] - acc
        for a in range(n):
            for b in range(a + 1, n):
                sv = 0.5 * (pu[j, a, b] + pu[j, b, a])
                pu[j, a, b] = sv
                pu[j, b, a] = sv
        loglik[j] = -0.5 * (maha + ld[0] + dof * LOG_2PI)  # eq 14 in the log domain
        if j == 0 or maha < best or maha != maha:  # min over modes, NaN-propagating as numpy's
            best = maha
    d2[0] = best
    top = 0.0
    for j in range(m):  # eq 15 by a log-sum-exp softmax of log c_j + log L_j
        mu_new[j] = math.log(max(cbar[j], TINY)) + loglik[j]
        if j == 0 or mu_new[j] > top or mu_new[j] != mu_new[j]:  # NaN-propagating max, as numpy's
            top = mu_new[j]
    tot = 0.0
    for j in range(m):
        mu_new[j] = math.exp(mu_new[j] - top)
        tot += mu_new[j]
    for j in range(m):
        mu_new[j] = mu_new[j] / tot
    return True


# --- batch kernels: one bank ---------------------------------------------------------------------------------


@kernel("int64(float64[:, :, ::1], float64[:, :, :, ::1], float64[:, ::1], int64[::1], float64[::1], "
        "float64[:, ::1], boolean[:, ::1], float64[:, ::1], int64[::1], float64[::1], float64[:, ::1], "
        "float64[:, ::1], float64[::1], boolean, float64[:, :, ::1], float64[:, :, :, ::1], float64[:, ::1], "
        "float64[::1], float64[:, ::1], float64[:, ::1], float64[:, ::1])")
def bank_update(x, p, mu, slots, dt, z, mask, r_var, codes, sigma, v, vinv, lam, horizontal,
                xu, pu, mu_new, d2, loglik, x_prior, var2):
    """ImmBank.update for a batch of slots, nothing stored: returns OK, or NOT_PD if an S is not positive
    definite (the caller raises, as the reference does)."""
    b = slots.shape[0]
    m, n = x.shape[1], x.shape[2]
    cbar = np.empty(m)
    xp = np.empty((m, n))
    pp = np.empty((m, n, n))
    f, q, p0, tmp = np.empty((n, n)), np.empty((n, n)), np.empty((n, n)), np.empty((n, n))
    trans, x0r = np.empty((m, m)), np.empty(n)
    d = z.shape[1]
    work = np.empty((4 * d + 3 + n, d))
    dd = np.empty(1)
    for i in range(b):
        s = slots[i]
        interact_predict(x[s], p[s], mu[s], dt[i], codes, sigma, v, vinv, lam, horizontal, cbar, xp, pp, f, q,
                         trans, x0r, p0, tmp)
        if not update_row(xp, pp, cbar, z[i], mask[i], r_var[i], xu[i], pu[i], mu_new[i], loglik[i],
                          x_prior[i], var2[i], dd, work):
            return NOT_PD
        d2[i] = dd[0]
    return OK


@kernel("void(float64[:, :, ::1], float64[:, :, :, ::1], float64[:, ::1], int64[::1], float64[::1], int64[::1], "
        "float64[::1], float64[:, ::1], float64[:, ::1], float64[::1], boolean, float64[:, ::1], "
        "float64[:, :, ::1], float64[:, ::1])")
def bank_predict(x, p, mu, slots, dt, codes, sigma, v, vinv, lam, horizontal, xo, po, cbar_out):
    """ImmBank.predict (Baek & Bang Sec. 3.3): interaction, mode-matched prediction, Markov-propagated mode
    probabilities (eq 20), combination; nothing stored."""
    b = slots.shape[0]
    m, n = x.shape[1], x.shape[2]
    xp = np.empty((m, n))
    pp = np.empty((m, n, n))
    f, q, p0, tmp = np.empty((n, n)), np.empty((n, n)), np.empty((n, n)), np.empty((n, n))
    trans, x0r = np.empty((m, m)), np.empty(n)
    for i in range(b):
        s = slots[i]
        interact_predict(x[s], p[s], mu[s], dt[i], codes, sigma, v, vinv, lam, horizontal, cbar_out[i], xp, pp, f, q,
                         trans, x0r, p0, tmp)
        combine_row(xp, pp, cbar_out[i], xo[i], po[i])


@kernel("void(float64[:, :, ::1], float64[:, :, :, ::1], float64[:, ::1], int64[::1], float64[:, ::1], "
        "float64[:, :, ::1])")
def bank_combine(x, p, mu, slots, xo, po):
    """ImmBank.posterior: combination (eqs 16-17) of the stored mode posteriors of the slots."""
    for i in range(slots.shape[0]):
        s = slots[i]
        combine_row(x[s], p[s], mu[s], xo[i], po[i])


# --- fused tracker kernels ----------------------------------------------------------------------------------

PIPE_FROM_H = (0, 1, 3, 4)  # pipeline indices [e, n, alt, ve, vn, vu] of bank-H [x, y, vx, vy]
PIPE_FROM_V = (2, 5)  # of bank-V [z, vz]


@kernel("void(float64[:, ::1], float64[:, :, ::1], float64[:, ::1], float64[:, :, ::1], int64, "
        "float64[:, ::1], float64[:, :, ::1])")
def _assemble(xh, ph, xv, pv, i, xs, ps):
    """Row i of ImmTracker._assemble: bank-H [x, y, vx, vy] and bank-V [z, vz] into [e, n, alt, ve, vn, vu]."""
    hidx = (0, 1, 3, 4)
    vidx = (2, 5)
    for a in range(6):
        for b in range(6):
            ps[i, a, b] = 0.0
    for a in range(4):
        xs[i, hidx[a]] = xh[i, a]
        for b in range(4):
            ps[i, hidx[a], hidx[b]] = ph[i, a, b]
    for a in range(2):
        xs[i, vidx[a]] = xv[i, a]
        for b in range(2):
            ps[i, vidx[a], vidx[b]] = pv[i, a, b]


@kernel("void(float64[:, :, ::1], float64[:, :, :, ::1], float64[:, ::1], int64[::1], float64[::1], "
        "float64[:, ::1], float64[:, ::1], float64[::1], "
        "float64[:, :, ::1], float64[:, :, :, ::1], float64[:, ::1], int64[::1], float64[::1], "
        "float64[:, ::1], float64[:, ::1], float64[::1], "
        "int64[::1], float64[::1], float64[:, ::1], float64[:, :, ::1])")
def tracker_predict(xh, ph, muh, codes_h, sigma_h, vh, vinvh, lamh, xv, pv, muv, codes_v, sigma_v, vv, vinvv, lamv,
                    slots, dt, xs, ps):
    """ImmTracker.predict in one call: both banks' IMM trajectory predictions to dt after each slot's last
    update, assembled into states (B, 6) [e, n, alt, ve, vn, vu] and covariances (B, 6, 6)."""
    b = slots.shape[0]
    oh = np.empty((b, 6))
    poh = np.empty((b, 6, 6))
    ov = np.empty((b, 2))
    pov = np.empty((b, 2, 2))
    ch = np.empty((b, xh.shape[1]))
    cv = np.empty((b, xv.shape[1]))
    bank_predict(xh, ph, muh, slots, dt, codes_h, sigma_h, vh, vinvh, lamh, True, oh, poh, ch)
    bank_predict(xv, pv, muv, slots, dt, codes_v, sigma_v, vv, vinvv, lamv, False, ov, pov, cv)
    for i in range(b):
        _assemble(oh, poh, ov, pov, i, xs, ps)


@kernel("void(float64[:, :, ::1], float64[:, :, :, ::1], float64[:, ::1], float64[:, :, ::1], "
        "float64[:, :, :, ::1], float64[:, ::1], int64[::1], float64[:, ::1], float64[:, :, ::1])")
def tracker_posterior(xh, ph, muh, xv, pv, muv, slots, xs, ps):
    """ImmTracker._posterior in one call: both banks' combined posteriors at the last update, assembled."""
    b = slots.shape[0]
    oh = np.empty((b, 6))
    poh = np.empty((b, 6, 6))
    ov = np.empty((b, 2))
    pov = np.empty((b, 2, 2))
    bank_combine(xh, ph, muh, slots, oh, poh)
    bank_combine(xv, pv, muv, slots, ov, pov)
    for i in range(b):
        _assemble(oh, poh, ov, pov, i, xs, ps)


@kernel("int64(float64[:, :, ::1], float64[:, :, :, ::1], float64[:, ::1], float64[::1], int64[::1], float64[::1], "
        "float64[:, ::1], float64[:, ::1], float64[::1], int64, float64, "
        "float64[:, :, ::1], float64[:, :, :, ::1], float64[:, ::1], int64[::1], float64[::1], "
        "float64[:, ::1], float64[:, ::1], float64[::1], "
        "int64[::1], float64[::1], float64[:, ::1], boolean[:, ::1], float64[:, ::1], "
        "float64[:, ::1], boolean[:, ::1], float64[:, ::1], float64[::1], float64, "
        "boolean[::1], boolean[::1])")
def tracker_update(xh, ph, muh, yaw, codes_h, sigma_h, vh, vinvh, lamh, turn_mode, yaw_tau,
                   xv, pv, muv, codes_v, sigma_v, vv, vinvv, lamv,
                   slots, dt, z_h, m_h, r_h, z_v, m_v, r_v, gate, max_speed, in_gate, plausible):
    """ImmTracker._update's numeric part in one call: one IMM cycle of both banks for each slot (distinct slots),
    the physical plausibility test (a position further than max_speed x max(dt, 1 s) + 5 sigma from the
    combined prediction), the chi-square gate (Radosavljevic eq 17: d^2 of the most permissive mode of each
    bank, summed, against gate[measured components]) and, for the accepted slots, the commit (x, P, mu and the
    Hwang eq 20 yaw rate through 1/(tau s + 1), as ImmBank.commit). Returns OK, or NOT_PD (nothing stored) if an
    innovation covariance is not positive definite."""
    b = slots.shape[0]
    mh, nh = xh.shape[1], xh.shape[2]
    mv, nv = xv.shape[1], xv.shape[2]
    xuh = np.empty((b, mh, nh))
    puh = np.empty((b, mh, nh, nh))
    muh_new = np.empty((b, mh))
    xuv = np.empty((b, mv, nv))
    puv = np.empty((b, mv, nv, nv))
    muv_new = np.empty((b, mv))
    llh = np.empty((b, mh))
    llv = np.empty((b, mv))
    xph = np.empty((b, nh))
    xpv = np.empty((b, nv))
    var2h = np.empty((b, 2))
    var2v = np.empty((b, 2))
    d2h = np.empty(b)
    d2v = np.empty(b)
    if bank_update(xh, ph, muh, slots, dt, z_h, m_h, r_h, codes_h, sigma_h, vh, vinvh, lamh, True,
                   xuh, puh, muh_new, d2h, llh, xph, var2h) != OK:
        return NOT_PD
    if bank_update(xv, pv, muv, slots, dt, z_v, m_v, r_v, codes_v, sigma_v, vv, vinvv, lamv, False,
                   xuv, puv, muv_new, d2v, llv, xpv, var2v) != OK:
        return NOT_PD
    xc = np.empty(nh)
    pc = np.empty((nh, nh))
    for i in range(b):
        jump = math.hypot(z_h[i, 0] - xph[i, 0], z_h[i, 1] - xph[i, 1])
        allowed = max_speed * max(dt[i], 1.0) + 5.0 * math.sqrt(var2h[i, 0] + var2h[i, 1] + r_h[i, 0] + r_h[i, 1])
        plausible[i] = jump <= allowed or not m_h[i, 0]  # a stale position is not measured
        dof = 0
        for a in range(z_h.shape[1]):
            if m_h[i, a]:
                dof += 1
        for a in range(z_v.shape[1]):
            if m_v[i, a]:
                dof += 1
        in_gate[i] = plausible[i] and d2h[i] + d2v[i] <= gate[dof]
        if not in_gate[i]:
            continue
        s = slots[i]
        xh[s] = xuh[i]
        ph[s] = puh[i]
        muh[s] = muh_new[i]
        xv[s] = xuv[i]
        pv[s] = puv[i]
        muv[s] = muv_new[i]
        if turn_mode >= 0:
            for a in range(nh):
                xc[a] = xuh[i, turn_mode, a]
        else:
            combine_row(xuh[i], puh[i], muh_new[i], xc, pc)
        # Hwang eq 20 (models.yaw_rate) and the exact discretisation of 1/(tau s + 1) (models.smooth_yaw_rate)
        vx, vy, ax, ay = xc[2], xc[3], xc[4], xc[5]
        speed2 = max(vx * vx + vy * vy, 1.0)
        new = np.sign(vx * ay - ax * vy) * math.sqrt((ax * ax + ay * ay) / speed2)
        kk = -math.expm1(-abs(dt[i]) / yaw_tau)
        yaw[s] = yaw[s] + kk * (new - yaw[s])
    return OK
