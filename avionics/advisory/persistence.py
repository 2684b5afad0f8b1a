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

from avionics.base.types import AdvisoryLevel

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
        for lvl in range(max(c for c, _, _ in history), NONE, -1):
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


# --- the alerting hysteresis of a DO-365 alerter (DAIDALUS) ---------------------------------------------------


class MofN:
    """DAIDALUS MofN (gov.nasa.larcfm.ACCoRD, v2.0.4): the highest value at least m of the last n values reached (a
    value counts for every value below it); -1 when none did. A new filter holds m copies of its first value
    (MofN.reset(val)), so that value passes at once. Used by the alerting hysteresis here and the bands' (bands.py)."""

    __slots__ = ("m", "n", "max", "queue")

    def __init__(self, m: int, n: int, val: int):
        self.m, self.n, self.max = m, n, val
        self.queue = [val if i < m else -1 for i in range(n)]

    def copy(self) -> "MofN":
        c = MofN.__new__(MofN)
        c.m, c.n, c.max, c.queue = self.m, self.n, self.max, list(self.queue)
        return c

    def apply(self, value: int) -> int:
        """MofN.m_of_n: take value in, return the filtered value."""
        if not (self.queue and 0 < self.m <= self.n):
            return value
        self.max = max(self.max, value)
        self.queue.pop(0)
        self.queue.append(value)
        return next((lvl for lvl in range(self.max, -1, -1) if sum(q >= lvl for q in self.queue) >= self.m), -1)

    def same_as(self, other: "MofN") -> bool:
        """MofN.sameAs, as the bands' hysteresis uses it: the same values in the window."""
        return self.queue == other.queue


class _HysteresisData:
    """One intruder's DAIDALUS HysteresisData (v2.0.4): its MofN over the last n raw alert levels, persistence (an
    alert does not drop within persistence_time_s of its last rise), and a reset when an evaluation comes more
    than hysteresis_time_s after the previous one (or not after it)."""

    __slots__ = ("mofn", "init_s", "last_s", "last")

    def __init__(self):
        self.mofn: MofN | None = None
        self.init_s, self.last_s, self.last = math.nan, math.nan, -1

    def apply(self, raw: int, now_s: float, hysteresis_s: float, persistence_s: float, m: int, n: int) -> int:
        if math.isnan(self.last_s) or now_s <= self.last_s or now_s - self.last_s > hysteresis_s:
            self.mofn = MofN(m, n, raw)  # HysteresisData.reset -> MofN.reset(raw)
            self.init_s, self.last_s, self.last = math.nan, math.nan, -1
        mofn = self.mofn.apply(raw)
        if not math.isnan(self.init_s) and self.last > 0 and mofn < self.last and \
                self.init_s <= now_s < self.init_s + persistence_s:
            pass  # persistence: the previous alert stays
        else:
            if mofn > 0 and mofn > self.last:
                self.init_s = now_s
            self.last = max(0, mofn)
        self.last_s = now_s
        return self.last


class AlertingHysteresis:
    """The alerting hysteresis of a DO-365 alerter (advisory/tables.py WcvAlerterSpec; DAIDALUS
    DaidalusCore.alerting_hysteresis_current_value): per intruder, once in each period_s of the clock (the first
    assessment in it), the raw alert level through `_HysteresisData`; between evaluations the level stays. DAIDALUS counts its M of N in evaluations and its
    published runs evaluate once a second; the core assesses at advisory.assessment_hz and on every report, so
    the filter samples the raw level at period_s (1 s) to keep the standard's timing."""

    def __init__(self, hysteresis_time_s: float, persistence_time_s: float, m: int, n: int, period_s: float = 1.0):
        if not 1 <= m <= n:
            raise ValueError(f"alerting hysteresis: need 1 <= m <= n, got m={m}, n={n}")
        self.hysteresis_s, self.persistence_s, self.m, self.n = hysteresis_time_s, persistence_time_s, m, n
        self.period_s = period_s
        self._data: dict = {}  # key -> _HysteresisData

    def last(self, keys) -> np.ndarray:
        """(N,) int: each intruder's alert level so far (0 when none), for the early alerting times."""
        return np.array([max(d.last, 0) if (d := self._data.get(k)) is not None else NONE for k in keys], int)

    def apply(self, now_s: float, keys, raw: np.ndarray) -> np.ndarray:
        out = np.empty(len(keys), int)
        for i, key in enumerate(keys):
            data = self._data.get(key)
            if data is None:
                data = self._data[key] = _HysteresisData()
            due = math.isnan(data.last_s) or self._slot(now_s) > self._slot(data.last_s)
            out[i] = data.apply(int(raw[i]), now_s, self.hysteresis_s, self.persistence_s, self.m, self.n) \
                if due else data.last
        return out

    def forget(self, key) -> None:
        self._data.pop(key, None)

    def _slot(self, t_s: float) -> int:
        """The evaluation slot of a time: evaluations fall at the first assessment of each period of the clock
        (each whole second), as DAIDALUS's 1 s grid does, whatever the assessment's phase."""
        return math.floor(t_s / self.period_s + 1e-6)


class NoHysteresis:
    """The TCAS alerter's levels need none here (their holds are the levels' own: alerting.py)."""

    def last(self, keys) -> np.ndarray:
        return np.zeros(len(keys), int)

    def apply(self, now_s: float, keys, raw: np.ndarray) -> np.ndarray:
        return raw

    def forget(self, key) -> None:
        pass
