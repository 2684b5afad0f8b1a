"""When to compute conflict probabilities: Hwang, Hwang & Tomlin's conditions for conflict-detection computation.

Condition 1 (rate):
  (a) every pair is assessed every tau seconds;
  (b) a pair whose aircraft changed flight mode since its last assessment is assessed at once;
  (c) a pair with Pc >= P-bar is assessed every tau_c < tau seconds.
Condition 2 (pair pre-filter):
  (a) the geometric cases: CASE I, the aircraft fly towards each other,
        (r_ij . v_i >= 0) and (r_ij . v_j <= 0) and sign(r_ij x v_i) != sign(r_ji x v_j);
      CASE II, one follows the other and is faster,
        (r_ij . v_i >= 0 and r_ij . v_j >= 0 and |v_i| > |v_j|) or (r_ij . v_i <= 0 and r_ij . v_j <= 0 and
        |v_i| < |v_j|)
      (the paper prints 'and' between the two alternatives of CASE II, which would leave it empty; 'or' is
      meant). r_ij is the vector from aircraft i to aircraft j.
  (b) the conflict probability is computed only when (a) holds and the predicted minimum distance within the
      look-ahead time is below the test safety distance alpha R (alpha >= 1; Hwang: 1.5).

Condition 2(a) is written for en-route ATC, where pairs on parallel or collinear opposite tracks are kept
apart by procedure: as printed it rejects an exact head-on (both cross products 0, so the signs are equal)
and any opposite-direction pair offset sideways. A DAA must not do that, so the default pre-filter
('min_distance') is condition 2(b) alone (the predicted minimum distance within the lookahead, optionally
widened by the position uncertainty, and optionally the vertical one); 'hwang' applies 2(a) and 2(b) as
printed. Everything is vectorised over pairs; the scheduler keeps per-pair times, modes and Pc in a dict.

The pre-filter (conflict.prefilter) is an object behind `Prefilter`, built in avionics/compose.py
(`build_prefilter`): `MinDistancePrefilter` ("min_distance"), `HwangPrefilter` ("hwang"), `NoPrefilter` ("none").
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol

import numpy as np

from avionics.base import jit
from avionics.conflict.prediction import cv_relative_prediction
from avionics.conflict.probability import as_c

kernels = jit.lazy(__name__, "avionics.conflict.kernels")  # the module, once jit.load() ran (jit.py)

TIME_EPSILON_S = 1e-6


def _cross(a, b):
    return a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]


def hwang_geometric_filter(r_ij, v_i, v_j) -> np.ndarray:
    """Hwang condition 2(a) as printed (CASE I or CASE II), for N pairs: r_ij (N, 2) from i to j, velocities
    v_i, v_j (N, 2)."""
    r_ij, v_i, v_j = (np.atleast_2d(np.asarray(a, float)) for a in (r_ij, v_i, v_j))
    a = np.einsum("ij,ij->i", r_ij, v_i)
    b = np.einsum("ij,ij->i", r_ij, v_j)
    case1 = (a >= 0.0) & (b <= 0.0) & (np.sign(_cross(r_ij, v_i)) != np.sign(_cross(-r_ij, v_j)))
    si, sj = np.hypot(v_i[:, 0], v_i[:, 1]), np.hypot(v_j[:, 0], v_j[:, 1])
    case2 = ((a >= 0.0) & (b >= 0.0) & (si > sj)) | ((a <= 0.0) & (b <= 0.0) & (si < sj))
    return case1 | case2


def predicted_min_distance(rel_pos, rel_vel, lookahead_s: float) -> np.ndarray:
    """Minimum of |s + v t| over t in [0, lookahead] (straight lines)."""
    s, v = np.atleast_2d(np.asarray(rel_pos, float)), np.atleast_2d(np.asarray(rel_vel, float))
    v2 = np.einsum("ij,ij->i", v, v)
    with np.errstate(divide="ignore", invalid="ignore"):
        t = np.where(v2 > 0.0, -np.einsum("ij,ij->i", s, v) / np.where(v2 > 0.0, v2, 1.0), 0.0)
    t = np.clip(t, 0.0, lookahead_s)
    m = s + v * t[:, None]
    return np.hypot(m[:, 0], m[:, 1])


def predicted_min_vertical(sz, vz, lookahead_s: float) -> np.ndarray:
    """Minimum of |sz + vz t| over t in [0, lookahead]."""
    sz, vz = np.atleast_1d(np.asarray(sz, float)), np.atleast_1d(np.asarray(vz, float))
    end = sz + vz * lookahead_s
    crosses = np.sign(sz) != np.sign(end)
    return np.where(crosses, 0.0, np.minimum(np.abs(sz), np.abs(end)))


def min_distance_filter(rel_pos, rel_vel, radius, lookahead_s: float, alpha: float = 1.5, extra_m=0.0,
                        sz=None, vz=None, half_height=None, alpha_z: float | None = None) -> np.ndarray:
    """Hwang condition 2(b): predicted minimum distance within the lookahead < alpha R + extra_m (extra_m (N,):
    e.g. a few sigma of the position uncertainty, so that an uncertain pair is not skipped). With sz, vz and
    half_height also the minimum vertical separation < alpha_z H (alpha_z defaults to alpha); NaN sz (unknown
    altitude) passes."""
    keep = predicted_min_distance(rel_pos, rel_vel, lookahead_s) < alpha * np.asarray(radius, float) + extra_m
    if sz is not None and half_height is not None:
        az = alpha if alpha_z is None else alpha_z
        mv = predicted_min_vertical(sz, vz, lookahead_s)
        keep &= np.isnan(mv) | (mv < az * np.asarray(half_height, float))
    return keep


def hwang_prefilter(r_ij, v_i, v_j, radius, lookahead_s: float, alpha: float = 1.5) -> np.ndarray:
    """Hwang conditions 2(a) and 2(b) as printed (r_ij from i to j; relative motion of j seen from i)."""
    r_ij, v_i, v_j = (np.atleast_2d(np.asarray(a, float)) for a in (r_ij, v_i, v_j))
    return hwang_geometric_filter(r_ij, v_i, v_j) & min_distance_filter(r_ij, v_j - v_i, radius, lookahead_s, alpha)


class Prefilter(Protocol):
    """keep(rel_x (N, 6), rel_p (N, 6, 6), has_alt (N,), z_margin_m (N,), own_vel (N, 2) or (2,) or None) -> (N,)
    bool: the pairs whose conflict probabilities are worth computing (the others get 0)."""

    def keep(self, rel_x, rel_p, has_alt, z_margin_m, own_vel=None) -> np.ndarray: ...


class NoPrefilter:
    """conflict.prefilter = "none": every pair is computed."""

    def keep(self, rel_x, rel_p, has_alt, z_margin_m, own_vel=None) -> np.ndarray:
        return np.ones(np.asarray(rel_x).shape[0], bool)


@dataclass(frozen=True, slots=True)
class MinDistancePrefilter:
    """conflict.prefilter = "min_distance": Hwang condition 2(b) alone, widened by 3 sigma of the predicted
    position at the horizon (CV prediction with the conflict stage's relative white acceleration): the predicted
    minimum distance within the lookahead < alpha R + 3 sigma, and where the altitude is known the minimum
    vertical separation < alpha (H + datum margin) + 3 sigma_z."""

    zone_radius_m: float
    zone_half_height_m: float
    lookahead_s: float
    step_s: float
    alpha: float
    accel_sigma_h_mps2: float
    accel_sigma_v_mps2: float

    def keep(self, rel_x, rel_p, has_alt, z_margin_m, own_vel=None) -> np.ndarray:
        """The compiled kernel (conflict/kernels.py min_distance_keep_pairs) when the kernels are ready, else
        keep_reference."""
        if not jit.ready():
            return self.keep_reference(rel_x, rel_p, has_alt, z_margin_m)
        n = np.shape(rel_x)[0]
        return kernels.min_distance_keep_pairs(
            as_c(rel_x), as_c(rel_p), as_c(has_alt, bool), as_c(np.broadcast_to(z_margin_m, (n,))),
            float(self.zone_radius_m), float(self.zone_half_height_m), float(self.lookahead_s), float(self.step_s),
            float(self.alpha), float(self.accel_sigma_h_mps2), float(self.accel_sigma_v_mps2))

    def keep_reference(self, rel_x, rel_p, has_alt, z_margin_m, own_vel=None) -> np.ndarray:
        t_end = np.array([self.lookahead_s])
        _, cov_xy, _, var_z = cv_relative_prediction(rel_x, rel_p, t_end, self.step_s, self.accel_sigma_h_mps2,
                                                     self.accel_sigma_v_mps2)
        extra = 3.0 * np.sqrt(np.trace(cov_xy[:, 0], axis1=1, axis2=2))  # 3 sigma (upper bound) at the horizon
        keep = min_distance_filter(rel_x[:, 0:2], rel_x[:, 3:5], self.zone_radius_m, self.lookahead_s, self.alpha,
                                   extra)
        zmax = self.alpha * (self.zone_half_height_m + z_margin_m) + 3.0 * np.sqrt(var_z[:, 0])
        return keep & (~has_alt | (predicted_min_vertical(rel_x[:, 2], rel_x[:, 5], self.lookahead_s) < zmax))


@dataclass(frozen=True, slots=True)
class HwangPrefilter(MinDistancePrefilter):
    """conflict.prefilter = "hwang": condition 2(a) as printed (needs the ownship horizontal velocity: intruder
    velocity = own + relative) and the min_distance test."""

    def keep(self, rel_x, rel_p, has_alt, z_margin_m, own_vel=None) -> np.ndarray:
        if own_vel is None:
            raise ValueError("the hwang pre-filter needs own_vel")
        keep = MinDistancePrefilter.keep(self, rel_x, rel_p, has_alt, z_margin_m)
        v_own = np.broadcast_to(np.asarray(own_vel, float), (rel_x.shape[0], 2))
        return keep & hwang_geometric_filter(rel_x[:, 0:2], v_own, v_own + rel_x[:, 3:5])


@dataclass
class _PairState:
    last_s: float
    pc: float
    mode: object


class ConflictScheduler:
    """Hwang condition 1: which pairs to (re)compute now.

    due(now, keys, modes) -> (N,) bool: never assessed; or tau elapsed (1a); or the mode token changed (1b; any
    hashable per pair, e.g. the most likely modes of both aircraft); or last Pc >= threshold and tau_c elapsed
    (1c). record(now, keys, pc, modes) after computing. The pipeline keeps the last Pc of pairs not due."""

    def __init__(self, period_s: float = 1.0, fast_period_s: float = 0.2, threshold: float = 0.1):
        if not 0.0 < fast_period_s <= period_s:
            raise ValueError("need 0 < fast_period_s <= period_s")
        self.period_s, self.fast_period_s, self.threshold = period_s, fast_period_s, threshold
        self._state: dict = {}

    def forget(self, key) -> None:
        self._state.pop(key, None)

    def last_pc(self, keys) -> np.ndarray:
        return np.array([self._state[k].pc if k in self._state else np.nan for k in keys], float)

    def due(self, now_s: float, keys, modes=None) -> np.ndarray:
        out = np.zeros(len(keys), bool)
        for i, k in enumerate(keys):
            st = self._state.get(k)
            if st is None:
                out[i] = True
                continue
            age = now_s - st.last_s + TIME_EPSILON_S
            mode_changed = modes is not None and modes[i] != st.mode
            fast = st.pc >= self.threshold and age >= self.fast_period_s
            out[i] = age >= self.period_s or mode_changed or fast
        return out

    def record(self, now_s: float, keys, pc, modes=None) -> None:
        for i, k in enumerate(keys):
            self._state[k] = _PairState(now_s, float(pc[i]), None if modes is None else modes[i])
