"""Persistence of conflict over successive assessments: Radosavljevic et al.'s binomial model and M-of-N.

Radosavljevic et al. (eqs 19-24): each assessment is a Bernoulli trial, conflict C with probability pi(k)
(eq 19); l conflicts among n assessments have probability pi^l (1 - pi)^(n-l) per ordering (eq 20), and the
number of conflicts is binomial (eqs 21-22):

    pdf(l; n) = n! / (l! (n - l)!) pi^l (1 - pi)^(n - l)        (eq 22, with the l! the paper's typesetting lost)
    mean n pi (eq 23),  variance n pi (1 - pi) (eq 24)

As an alert filter: alert when P(at least l of the last n assessments were in conflict) >= a confidence. With
one pi for all n trials (the paper's model) that probability is a function of pi alone; with each
assessment's own Pc (pi_1..pi_n, independent trials) the count is Poisson-binomial, computed exactly by the
O(n^2) convolution recursion - the binomial is its special case pi_i = pi. The plain M-of-N filter counts
assessments whose Pc reached a threshold.

All functions are vectorised over pairs; `PersistenceFilter` keeps the last n values per pair key.
"""

from __future__ import annotations

from collections import deque

import numpy as np
from scipy import stats

MODELS = ("poisson_binomial", "binomial", "m_of_n")


def binomial_pmf(l, n, p) -> np.ndarray:
    """Eq 22: C(n, l) p^l (1 - p)^(n - l)."""
    return stats.binom.pmf(l, n, p)


def binomial_at_least(l, n, p) -> np.ndarray:
    """P(at least l conflicts in n trials of probability p) = sum_{j >= l} eq 22 (1 for l <= 0, 0 for l > n)."""
    l = np.asarray(l)
    return np.where(l <= 0, 1.0, stats.binom.sf(l - 1, n, p))


def binomial_mean_var(n, p):
    """Eqs 23-24: (n p, n p (1 - p))."""
    n, p = np.asarray(n, float), np.asarray(p, float)
    return n * p, n * p * (1.0 - p)


def count_distribution(probs) -> np.ndarray:
    """Distribution of the number of conflicts among independent trials with probabilities probs (..., n):
    (..., n + 1), entry j = P(exactly j). Poisson-binomial by the convolution recursion."""
    probs = np.asarray(probs, float)
    n = probs.shape[-1]
    dist = np.zeros(probs.shape[:-1] + (n + 1,))
    dist[..., 0] = 1.0
    for i in range(n):
        p = probs[..., i, None]
        shifted = np.zeros_like(dist)
        shifted[..., 1:] = dist[..., :-1]
        dist = dist * (1.0 - p) + shifted * p
    return dist


def poisson_binomial_at_least(l: int, probs) -> np.ndarray:
    """P(at least l of the trials with probabilities probs (..., n) were conflicts)."""
    dist = count_distribution(probs)
    if l <= 0:
        return np.ones(dist.shape[:-1])
    return dist[..., l:].sum(axis=-1)


def m_of_n(flags, m: int) -> np.ndarray:
    """True where at least m of the flags (..., n) are set."""
    return np.asarray(flags, bool).sum(axis=-1) >= m


class PersistenceFilter:
    """Alert filter over the last n assessments of each pair.

    model 'poisson_binomial': alert when P(at least l of the last n were conflicts) >= confidence, with each
        assessment's own Pc (missing history counts as Pc = 0).
    model 'binomial': the same with one pi for all n trials, the mean Pc over the last n (Radosavljevic's
        binomial with pi estimated from the window).
    model 'm_of_n': alert when at least l of the last n had Pc >= pc_threshold.

    update(keys, pc) appends one assessment per key and returns (alert (N,) bool, score (N,)), the score being
    P(at least l of n) (or the count / n for m_of_n)."""

    def __init__(self, model: str = "poisson_binomial", l: int = 3, n: int = 5, confidence: float = 0.5,
                 pc_threshold: float = 0.5):
        if model not in MODELS:
            raise ValueError(f"model must be one of {MODELS}, got {model!r}")
        if not 1 <= l <= n:
            raise ValueError("need 1 <= l <= n")
        if not 0.0 <= confidence <= 1.0 or not 0.0 <= pc_threshold <= 1.0:
            raise ValueError("confidence and pc_threshold are probabilities")
        self.model, self.l, self.n = model, l, n
        self.confidence, self.pc_threshold = confidence, pc_threshold
        self._hist: dict = {}

    def forget(self, key) -> None:
        self._hist.pop(key, None)

    def window(self, keys) -> np.ndarray:
        """(N, n) last n Pc values per key, oldest first, zero-padded."""
        out = np.zeros((len(keys), self.n))
        for i, k in enumerate(keys):
            h = self._hist.get(k, ())
            if h:
                out[i, self.n - len(h):] = h
        return out

    def update(self, keys, pc) -> tuple[np.ndarray, np.ndarray]:
        pc = np.clip(np.asarray(pc, float), 0.0, 1.0)
        for k, p in zip(keys, pc):
            self._hist.setdefault(k, deque(maxlen=self.n)).append(float(p))
        w = self.window(keys)
        if self.model == "m_of_n":
            count = (w >= self.pc_threshold).sum(axis=1)
            return count >= self.l, count / self.n
        if self.model == "binomial":
            score = binomial_at_least(self.l, self.n, w.mean(axis=1))
        else:
            score = poisson_binomial_at_least(self.l, w)
        return score >= self.confidence, score

