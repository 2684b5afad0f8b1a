"""Trajectory prediction over a lookahead and the conflict probability along it.

IMM prediction (Baek & Bang Sec. 3.3): from the current per-mode estimates x_j, P_j and mode probabilities mu,
repeat for every step of the lookahead (default 60 s in 1 s steps)

  1. interaction      c_j = sum_i pi_ij mu_i,  mu_ij = pi_ij mu_i / c_j                  (eq 11)
                      x_0j = sum_i mu_ij x_i,  P_0j = sum_i mu_ij (P_i + dx dx^T)          (eqs 12-13)
  2. mode-matched     x_j = A_j x_0j,  P_j = A_j P_0j A_j^T + B_j Q_j B_j^T                (eqs 18-19)
  3. mode prob.       mu(k+1) = Pi mu(k)  (= c)                                          (eq 20)
  4. combination      x = sum_j mu_j x_j,  P = sum_j mu_j (P_j + dx dx^T)                 (eqs 16-17)

The model set is an input: each mode is a motion model object (avionics/tracking/models.py MotionModel:
matrices(dt, x) -> (F_mean, F_cov, Q) with x the mode's mixed states (B, n)), so heading-dependent noise (Baek &
Bang eq 31, from each mode's own velocity here) plugs in directly. The interaction, mode-matched prediction and
combination are the tracker's (avionics/tracking/imm.py `interact`, `mode_matched_predict`, `combine`): one
implementation of the IMM prediction. The transition matrix is M[from, to] for one prediction step (the
convention of avionics/tracking and filterpy; Baek & Bang's Pi with pi_ij = P{to i | from j} is its transpose,
so eq 20 reads mu(k+1) = M^T mu(k)).

Paielli & Erzberger's error-growth model as used by Hwang, Hwang & Tomlin (Sec. 4): the prediction error of
one aircraft is Gaussian with principal axes along and across its track; the along-track sigma grows at 15 kn
(0.25 nm/min, a speed uncertainty), the cross-track sigma at v/57 per unit time (a 1 deg heading error) from
the current estimate's error, saturating at 1 nm; rotated into the east-north frame (eq 22), and summed over
the pair (eq 23 with the wind cross-correlation Q_sr = 0).

Conflict probability along the prediction: instantaneous Pc (t = 0), the maximum predicted Pc over the
lookahead and its time (on the step grid), and the probability of a conflict anywhere within the lookahead by
Monte Carlo over trajectories (jump-Markov sampling of modes, process noise, continuous-time check between
steps), which is what the max-over-time curve cannot give (the events at different times overlap).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

import numpy as np

from avionics.conflict.probability import conflict_probability, vertical_probability
from avionics.base import jit
from avionics.base.units import KT, NM
from avionics.tracking.imm import combine, interact, mode_matched_predict
from avionics.tracking.models import MotionModel

kernels = jit.lazy(__name__, "avionics.conflict.kernels")  # the module, once jit.load() ran (jit.py)

PE_ALONG_RATE_MPS = 15.0 * KT  # Hwang: 15 kn along-track speed uncertainty (0.25 nm/min)
PE_CROSS_RATE_PER_SPEED = 1.0 / 57.0  # Hwang: cross-track growth v/57 (1 deg of heading)
PE_CROSS_MAX_M = 1.0 * NM  # Hwang: the cross-track sigma saturates at 1 nm

# --- model plumbing -------------------------------------------------------------------------------------


def _model_matrices(model: MotionModel, dt: float, x: np.ndarray):
    """(F_mean, F_cov, Q) of a motion model, each broadcast to (B, n, n)."""
    fm, fc, q = model.matrices(dt, x)
    b, n = x.shape
    return (np.broadcast_to(np.asarray(fm, float), (b, n, n)), np.broadcast_to(np.asarray(fc, float), (b, n, n)),
            np.broadcast_to(np.asarray(q, float), (b, n, n)))


@dataclass(frozen=True)
class ModeSet:
    """The IMM model set for prediction: one motion model (models.MotionModel) per mode and the per-step
    transition matrix M[from, to]."""

    models: tuple
    transition: np.ndarray
    names: tuple = ()

    def __post_init__(self):
        t = np.asarray(self.transition, float)
        m = len(self.models)
        if t.shape != (m, m) or (t < 0).any() or not np.allclose(t.sum(axis=1), 1.0):
            raise ValueError("transition must be (M, M), non-negative, rows summing to 1 (M[from, to])")
        object.__setattr__(self, "transition", t)
        object.__setattr__(self, "models", tuple(self.models))


@dataclass(frozen=True)
class Prediction:
    """Predicted trajectories at t_s (K + 1 times, 0 first): combined (x, p) and per mode (x_modes, p_modes, mu)."""

    t_s: np.ndarray  # (K+1,)
    x: np.ndarray  # (N, K+1, n)
    p: np.ndarray  # (N, K+1, n, n)
    x_modes: np.ndarray  # (N, K+1, M, n)
    p_modes: np.ndarray  # (N, K+1, M, n, n)
    mu: np.ndarray  # (N, K+1, M)


def lookahead_times(lookahead_s: float, step_s: float) -> np.ndarray:
    k = int(round(lookahead_s / step_s))
    if k < 0 or abs(k * step_s - lookahead_s) > 1e-9 * max(1.0, lookahead_s):
        raise ValueError("lookahead_s must be a non-negative multiple of step_s")
    return np.arange(k + 1) * step_s


def imm_predict(x_modes, p_modes, mu, modes: ModeSet, lookahead_s: float = 60.0, step_s: float = 1.0) -> Prediction:
    """IMM trajectory prediction (Baek & Bang Sec. 3.3) for N tracks: x_modes (N, M, n), p_modes (N, M, n, n),
    mu (N, M) -> Prediction over [0, lookahead] every step_s, per mode and combined."""
    x = np.array(x_modes, float)
    p = np.array(p_modes, float)
    mu = np.array(mu, float)
    n_tr, m, n = x.shape
    t = lookahead_times(lookahead_s, step_s)
    trans = modes.transition
    xs = np.empty((n_tr, t.size, m, n))
    ps = np.empty((n_tr, t.size, m, n, n))
    mus = np.empty((n_tr, t.size, m))
    xs[:, 0], ps[:, 0], mus[:, 0] = x, p, mu
    for k in range(1, t.size):
        cbar, x0, p0 = interact(mu, x, p, trans)  # eqs 11-13; cbar is also mu(k+1) of eq 20
        x, p, _ = mode_matched_predict(modes.models, step_s, x0, p0)  # eqs 18-19
        mu = cbar  # eq 20
        xs[:, k], ps[:, k], mus[:, k] = x, p, mu
    xc, pc = combine(xs, ps, mus)
    return Prediction(t, xc, pc, xs, ps, mus)


def model_predict(x, p, model: MotionModel, lookahead_s: float = 60.0, step_s: float = 1.0) -> Prediction:
    """Single-model prediction (the CV-only or CA-only curves of Baek & Bang Fig. 7): x (N, n), p (N, n, n)."""
    x = np.asarray(x, float)
    p = np.asarray(p, float)
    return imm_predict(x[:, None], p[:, None], np.ones((x.shape[0], 1)), ModeSet((model,), np.ones((1, 1))),
                       lookahead_s, step_s)


# --- the pipeline's CV prediction in closed form ---------------------------------------------------------


def cv_relative_prediction(rel_x, rel_p, t_s, step_s: float, sigma_h_mps2: float, sigma_v_mps2: float):
    """Relative state [e, n, z, ve, vn, vz] (N, 6), covariance (N, 6, 6), propagated by the CV model of the
    tracks (piecewise-constant white acceleration per step, Bar-Shalom sec. 6.3.3; sigma the relative
    acceleration noise, intruder and ownship combined) to the times t_s = k step_s, in closed form:

        m(t) = m_pos + t m_vel
        P_pos(t) = P_pp + t (P_pv + P_vp) + t^2 P_vv + sigma^2 step^4 (k^3/3 - k/12) I

    (the last term is sum_{i<k} F^i Q F^iT for Q = sigma^2 [[h^4/4, h^3/2], [h^3/2, h^2]]).
    t_s: (K,) times common to every pair, or (N, K) per pair (e.g. one time each: the same numbers as the
    common grid's at those times). Returns mean_xy (N, K, 2), cov_xy (N, K, 2, 2), mean_z (N, K), var_z (N, K)."""
    rel_x = np.asarray(rel_x, float)
    rel_p = np.asarray(rel_p, float)
    t = np.asarray(t_s, float)
    k = np.rint(t / step_s)
    qpos = step_s**4 * (k**3 / 3.0 - k / 12.0)  # per unit sigma^2
    tb = t if t.ndim == 2 else t[None, :]  # (N or 1, K)
    mean = rel_x[:, None, 0:3] + tb[:, :, None] * rel_x[:, None, 3:6]
    pp, pv, vv = rel_p[:, 0:3, 0:3], rel_p[:, 0:3, 3:6], rel_p[:, 3:6, 3:6]
    cross = pv + np.swapaxes(pv, 1, 2)
    cov = pp[:, None] + tb[:, :, None, None] * cross[:, None] + (tb * tb)[:, :, None, None] * vv[:, None]
    cov_xy = cov[:, :, 0:2, 0:2].copy()
    cov_xy[:, :, 0, 0] += sigma_h_mps2**2 * qpos
    cov_xy[:, :, 1, 1] += sigma_h_mps2**2 * qpos
    var_z = cov[:, :, 2, 2] + sigma_v_mps2**2 * qpos
    return mean[:, :, 0:2], cov_xy, mean[:, :, 2], var_z


# --- Paielli & Erzberger error growth (Hwang Sec. 4) ------------------------------------------------------


def pe_track_covariance(t_s, velocity_xy, p_pos0, along_rate_mps: float = PE_ALONG_RATE_MPS,
                        cross_rate_per_speed: float = PE_CROSS_RATE_PER_SPEED,
                        cross_max_m: float = PE_CROSS_MAX_M) -> np.ndarray:
    """Prediction-error covariance of one aircraft at times t_s ((K,) or per pair (N, K)): (N, K, 2, 2), east-north.

    sigma_along(t) = sigma_along(0) + along_rate t                     (15 kn)
    sigma_cross(t) = min(sigma_cross(0) + |v|/57 t, max(1 nm, sigma_cross(0)))
    Q(t) = R_rot diag(sigma_along^2, sigma_cross^2) R_rot^T            (Hwang eq 22)

    sigma_along(0), sigma_cross(0): the current estimate's position error (p_pos0 (N, 2, 2)) along and across
    the track. A stationary aircraft has no track: both axes grow at the along-track rate (a speed
    uncertainty in any direction)."""
    v = np.atleast_2d(np.asarray(velocity_xy, float))
    p0 = np.asarray(p_pos0, float).reshape(-1, 2, 2)
    t = np.asarray(t_s, float)
    n = max(v.shape[0], p0.shape[0], t.shape[0] if t.ndim == 2 else 1)
    v, p0 = np.broadcast_to(v, (n, 2)), np.broadcast_to(p0, (n, 2, 2))
    t = np.broadcast_to(t if t.ndim == 2 else t[None, :], (n, t.shape[-1]))  # (N, K): common or per-pair times
    speed = np.hypot(v[:, 0], v[:, 1])
    moving = speed > 0.0
    u = np.where(moving[:, None], v / np.where(moving, speed, 1.0)[:, None], np.array([1.0, 0.0]))
    nrm = np.stack([-u[:, 1], u[:, 0]], axis=-1)
    s_a0 = np.sqrt(np.maximum(np.einsum("ni,nij,nj->n", u, p0, u), 0.0))
    s_c0 = np.sqrt(np.maximum(np.einsum("ni,nij,nj->n", nrm, p0, nrm), 0.0))
    s_a = s_a0[:, None] + along_rate_mps * t
    cross_rate = np.where(moving, speed * cross_rate_per_speed, along_rate_mps)
    cap = np.where(moving, np.maximum(cross_max_m, s_c0), np.inf)
    s_c = np.minimum(s_c0[:, None] + cross_rate[:, None] * t, cap[:, None])
    return (s_a**2)[..., None, None] * np.einsum("ni,nj->nij", u, u)[:, None] + \
        (s_c**2)[..., None, None] * np.einsum("ni,nj->nij", nrm, nrm)[:, None]


def pe_pair_covariance(t_s, v_own, p_own, v_int, p_int) -> np.ndarray:
    """Hwang eq 23 with Q_sr = 0: M(t) = Q_stochastic(t) + Q_reference(t), (N, K, 2, 2)."""
    return pe_track_covariance(t_s, v_own, p_own) + pe_track_covariance(t_s, v_int, p_int)


def pe_conflict_probability(rel_pos, rel_vel, v_own, p_own, v_int, p_int, radius, lookahead_s: float = 60.0,
                            delta_s: float = 0.0, step_s: float = 1.0):
    """Hwang, Hwang & Tomlin Sec. 4 probabilistic detection for N pairs: the predicted minimum-separation time
    t_md (the CPA time clamped to [0, lookahead]), the combined covariance M(t_md) of eq 23 from the growth
    model, and Pc by eq 24 (the strip swept by the zone along the relative velocity). delta_s > 0: the maximum
    of eq 24 over [t_md - delta, t_md + delta] (step_s grid), Hwang's refinement for turning aircraft.
    Returns (pc, t_md)."""
    from avionics.conflict.probability import pc_paielli_erzberger

    rel_pos = np.atleast_2d(np.asarray(rel_pos, float))
    rel_vel = np.atleast_2d(np.asarray(rel_vel, float))
    v2 = np.einsum("ij,ij->i", rel_vel, rel_vel)
    with np.errstate(divide="ignore", invalid="ignore"):
        t_md = np.where(v2 > 0.0, -np.einsum("ij,ij->i", rel_pos, rel_vel) / np.where(v2 > 0.0, v2, 1.0), 0.0)
    t_md = np.clip(t_md, 0.0, lookahead_s)
    offsets = np.arange(-delta_s, delta_s + 0.5 * step_s, step_s) if delta_s > 0.0 else np.zeros(1)
    tt = np.clip(t_md[:, None] + offsets[None, :], 0.0, lookahead_s)  # (N, J)
    m = pe_pair_covariance(tt, v_own, p_own, v_int, p_int)  # (N, J, 2, 2)
    j = offsets.size
    pc = pc_paielli_erzberger((rel_pos[:, None, :] + tt[..., None] * rel_vel[:, None, :]).reshape(-1, 2),
                              m.reshape(-1, 2, 2), np.repeat(np.broadcast_to(np.asarray(radius, float),
                                                                             (rel_pos.shape[0],)), j),
                              np.repeat(rel_vel, j, axis=0)).reshape(-1, j)
    best = pc.max(axis=1)
    return best, t_md


# --- Pc along a prediction ---------------------------------------------------------------------------------


def pc_curve(mean_xy, cov_xy, radius, method: str = "exact", *, mean_z=None, var_z=None, half_height=None,
             weights=None, rel_vel=None, n_blocks: int = 10, samples: int = 10000, rng=None) -> np.ndarray:
    """Pc at every predicted time: mean_xy (N, K, 2), cov_xy (N, K, 2, 2) (or per mode (N, K, M, 2) and
    (N, K, M, 2, 2) with weights (N, K, M)); vertical mean_z, var_z (N, K) or (N, K, M). Returns (N, K)."""
    mean_xy = np.asarray(mean_xy, float)
    n, k = mean_xy.shape[:2]
    tail = mean_xy.shape[2:]
    flat = lambda a, extra: None if a is None else np.reshape(np.broadcast_to(np.asarray(a, float), (n, k) + extra),
                                                              (n * k,) + extra)
    mix = (tail[0],) if len(tail) == 2 else ()
    rad = np.broadcast_to(np.asarray(radius, float).reshape(-1, 1) if np.ndim(radius) else radius, (n, k)).reshape(-1)
    hh = None if half_height is None else np.broadcast_to(
        np.asarray(half_height, float).reshape(-1, 1) if np.ndim(half_height) else half_height, (n, k)).reshape(-1)
    pc = conflict_probability(
        flat(mean_xy, tail), flat(cov_xy, tail + (2,)), rad, method, weights=flat(weights, mix),
        rel_vel=flat(rel_vel, (2,)), half_height=hh, mean_z=flat(mean_z, mix), var_z=flat(var_z, mix),
        n_blocks=n_blocks, samples=samples, rng=rng)
    return pc.reshape(n, k)


def max_over_lookahead(pc, t_s):
    """(max Pc, its time) per row of pc (N, K) over times t_s (K,); the earliest time on ties; NaN rows -> NaN."""
    pc = np.asarray(pc, float)
    filled = np.where(np.isnan(pc), -1.0, pc)
    i = np.argmax(filled, axis=1)
    best = pc[np.arange(pc.shape[0]), i]
    return best, np.where(np.isnan(best), np.nan, np.asarray(t_s, float)[i])


# --- Monte Carlo over trajectories: P(conflict anywhere within the lookahead) ------------------------------


def _segment_hits(p0, p1, z0, z1, radius, half_height):
    """True where the straight segment p0 -> p1 (horizontal, (..., 2)) with z0 -> z1 passes inside the disk and
    the slab at the same instant (z0 None: horizontal only)."""
    d = p1 - p0
    a = np.einsum("...i,...i->...", d, d)
    b = np.einsum("...i,...i->...", p0, d)
    c = np.einsum("...i,...i->...", p0, p0) - radius**2
    disc = b * b - a * c
    sq = np.sqrt(np.maximum(disc, 0.0))
    with np.errstate(divide="ignore", invalid="ignore"):
        ta = np.where(a > 0.0, (-b - sq) / np.where(a > 0.0, a, 1.0), np.where(c <= 0.0, 0.0, np.inf))
        tb = np.where(a > 0.0, (-b + sq) / np.where(a > 0.0, a, 1.0), np.where(c <= 0.0, 1.0, -np.inf))
    ok = (disc >= 0.0) | (a == 0.0)
    lo, hi = np.maximum(ta, 0.0), np.minimum(tb, 1.0)
    if z0 is not None:
        dz = z1 - z0
        with np.errstate(divide="ignore", invalid="ignore"):
            safe = np.where(dz != 0.0, dz, 1.0)
            u1, u2 = (-half_height - z0) / safe, (half_height - z0) / safe
        level_in = np.abs(z0) <= half_height
        za = np.where(dz != 0.0, np.minimum(u1, u2), np.where(level_in, 0.0, np.inf))
        zb = np.where(dz != 0.0, np.maximum(u1, u2), np.where(level_in, 1.0, -np.inf))
        lo, hi = np.maximum(lo, za), np.minimum(hi, zb)
    return ok & (lo <= hi)


def _sqrt_psd(p: np.ndarray) -> np.ndarray:
    """Symmetric square roots of covariances (..., n, n), semi-definite allowed."""
    w, v = np.linalg.eigh(0.5 * (p + np.swapaxes(p, -1, -2)))
    return (v * np.sqrt(np.maximum(w, 0.0))[..., None, :]) @ np.swapaxes(v, -1, -2)


def pc_within_cv_mc(rel_x, rel_p, radius, lookahead_s: float, step_s: float, sigma_h_mps2: float,
                    sigma_v_mps2: float, half_height=None, samples: int = 1000, rng=None) -> np.ndarray:
    """`pc_within_cv_mc_reference` (the method is described there) with each step's arithmetic in the compiled
    kernel (conflict/kernels.py within_step) when the compiled kernels are ready (avionics.base.jit.ready). The random numbers
    are the reference's, drawn by numpy from the same Generator in the same order and sizes, so the result is
    the reference's, sample for sample."""
    if not jit.ready():
        return pc_within_cv_mc_reference(rel_x, rel_p, radius, lookahead_s, step_s, sigma_h_mps2, sigma_v_mps2,
                                         half_height, samples, rng)
    rng = np.random.default_rng(rng)
    rel_x = np.asarray(rel_x, float)
    n = rel_x.shape[0]
    if n == 0:
        return np.zeros(0)
    steps = int(round(lookahead_s / step_s))
    if steps == 0:  # the instant only: no steps to compile
        return pc_within_cv_mc_reference(rel_x, rel_p, radius, lookahead_s, step_s, sigma_h_mps2, sigma_v_mps2,
                                         half_height, samples, rng)
    root = _sqrt_psd(np.asarray(rel_p, float))
    x = rel_x[:, None, :] + np.einsum("nij,nsj->nsi", root, rng.standard_normal((n, samples, 6)))
    r = np.broadcast_to(np.asarray(radius, float), (n,))
    vertical = half_height is not None
    sig = np.array([sigma_h_mps2, sigma_h_mps2, sigma_v_mps2])
    h = step_s
    f32 = np.float32
    pos = np.ascontiguousarray(x[..., 0:3].reshape(n * samples, 3), dtype=f32)
    vel = np.ascontiguousarray(x[..., 3:6].reshape(n * samples, 3), dtype=f32)
    owner = np.repeat(np.arange(n, dtype=np.int64), samples)
    r = np.repeat(r, samples)
    reach0 = (r + 1.0).astype(f32)
    hh = np.repeat(np.broadcast_to(np.asarray(half_height, float), (n,)), samples) if vertical else np.zeros(r.size)
    hits = np.zeros(n)
    sig32 = sig.astype(f32)
    h32, half_h2 = f32(h), f32(0.5 * h * h)
    m = owner.size
    for k in range(steps):
        a = rng.standard_normal((m, 3), dtype=f32)
        drop = k % 4 == 3 and k + 1 < steps
        v_min = 6.0 * sig[0] * h * np.sqrt(steps - k - 1) if drop else 0.0
        m = kernels.within_step(pos, vel, a, owner, r, reach0, hh, vertical, sig32, h32, half_h2, drop, float(v_min),
                                hits, m)
        if m == 0:
            break
    return hits / samples


def pc_within_cv_mc_reference(rel_x, rel_p, radius, lookahead_s: float, step_s: float, sigma_h_mps2: float,
                              sigma_v_mps2: float, half_height=None, samples: int = 1000, rng=None) -> np.ndarray:
    """P(conflict at any time in [0, lookahead]) for the pipeline's relative CV model: N pairs of relative
    state (N, 6) [e, n, z, ve, vn, vz] and covariance (N, 6, 6); samples trajectories per pair with
    piecewise-constant white acceleration (sigma per axis) in steps of step_s; a trajectory is in conflict
    if a straight segment between consecutive steps enters the disk (and the slab, half_height (N,) or scalar,
    None or inf entries: horizontal only) at the same instant. Returns (N,) fractions."""
    rng = np.random.default_rng(rng)
    rel_x = np.asarray(rel_x, float)
    n = rel_x.shape[0]
    if n == 0:
        return np.zeros(0)
    root = _sqrt_psd(np.asarray(rel_p, float))
    x = rel_x[:, None, :] + np.einsum("nij,nsj->nsi", root, rng.standard_normal((n, samples, 6)))
    r = np.broadcast_to(np.asarray(radius, float), (n,))[:, None]
    hh = None if half_height is None else np.broadcast_to(np.asarray(half_height, float), (n,))[:, None]
    vertical = hh is not None
    sig = np.array([sigma_h_mps2, sigma_h_mps2, sigma_v_mps2])
    steps = int(round(lookahead_s / step_s))
    h = step_s
    if steps == 0:  # the instant only
        inside = np.hypot(x[..., 0], x[..., 1]) <= r
        if vertical:
            inside &= np.abs(x[..., 2]) <= hh
        return inside.mean(axis=1)
    # Flat (n * samples) arrays of the samples still undecided. A sample in conflict is counted for its pair
    # and removed; so is a sample that can no longer come back: outside the disk, receding at a radial speed
    # v_r > 6 sigma_h h sqrt(steps left). (Along any path d v_r/dt = (|v|^2 - v_r^2)/r + a.r_hat >= a.r_hat,
    # so re-entering needs sum_k a_k.u_k (u_k = the integral of r_hat over step k, |u_k| <= h) to exceed v_r:
    # a sum of zero-mean Gaussian increments of spread <= sigma_h h, which reaches 6 times its total spread
    # with probability < exp(-18) = 2e-8 (exponential martingale inequality; u_k's own dependence on a_k
    # adds a second-order term that only raises v_r): no bias at Monte Carlo precision.) Per step
    # only the samples that can reach the disk during the step (start range - step length <= R, 1 m of slack
    # for the float32 rounding) get the exact segment test, in float64. The propagation runs in float32
    # (memory-bound, so faster; float32 resolves 2 mm at 20 km).
    f32 = np.float32
    pos = np.ascontiguousarray(x[..., 0:3].reshape(n * samples, 3), dtype=f32)
    vel = np.ascontiguousarray(x[..., 3:6].reshape(n * samples, 3), dtype=f32)
    owner = np.repeat(np.arange(n), samples)
    r = np.repeat(r[:, 0], samples)
    reach0 = (r + 1.0).astype(f32)
    hh = np.repeat(hh[:, 0], samples) if vertical else None
    hits = np.zeros(n)
    sig32 = sig.astype(f32)
    h32, half_h2 = f32(h), f32(0.5 * h * h)
    for k in range(steps):
        a = rng.standard_normal((owner.size, 3), dtype=f32)
        a *= sig32
        pos1 = pos + vel * h32 + a * half_h2
        d = pos1[:, 0:2] - pos[:, 0:2]
        reach = reach0 + np.sqrt(np.einsum("ij,ij->i", d, d))
        cand = np.flatnonzero(np.einsum("ij,ij->i", pos[:, 0:2], pos[:, 0:2]) <= reach * reach)
        a *= h32
        vel += a
        done = np.zeros(owner.size, bool)
        if cand.size:
            p0, p1 = pos[cand].astype(float), pos1[cand].astype(float)
            hit = cand[_segment_hits(p0[:, 0:2], p1[:, 0:2], p0[:, 2] if vertical else None,
                                     p1[:, 2] if vertical else None, r[cand], hh[cand] if vertical else None)]
            hits += np.bincount(owner[hit], minlength=n)
            done[hit] = True
        if k % 4 == 3 and k + 1 < steps:  # every few steps: drop the samples that cannot come back
            range2 = np.einsum("ij,ij->i", pos1[:, 0:2], pos1[:, 0:2])
            radial = np.einsum("ij,ij->i", pos1[:, 0:2], vel[:, 0:2])  # v_r |r|
            v_min = 6.0 * sig[0] * h * np.sqrt(steps - k - 1)
            done |= (range2 > r * r) & (radial > v_min * np.sqrt(range2))
        if done.any():
            keep = ~done
            pos1, vel, owner, r, reach0 = pos1[keep], vel[keep], owner[keep], r[keep], reach0[keep]
            hh = hh[keep] if vertical else None
            if owner.size == 0:
                break
        pos = pos1
    return hits / samples


def pc_within_imm_mc(x_modes, p_modes, mu, modes: ModeSet, radius, lookahead_s: float = 60.0,
                     step_s: float = 1.0, pos_idx: Sequence[int] = (0, 1), samples: int = 1000, rng=None,
                     vertical=None, half_height=None) -> np.ndarray:
    """P(conflict at any time within the lookahead) over the IMM mode mixture, by Monte Carlo over trajectories
    of the jump-Markov linear system itself: initial mode ~ mu, initial state ~ N(x_j, P_j), then per step a
    mode switch by M[from, to], x <- F_mean x + w with w ~ N(0, Q) of the current mode; the states are
    *relative* (intruder minus reference: give the reference's own noise inside Q if it has any). Horizontal
    position at pos_idx. vertical: optional (x_modes, p_modes, mu, ModeSet) of a vertical [z, vz] mixture,
    sampled independently; then a conflict needs |z| <= half_height at the same time. (N,) fractions."""
    rng = np.random.default_rng(rng)
    idx = list(pos_idx)

    def sample(xm, pm, mu0, ms):
        xm, pm, mu0 = np.asarray(xm, float), np.asarray(pm, float), np.asarray(mu0, float)
        n, m, dim = xm.shape
        cdf = np.cumsum(mu0 / mu0.sum(axis=1, keepdims=True), axis=1)
        mode = np.minimum((rng.random((n, samples))[:, :, None] > cdf[:, None, :]).sum(axis=2), m - 1)
        root = _sqrt_psd(pm)  # (n, m, d, d)
        rows = np.arange(n)[:, None]
        x = xm[rows, mode] + np.einsum("nsij,nsj->nsi", root[rows, mode], rng.standard_normal((n, samples, dim)))
        return x.reshape(n * samples, dim), mode.reshape(-1)

    def advance(x, mode, ms: ModeSet):
        cum = np.cumsum(ms.transition, axis=1)
        u = rng.random(mode.shape[0])
        new_mode = np.minimum((u[:, None] > cum[mode]).sum(axis=1), len(ms.models) - 1)
        out = np.empty_like(x)
        for j, model in enumerate(ms.models):
            sel = np.flatnonzero(new_mode == j)
            if sel.size == 0:
                continue
            fm, _, q = _model_matrices(model, step_s, x[sel])
            qroot = _sqrt_psd(q[:1]) if _uniform(q) else _sqrt_psd(q)
            w = np.einsum("bij,bj->bi", np.broadcast_to(qroot, q.shape), rng.standard_normal(x[sel].shape))
            out[sel] = np.einsum("bij,bj->bi", fm, x[sel]) + w
        return out, new_mode

    xh, mh = sample(x_modes, p_modes, mu, modes)
    n = np.asarray(x_modes).shape[0]
    r = np.repeat(np.broadcast_to(np.asarray(radius, float), (n,)), samples)
    if vertical is not None:
        vx, vp, vmu, vms = vertical
        xv, mv = sample(vx, vp, vmu, vms)
        hh = np.repeat(np.broadcast_to(np.asarray(half_height, float), (n,)), samples)
    steps = int(round(lookahead_s / step_s))
    inside = np.hypot(xh[:, idx[0]], xh[:, idx[1]]) <= r
    if vertical is not None:
        inside &= np.abs(xv[:, 0]) <= hh
    hit = inside.copy()
    for _ in range(steps):
        xh1, mh = advance(xh, mh, modes)
        z0 = z1 = None
        if vertical is not None:
            xv1, mv = advance(xv, mv, vms)
            z0, z1 = xv[:, 0], xv1[:, 0]
        hit |= _segment_hits(xh[:, idx], xh1[:, idx], z0, z1, r, hh if vertical is not None else None)
        xh = xh1
        if vertical is not None:
            xv = xv1
    return hit.reshape(n, samples).mean(axis=1)


def _uniform(q: np.ndarray) -> bool:
    return q.shape[0] == 1 or bool(np.all(q == q[:1]))


def relative_modes(x_modes, p_modes, ref_x, ref_p=None):
    """Per-mode relative estimates (intruder mode states minus a reference state in the same layout), with the
    reference covariance added (independent estimates, Baek & Bang eq 23)."""
    x_modes = np.asarray(x_modes, float)
    rel = x_modes - np.asarray(ref_x, float)[:, None, :]
    p = np.asarray(p_modes, float)
    if ref_p is not None:
        p = p + np.asarray(ref_p, float)[:, None, :, :]
    return rel, p


__all__ = [
    "ModeSet", "Prediction", "lookahead_times", "combine", "imm_predict", "model_predict",
    "cv_relative_prediction", "pe_track_covariance", "pe_pair_covariance", "pe_conflict_probability", "pc_curve",
    "max_over_lookahead", "pc_within_cv_mc", "pc_within_imm_mc", "relative_modes", "vertical_probability",
    "PE_ALONG_RATE_MPS", "PE_CROSS_RATE_PER_SPEED", "PE_CROSS_MAX_M",
]
