"""TCAS II v7.1 threat detection through the `tcas2` alerter (advisory/alerting.py), and the per-intruder advisory
state.

The tests themselves (DO-185B, DAIDALUS TCAS3D) live in advisory/alerting.py (`TCAS3D`, `TcasRaContinuation`);
`detect` and `ra_continues` are their one-call forms over a single sensitivity level, for simulations and tests.
The core builds its alerter in avionics/compose.py (`build_alerter`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from avionics.advisory.alerting import Encounter, TcasRaContinuation, ra_thresholds, tcas2_alerter
from avionics.advisory.tables import SensitivityLevel
from avionics.conflict.cpa import PairGeometry
from avionics.core.types import AdvisoryLevel


def detect(g: PairGeometry, level: SensitivityLevel, has_altitude: np.ndarray, vertical_margin_m: np.ndarray,
           ra_enabled: bool = True, hmd_filter: bool = True, threat_eligible: np.ndarray | bool = True) -> np.ndarray:
    """Candidate advisory level (N,) of int: NONE, TA or RA from the geometry alone (the tcas2 alerter).

    vertical_margin_m widens the vertical tests where the relative altitude crosses datums: the
    separation used is |sz| - margin (never below 0), so uncertainty never hides a threat.
    threat_eligible (N,) is False where no RA threat may be declared (the intruder's vertical rate).
    """
    encounter = Encounter(g, np.asarray(has_altitude, bool), vertical_margin_m, threat_eligible)
    return tcas2_alerter(hmd_filter).alert(encounter, level, None if ra_enabled else int(AdvisoryLevel.TA))


def ra_continues(g: PairGeometry, level: SensitivityLevel, was_ra: np.ndarray, hmd_filter: bool = True) -> np.ndarray:
    """Which current RA threats stay threats although the RA tests no longer hold: while the range still closes,
    unless the HMD filter ends it (alerting.TcasRaContinuation, without its altitude and eligibility terms, which
    the caller applies)."""
    thresholds = ra_thresholds(level)
    if thresholds is None:  # a level without RAs has no RA to continue
        return np.zeros(len(g.range_m), bool)
    known = Encounter(g, np.ones(len(g.range_m), bool))
    return TcasRaContinuation(hmd_filter)(known, thresholds, np.asarray(was_ra, bool))


@dataclass
class AdvisoryState:
    """One intruder's advisory over time: upgrades at once, a TA (or an RA ending) holds for ta_min_s."""

    level: AdvisoryLevel = AdvisoryLevel.NONE
    alert_onset_s: float | None = None  # when the current alert (TA or RA) began

    def next(self, now_s: float, candidate: AdvisoryLevel, ta_min_s: float, force: bool = False) -> bool:
        """Move to the level the candidate allows; force (stale data, no ownship) skips the TA hold.
        Returns True when the level changed."""
        previous = self.level
        if candidate >= self.level or force:
            new = candidate
        elif self.alert_onset_s is not None and now_s - self.alert_onset_s < ta_min_s:
            new = AdvisoryLevel.TA  # a TA stays at least ta_min_s; an ended RA steps down to that TA
        else:
            new = candidate
        if new is not AdvisoryLevel.NONE and previous is AdvisoryLevel.NONE:
            self.alert_onset_s = now_s
        if new is AdvisoryLevel.NONE:
            self.alert_onset_s = None
        self.level = new
        return new is not previous
