"""Parameters of the conflict stage: [conflict] (avionics/conflict/assess.py, docs/conflict.md). docs/configuration.md
and config/default.toml document them."""

from __future__ import annotations

from dataclasses import dataclass

from avionics.base.params import ConfigError, require_positive

CONFLICT_METHODS = ("exact", "one_block", "blocks", "pe", "mc")
PREFILTERS = ("min_distance", "hwang", "none")


@dataclass(frozen=True)
class ConflictConfig:
    """Conflict prediction and probability (avionics/conflict/assess.py, docs/conflict.md)."""

    method: str = "exact"  # exact | one_block | blocks | pe | mc
    n_blocks: int = 10  # blocks: number of blocks (Baek & Bang eq 29)
    zone_radius_m: float = 1219.2  # conflict disk radius R: 4000 ft (DO-365 well clear, HMD*)
    zone_half_height_m: float = 137.16  # conflict slab half-height H: 450 ft (DO-365 h*)
    lookahead_s: float = 60.0  # prediction horizon
    step_s: float = 1.0  # prediction step
    accel_sigma_h_mps2: float = 2.0  # relative white acceleration (intruder and ownship) of the prediction
    accel_sigma_v_mps2: float = 1.0
    mc_samples: int = 10000  # method mc: samples per pair and time
    within_samples: int = 500  # trajectories per pair for P(conflict within lookahead); 0: not computed
    # At most this many pairs' within-probabilities per second (token bucket, stalest first): the Monte Carlo
    # costs ~2 ms per pair, and its cost must stay bounded however much traffic converges at once.
    within_max_pairs_per_s: float = 50.0
    # ... and at most this many in one call (the bucket's size): one step never runs more than a few ms of it
    within_burst_pairs: int = 1
    seed: int = 0  # Monte Carlo seed (reproducible runs)
    prefilter: str = "min_distance"  # min_distance | hwang | none (Hwang condition 2)
    prefilter_alpha: float = 1.5  # test safety distance alpha R (Hwang: 1.5)
    schedule_period_s: float = 1.0  # Hwang tau: every pair at least this often
    schedule_fast_period_s: float = 0.2  # Hwang tau_c: pairs with Pc >= schedule_threshold this often
    schedule_threshold: float = 0.1  # Hwang P-bar

    def validate(self) -> None:
        c = self
        if c.method not in CONFLICT_METHODS:
            raise ConfigError(f"conflict.method: {c.method!r} is not one of {', '.join(CONFLICT_METHODS)}")
        if c.prefilter not in PREFILTERS:
            raise ConfigError(f"conflict.prefilter: {c.prefilter!r} is not min_distance, hwang or none")
        require_positive("conflict", c, ("zone_radius_m", "zone_half_height_m", "step_s", "schedule_period_s",
                                         "schedule_fast_period_s"))
        if c.lookahead_s < 0 or abs(c.lookahead_s / c.step_s - round(c.lookahead_s / c.step_s)) > 1e-9:
            raise ConfigError("conflict.lookahead_s: must be a non-negative multiple of conflict.step_s")
        if c.lookahead_s / c.step_s > 3600:
            raise ConfigError("conflict.lookahead_s / step_s: at most 3600 steps")
        if c.accel_sigma_h_mps2 < 0 or c.accel_sigma_v_mps2 < 0:
            raise ConfigError("conflict.accel_sigma_*: must be >= 0")
        if not 1 <= c.n_blocks <= 1000:
            raise ConfigError("conflict.n_blocks: need 1 <= n_blocks <= 1000")
        if c.mc_samples < 1 or c.within_samples < 0:
            raise ConfigError("conflict.mc_samples must be >= 1 and conflict.within_samples >= 0")
        if not c.within_max_pairs_per_s > 0:
            raise ConfigError("conflict.within_max_pairs_per_s must be > 0")
        if not isinstance(c.within_burst_pairs, int) or c.within_burst_pairs < 1:
            raise ConfigError("conflict.within_burst_pairs must be a whole number >= 1")
        if c.seed < 0:  # numpy's SeedSequence takes non-negative integers only
            raise ConfigError(f"conflict.seed: {c.seed} must be a whole number >= 0")
        if c.prefilter_alpha < 1.0:
            raise ConfigError("conflict.prefilter_alpha: must be >= 1 (Hwang's alpha)")
        if c.schedule_fast_period_s > c.schedule_period_s:
            raise ConfigError("conflict.schedule_fast_period_s must be <= conflict.schedule_period_s")
        if not 0.0 <= c.schedule_threshold <= 1.0:
            raise ConfigError("conflict.schedule_threshold: must be a probability in [0, 1]")
