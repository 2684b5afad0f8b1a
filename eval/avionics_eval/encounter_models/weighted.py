"""Weighted estimates of a probability from importance-weighted encounters, with an effective-sample-size
Wilson interval.

p = sum(w x) / sum(w) (the self-normalised importance-sampling estimate). Its variance is estimated by the
delta method, var = sum(w^2 (x - p)^2) / (sum w)^2 (Owen, *Monte Carlo theory, methods and examples*, 2013,
section 9.2, self-normalised importance sampling), and the interval is the Wilson score interval (Wilson 1927)
of p at the effective sample size of this estimate, n_p = p (1 - p) / var: the number of unweighted trials
that would give p the same variance. With all weights equal n_p = n and it is the ordinary Wilson interval.
Where var is 0 (no event, or every encounter an event) n_p is Kish's effective sample size of the weights,
(sum w)^2 / sum(w^2) (Kish, *Survey Sampling*, 1965), which for 0 events gives the Wilson analogue of the rule
of three, z^2 / (n + z^2). Kish's n_eff alone ignores how the weights go with x: the pairing oversamples small
misses, so NMAC encounters carry small weights and Kish's n_eff would overstate an NMAC probability's variance
many times over (docs/evaluation.md). `events` is how many encounters the estimate rests on."""

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
    effective_n: float  # Kish's, of the weights
    events: int  # encounters with x true (unweighted count): the NMACs behind a P(NMAC), for instance
    interval_n: float = math.nan  # the effective sample size the interval uses (n_p, or Kish's when var is 0)


def wilson_interval(p: float, n: float, z: float) -> tuple[float, float]:
    """The Wilson score interval of a proportion p observed in n (here effective, not whole) trials."""
    denom = 1 + z * z / n
    centre = (p + z * z / (2 * n)) / denom
    half = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / denom
    # p = 0 (or 1) is a bound exactly: centre - half is 0 only up to rounding
    return (0.0 if p <= 0.0 else max(0.0, centre - half)), (1.0 if p >= 1.0 else min(1.0, centre + half))


def weighted_proportion(x: np.ndarray, weights: np.ndarray, confidence: float = 0.95) -> WeightedProportion:
    x = np.asarray(x, dtype=bool)
    w = np.asarray(weights, dtype=float)
    if x.shape != w.shape or w.size == 0 or (w < 0).any() or not np.isfinite(w).all() or w.sum() <= 0:
        raise ValueError("weights must be finite, >= 0, not all 0, one per encounter")
    total = w.sum()
    p = float(w[x].sum() / total)
    n_eff = float(total ** 2 / (w ** 2).sum())
    var = float((w * w * (x - p) ** 2).sum() / (total * total))
    n_p = p * (1 - p) / var if var > 0 and 0 < p < 1 else n_eff
    z = float(norm.ppf(0.5 + confidence / 2))
    low, high = wilson_interval(p, n_p, z)
    return WeightedProportion(p, low, high, n_eff, int(x.sum()), n_p)


NMAC_HORIZONTAL_FT = 500.0  # NMAC: within 500 ft horizontally and 100 ft vertically (DO-365; the tool's README)
NMAC_VERTICAL_FT = 100.0


def nmac(own, intruder) -> np.ndarray:
    """Per encounter: whether the two 1 Hz tracks (Tracks) are ever within the NMAC cylinder at a sample."""
    horizontal = np.hypot(intruder.north_ft - own.north_ft, intruder.east_ft - own.east_ft)
    vertical = np.abs(intruder.alt_ft - own.alt_ft)
    return ((horizontal < NMAC_HORIZONTAL_FT) & (vertical < NMAC_VERTICAL_FT)).any(axis=1)


BOOTSTRAP_BLOCK = 100  # resamples drawn at once


@dataclass(frozen=True)
class WeightedRatio:
    estimate: float
    low: float
    high: float
    numerator_events: int    # encounters behind the numerator (NMACs with DAA, for a risk ratio)
    denominator_events: int  # and behind the denominator (NMACs without)


def weighted_ratio(numerator: np.ndarray, denominator: np.ndarray, weights: np.ndarray, rng: np.random.Generator,
                   resamples: int = 2000, confidence: float = 0.95) -> WeightedRatio:
    """sum(w a) / sum(w b) (a risk ratio: a = NMAC with DAA, b = NMAC without) and its weighted-bootstrap
    percentile interval: encounters resampled with replacement, each keeping its weight (Efron & Tibshirani,
    An Introduction to the Bootstrap, 1993, ch. 13), so a pair (a, b) of one encounter stays together. Where the
    bootstrap cannot move (see below) the interval is the effective-sample-size Wilson one of the share of the
    denominator's weight in the numerator. NaN when no encounter has b."""
    a, b = np.asarray(numerator, bool), np.asarray(denominator, bool)
    w = np.asarray(weights, float)
    if not (a.shape == b.shape == w.shape) or (w < 0).any() or not np.isfinite(w).all():
        raise ValueError("numerator, denominator and weights must be one finite weight >= 0 per encounter")
    den = float(w[b].sum())
    estimate = float(w[a].sum()) / den if den > 0 else float("nan")
    n = w.size
    num_b, den_b = np.zeros(resamples), np.zeros(resamples)
    for start in range(0, resamples, BOOTSTRAP_BLOCK):  # blocks: memory of BOOTSTRAP_BLOCK x n counts at a time
        k = min(BOOTSTRAP_BLOCK, resamples - start)
        counts = rng.multinomial(n, np.full(n, 1.0 / n), size=k) if n else np.zeros((k, 0))
        num_b[start:start + k], den_b[start:start + k] = counts @ (w * a), counts @ (w * b)
    ratios = np.divide(num_b, den_b, out=np.full(resamples, np.nan), where=den_b > 0)
    ratios = ratios[np.isfinite(ratios)]
    tail = (1 - confidence) / 2
    low, high = (np.quantile(ratios, [tail, 1 - tail]) if ratios.size else (float("nan"), float("nan")))
    if den > 0 and high - low <= 1e-12 * max(1.0, abs(estimate)):
        # Every resample gives the same ratio: no numerator event, or the numerator's encounters are exactly the
        # denominator's. The percentile interval collapses to a point; the share of the denominator's weight
        # that is also numerator (0 or 1 here) is a weighted proportion among the denominator's encounters,
        # whose effective-sample-size Wilson interval does not (0 events of n_eff: upper z^2 / (n_eff + z^2),
        # the Wilson analogue of the rule of three), plus the numerator's weight outside the denominator's.
        share = weighted_proportion(a[b], w[b], confidence)
        outside = float(w[a & ~b].sum()) / den
        low, high = share.low + outside, share.high + outside
    return WeightedRatio(estimate, float(low), float(high), int(a.sum()), int(b.sum()))
