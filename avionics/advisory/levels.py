"""One alert level, as DAIDALUS's AlertThresholds is one (gov.nasa.larcfm.ACCoRD.AlertThresholds, v2.0.4): the type
the alerter (advisory/alerting.py Alerter) and the guidance bands (advisory/bands.py BandsEngine) both read.

A level is a detector with its thresholds, an alerting time and an early alerting time (AlertThresholds
getAlertingTime, getEarlyAlertingTime) and the bands region its conflicts paint (getRegion: NONE, FAR, MID, NEAR),
plus what this project adds: the advisory it raises (TA or RA) and the TCAS hysteresis (a minimum duration, a
continuation). A well-clear alerter's levels are read from a profile's [[alerter.levels]] tables
(advisory/tables.py): the TOML profiles (advisory/profiles/*.toml) are the only source of their numbers.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol

import numpy as np


class Detector(Protocol):
    """DAIDALUS Detection3D over N pairs (an advisory/alerting.py Encounter): `violation` (the volume is lost now)
    and `conflict` (it is lost at some time within [0, time_s]; for TCAS3D the time is the TAU of the thresholds).
    Returns (N,) bool."""

    def violation(self, encounter, thresholds) -> np.ndarray: ...

    def conflict(self, encounter, thresholds, time_s: float) -> np.ndarray: ...


class Continuation(Protocol):
    """Keeps an alert of a level on after its detector stopped firing (hysteresis): (N,) bool for the pairs that
    had the level (`had` (N,) bool) and keep it."""

    def __call__(self, encounter, thresholds, had: np.ndarray) -> np.ndarray: ...


@dataclass(frozen=True)
class AlertLevel:
    """One alert level (DAIDALUS AlertThresholds): its number (1 = least severe), name, detector, the detector's
    thresholds (see `thresholds_at`) and its hysteresis: min_duration_s (an alert of this level, once on, is held
    at least this long: the TCAS TA's 8 s) and a continuation (keeps it on after the detector stops firing: the
    TCAS RA while the range closes).

    alerting_time_s: the detector's conflict must begin within it (None: the thresholds' own, the TCAS TAU);
    early_alerting_time_s: used instead for an intruder whose alert is already this level (DAIDALUS
    DaidalusCore.check_alerting_thresholds). advisory: the advisory level it raises (AdvisoryLevel TA or RA;
    None: its own number, as the tcas2 alerter's TA and RA). region: the guidance-bands region its conflicts
    paint (DAIDALUS BandsRegion: NONE, FAR, MID, NEAR)."""

    number: int
    name: str
    detector: Detector
    thresholds: object  # a value, or a function of the sensitivity level: see thresholds_at
    min_duration_s: float = 0.0
    continuation: Continuation | None = None
    alerting_time_s: float | None = None
    early_alerting_time_s: float | None = None
    advisory: int | None = None
    region: str = "NONE"

    @property
    def advisory_level(self) -> int:
        return self.number if self.advisory is None else self.advisory

    def thresholds_at(self, level):
        """The detector's thresholds at a sensitivity level (advisory/tables.py SensitivityLevel): `thresholds`
        itself where it is a value (a well-clear level's WcvThresholds, the same at every level), else
        `thresholds(level)` (the TCAS columns of the level's row; None where the level has no such alert)."""
        return self.thresholds(level) if callable(self.thresholds) else self.thresholds

    def fires(self, encounter, level, early: np.ndarray | None = None) -> np.ndarray | None:
        """(N,) bool: the detector's conflict within the alerting time (the early one where `early`, (N,) bool);
        None without thresholds."""
        thresholds = self.thresholds_at(level)
        if thresholds is None:
            return None
        time_s = self.alerting_time_s if self.alerting_time_s is not None else thresholds.alerting_time_s
        fires = self.detector.conflict(encounter, thresholds, time_s)
        if early is not None and self.early_alerting_time_s is not None and early.any():
            fires = np.where(early, self.detector.conflict(encounter, thresholds, self.early_alerting_time_s), fires)
        return fires
