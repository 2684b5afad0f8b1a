"""The conflict-probability stage the pipeline calls: one function, N pairs in, (N,) arrays out.

    conflict_probabilities(rel_x, rel_p, config=None, *, method=ExactPc(), has_alt=None, z_margin_m=None,
                           rng=None, return_curve=False, within=None) -> dict[str, np.ndarray]

Inputs (SI units, the pipeline's state layout; intruder minus ownship, altitudes already in a common datum):
    rel_x       (N, 6)    [d_east m, d_north m, d_alt m, d_v_east m/s, d_v_north m/s, d_v_up m/s]
    rel_p       (N, 6, 6) covariance of rel_x: P_intruder + P_ownship (independent filters, Baek & Bang eq 23);
                          horizontal-vertical cross terms are ignored (no tracker here couples them)
    config      ConflictConfig (avionics/conflict/params.py, [conflict]); None: the defaults. Its `method` and
                `prefilter` names are not read here: avionics/compose.py turns them into objects
    method      the Pc method: a probability.PcMethod (ExactPc, OneBlockPc, BlocksPc, PaielliErzbergerPc,
                MonteCarloPc); compose.build_pc_method(config) gives the configured one
    has_alt     (N,) bool: False where the intruder altitude is unknown -> horizontal-only probability
    z_margin_m  (N,) m >= 0: widening of the slab half-height (the datum-mismatch margin), default 0
    rng         seed or numpy Generator for the Monte Carlo parts (default config.seed: reproducible)

Output dict, every entry (N,) float:
    pc_now          instantaneous Pc: P(|x_h| <= R and |z| <= H) now, by the method
    pc_max          maximum predicted Pc over [0, lookahead] (CV prediction, step config.step_s)
    t_pc_max_s      time of pc_max (s from now; the earliest on ties)
    pc_within       P(conflict at any time within the lookahead), Monte Carlo over config.within_samples
                    trajectories per pair (NaN when within_samples = 0, and for pairs outside the optional
                    (N,) bool mask `within`); >= pc_max up to MC noise
    pc_pe           Paielli-Erzberger / Hwang eq 24 encounter probability with the covariance predicted to
                    the CPA time (clamped to the lookahead), times the slab probability at that time; 0 for
                    pairs failing Hwang's condition 2(b) (eq 24 alone cannot tell receding from approaching)
  and with return_curve=True also t_s (K,) and pc_curve (N, K).

Prediction: the CV model of the tracks in closed form (prediction.cv_relative_prediction) with relative
white acceleration config.accel_sigma_h_mps2 / accel_sigma_v_mps2. For IMM tracks use
prediction.imm_predict and prediction.pc_curve directly with the tracker's per-mode estimates.

`ConflictAssessor` wraps the function with Hwang's conditions (scheduling.py): pairs failing the pre-filter (a
scheduling.Prefilter object) get zeros without computation ('filtered'), pairs not due keep their last values
('computed' False). The Monte Carlo pc_within, the stage's one costly output, is recomputed at most every schedule_period_s (pairs on
the fast schedule refresh their Pc now and max at the fast rate and keep pc_within between) and for at most
within_max_pairs_per_s pairs per second, the stalest first (a token bucket holding one second's worth, at most
within_burst_pairs): its cost stays bounded when many pairs converge at once, and each pair's value is then
refreshed less often; no one call runs more than within_burst_pairs of it, so that the step that makes it does
not hold a fresh report behind tens of milliseconds of Monte Carlo (issue 13: the p99 at 1 Hz fell from 54-132
ms to 7-8 ms at 100 intruders with the Monte Carlo off, docs/performance.md).
"""

from __future__ import annotations

import numpy as np

from avionics.conflict.params import ConflictConfig
from avionics.conflict.prediction import cv_relative_prediction, lookahead_times, max_over_lookahead, pc_within_cv_mc
from avionics.conflict.probability import ExactPc, PcMethod, as_c, pc_paielli_erzberger, vertical_probability
from avionics.conflict.scheduling import TIME_EPSILON_S, ConflictScheduler, Prefilter, min_distance_filter
from avionics.base import jit

kernels = jit.lazy(__name__, "avionics.conflict.kernels")  # the module, once jit.load() ran (jit.py)

KEYS = ("pc_now", "pc_max", "t_pc_max_s", "pc_within", "pc_pe")
ZONE_COLUMNS = ("pc_now", "pc_max", "t_pc_max_s", "pc_pe")  # kernels.zone_pairs' columns


def pc_along(method: PcMethod, mean_xy, cov_xy, radius_m: float, rel_vel, rng) -> np.ndarray:
    """The horizontal Pc at every predicted time: mean_xy (N, K, 2), cov_xy (N, K, 2, 2), rel_vel (N, K, 2) ->
    (N, K), every time of every pair in one call of the method."""
    n, k = mean_xy.shape[:2]
    pc = method.probability(mean_xy.reshape(n * k, 2), cov_xy.reshape(n * k, 2, 2), np.full(n * k, radius_m),
                            rel_vel=np.reshape(rel_vel, (n * k, 2)), rng=rng)
    return pc.reshape(n, k)


def conflict_probabilities(rel_x, rel_p, config: ConflictConfig | None = None, *, method: PcMethod = ExactPc(),
                           has_alt=None, z_margin_m=None, rng=None, return_curve: bool = False,
                           within=None) -> dict[str, np.ndarray]:
    cfg = config or ConflictConfig()
    rel_x = np.asarray(rel_x, float).reshape(-1, 6)
    rel_p = np.asarray(rel_p, float).reshape(-1, 6, 6)
    n = rel_x.shape[0]
    has_alt = np.ones(n, bool) if has_alt is None else np.asarray(has_alt, bool)
    margin = np.zeros(n) if z_margin_m is None else np.broadcast_to(np.asarray(z_margin_m, float), (n,))
    t = lookahead_times(cfg.lookahead_s, cfg.step_s)
    if n == 0:
        out = {k: np.zeros(0) for k in KEYS}
        if return_curve:
            out.update(t_s=t, pc_curve=np.zeros((0, t.size)))
        return out
    rng = np.random.default_rng(cfg.seed if rng is None else rng)
    half = cfg.zone_half_height_m + margin
    if isinstance(method, ExactPc) and jit.ready():
        # fused (conflict/kernels.py zone_pairs): the curve, its maximum and eq 24 behind condition 2(b), one call
        curve, cols = np.empty((n, t.size)), np.empty((n, len(ZONE_COLUMNS)))
        kernels.zone_pairs(as_c(rel_x), as_c(rel_p), as_c(t), float(cfg.step_s), float(cfg.accel_sigma_h_mps2),
                           float(cfg.accel_sigma_v_mps2), float(cfg.zone_radius_m), as_c(half), as_c(has_alt, bool),
                           float(cfg.lookahead_s), float(cfg.prefilter_alpha), curve, cols)
        out = dict(zip(ZONE_COLUMNS, cols.T))
    else:
        out = _zone_reference(rel_x, rel_p, t, cfg, method, has_alt, half, rng)
        curve = out.pop("pc_curve")

    out["pc_within"] = np.full(n, np.nan)
    within = np.ones(n, bool) if within is None else np.asarray(within, bool)
    if cfg.within_samples > 0 and within.any():
        hh = np.where(has_alt, half, np.inf)[within]
        out["pc_within"][within] = pc_within_cv_mc(rel_x[within], rel_p[within], cfg.zone_radius_m, cfg.lookahead_s,
                                                   cfg.step_s, cfg.accel_sigma_h_mps2, cfg.accel_sigma_v_mps2, hh,
                                                   cfg.within_samples, rng)
    if return_curve:
        out.update(t_s=t, pc_curve=curve)
    return out


def _zone_reference(rel_x, rel_p, t, cfg: ConflictConfig, method: PcMethod, has_alt, half, rng) -> dict:
    """The numpy reference of conflict_probabilities' numbers but pc_within (and of kernels.zone_pairs with the
    exact method): ZONE_COLUMNS and the curve "pc_curve"."""
    n = rel_x.shape[0]
    # the (clamped) CPA time of the mean, on the step grid: where Hwang's eq 24 is evaluated below
    v2 = np.einsum("ij,ij->i", rel_x[:, 3:5], rel_x[:, 3:5])
    with np.errstate(divide="ignore", invalid="ignore"):
        t_cpa = np.where(v2 > 0.0, -np.einsum("ij,ij->i", rel_x[:, 0:2], rel_x[:, 3:5]) / np.where(v2 > 0, v2, 1), 0.0)
    k = np.clip(np.rint(t_cpa / cfg.step_s), 0, t.size - 1).astype(int)
    rows = np.arange(n)
    mean_xy, cov_xy, mean_z, var_z = cv_relative_prediction(rel_x, rel_p, t, cfg.step_s, cfg.accel_sigma_h_mps2,
                                                            cfg.accel_sigma_v_mps2)
    vel = np.broadcast_to(rel_x[:, None, 3:5], mean_xy.shape)
    curve = pc_along(method, mean_xy, cov_xy, cfg.zone_radius_m, vel, rng)
    pv = vertical_probability(mean_z, var_z, half[:, None])
    curve = curve * np.where(has_alt[:, None], pv, 1.0)
    mean_k, cov_k, pv_k = mean_xy[rows, k], cov_xy[rows, k], pv[rows, k]
    pc_max, t_max = max_over_lookahead(curve, t)
    # Hwang eq 24 at the (clamped) CPA time of the mean.
    pe = pc_paielli_erzberger(mean_k, cov_k, cfg.zone_radius_m, rel_x[:, 3:5])
    # eq 24 is blind to the direction of motion (a receding pair gets the Pc of an approaching one): Hwang's
    # condition 2(b) - only pairs whose predicted minimum distance within the lookahead is below alpha R (plus
    # 3 sigma of the predicted position) - removes that.
    near = min_distance_filter(rel_x[:, 0:2], rel_x[:, 3:5], cfg.zone_radius_m, cfg.lookahead_s,
                               cfg.prefilter_alpha, 3.0 * np.sqrt(np.trace(cov_k, axis1=1, axis2=2)))
    return {"pc_now": curve[:, 0], "pc_max": pc_max, "t_pc_max_s": t_max,
            "pc_pe": np.where(near, pe * np.where(has_alt, pv_k, 1.0), 0.0), "pc_curve": curve}


class ConflictAssessor:
    """conflict_probabilities behind Hwang's conditions for conflict-detection computation.

    assess(now_s, keys, rel_x, rel_p, has_alt=None, z_margin_m=None, modes=None, own_vel=None) -> dict with the
    KEYS of conflict_probabilities plus the (N,) bool arrays 'computed' (recomputed now) and 'filtered'
    (skipped by the pre-filter: all probabilities 0). modes: per-pair hashable flight-mode token (condition
    1(b)); own_vel (N, 2) or (2,): ownship horizontal velocity, needed by the 'hwang' pre-filter only
    (intruder velocity = own + relative).

    The pre-filter and the Pc method are objects (scheduling.Prefilter, probability.PcMethod), built from the
    configuration by avionics/compose.py (`build_conflict_assessor`); `config` gives the zone, lookahead,
    prediction noise, schedule and Monte Carlo budget."""

    def __init__(self, config: ConflictConfig, prefilter: Prefilter, method: PcMethod):
        self.config = config
        self.prefilter = prefilter
        self.method = method
        c = self.config
        self.scheduler = ConflictScheduler(c.schedule_period_s, c.schedule_fast_period_s, c.schedule_threshold)
        self._cache: dict = {}
        self._within_s: dict = {}  # when each pair's pc_within was last computed
        # a second's worth at most, never more than a burst (so one step's Monte Carlo stays a few ms), at least one
        self._within_capacity = max(min(c.within_max_pairs_per_s, float(c.within_burst_pairs)), 1.0)
        self._within_tokens = self._within_capacity
        self._within_last_s: float | None = None
        self._rng = np.random.default_rng(c.seed)

    def forget(self, key) -> None:
        self.scheduler.forget(key)
        self._cache.pop(key, None)
        self._within_s.pop(key, None)

    def last(self, keys) -> dict[str, np.ndarray]:
        """The values last assessed for these pairs (0, and NaN for pc_within, where none are known)."""
        empty = {k: (np.nan if k == "pc_within" else 0.0) for k in KEYS}
        rows = [self._cache.get(key, empty) for key in keys]
        return {k: np.array([row[k] for row in rows], float) for k in KEYS}

    def within_age(self, now_s: float, keys) -> np.ndarray:
        """Seconds since each pair's pc_within Monte Carlo ran; NaN where it has not (pc_within NaN, or 0 from
        the pre-filter)."""
        return np.array([now_s - self._within_s.get(k, np.nan) for k in keys], float)

    def _within_due(self, now_s: float, keys, eligible: np.ndarray) -> np.ndarray:
        """Which of these pairs (those eligible: not pre-filtered) get a fresh pc_within now: due by
        schedule_period_s, within the token bucket, never-computed and stalest first."""
        c = self.config
        within = np.zeros(len(keys), bool)
        if c.within_samples == 0:
            return within
        if self._within_last_s is not None:
            self._within_tokens = min(self._within_capacity, self._within_tokens +
                                      (now_s - self._within_last_s) * c.within_max_pairs_per_s)
        self._within_last_s = now_s
        last = np.array([self._within_s.get(k, -np.inf) for k in keys], float)
        due = np.flatnonzero(eligible & (now_s - last + TIME_EPSILON_S >= c.schedule_period_s))
        take = due[np.argsort(last[due], kind="stable")][:int(self._within_tokens + 1e-9)]  # a whole token despite float time steps
        self._within_tokens -= take.size
        within[take] = True
        return within

    def assess(self, now_s: float, keys, rel_x, rel_p, has_alt=None, z_margin_m=None, modes=None,
               own_vel=None) -> dict[str, np.ndarray]:
        rel_x = np.asarray(rel_x, float).reshape(-1, 6)
        rel_p = np.asarray(rel_p, float).reshape(-1, 6, 6)
        n = rel_x.shape[0]
        has_alt = np.ones(n, bool) if has_alt is None else np.asarray(has_alt, bool)
        margin = np.zeros(n) if z_margin_m is None else np.broadcast_to(np.asarray(z_margin_m, float), (n,))
        keep = self.prefilter.keep(rel_x, rel_p, has_alt, margin, own_vel)
        due = self.scheduler.due(now_s, keys, modes)
        stale = np.array([k not in self._cache for k in keys], bool)
        # a pair whose pc_within is due gets its turn at any call, not only with its Pc's schedule (so that the
        # bucket's small bursts add up to the budget), and its Pc is recomputed with it
        within_all = self._within_due(now_s, keys, keep)
        compute = keep & (due | stale | within_all)
        out = {k: np.zeros(n) for k in KEYS}
        out["t_pc_max_s"][:] = 0.0
        if compute.any():
            i = np.flatnonzero(compute)
            within = within_all[i]
            res = conflict_probabilities(rel_x[i], rel_p[i], self.config, method=self.method, has_alt=has_alt[i],
                                         z_margin_m=margin[i], rng=self._rng, within=within)
            for j, idx in enumerate(i):
                if within[j]:
                    self._within_s[keys[idx]] = now_s
                else:  # not due, or over the budget: the last value (NaN until the first)
                    res["pc_within"][j] = self._cache.get(keys[idx], {}).get("pc_within", np.nan)
                self._cache[keys[idx]] = {k: float(res[k][j]) for k in KEYS}
            for k in KEYS:
                out[k][i] = res[k]
        reuse = keep & ~compute
        for idx in np.flatnonzero(reuse):
            for k, v in self._cache[keys[idx]].items():
                out[k][idx] = v
        cache = self._cache
        for idx in np.flatnonzero(~keep):  # Pc 0 now; computed at once when the pre-filter next lets it pass
            if keys[idx] in cache:  # a pair is cached, scheduled and timed together (below): else none of these
                self.forget(keys[idx])
        if compute.any():
            i = np.flatnonzero(compute)
            self.scheduler.record(now_s, [keys[j] for j in i], out["pc_max"][i],
                                  None if modes is None else [modes[j] for j in i])
        out["computed"] = compute
        out["filtered"] = ~keep
        return out
