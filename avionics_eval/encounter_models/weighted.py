"""Weighted estimates of a probability from importance-weighted encounters, with the effective-sample-size
Wilson interval: p = sum(w x) / sum(w), n_eff = (sum w)^2 / sum(w^2) (Kish's effective sample size), and the
Wilson score interval of p at n_eff trials (Wilson 1927). With all weights equal it is the ordinary Wilson
interval; with uneven weights it widens as n_eff falls. `events` is how many encounters the estimate rests on."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.stats import norm


@dataclass(frozen=True)
class WeightedProportion:
    estimate: float
    low: float
    high: float
    effective_n: float
    events: int  # encounters with x true (unweighted count): the NMACs behind a P(NMAC), for instance


def weighted_proportion(x: np.ndarray, weights: np.ndarray, confidence: float = 0.95) -> WeightedProportion:
    x = np.asarray(x, dtype=bool)
    w = np.asarray(weights, dtype=float)
    if x.shape != w.shape or w.size == 0 or (w < 0).any() or not np.isfinite(w).all() or w.sum() <= 0:
        raise ValueError("weights must be finite, >= 0, not all 0, one per encounter")
    total = w.sum()
    p = float(w[x].sum() / total)
    n_eff = float(total ** 2 / (w ** 2).sum())
    z = float(norm.ppf(0.5 + confidence / 2))
    denom = 1 + z * z / n_eff
    centre = (p + z * z / (2 * n_eff)) / denom
    half = z * math.sqrt(p * (1 - p) / n_eff + z * z / (4 * n_eff * n_eff)) / denom
    return WeightedProportion(p, max(0.0, centre - half), min(1.0, centre + half), n_eff, int(x.sum()))
