"""Vectorised IMM bank: N tracks x M modes stacked in arrays, one call updates any subset of the tracks.

One ImmBank holds one axis group (the horizontal [x, y, vx, vy, ax, ay] or the vertical [z, vz] state) for every
track slot: x (C, M, n), P (C, M, n, n), mu (C, M). `update(slots, dt, z, mask, r_var)` runs one IMM cycle for
the given slots only (Baek & Bang eqs 11-17, the same as Hwang eqs 3-5 and Dai eqs 26-40):

    interaction      mixing probabilities mu_ij = M_ij(dt) mu_i / c_j             Baek & Bang eq 11
                     mixed x_0j, P_0j                                             Baek & Bang eqs 12-13
    mode filtering   x_j- = F_j x_0j, P_j- = F_j P_0j F_j^T + Q_j               Baek & Bang eqs 18-19
                     Kalman update (Joseph form), residual r_j, covariance S_j    Dai eqs 30-36
    likelihood       log N(r_j; 0, S_j) (log domain)                              Baek & Bang eq 14
                     or the residual-mean likelihood of RMIMM                     Hwang eqs 11-14
    mode probability mu_j = c_j Lambda_j / c                                       Baek & Bang eq 15
    combination      x = sum mu_j x_j, P = sum mu_j (P_j + dx dx^T)               Baek & Bang eqs 16-17

with the measurement noise optionally learnt by variational Bayes (Dai eqs 17-25). The measured components are
the first d of the state (Hwang's C = [I 0]: position and velocity); a component missing from a report is
masked out exactly (its row of H is zero, its residual zero, its innovation variance 1).

`update` computes everything without touching the bank and returns a Pending cycle with the chi-square gate
statistic of each track (Radosavljevic eq 17); `commit(pending, accept)` then stores the accepted tracks only.
Between reports nothing is stored: `predict(slots, dt)` is the IMM trajectory prediction of Baek & Bang Sec.
3.3 (interaction, mode-matched prediction, pure Markov mode propagation mu(k+1) = Pi mu(k) of eq 20,
combination), so a coasting track's mode probabilities follow the Markov chain only (filterpy's
`IMMEstimator.update(None)` would instead renormalise them with stale likelihoods).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from avionics.base import jit
from avionics.tracking import bank_spec, models

kernels = jit.lazy(__name__, "avionics.tracking.kernels")  # the module, once jit.load() ran (jit.py)

LOG_2PI = math.log(2.0 * math.pi)
TINY = 1e-300
LIKELIHOODS = ("standard", "rmimm", "rmimm-recursive")


@dataclass(frozen=True)
class VbParams:
    """Variational-Bayes measurement noise (Dai eqs 17-25, after Sarkka & Nummenmaa 2009).

    Each track's estimate starts at its nominal (configured) variances with prior_count pseudo-observations
    (alpha_0 = prior_count, beta_0 = prior_count * nominal). eq 17's forgetting factor uses the estimate
    normalised by the nominal variance, so that c1..c3 mean the same for metres and metres per second."""

    iterations: int = 5  # N of eqs 22-25 (Dai: 30; the fixed point converges in a few)
    c1: float = 1000.0
    c2: float = 500.0
    c3: float = 5000.0
    prior_count: float = 5.0
    floor_fraction: float = 1e-2  # the estimate never drops below this fraction of nominal


@dataclass
class Pending:
    """One IMM cycle computed for a batch of slots, not yet stored."""

    slots: np.ndarray
    dt: np.ndarray
    x: np.ndarray  # (B, M, n) mode posteriors
    p: np.ndarray  # (B, M, n, n)
    mu: np.ndarray  # (B, M)
    d2: np.ndarray  # (B,) gate statistic: min over modes of r^T S^-1 r (Radosavljevic eq 17)
    dof: np.ndarray  # (B,) measured components
    loglik: np.ndarray  # (B, M) log-likelihoods actually used (after RMIMM)
    extra: dict = field(default_factory=dict)


def _as_index(slots: np.ndarray):
    """A slice for a contiguous ascending run of slots (views, no gather copies), else the index array."""
    if len(slots) > 1 and slots[-1] - slots[0] == len(slots) - 1 and (np.diff(slots) == 1).all():
        return slice(int(slots[0]), int(slots[-1]) + 1)
    return slots


def _sym(p: np.ndarray) -> np.ndarray:
    return 0.5 * (p + np.swapaxes(p, -1, -2))


class ImmBank:
    """N tracks x M modes of one axis group. modes: the mode filters' motion models (models.MotionModel objects,
    one state dimension), d: the measured components (the first d of the state), switch_matrix M[from, to] for
    period_s."""

    def __init__(self, modes: list[models.MotionModel], d: int, switch_matrix: np.ndarray, period_s: float = 1.0,
                 likelihood: str = "standard", vb: VbParams | None = None, rmimm_floor: float = 1.0,
                 capacity: int = 16, yaw_time_constant_s: float = 11.9, compiled: bool | None = None):
        if len(modes) < 1 or len({m.dim for m in modes}) != 1:
            raise ValueError("modes must be non-empty and share one state dimension")
        if likelihood not in LIKELIHOODS:
            raise ValueError(f"likelihood must be one of {LIKELIHOODS}, got {likelihood!r}")
        self.modes = list(modes)
        self.names = [m.name for m in modes]
        self.m = len(modes)
        self.n = modes[0].dim
        self.d = d
        self.chain = models.MarkovChain(switch_matrix, period_s)
        self.likelihood = likelihood
        self.vb = vb
        self.rmimm_floor = rmimm_floor
        self.yaw_time_constant_s = yaw_time_constant_s
        self.horizontal = self.n == models.H_DIM
        self._turn_mode = next((i for i, m in enumerate(self.modes) if m.estimates_turn), None)
        self.spec = bank_spec.BankSpec(self.modes, self.chain, likelihood, vb)
        self.compiled = compiled
        self._alloc(capacity)

    @property
    def compiled(self) -> bool:
        """True: this cycle runs the compiled kernels (tracking/kernels.py), False: the numpy reference below. Asked
        at every call: both paths keep the same arrays (x, p, mu, yaw; the covered configurations need no ebar or
        VB state), so a bank switches between two steps when the live loop switches (jit.ready, jit.switch)."""
        if self._compiled is None:
            return self.spec.covered and jit.ready()
        return self._compiled

    @compiled.setter
    def compiled(self, value: bool | None) -> None:
        """None: compiled when the kernels are ready (jit.ready) and this configuration is covered
        (bank_spec.BankSpec); True forces the kernels (plain Python when jit is off: for tests), False the
        reference."""
        if value and not self.spec.covered:
            raise ValueError(f"no compiled kernels for modes {self.names} with the {self.likelihood} likelihood"
                             f"{' and VB noise' if self.vb is not None else ''}")
        self._compiled = None if value is None else bool(value)

    # -- storage -----------------------------------------------------------------------------------------
    def _alloc(self, capacity: int) -> None:
        m, n, d = self.m, self.n, self.d
        self.capacity = capacity
        self.x = np.zeros((capacity, m, n))
        self.p = np.tile(np.eye(n), (capacity, m, 1, 1))
        self.mu = np.full((capacity, m), 1.0 / m)
        self.ebar = np.zeros((capacity, m, m, n))  # RMIMM: E[e_j | true mode t], Hwang eqs 12-13
        self.yaw = np.zeros(capacity)  # smoothed Hwang eq 20 yaw rate, rad/s counter-clockwise
        self.vb_alpha = np.ones((capacity, d))
        self.vb_beta = np.ones((capacity, d))
        self.vb_hist = np.ones((capacity, 2, d))  # normalised variance estimates at k-1, k-2 (eq 17)
        self.vb_nominal = np.ones((capacity, d))

    def grow(self, capacity: int) -> None:
        if capacity <= self.capacity:
            return
        old = {k: getattr(self, k) for k in ("x", "p", "mu", "ebar", "yaw", "vb_alpha", "vb_beta", "vb_hist", "vb_nominal")}
        c0 = self.capacity
        self._alloc(capacity)
        for k, v in old.items():
            getattr(self, k)[:c0] = v

    def init(self, slots, x: np.ndarray, p: np.ndarray, mu: np.ndarray | None = None,
             nominal_var: np.ndarray | None = None) -> None:
        """Start the given slots: every mode at (x, p); mode probabilities mu (default uniform); VB noise at
        nominal_var (B, d)."""
        slots = np.atleast_1d(slots)
        x = np.broadcast_to(np.asarray(x, float), (len(slots), self.n))
        p = np.broadcast_to(np.asarray(p, float), (len(slots), self.n, self.n))
        self.x[slots] = x[:, None, :]
        self.p[slots] = p[:, None, :, :]
        for j in (j for j, mode in enumerate(self.modes) if not mode.accelerates):  # CV carries no acceleration
            self.x[slots, j, 4:6] = 0.0
            self.p[slots, j, 4:6, :] = 0.0
            self.p[slots, j, :, 4:6] = 0.0
            self.p[slots, j, 4, 4] = self.p[slots, j, 5, 5] = models.CV_ACCEL_FLOOR_MPS2**2
        self.mu[slots] = 1.0 / self.m if mu is None else mu
        self.ebar[slots] = 0.0
        self.yaw[slots] = 0.0
        if self.vb is not None:
            nominal = np.broadcast_to(np.asarray(nominal_var, float), (len(slots), self.d))
            self.vb_nominal[slots] = nominal
            self.vb_alpha[slots] = self.vb.prior_count
            self.vb_beta[slots] = self.vb.prior_count * nominal
            self.vb_hist[slots] = 1.0

    def reframe(self, change, slots) -> None:
        """Carry the horizontal states of these slots into a new tangent plane (avionics/base/frame.py): every
        mode's [x, y, vx, vy, ax, ay] and covariance, and the RMIMM residual means. Mode probabilities, the yaw
        rate and the VB noise variances are frame-free (the planes differ by a fraction of a degree)."""
        if not self.horizontal or not len(slots):
            return
        self.x[slots], self.p[slots], t = change.carry(self.x[slots], self.p[slots], vectors=(2, 4))
        self.ebar[slots] = np.einsum("bjkl,bjtl->bjtk", t, self.ebar[slots])

    def noise_estimate(self, slots) -> np.ndarray:
        """(B, d) VB measurement-noise variance estimates (Dai eq 22), or NaN without VB."""
        slots = np.atleast_1d(slots)
        if self.vb is None:
            return np.full((len(slots), self.d), np.nan)
        return self.vb_beta[slots] / self.vb_alpha[slots]

    # -- the IMM cycle -----------------------------------------------------------------------------------
    def _interact_predict(self, slots: np.ndarray, dt: np.ndarray):
        """Interaction (eqs 11-13) and mode-matched prediction (eqs 18-19) for a batch."""
        sel = _as_index(slots)
        mu = self.mu[sel]  # (B, M)
        x = self.x[sel]  # (B, M, n)
        cbar, x0, p0 = interact(mu, x, self.p[sel], self.chain.at(dt))
        heading = None
        if self.horizontal:
            xc = (mu[:, None, :] @ x)[:, 0, :]
            heading = models.heading_rad(xc[:, 2], xc[:, 3])
        xp, pp, fms = mode_matched_predict(self.modes, dt, x0, p0, heading)
        fm = np.stack(fms, axis=1) if self.likelihood == "rmimm-recursive" else None
        return cbar, x0, xp, pp, fm

    def predict(self, slots, dt):
        """IMM trajectory prediction to dt after each slot's last update (Baek & Bang Sec. 3.3), nothing
        stored: combined x (B, n), P (B, n, n) and Markov-propagated mode probabilities (B, M) (eq 20)."""
        slots = np.atleast_1d(slots)
        dt = np.broadcast_to(np.asarray(dt, float), slots.shape)
        if self.compiled:
            b, sp = len(slots), self.spec
            x, p, cbar = np.empty((b, self.n)), np.empty((b, self.n, self.n)), np.empty((b, self.m))
            kernels.bank_predict(self.x, self.p, self.mu, kernels.arr(slots, np.int64),
                                 kernels.arr(dt), sp.codes, sp.sigma, sp.v, sp.vinv, sp.lam,
                                 self.horizontal, x, p, cbar)
            return x, p, cbar
        cbar, _, xp, pp, _ = self._interact_predict(slots, dt)
        x, p = combine(xp, pp, cbar)
        return x, p, cbar

    def mode_probabilities(self, slots, dt) -> np.ndarray:
        """Mode probabilities Markov-propagated dt after each slot's last update (Baek & Bang eq 20; the cbar
        of predict) without predicting the states: (B, M)."""
        slots = np.atleast_1d(slots)
        dt = np.broadcast_to(np.asarray(dt, float), slots.shape)
        return (self.mu[slots][:, None, :] @ self.chain.at(dt))[:, 0, :]

    def posterior(self, slots):
        """Combined posterior at each slot's last update (eqs 16-17)."""
        slots = np.atleast_1d(slots)
        if self.compiled:
            x, p = np.empty((len(slots), self.n)), np.empty((len(slots), self.n, self.n))
            kernels.bank_combine(self.x, self.p, self.mu, kernels.arr(slots, np.int64), x, p)
            return x, p
        return combine(self.x[slots], self.p[slots], self.mu[slots])

    def update(self, slots, dt, z: np.ndarray, mask: np.ndarray, r_var: np.ndarray,
               r_cov: np.ndarray | None = None) -> Pending:
        """One IMM cycle for the slots with measurements z (B, d), mask (B, d) of measured components and
        measurement variances r_var (B, d) (ignored under VB, which estimates them). Nothing is stored.
        r_cov (B, d, d): a full measurement covariance instead of r_var's diagonal, for measurements whose
        components are correlated (a polar measurement converted to east, north: measurement.py); it runs the
        numpy reference below (the compiled kernels take a diagonal) and not under VB (a diagonal estimate)."""
        slots = np.atleast_1d(slots)
        b, d = len(slots), self.d
        dt = np.broadcast_to(np.asarray(dt, float), slots.shape)
        mask = np.asarray(mask, bool).reshape(b, d)
        mf = mask.astype(float)
        z = np.where(mask, np.asarray(z, float).reshape(b, d), 0.0)
        if r_cov is not None and self.vb is not None:
            raise ValueError("a full measurement covariance cannot be learnt by the diagonal VB estimate")
        if self.compiled and r_cov is None:
            return self._update_compiled(slots, dt, z, mask, r_var)
        cbar, x0, xp, pp, fm = self._interact_predict(slots, dt)
        # combined prediction (eqs 16-17 on the priors): its mean, and the variance of its first two components
        x_prior = (cbar[:, None, :] @ xp)[:, 0, :]
        spread = xp[:, :, :2] - x_prior[:, None, :2]
        var2 = (cbar[:, :, None] * (np.diagonal(pp[:, :, :2, :2], axis1=2, axis2=3) + spread**2)).sum(axis=1)
        extra: dict = {"x_prior": x_prior, "var_prior": var2}

        if self.vb is not None:
            r_var, vb_extra = self._variational_noise(slots, *combine(xp, pp, cbar), z, mask)
            extra.update(vb_extra)
        r_var = np.where(mask, np.asarray(r_var, float).reshape(b, d), 1.0)

        # Mode-matched update (Dai eqs 30-36), masked components: zero residual, unit variance, no gain.
        full = mask.all()
        r_mat = r_var[:, None, :, None] * np.eye(d) if r_cov is None else np.asarray(r_cov, float).reshape(b, 1, d, d)
        s = pp[:, :, :d, :d] + r_mat  # eq 32 (masked: 1 on the diagonal)
        r = z[:, None, :] - xp[:, :, :d]  # eq 30
        pht = pp[:, :, :, :d]  # P H^T
        if not full:
            mm = mf[:, :, None] * mf[:, None, :]
            s = s * mm[:, None] + (1.0 - mm[:, None]) * np.eye(d)
            r = r * mf[:, None, :]
            pht = pht * mf[:, None, None, :]  # masked columns zeroed: no gain
        s_inv, logdet = spd_inverse(s)  # (B, M, d, d), (B, M); raises LinAlgError unless S is PD
        k = pht @ s_inv  # eq 33, (B, M, n, d)
        w = (s_inv @ r[..., None])[..., 0]  # S^-1 r
        maha = (r * w).sum(axis=-1)
        x_upd = xp + (k @ r[..., None])[..., 0]  # eq 35
        p_upd = _sym(pp - k @ np.swapaxes(pht, -1, -2))  # eq 36: P - K S K^T = P - K H P, kept symmetric
        dof = mask.sum(axis=1)
        loglik = -0.5 * (maha + logdet + dof[:, None] * LOG_2PI)  # eq 14 in the log domain

        if self.likelihood != "standard":
            loglik, rm_extra = self._residual_mean(loglik, slots, x0, xp, fm, k, s_inv, cbar, mf)
            extra.update(rm_extra)

        logw = np.log(np.maximum(cbar, TINY)) + loglik  # eq 15: mu_j = c_j Lambda_j / c
        logw -= logw.max(axis=1, keepdims=True)
        w_mu = np.exp(logw)
        mu_new = w_mu / w_mu.sum(axis=1, keepdims=True)
        return Pending(slots, dt, x_upd, p_upd, mu_new, maha.min(axis=1), dof, loglik, extra)

    def _update_compiled(self, slots, dt, z, mask, r_var) -> Pending:
        """update() through kernels.bank_update: the same cycle, the same Pending."""
        b, m, n, sp = len(slots), self.m, self.n, self.spec
        x, p, mu = np.empty((b, m, n)), np.empty((b, m, n, n)), np.empty((b, m))
        d2, loglik, x_prior, var2 = np.empty(b), np.empty((b, m)), np.empty((b, n)), np.empty((b, 2))
        status = kernels.bank_update(self.x, self.p, self.mu, kernels.arr(slots, np.int64),
                                     kernels.arr(dt), z, kernels.arr(mask, bool),
                                     kernels.arr(np.broadcast_to(np.asarray(r_var, float).reshape(b, -1), (b, self.d))),
                                     sp.codes, sp.sigma, sp.v, sp.vinv, sp.lam, self.horizontal,
                                     x, p, mu, d2, loglik, x_prior, var2)
        if status != kernels.OK:
            raise np.linalg.LinAlgError("matrix is not positive definite")
        return Pending(slots, dt, x, p, mu, d2, mask.sum(axis=1), loglik, {"x_prior": x_prior, "var_prior": var2})

    def _residual_mean(self, loglik, slots, x0, xp, fm, k, s_inv, cbar, mf):
        """RMIMM likelihood (Hwang eqs 11-14): Lambda_j <- Lambda_j / ||E[r_j | Z^k-1]||, with

            E[r_j] = sum_t mu-hat_t E[r_j | true mode t]                                eq 13
            E[r_j | t] = C A_t E[e_j | t] + C (A_t - A_j) x_0j                           eq 11

        The eq 14 normalisation over j cancels in eq 15. ||.|| is the Mahalanobis norm in S_j (positions and
        velocities in one norm need a common unit), floored at rmimm_floor (eq 14's 'otherwise' case, E = 0).

        E[e_j | t], the mean error of filter j if mode t is true, comes from one of two sources:
        - "rmimm" (default): the IMM's own estimate, E[e_j | t] = x_0t - x_0j (mode t's filter is the best
          estimate of the truth under hypothesis t). Then E[r_j | t] = C (A_t x_0t - A_j x_0j) and
          E[r_j] = C (x-bar^- - x_j^-): the offset of filter j's predicted measurement from the IMM's.
        - "rmimm-recursive": the Hanlon-Maybeck recursion of eq 12, e_jt(k) = (I - K_j C)[A_t e_jt(k-1) +
          (A_t - A_j) x_0j], which assumes the true mode never changes. Under Markov switching it does not
          forget: after a turn, CV's acceleration error under 'CT is true' is unobservable to CV and persists,
          so CV stays penalised and the IMM locks into CT (see docs/tracking.md for the numbers)."""
        d = self.d
        extra = {}
        if self.likelihood == "rmimm":
            xbar = np.einsum("bt,btn->bn", cbar, xp)
            er = (xbar[:, None, :d] - xp[:, :, :d]) * mf[:, None, :]
        else:
            ebar = self.ebar[slots]  # (B, j, t, n)
            inner = np.einsum("btmn,bjtn->bjtm", fm, ebar)
            inner += np.einsum("btmn,bjn->bjtm", fm, x0) - np.einsum("bjmn,bjn->bjm", fm, x0)[:, :, None, :]
            m_jt = inner[..., :d] * mf[:, None, None, :]
            er = np.einsum("bt,bjtd->bjd", cbar, m_jt)
            extra["ebar"] = inner - np.einsum("bjnd,bjtd->bjtn", k, m_jt)
        norm = np.sqrt(np.maximum(np.einsum("bjd,bjde,bje->bj", er, s_inv, er), 0.0))
        return loglik - np.log(np.maximum(norm, self.rmimm_floor)), extra

    def _variational_noise(self, slots, xm, pm, z, mask):
        """VB adaptive measurement noise, Dai eqs 17-25, on the IMM's combined prediction (Dai runs it on a
        separate CS-model filter, eqs 18-19; the IMM mixture already contains the manoeuvre hypotheses, so a
        turn is not mistaken for noise). Returns the variances for the mode filters (eq 22 after N iterations)."""
        vb = self.vb
        d = self.d
        nominal = self.vb_nominal[slots]
        mf = mask.astype(float)
        hist = self.vb_hist[slots]  # normalised sigma at k-1, k-2
        rho = np.exp(-(vb.c1 * hist[:, 0] + vb.c2 * (hist[:, 0] - hist[:, 1]) ** 2 + vb.c3) / 1e5)  # eq 17
        rho = np.where(mask, rho, 1.0)  # an unmeasured component keeps its statistics
        alpha_m = rho * self.vb_alpha[slots]  # eq 20
        beta_m = rho * self.vb_beta[slots]  # eq 21
        alpha = alpha_m + 0.5 * mf
        beta = beta_m.copy()
        # xm, pm: m_k^-, P_k^- (the IMM's combined prediction)
        hp = pm[:, :d, :d]
        y = z - xm[:, :d]
        floor = vb.floor_fraction * nominal
        eye_d = np.eye(d)
        mm = mf[:, :, None] * mf[:, None, :]
        for _ in range(vb.iterations):  # eqs 22-25 (a fixed-point loop, vectorised over tracks)
            sig = np.maximum(beta / alpha, floor)  # eq 22
            s = hp * mm + np.where(mask, sig, 1.0)[:, :, None] * eye_d
            gain = (pm[:, :, :d] * mf[:, None, :]) @ spd_inverse(s)[0]
            m_new = xm + np.einsum("bnd,bd->bn", gain, y * mf)  # eq 23
            p_new = pm - gain @ (pm[:, :d, :] * mf[:, :, None])  # eq 24
            resid = z - m_new[:, :d]
            beta = beta_m + mf * (0.5 * resid**2 + 0.5 * np.diagonal(p_new[:, :d, :d], axis1=1, axis2=2))  # eq 25
        sig = np.maximum(beta / alpha, floor)
        new_hist = np.stack([np.where(mask, sig / nominal, hist[:, 0]), hist[:, 0]], axis=1)
        return sig, {"vb_alpha": alpha, "vb_beta": beta, "vb_hist": new_hist}

    def commit(self, pending: Pending, accept=None) -> None:
        """Store the accepted part of a pending cycle."""
        sel = np.ones(len(pending.slots), bool) if accept is None else np.asarray(accept, bool)
        if not sel.any():
            return
        slots = _as_index(pending.slots[sel])
        self.x[slots] = pending.x[sel]
        self.p[slots] = pending.p[sel]
        self.mu[slots] = pending.mu[sel]
        for name in ("ebar", "vb_alpha", "vb_beta", "vb_hist"):
            if name in pending.extra:
                getattr(self, name)[slots] = pending.extra[name][sel]
        if self.horizontal:
            state = pending.x[sel, self._turn_mode] if self._turn_mode is not None else \
                combine(pending.x[sel], pending.p[sel], pending.mu[sel])[0]
            self.yaw[slots] = models.smooth_yaw_rate(self.yaw[slots], models.yaw_rate(state), pending.dt[sel],
                                                     self.yaw_time_constant_s)


def interact(mu: np.ndarray, x: np.ndarray, p: np.ndarray, trans: np.ndarray):
    """Interaction, Baek & Bang eqs 11-13, for a batch: mu (B, M), x (B, M, n), p (B, M, n, n), trans (B, M, M) or
    (M, M) [from, to] -> predicted mode probabilities c (B, M) (eq 11's c_j, Hwang eq 5 mu-hat; eq 20's mu(k+1)),
    mixed x_0j (B, M, n) and P_0j (B, M, n, n)."""
    b, m, n = x.shape
    cbar = (mu[:, None, :] @ trans)[:, 0, :]  # predicted mode probabilities (Hwang eq 5 mu-hat)
    omega = trans * mu[:, :, None] / np.maximum(cbar, TINY)[:, None, :]  # Baek & Bang eq 11, mu_ij
    # eqs 12-13 as sums over i of omega_ij (x_i, P_i + dx dx^T), evaluated about mode 0's state (small
    # differences, no cancellation): P_0j = sum_i omega_ij (P_i + d_i d_i^T) - d_0j d_0j^T, d = x - x_ref.
    omega_t = np.swapaxes(omega, 1, 2)  # (B, j, i)
    ref = x[:, :1, :]
    dxr = x - ref
    x0r = omega_t @ dxr  # (B, j, n)
    second = (p + dxr[:, :, :, None] * dxr[:, :, None, :]).reshape(b, m, n * n)
    p0 = -(x0r[:, :, :, None] * x0r[:, :, None, :]).reshape(b, m, n * n)
    for i in range(m):
        p0 += omega_t[:, :, i, None] * second[:, None, i, :]
    return cbar, x0r + ref, p0.reshape(b, m, n, n)


def mode_matched_predict(modes, dt, x0: np.ndarray, p0: np.ndarray, heading=None):
    """Mode-matched prediction, Baek & Bang eqs 18-19: x_j- = F_j x_0j, P_j- = F_j P_0j F_j^T + Q_j for every
    mode (models.MotionModel objects), vectorised over the batch; dt scalar or (B,); heading (B,) the combined
    heading of eq 31 (None: each mode's own). Returns x (B, M, n), P (B, M, n, n) and the F_mean of each mode."""
    b, m, n = x0.shape
    xp = np.empty((b, m, n))
    pp = np.empty((b, m, n, n))
    fms = []
    for j, mode in enumerate(modes):  # loop over modes (M <= 4), each vectorised over the batch
        f_mean, f_cov, q = mode.matrices(dt, x0[:, j], heading)
        xp[:, j] = (f_mean @ x0[:, j, :, None])[..., 0]  # eq 18
        pp[:, j] = f_cov @ p0[:, j] @ np.swapaxes(f_cov, -1, -2) + q  # eq 19
        fms.append(f_mean)
    return xp, _sym(pp), fms


def combine(x: np.ndarray, p: np.ndarray, mu: np.ndarray):
    """Combination, Baek & Bang eqs 16-17, over the mode axis (..., M, n): x = sum mu_j x_j,
    P = sum mu_j (P_j + (x_j - x)(x_j - x)^T)."""
    *lead, m, n = x.shape
    ref = x[..., :1, :]
    dxr = x - ref
    xr = (mu[..., None, :] @ dxr)[..., 0, :]
    second = p + dxr[..., :, :, None] * dxr[..., :, None, :]
    pc = (mu[..., None, :] @ second.reshape(*lead, m, n * n)).reshape(*lead, n, n) - xr[..., :, None] * xr[..., None, :]
    return xr + ref[..., 0, :], _sym(pc)


def spd_inverse(s: np.ndarray):
    """Inverse and log-determinant of a stack of small symmetric positive definite matrices (..., d, d), by a
    Cholesky factorisation written out over the d x d entries and vectorised over the stack (numpy's batched
    LAPACK calls cost about 0.3 us per 4 x 4 matrix; this costs a few numpy operations per entry).
    Raises numpy.linalg.LinAlgError if a matrix is not positive definite."""
    d = s.shape[-1]
    lead = s.shape[:-2]
    a = np.moveaxis(s.reshape(-1, d, d), 0, -1)  # (d, d, N): contiguous rows per entry
    low = [[None] * d for _ in range(d)]
    for j in range(d):
        v = a[j, j] - sum(low[j][k] * low[j][k] for k in range(j)) if j else a[j, j].copy()
        if not (v > 0.0).all():
            raise np.linalg.LinAlgError("matrix is not positive definite")
        low[j][j] = np.sqrt(v)
        for i in range(j + 1, d):
            acc = a[i, j] - sum(low[i][k] * low[j][k] for k in range(j)) if j else a[i, j]
            low[i][j] = acc / low[j][j]
    inv_l = [[None] * d for _ in range(d)]  # L^-1, lower triangular
    for i in range(d):
        inv_l[i][i] = 1.0 / low[i][i]
        for j in range(i):
            acc = sum(low[i][k] * inv_l[k][j] for k in range(j, i))
            inv_l[i][j] = -acc * inv_l[i][i]
    out = np.empty((d, d) + a.shape[2:])
    for i in range(d):
        for j in range(i + 1):
            v = sum(inv_l[k][i] * inv_l[k][j] for k in range(i, d))  # (L^-T L^-1)_ij
            out[i, j] = v
            out[j, i] = v
    logdet = 2.0 * sum(np.log(low[i][i]) for i in range(d))
    return np.moveaxis(out, -1, 0).reshape(lead + (d, d)), logdet.reshape(lead)
