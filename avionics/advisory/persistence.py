"""Persistence of a candidate advisory over successive assessments (advisory.persistence): which candidates the
alert gate lets through, as objects behind one Protocol (built in avionics/compose.py, `build_gate`).

Counted over the assessments that follow a new report of the intruder (the 10 Hz re-assessments between reports
carry no new evidence):
  none      `NoPersistence`: every candidate counts at once
  m-of-n    `MOfNPersistence`: at least m of the last n assessments had the candidate level (or higher)
  binomial  `BinomialPersistence`: Radosavljevic et al. eqs 19-24. Each assessment is a Bernoulli trial, in
            conflict with probability pi (eq 19); l conflicts among n assessments have probability
            pi^l (1 - pi)^(n-l) per ordering (eq 20), and the number of conflicts is binomial (eqs 21-22):
                pdf(l; n) = n! / (l! (n - l)!) pi^l (1 - pi)^(n - l)        (eq 22; mean n pi eq 23,
                                                                              variance n pi (1 - pi) eq 24)
            With pi the mean per-assessment Pc over the last n (of the level's volume: pc_ta, pc_ra), the level
            is let through when P(at least m of n in conflict) = sum_{k=m}^{n} pdf(k; n) >= confidence.

A candidate never exceeds what the filter last allowed; dropping an alert is never delayed.
"""

from __future__ import annotations

import math
from collections import deque
from typing import Protocol

import numpy as np

from avionics.core.types import AdvisoryLevel

TA, RA, NONE = int(AdvisoryLevel.TA), int(AdvisoryLevel.RA), int(AdvisoryLevel.NONE)


def binomial_pmf(k: int, n: int, p: float) -> float:
    """Radosavljevic eq 22: C(n, k) p^k (1 - p)^(n - k)."""
    return math.comb(n, k) * p**k * (1.0 - p) ** (n - k)


def at_least_m_of_n(p: float, m: int, n: int) -> float:
    """Binomial tail: P(at least m successes in n independent trials of probability p), eq 22 summed."""
    return sum(binomial_pmf(k, n, p) for k in range(m, n + 1))


class Persistence(Protocol):
    """persist(keys, candidates, pc_ta, pc_ra, updated) -> (N,) int levels let through; `updated`: the keys with
    a new report in this assessment (only those count). forget(key) when the intruder goes."""

    def persist(self, keys, candidates: np.ndarray, pc_ta: np.ndarray, pc_ra: np.ndarray, updated) -> np.ndarray: ...

    def forget(self, key) -> None: ...


class NoPersistence:
    """advisory.persistence = "none"."""

    def persist(self, keys, candidates, pc_ta, pc_ra, updated) -> np.ndarray:
        return candidates

    def forget(self, key) -> None:
        pass


class _WindowPersistence:
    """The last n (candidate level, pc_ta, pc_ra) per intruder, after each new report, and the verdict on them."""

    def __init__(self, m: int, n: int):
        if not 1 <= m <= n:
            raise ValueError(f"persistence: need 1 <= m <= n, got m={m}, n={n}")
        self.m, self.n = m, n
        self._history: dict = {}  # key -> deque of (candidate level, pc_ta, pc_ra) per new report
        self._verdict: dict = {}  # key -> level the filter lets through

    def forget(self, key) -> None:
        self._history.pop(key, None)
        self._verdict.pop(key, None)

    def persist(self, keys, candidates, pc_ta, pc_ra, updated) -> np.ndarray:
        out = candidates.copy()
        for i, key in enumerate(keys):
            if key in updated:
                history = self._history.setdefault(key, deque(maxlen=self.n))
                history.append((int(candidates[i]), float(pc_ta[i]), float(pc_ra[i])))
                self._verdict[key] = self._judge(history)
            out[i] = min(int(candidates[i]), self._verdict.get(key, NONE))
        return out

    def _judge(self, history) -> int:
        raise NotImplementedError


class MOfNPersistence(_WindowPersistence):
    """advisory.persistence = "m-of-n": a level when at least m of the last n assessments had it (or higher)."""

    def _judge(self, history) -> int:
        for lvl in (RA, TA):
            if sum(c >= lvl for c, _, _ in history) >= self.m:
                return lvl
        return NONE


class BinomialPersistence(_WindowPersistence):
    """advisory.persistence = "binomial" (Radosavljevic eqs 19-24): a level when P(at least m of n in conflict),
    with pi the mean Pc of the level's volume over the last n, reaches `confidence`."""

    def __init__(self, m: int, n: int, confidence: float):
        super().__init__(m, n)
        if not 0.0 <= confidence <= 1.0:
            raise ValueError(f"persistence: confidence {confidence} is not a probability")
        self.confidence = confidence

    def _judge(self, history) -> int:
        for lvl, column in ((RA, 2), (TA, 1)):
            p = sum(h[column] for h in history) / len(history)
            if at_least_m_of_n(p, self.m, self.n) >= self.confidence:
                return lvl
        return NONE
