"""Alert criteria and the alert gate: which alerter candidates become advisories.

criterion (advisory.criterion), objects behind `Criterion` (built in avionics/compose.py, `build_gate`):
  tcas      `TcasCriterion`: the deterministic TCAS II tests alone
  tcas+pc   `TcasPcCriterion`: the TCAS test and the conflict probability of the level's protected volume above
            a threshold
  pc        `PcCriterion`: the probability alone, within the level's tau horizon (t_cpa <= tau, closing)
The volumes: TA = disk of TA DMOD x slab of TA ZTHR; RA = disk of the RA HMD (RA DMOD where a profile has no
HMD) x slab of ALIM: Pc is the probability that the miss at CPA falls inside (conflict.pc_at_cpa, with the
conflict stage's prediction noise conflict.accel_sigma_h_mps2 / accel_sigma_v_mps2).

persistence (advisory.persistence): advisory/persistence.py.

`AlertGate` = a criterion and a persistence.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol

import numpy as np

from avionics.advisory.persistence import NoPersistence, Persistence
from avionics.advisory.tables import SensitivityLevel
from avionics.conflict.cpa import PairGeometry
from avionics.base.types import AdvisoryLevel

TA, RA, NONE = int(AdvisoryLevel.TA), int(AdvisoryLevel.RA), int(AdvisoryLevel.NONE)


class Criterion(Protocol):
    """admit(candidates, pc_ta, pc_ra, g, level, has_alt, ra_allowed) -> (N,) int candidate levels."""

    def admit(self, candidates: np.ndarray, pc_ta: np.ndarray, pc_ra: np.ndarray, g: PairGeometry,
              level: SensitivityLevel, has_alt: np.ndarray, ra_allowed: bool) -> np.ndarray: ...


class TcasCriterion:
    """advisory.criterion = "tcas": the alerter's candidates as they are."""

    def admit(self, candidates, pc_ta, pc_ra, g, level, has_alt, ra_allowed) -> np.ndarray:
        return candidates


@dataclass(frozen=True, slots=True)
class TcasPcCriterion:
    """advisory.criterion = "tcas+pc": an RA needs the TCAS RA and Pc(RA volume) >= pc_ra_threshold; a TA the TCAS
    TA (or RA) and Pc(TA volume) >= pc_ta_threshold."""

    pc_ta_threshold: float
    pc_ra_threshold: float

    def admit(self, candidates, pc_ta, pc_ra, g, level, has_alt, ra_allowed) -> np.ndarray:
        ra = (candidates == RA) & (pc_ra >= self.pc_ra_threshold)
        ta = (candidates >= TA) & (pc_ta >= self.pc_ta_threshold)
        return np.where(ra, RA, np.where(ta | ra, TA, NONE))


@dataclass(frozen=True, slots=True)
class PcCriterion:
    """advisory.criterion = "pc": closing with the CPA within the level's TA (RA) tau and Pc of the TA (RA)
    volume above its threshold; an RA also needs the intruder's altitude and an RA allowed at this level."""

    pc_ta_threshold: float
    pc_ra_threshold: float

    def admit(self, candidates, pc_ta, pc_ra, g, level, has_alt, ra_allowed) -> np.ndarray:
        closing = g.s_dot_v < 0.0
        ta = closing & (g.t_cpa_s <= level.ta_tau_s) & (pc_ta >= self.pc_ta_threshold)
        ra = np.zeros_like(ta)
        if ra_allowed and level.ra_tau_s is not None:
            ra = closing & has_alt & (g.t_cpa_s <= level.ra_tau_s) & (pc_ra >= self.pc_ra_threshold)
        return np.where(ra, RA, np.where(ta | ra, TA, NONE))


class AlertGate:
    """The criterion, then (per new report) the persistence filter."""

    def __init__(self, criterion: Criterion | None = None, persistence: Persistence | None = None):
        self.criterion = criterion if criterion is not None else TcasCriterion()
        self.persistence = persistence if persistence is not None else NoPersistence()

    def forget(self, key) -> None:
        self.persistence.forget(key)

    def admit(self, candidates, pc_ta, pc_ra, g, level, has_alt, ra_allowed) -> np.ndarray:
        return self.criterion.admit(candidates, pc_ta, pc_ra, g, level, has_alt, ra_allowed)

    def persist(self, keys, candidates, pc_ta, pc_ra, updated) -> np.ndarray:
        return self.persistence.persist(keys, candidates, pc_ta, pc_ra, updated)
