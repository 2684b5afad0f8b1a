"""The per-intruder advisory state (TA hold, RA ending). The threat tests themselves (TCAS II v7.1, DO-185B,
DAIDALUS TCAS3D) are the `tcas2` alerter's levels in advisory/alerting.py (`TCAS3D`, `TcasRaContinuation`);
the core builds its alerter in avionics/compose.py (`build_alerter`).
"""

from __future__ import annotations

from dataclasses import dataclass

from avionics.core.types import AdvisoryLevel


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
