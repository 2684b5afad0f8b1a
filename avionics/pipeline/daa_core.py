"""The functional core: step(now, inputs) -> StepResult, with no I/O, clocks or sockets inside.

One step, in order (each job a module of this package):
intake.py (validated inputs into the ownship filter and the tracker, in the tracking frame) -> schedule.py (which
intruders are due: those a report updated, and a slice of the re-assessment pass) -> assessment.py (prediction,
geometry, detection, Pc) -> advice.py (sensitivity level's TA/RA logic, RAs, each intruder's advisory) ->
records.py (the advisory state and latest advisories) -> bands_traffic.py (a DO-365 alerter's guidance bands,
once a second). containment.py is the fault boundary around each stage; views.py what the shell reads.

The live runner and fast-time replay both drive this object, so what was evaluated is what flies.
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Sequence, Set as AbstractSet
from dataclasses import dataclass, replace
from typing import Iterable

from avionics.compose import Components, build_components
from avionics.config import Config
from avionics.base.types import LOST, Advisory, AdvisoryLevel, Input, IntruderKey
from avionics.pipeline import views
from avionics.pipeline.advice import Adviser
from avionics.pipeline.assessment import Assessor
from avionics.pipeline.bands_traffic import BandsTraffic
from avionics.pipeline.containment import FAULT, Containment
from avionics.pipeline.intake import Intake
from avionics.pipeline.records import AdvisoryRecords, advisory_of, with_level
from avionics.pipeline.schedule import KEY_ORDER, AssessmentSchedule
from avionics.tracking.interface import Tracker
from avionics.tracking.ownship import OwnshipState


@dataclass(frozen=True, slots=True)
class StepResult:
    time_s: float
    changes: list[Advisory]  # advisories whose level, RA sense or RA strength changed in this step
    assessed: Sequence[Advisory]  # the advisory of every intruder assessed in this step (built when read)
    bands: object | None = None  # advisory/bands.py Bands: a DO-365 alerter's guidance, once a second


class DaaCore:
    def __init__(self, config: Config, counters: Counter | None = None, components: Components | None = None):
        """components: the parts (compose.py); by default built from config by the composition root."""
        self.config = config
        self.counters = counters if counters is not None else Counter()
        parts = components if components is not None else build_components(config, self.counters)
        self.profile = parts.profile
        self.levels = parts.levels
        self.inhibits = parts.inhibits
        self.gate = parts.gate  # advisory.criterion and advisory.persistence
        self.hysteresis = parts.hysteresis
        self.conflict = parts.conflict  # conflict.prefilter and conflict.method
        self.tracker: Tracker = parts.tracker  # tracking.filter: cv or an IMM
        self.records = AdvisoryRecords()  # the advisory state and latest advisory of every assessed intruder
        self.containment = Containment(self.counters, self.records, self._drop_track)  # the fault boundaries
        self.intake = Intake(config, self.counters, self.tracker, self.containment)  # inputs into the filters
        self.schedule = AssessmentSchedule(config.advisory, self.counters)  # which intruders each step assesses
        self.assessor = Assessor(config, parts, self.tracker, self.intake, self.containment)  # the numbers
        self.adviser = Adviser(config, parts, self.records, self.containment)  # the advisory logic
        # a DO-365 alerter's guidance bands (advisory/bands.py; parts.bands None: none) and their traffic
        self.bands_traffic = BandsTraffic(parts.bands, self.adviser.alert_names, self.schedule, self.containment)
        self._last_ownship: OwnshipState | None = None

    # -- the parts the shell reads (daa.py) -----------------------------------------------------------------
    @property
    def ownship(self):
        """The ownship filter (tracking/ownship.py): a new one after the old one failed."""
        return self.intake.ownship

    @property
    def frame(self):
        """The tracking frame (base/frame.py), kept at the ownship."""
        return self.intake.frame

    @property
    def level(self):
        """The sensitivity level of the last assessment (advisory/tables.py SensitivityLevel); None: none."""
        return self.records.level

    @property
    def active(self) -> dict[IntruderKey, Advisory]:
        """The latest advisory of every intruder at TA or RA."""
        return self.records.active

    @property
    def faults(self):
        """Intruders in the failed state (containment.py Fault), their tracks dropped."""
        return self.containment.faults

    @property
    def step_fault(self):
        """The last step failed outside the per-intruder boundaries (containment.py Fault); None: it did not."""
        return self.containment.step_fault

    # -- step ------------------------------------------------------------------------------------------------
    def step(self, now_s: float, inputs: Iterable[Input] = ()) -> StepResult:
        changes, self.containment.pending = self.containment.pending, []
        try:
            return self._step(now_s, inputs, changes)
        except Exception as exc:  # noqa: BLE001  (the step's boundary: the process goes on, the next step retries)
            self.containment.step_failed(
                now_s, exc, lambda: self.records.end(now_s, sorted(self.records.latest), FAULT, changes))
            return StepResult(now_s, changes, views.Assessed([]))

    def _step(self, now_s: float, inputs: Iterable[Input], changes: list[Advisory]) -> StepResult:
        dirty = self.intake.take(now_s, inputs, changes)
        tick = self.schedule.tick(now_s)
        if tick:
            for key in self.tracker.prune(now_s):
                gone = self.records.latest.get(key)
                if gone is not None and self.records.states.level_of(key) is not AdvisoryLevel.NONE:
                    # still alerting when deleted: a lost threat held until now (advisory/logic.py lost_hold)
                    changes.append(with_level(advisory_of(gone), now_s, AdvisoryLevel.NONE, LOST))
                self._forget(key)
            self.containment.expire(now_s, self.tracker.tracks, self.config.tracking.delete_after_s)
        periodic = self.schedule.due(now_s, tick, self.tracker.tracks)
        keys = sorted((k for k in dirty.union(periodic) if k in self.tracker.tracks), key=KEY_ORDER)
        assessed = self._assess(now_s, keys, changes, dirty, periodic) if keys else []
        if tick:  # an assessment went through again
            self.containment.step_works(now_s)
        return StepResult(now_s, changes, views.Assessed(assessed),
                          self.bands_traffic.compute(now_s, self.intake.ownship, self.records.states) if tick else None)

    def _assess(self, now_s: float, keys: list[IntruderKey], changes: list[Advisory],
                updated: AbstractSet[IntruderKey] = frozenset(),
                periodic: AbstractSet[IntruderKey] = frozenset()) -> list:
        """Assess keys (those updated by a report in this step, and this step's slice of the re-assessment pass,
        `periodic`); their latest advisories (`records.latest` entries), the changes appended to changes."""
        self._last_ownship = own = self.intake.ownship_at(now_s)
        if own is None:
            self.records.level = None  # no ownship altitude: no sensitivity level either
            return self.records.end(now_s, keys, "no_ownship", changes)
        agl = self.agl_m(own)
        sl_altitude = own.pressure_altitude_m if own.pressure_altitude_m is not None else float(own.x[2])
        self.records.level = level = self.levels.select(agl, sl_altitude)
        inhibits = self.inhibits.update(agl)
        ra_allowed = self.config.advisory.ra_enabled and not inhibits.ra
        # Stage boundaries (containment.py): an intruder that fails a stage is out of `keys` from there on
        # (prediction, conflict) or failed in the advisory logic (whose arrays keep every row).
        keys, xs, ps = self.assessor.predicted(now_s, keys, changes)
        ev = self.assessor.evaluated(now_s, keys, xs, ps, own, level, ra_allowed, periodic, changes) if keys else None
        if ev is None:
            return []
        self.bands_traffic.record(now_s, ev, own.x[2])
        self.counters["assessment.datum_mismatch"] += int(ev.mismatch.sum())
        out = self.adviser.advise(now_s, ev, level, ra_allowed, inhibits, own, agl, updated, changes)
        if self.containment.faults:
            self.containment.recovered(now_s, ev.keys)
        return out

    def agl_m(self, own: OwnshipState) -> float | None:
        """Ownship's height above ground: MSL minus advisory.ground_elevation_m when that is configured, else the
        height above home (GLOBAL_POSITION_INT relative_alt); None when neither is known."""
        ground = self.config.advisory.ground_elevation_m
        return float(own.x[2]) - ground if ground is not None else own.height_above_home_m

    def _drop_track(self, key: IntruderKey) -> None:
        """Forget an intruder in every stage: its next report starts a new track."""
        self.tracker.drop(key)
        self._forget(key)

    def _forget(self, key: IntruderKey) -> None:
        """Forget an intruder's assessments in every stage after tracking (its track is gone)."""
        self.intake.forget(key)
        self.gate.forget(key)
        self.hysteresis.forget(key)
        self.conflict.forget(key)
        self.records.forget(key)
        self.bands_traffic.forget(key)

    # -- views for the shell (daa.py) ------------------------------------------------------------------------
    def predict_tracks(self, keys: list[IntruderKey], now_s: float):
        """Contained prediction for the shell (track publication): (keys that went through, xs, ps). An intruder
        that fails here fails as in step(); its failed-state advisory comes with the next step's changes."""
        return self.assessor.predicted(now_s, keys, self.containment.pending)

    def ra_threatened_if(self, now_s: float, moves) -> bool:
        """Whether some tracked intruder's geometry would raise an RA were ownship moved by any of `moves`, each
        (dz_m, vz_mps): dz_m higher than now and flying at vz_mps vertically (Assessor.ra_threatened); the tracks
        are predicted once for all of them. The guidance's check that a return to the mission's altitude is clear
        of conflict. False without an ownship or a sensitivity level."""
        own, level = self.intake.ownship_at(now_s), self.records.level
        if own is None or level is None:
            return False
        keys, xs, ps = self.predict_tracks(list(self.tracker.tracks), now_s)
        for dz_m, vz_mps in moves:
            x = own.x.copy()
            x[2] += dz_m
            x[5] = vz_mps
            pressure = own.pressure_altitude_m + dz_m if own.pressure_altitude_m is not None else None
            moved = replace(own, x=x, pressure_altitude_m=pressure, height_above_home_m=own.height_above_home_m + dz_m)
            if self.assessor.ra_threatened(now_s, keys, xs, ps, moved, level):
                return True
        return False

    def end_all(self, now_s: float, reason: str) -> list[Advisory]:
        """End every active advisory now with reason (e.g. "shutdown"); the ended ones, for announcing."""
        changes: list[Advisory] = []
        self.records.end(now_s, sorted(self.records.latest), reason, changes)
        return changes

    def advisory(self, key: IntruderKey) -> Advisory | None:
        """An intruder's latest advisory; None: never assessed."""
        return views.advisory(self.records, key)

    def advisory_reader(self, key: IntruderKey):
        """(level, its latest advisory built when called, its ASSESSMENT_FIELDS): for the track views."""
        return views.advisory_reader(self.records, key)

    def datum_mismatch_keys(self) -> list[IntruderKey]:
        """The intruders whose latest assessment compared altitudes across datums."""
        return views.datum_mismatch_keys(self.records)

    def active_view(self):
        """A read-only copy of `active`, shared by the results until it changes."""
        return self.records.active_view()

    def ownship_state(self) -> OwnshipState | None:
        """The ownship state the last assessment used."""
        return self._last_ownship
