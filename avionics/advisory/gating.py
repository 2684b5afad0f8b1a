"""Alert criteria and persistence: which TCAS candidates become advisories.

criterion (advisory.criterion):
  tcas      the deterministic TCAS II tests alone
  tcas+pc   the TCAS test and the conflict probability of the level's protected volume above a threshold
  pc        the probability alone, within the level's tau horizon (t_cpa <= tau, closing)
The volumes: TA = disk of TA DMOD x slab of TA ZTHR; RA = disk of the RA HMD (RA DMOD where a profile has no
HMD) x slab of ALIM: Pc is the probability that the miss at CPA falls inside (conflict.pc_at_cpa).

persistence (advisory.persistence), counted over assessments that follow a new report of the intruder (the
10 Hz re-assessments between reports carry no new evidence):
  none      every candidate counts at once
  m-of-n    at least m of the last n assessments had the candidate level (or higher)
  binomial  Radosavljevic et al. eqs 19-24: with p the mean per-assessment probability over the last n,
            P(at least m of n in conflict) = sum_{k=m}^{n} C(n,k) p^k (1-p)^(n-k) >= persistence_confidence
"""

from __future__ import annotations

import math
from collections import deque

import numpy as np

from avionics.advisory.tables import SensitivityLevel
from avionics.config import AdvisoryConfig
from avionics.conflict.cpa import PairGeometry
from avionics.core.types import AdvisoryLevel

TA, RA, NONE = int(AdvisoryLevel.TA), int(AdvisoryLevel.RA), int(AdvisoryLevel.NONE)


def at_least_m_of_n(p: float, m: int, n: int) -> float:
    """Binomial tail: P(at least m successes in n independent trials of probability p)."""
    return sum(math.comb(n, k) * p**k * (1.0 - p) ** (n - k) for k in range(m, n + 1))


class AlertGate:
    def __init__(self, config: AdvisoryConfig):
        self.config = config
        self._history: dict = {}  # key -> deque of (candidate level, pc_ta, pc_ra) per new report
        self._verdict: dict = {}  # key -> level the persistence filter lets through

    def forget(self, key) -> None:
        self._history.pop(key, None)
        self._verdict.pop(key, None)

    def criterion(self, candidates: np.ndarray, pc_ta: np.ndarray, pc_ra: np.ndarray, g: PairGeometry,
                  level: SensitivityLevel, has_alt: np.ndarray, ra_allowed: bool) -> np.ndarray:
        cfg = self.config
        if cfg.criterion == "tcas":
            return candidates
        if cfg.criterion == "tcas+pc":
            ra = (candidates == RA) & (pc_ra >= cfg.pc_ra_threshold)
            ta = (candidates >= TA) & (pc_ta >= cfg.pc_ta_threshold)
        else:  # "pc"
            closing = g.s_dot_v < 0.0
            ta = closing & (g.t_cpa_s <= level.ta_tau_s) & (pc_ta >= cfg.pc_ta_threshold)
            ra = np.zeros_like(ta)
            if ra_allowed and level.ra_tau_s is not None:
                ra = closing & has_alt & (g.t_cpa_s <= level.ra_tau_s) & (pc_ra >= cfg.pc_ra_threshold)
        return np.where(ra, RA, np.where(ta | ra, TA, NONE))

    def persist(self, keys, candidates: np.ndarray, pc_ta: np.ndarray, pc_ra: np.ndarray, updated) -> np.ndarray:
        cfg = self.config
        if cfg.persistence == "none":
            return candidates
        out = candidates.copy()
        for i, key in enumerate(keys):
            if key in updated:
                history = self._history.setdefault(key, deque(maxlen=cfg.persistence_n))
                history.append((int(candidates[i]), float(pc_ta[i]), float(pc_ra[i])))
                self._verdict[key] = self._judge(history)
            # a candidate never exceeds what the filter allowed; dropping an alert is never delayed
            out[i] = min(int(candidates[i]), self._verdict.get(key, NONE))
        return out

    def _judge(self, history) -> int:
        cfg = self.config
        m, n = cfg.persistence_m, cfg.persistence_n
        if cfg.persistence == "m-of-n":
            for lvl in (RA, TA):
                if sum(c >= lvl for c, _, _ in history) >= m:
                    return lvl
            return NONE
        for lvl, column in ((RA, 2), (TA, 1)):  # binomial
            p = sum(h[column] for h in history) / len(history)
            if at_least_m_of_n(p, m, n) >= cfg.persistence_confidence:
                return lvl
        return NONE
