"""The advisory records: every assessed intruder's advisory state and latest advisory, and the advisories at TA or
RA. Written by the assessment (advice.py) and the fault containment; read by the views for the shell (views.py).

The advisory logic's state is held in arrays (advisory/logic.py AdvisoryStates), and an `Advisory` is built at
once only for an intruder that alerts, alerted or changed; a quiet intruder's latest entry is (`AssessmentRows`,
row), built from its step's arrays when read (`advisory_of`): both ways give the same record.
"""

from __future__ import annotations

import math
from dataclasses import replace
from types import MappingProxyType

import numpy as np

from avionics.advisory.logic import AdvisoryStates
from avionics.advisory.resolution import Threat
from avionics.advisory.tables import SensitivityLevel
from avionics.base.types import ASSESSMENT_FIELDS, Advisory, AdvisoryLevel, IntruderKey

NONE, RA = int(AdvisoryLevel.NONE), int(AdvisoryLevel.RA)


class AssessmentRows:
    """One assessment's arrays, from which the advisory of an intruder that is not alerting, and was not, is
    built only when something asks for it (issue 13, item 2): most intruders are in that state at every step, and
    building an `Advisory` costs more than assessing the intruder. An alerting or changed intruder's advisory is
    built at once (advice.py); both ways give the same record."""

    __slots__ = ("now_s", "keys", "sl", "geometry", "mod_tau", "has_alt", "datums", "mismatch", "pc_ta", "pc_ra",
                 "pc", "within_age", "integrity", "stale", "alerts", "alert_names", "own_levels")

    def __init__(self, now_s, keys, level, ev, stale, alerts, alert_names, own_levels):
        self.now_s, self.keys, self.sl = now_s, keys, level.sl
        self.geometry, self.has_alt, self.mismatch = ev.geometry, ev.has_alt, ev.mismatch
        self.mod_tau = {AdvisoryLevel.TA: ev.geometry.mod_tau(level.ta_dmod_m)}  # the RA's added when one is
        self.datums = [t.datum for t in ev.tracks]  # a track's datum and integrity may change after this step
        self.integrity = [t.integrity.label for t in ev.tracks]
        self.pc_ta, self.pc_ra = ev.pc_ta, ev.pc_ra if level.ra_tau_s is not None else None
        self.pc, self.within_age = ev.pc, ev.within_age
        self.stale, self.alerts, self.alert_names, self.own_levels = stale, alerts, alert_names, own_levels

    def assessment(self, i: int, level: AdvisoryLevel = AdvisoryLevel.NONE) -> tuple:
        """Row i's ASSESSMENT_FIELDS at level, in order: what `advisory` puts in the record, and what the 2 Hz
        `traffic` publication reads for every track without building one."""
        g, has_alt, pc = self.geometry, self.has_alt[i], self.pc
        return (float(g.range_m[i]), float(g.t_cpa_s[i]), float(g.hmd_m[i]), float(g.vmd_m[i]) if has_alt else None,
                float(g.range_tau_s[i]), float(self.mod_tau.get(level, self.mod_tau[AdvisoryLevel.TA])[i]),
                float(self.pc_ta[i]), float(self.pc_ra[i]) if self.pc_ra is not None else None,
                float(pc["pc_now"][i]), float(pc["pc_max"][i]), float(pc["t_pc_max_s"][i]),
                _finite_or_none(pc["pc_within"][i]), _finite_or_none(self.within_age[i]))

    def advisory(self, i: int, level: AdvisoryLevel = AdvisoryLevel.NONE, reason: str | None = None,
                 ra: dict | None = None) -> Advisory:
        """Row i's advisory at level; reason None: that of an intruder at NONE (stale, diverging or clear)."""
        g, has_alt, alert = self.geometry, self.has_alt[i], int(self.alerts[i])
        if reason is None:
            reason = "stale" if self.stale[i] else "diverging" if g.s_dot_v[i] > 0.0 else "clear"
        return Advisory(
            intruder=self.keys[i], level=level, time_s=self.now_s, reason=reason, sensitivity_level=self.sl,
            closure_rate_mps=float(g.closure_rate_mps[i]),
            vertical_tau_s=float(g.vertical_tau_s[i]) if has_alt else math.inf,
            altitude_datum=self.datums[i] if has_alt else None, datum_mismatch=bool(self.mismatch[i]),
            integrity=self.integrity[i],
            **dict(zip(ASSESSMENT_FIELDS, self.assessment(i, level))),
            **(dict(alert_level=alert, alert_name=self.alert_names[alert]) if self.own_levels else {}),
            **(ra or {}),
        )


Entry = Advisory | tuple[AssessmentRows, int]  # an intruder's latest advisory: built, or (rows, row) to build it


def advisory_of(entry: Entry) -> Advisory:
    """An intruder's latest advisory: built already, or (rows, i) of an `AssessmentRows` to build it from."""
    return entry if type(entry) is Advisory else entry[0].advisory(entry[1])


def blank_advisory(key: IntruderKey, now_s: float, reason: str, sensitivity_level: int) -> Advisory:
    """The advisory of an intruder never assessed: level NONE, geometry unknown (NaN; null on zenoh)."""
    nan = math.nan
    return Advisory(intruder=key, level=AdvisoryLevel.NONE, time_s=now_s, reason=reason,
                    sensitivity_level=sensitivity_level, range_m=nan, closure_rate_mps=nan, t_cpa_s=nan, hmd_m=nan,
                    vmd_m=None, range_tau_s=math.inf, mod_tau_s=math.inf, vertical_tau_s=math.inf,
                    altitude_datum=None, datum_mismatch=False)


def _finite_or_none(value: float) -> float | None:
    return float(value) if math.isfinite(value) else None


def with_level(advisory: Advisory, now_s: float, level: AdvisoryLevel, reason: str) -> Advisory:
    """The advisory moved to level (NONE: ended) without an RA; a DO-365 alert level ends with it."""
    ended = level is AdvisoryLevel.NONE and advisory.alert_level is not None
    return replace(advisory, level=level, time_s=now_s, reason=reason, ra_sense=None, ra_strength=None,
                   ra_words=None, target_vertical_rate_mps=None, ra_reversed=False, ra_crossing=False,
                   ra_separation_m=None, ra_composite=False, **(dict(alert_level=NONE, alert_name="NONE") if ended else {}))


class AdvisoryRecords:
    """What the advisory logic remembers of every assessed intruder between steps, and its latest advisory."""

    def __init__(self):
        self.states = AdvisoryStates()  # every assessed intruder's advisory state, in arrays (advisory/logic.py)
        self.ra_threats: dict[IntruderKey, Threat] = {}  # the intruders at RA, for the resolution's one manoeuvre
        self.latest: dict[IntruderKey, Entry] = {}  # its latest advisory, or the rows to build it from
        self.active: dict[IntruderKey, Advisory] = {}  # the latest advisory of every intruder at TA or RA
        self._active_view: MappingProxyType | None = None  # a read-only copy of it, made again after a change
        self.level: SensitivityLevel | None = None  # the sensitivity level of the last assessment

    def remember(self, key: IntruderKey, advisory: Advisory) -> None:
        self.latest[key] = advisory
        if advisory.level is AdvisoryLevel.NONE:
            if self.active.pop(key, None) is not None:
                self._active_view = None
        else:
            self.active[key] = advisory
            self._active_view = None

    def active_view(self) -> MappingProxyType:
        """A read-only copy of `active`, shared by the results until it changes (a step's results are not
        copied for every step when nothing changed)."""
        if self._active_view is None:
            self._active_view = MappingProxyType(dict(self.active))
        return self._active_view

    def end(self, now_s: float, keys: list[IntruderKey], reason: str, changes: list[Advisory]) -> list:
        """End the advisories of keys with the reason (no ownship, a failed step, shutdown): those that change
        are appended to changes. The latest advisories of keys (`latest` entries)."""
        for key in keys:
            self.ra_threats.pop(key, None)
        keys = [k for k in keys if k in self.latest]
        ended = self.states.end(self.states.rows(keys))
        for i in np.flatnonzero(ended):
            key = keys[i]
            advisory = with_level(advisory_of(self.latest[key]), now_s, AdvisoryLevel.NONE, reason)
            self.remember(key, advisory)
            changes.append(advisory)
        return [self.latest[k] for k in keys]

    def forget(self, key: IntruderKey) -> None:
        """Forget an intruder (its track is gone)."""
        self.ra_threats.pop(key, None)
        self.states.forget(key)
        self.latest.pop(key, None)
        if self.active.pop(key, None) is not None:
            self._active_view = None
