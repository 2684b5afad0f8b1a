"""The functional core: step(now, inputs) -> StepResult, with no I/O, clocks or sockets inside.

intake (validated inputs into the ownship filter and the tracker, in the tracking frame: intake.py) -> assess
(CPA, tau, Pc) -> advise (sensitivity level, TA/RA tests, advisory state per intruder).

The live runner and fast-time replay both drive this object, so what was evaluated is what flies.
Intruders updated in a step are assessed in that step (report-to-advisory latency is one step); every
intruder is re-assessed at assessment_hz so that coasting tracks and timeouts are seen too. That re-assessment
pass is spread over the steps after each tick in slices (schedule.py), so that a fresh
report never waits behind a whole pass. The advisory state is held in arrays (advisory/logic.py), and an
`Advisory` is built at once only for an intruder that alerts, alerted or changed; the others' are built from
the step's arrays when read (records.py).

Fault containment (containment.py): each stage call is guarded, so that one intruder's bad numbers fail that
intruder alone, and an exception outside those boundaries fails the step, not the process.
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Sequence
from dataclasses import dataclass
from functools import partial
from typing import Iterable

import numpy as np

from avionics.advisory.logic import lost_hold
from avionics.advisory.resolution import Threat
from avionics.compose import Components, build_components
from avionics.config import Config
from avionics.core.types import LOST, Advisory, AdvisoryLevel, Input, IntruderKey
from avionics.pipeline.assessment import Assessor
from avionics.pipeline.bands_traffic import BandsTraffic
from avionics.pipeline.containment import FAULT, Containment
from avionics.pipeline.intake import Intake
from avionics.pipeline.records import NONE, RA, AdvisoryRecords, AssessmentRows, advisory_of, with_level
from avionics.pipeline.schedule import KEY_ORDER, AssessmentSchedule
from avionics.tracking.interface import Tracker
from avionics.tracking.ownship import OwnshipState



@dataclass(frozen=True, slots=True)
class StepResult:
    time_s: float
    changes: list[Advisory]  # advisories whose level, RA sense or RA strength changed in this step
    assessed: Sequence[Advisory]  # the advisory of every intruder assessed in this step (built when read)
    bands: object | None = None  # advisory/bands.py Bands: a DO-365 alerter's guidance, once a second


def _no_advisory() -> None:
    return None


class Assessed(Sequence):
    """The advisories of a step's assessed intruders, each built when read (records.py)."""

    __slots__ = ("_entries",)

    def __init__(self, entries: list):
        self._entries = entries

    def __len__(self) -> int:
        return len(self._entries)

    def __getitem__(self, i):
        if isinstance(i, slice):
            return [advisory_of(e) for e in self._entries[i]]
        return advisory_of(self._entries[i])


class DaaCore:
    def __init__(self, config: Config, counters: Counter | None = None, components: Components | None = None):
        """components: the parts (compose.py); by default built from config by the composition root."""
        self.config = config
        self.counters = counters if counters is not None else Counter()
        parts = components if components is not None else build_components(config, self.counters)
        self.profile = parts.profile
        self.levels = parts.levels
        self.resolution = parts.resolution
        self.inhibits = parts.inhibits
        self.alerter = parts.alerter  # TA and RA: the tcas2 alerter's levels; or a DO-365 alerter's three
        self._alert_names = self.alerter.names()
        self.hysteresis = parts.hysteresis  # a DO-365 alerter's M of N and persistence (DAIDALUS HysteresisData)
        self.gate = parts.gate  # advisory.criterion and advisory.persistence
        self.conflict = parts.conflict  # conflict.prefilter and conflict.method
        self.tracker: Tracker = parts.tracker  # tracking.filter: cv or an IMM
        self.records = AdvisoryRecords()  # the advisory state and latest advisory of every assessed intruder
        self.containment = Containment(self.counters, self.records, self._drop_track)  # the fault boundaries
        self.intake = Intake(config, self.counters, self.tracker, self.containment)  # inputs into the filters
        self._advisory_level = np.array([self.alerter.advisory_of(a) for a in range(self.alerter.most_severe + 1)])
        self.schedule = AssessmentSchedule(config.advisory, self.counters)  # which intruders each step assesses
        self.assessor = Assessor(config, parts, self.tracker, self.intake, self.containment)  # the numbers
        # a DO-365 alerter's guidance bands (advisory/bands.py; parts.bands None: none) and their traffic
        self.bands_traffic = BandsTraffic(parts.bands, self._alert_names, self.schedule, self.containment)
        self._last_ownship: OwnshipState | None = None

    @property
    def level(self):
        """The sensitivity level of the last assessment (advisory/tables.py SensitivityLevel); None: none."""
        return self.records.level

    @property
    def ownship(self):
        """The ownship filter (tracking/ownship.py): a new one after the old one failed."""
        return self.intake.ownship

    @property
    def frame(self):
        """The tracking frame (core/frame.py), kept at the ownship."""
        return self.intake.frame

    @property
    def faults(self):
        """Intruders in the failed state (containment.py Fault), their tracks dropped."""
        return self.containment.faults

    @property
    def step_fault(self):
        """The last step failed outside the per-intruder boundaries (containment.py Fault); None: it did not."""
        return self.containment.step_fault

    @property
    def active(self) -> dict[IntruderKey, Advisory]:
        """The latest advisory of every intruder at TA or RA."""
        return self.records.active

    # -- step ------------------------------------------------------------------------------------------------
    def step(self, now_s: float, inputs: Iterable[Input] = ()) -> StepResult:
        changes, self.containment.pending = self.containment.pending, []
        try:
            return self._step(now_s, inputs, changes)
        except Exception as exc:  # noqa: BLE001  (the step's boundary: the process goes on, the next step retries)
            self.containment.step_failed(
                now_s, exc, lambda: self.records.end(now_s, sorted(self.records.latest), FAULT, changes))
            return StepResult(now_s, changes, Assessed([]))

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
        return StepResult(now_s, changes, Assessed(assessed),
                          self.bands_traffic.compute(now_s, self.intake.ownship, self.records.states) if tick else None)

    def agl_m(self, own: OwnshipState) -> float | None:
        """Ownship's height above ground: MSL minus advisory.ground_elevation_m when that is configured, else the
        height above home (GLOBAL_POSITION_INT relative_alt); None when neither is known."""
        ground = self.config.advisory.ground_elevation_m
        return float(own.x[2]) - ground if ground is not None else own.height_above_home_m

    def _assess(self, now_s: float, keys: list[IntruderKey], changes: list[Advisory],
                updated: set[IntruderKey] = frozenset(), periodic: set[IntruderKey] = frozenset()) -> list:
        """Assess keys (those updated by a report in this step, and this step's slice of the re-assessment pass,
        `periodic`); their latest advisories (`_latest` entries), the changes appended to changes."""
        self._last_ownship = own = self.intake.ownship_at(now_s)
        if own is None:
            self.records.level = None  # no ownship altitude: no sensitivity level either
            return self.records.end(now_s, keys, "no_ownship", changes)
        cfg = self.config
        agl = self.agl_m(own)
        sl_altitude = own.pressure_altitude_m if own.pressure_altitude_m is not None else float(own.x[2])
        self.records.level = level = self.levels.select(agl, sl_altitude)
        inhibits = self.inhibits.update(agl)
        ra_allowed = cfg.advisory.ra_enabled and not inhibits.ra

        # Stage boundaries (module docstring): an intruder that fails a stage is out of `keys` from there on
        # (prediction, conflict) or in `failed` (the advisory logic, whose arrays keep every row).
        keys, xs, ps = self.assessor.predicted(now_s, keys, changes)
        ev = self.assessor.evaluated(now_s, keys, xs, ps, own, level, ra_allowed, periodic, changes) if keys else None
        if ev is None:
            return []
        keys, xs, geometry = ev.keys, ev.xs, ev.geometry
        self.bands_traffic.record(now_s, ev, own.x[2])
        self.counters["assessment.datum_mismatch"] += int(ev.mismatch.sum())
        failed: set[IntruderKey] = set()
        candidates, continued, stale = self._decided(now_s, keys, ev, level, ra_allowed, updated, failed, changes)
        live = np.array([i for i, k in enumerate(keys) if k not in failed], np.intp) if failed else \
            np.arange(len(keys))
        rows = self.records.states.rows([keys[i] for i in live])
        previous_level = self.records.states.level[rows].astype(int)
        previous_alert = self.records.states.alert[rows].astype(int)
        # a stale track ends its alert at once, unless it is a lost threat whose coasted track still calls for it:
        # that alert is held at its level (advisory/logic.py lost_hold), with the DMOD of that level
        ra_dmod = level.ra_dmod_m if level.ra_dmod_m is not None else level.ta_dmod_m
        dmod = np.where(previous_level == RA, ra_dmod, level.ta_dmod_m)
        held, lost = lost_hold(previous_level, stale[live], geometry.s_dot_v[live] < 0.0, geometry.range_m[live], dmod)
        alerts = np.where(stale, NONE, candidates)
        alerts[live[held]] = previous_alert[held]
        ta_hold_s = self.alerter.level(int(AdvisoryLevel.TA)).min_duration_s  # TCAS II: a TA stays 8 s
        self.records.states.next(rows, now_s, self._advisory_level[alerts[live]], ta_hold_s, force=stale[live] & ~held)
        levels = self.records.states.level[rows].astype(int)
        own_levels = self.alerter.own_levels
        self.records.states.alert[rows] = alerts[live] if own_levels else levels
        self.records.states.mismatch[rows] = ev.mismatch[live]
        ra_rows = live[levels == int(AdvisoryLevel.RA)]
        if self.records.ra_threats:  # an assessed intruder no longer at RA is no longer an RA threat
            assessed = set(keys)
            for key in [k for k in self.records.ra_threats if k in assessed and self.records.states.level_of(k) is not
                        AdvisoryLevel.RA]:
                del self.records.ra_threats[key]
        for i in ra_rows:
            self.records.ra_threats[keys[i]] = Threat(float(geometry.sz_m[i]), float(xs[i, 5]), float(geometry.t_cpa_s[i]),
                                               keys[i])
        try:
            resolution = self.resolution.resolve(now_s, list(self.records.ra_threats.values()), float(own.x[5]),
                                                 level.alim_m or 0.0, inhibits, float(own.x[2]),
                                                 self.inhibits.floors(float(own.x[2]), agl))
            blocked = self.resolution.blocked if resolution is None else ""
        except Exception as exc:  # noqa: BLE001  (one manoeuvre for every RA threat: they all fail with it)
            for key in sorted(self.records.ra_threats):
                self.containment.fail(now_s, key, "resolution", exc, changes, failed)
            resolution, blocked = None, ""
        step = AssessmentRows(now_s, keys, level, ev, stale, alerts, self._alert_names, own_levels)
        if len(ra_rows):  # modified tau at the RA's DMOD only when an intruder is at RA (the others read the TA's)
            step.mod_tau[AdvisoryLevel.RA] = geometry.mod_tau(level.ra_dmod_m)
        # an intruder alerting now or before (or with a DO-365 alert level) gets its advisory built now; the
        # others (most of them) are (step, row) until something reads them
        eager = (levels != NONE) | (previous_level != NONE)
        if own_levels:
            eager |= (alerts[live] != NONE) | (previous_alert != NONE)
        out = []
        for j, i in enumerate(live):
            key = keys[i]
            if key in failed:  # the resolution failed for its RA
                continue
            if not eager[j]:
                self.records.latest[key] = entry = (step, i)
                out.append(entry)
                continue
            try:
                advisory = self._built(step, i, key, levels[j], candidates[i], stale[i], continued[i], level,
                                       resolution, blocked, lost[j])
            except Exception as exc:  # noqa: BLE001  (stage boundary: this intruder's advisory)
                self.containment.fail(now_s, key, "advisory", exc, changes, failed)
                continue
            previous = self.records.latest.get(key)
            previous = advisory_of(previous) if previous is not None else None
            self.records.remember(key, advisory)
            if previous is None and advisory.level is not AdvisoryLevel.NONE or \
                    previous is not None and previous.ra_key() != advisory.ra_key():
                changes.append(advisory)
            out.append(advisory)
        if self.containment.faults:  # those that failed before and whose new tracks were assessed are back
            self.containment.recovered(now_s, keys)
        return out

    def _built(self, step: AssessmentRows, i, key, level_number, candidate_alert, stale, continued, level, resolution,
               blocked, lost) -> Advisory:
        """Intruder i's advisory from the step's arrays, with its level's reason and its RA. lost: a lost threat
        (held, or ending): its reason is LOST whatever else holds."""
        state = AdvisoryLevel(int(level_number))
        if blocked and state is AdvisoryLevel.RA:  # no RA would help: the threat stays a TA
            state = AdvisoryLevel.TA
            self.records.states.level[self.records.states.row(key)] = int(state)
        threat = self.records.ra_threats.get(key) if state is AdvisoryLevel.RA else None
        if lost:
            reason = LOST
        elif blocked and key in self.records.ra_threats:
            reason = blocked
        elif threat is not None and resolution.reason:
            reason = resolution.reason
        elif threat is not None and continued:
            reason = "closing"
        else:
            candidate = AdvisoryLevel(self.alerter.advisory_of(NONE if stale else int(candidate_alert)))
            dmod = level.ra_dmod_m if state is AdvisoryLevel.RA else level.ta_dmod_m
            reason = self._reason(state, candidate, stale, step.geometry.s_dot_v[i], step.geometry.range_m[i], dmod)
        return step.advisory(i, state, reason, _ra_fields(resolution, threat) if threat is not None and resolution
                             else None)

    @staticmethod
    def _reason(level: AdvisoryLevel, candidate: AdvisoryLevel, stale: bool, s_dot_v: float, range_m: float,
                dmod_m: float) -> str:
        if stale:
            return "stale"
        if level is not candidate:
            return "hold"  # TA minimum duration
        if level is AdvisoryLevel.NONE:
            return "diverging" if s_dot_v > 0.0 else "clear"
        return "range" if range_m <= dmod_m else "tau"

    def _decided(self, now_s, keys, ev, level, ra_allowed, updated, failed, changes):
        """The advisory logic's vectorised part (persistence, RA continuation, staleness) over every row; a row
        whose intruder fails here is in `failed` and its values are NONE."""
        cfg = self.config
        candidates = ev.candidates

        def run(rows):
            ks = [keys[i] for i in rows]
            cands = self.gate.persist(ks, candidates[rows], ev.pc_ta[rows], ev.pc_ra[rows], updated)
            states = self.records.states.rows(ks)  # before reading the arrays: allocating may grow them
            previous = self.records.states.level[states].astype(int)
            # the levels' continuations: RA threats kept although the RA tests no longer hold (alerting.py)
            encounter = ev.encounter if len(rows) == len(keys) else ev.encounter.take(rows)
            cands, continued = self.alerter.hold(encounter, level, previous, cands,
                                                 None if ra_allowed else self.alerter.highest_without_ra)
            cands = self.hysteresis.apply(now_s, ks, cands)
            stale = np.array([now_s - ev.tracks[i].last_report_s > cfg.tracking.max_coast_s for i in rows], bool)
            return cands, continued, stale

        # persistence keeps a history per intruder: after a failed vectorised call the lone runs are the result
        # (those intruders before the one that raised may have had this report counted twice, this once)
        rows, res = self.containment.contained("advisory", now_s, keys, changes, run,
                                    combine=lambda parts: tuple(np.concatenate(a) for a in zip(*parts)))
        n = len(keys)
        cands, continued, stale = np.zeros(n, int), np.zeros(n, bool), np.zeros(n, bool)
        if res is not None:
            cands[rows], continued[rows], stale[rows] = res
        failed.update(keys[i] for i in set(range(n)) - set(rows.tolist()))
        return cands, continued, stale

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

    # -- views for the shell -------------------------------------------------------------------------------
    def predict_tracks(self, keys: list[IntruderKey], now_s: float):
        """Contained prediction for the shell (track publication): (keys that went through, xs, ps). An intruder
        that fails here fails as in step(); its failed-state advisory comes with the next step's changes."""
        return self.assessor.predicted(now_s, keys, self.containment.pending)

    def end_all(self, now_s: float, reason: str) -> list[Advisory]:
        """End every active advisory now with reason (e.g. "shutdown"); the ended ones, for announcing."""
        changes: list[Advisory] = []
        self.records.end(now_s, sorted(self.records.latest), reason, changes)
        return changes

    def advisory(self, key: IntruderKey) -> Advisory | None:
        """An intruder's latest advisory (built now if the step left it as arrays); None: never assessed."""
        entry = self.records.latest.get(key)
        return None if entry is None else advisory_of(entry)

    def advisory_reader(self, key: IntruderKey):
        """(level, a callable returning the intruder's latest advisory as of now, built when called, and its
        ASSESSMENT_FIELDS): for the track views, whose publications read the level and those fields of every
        track and the whole advisory of a few."""
        entry = self.records.latest.get(key)
        if entry is None:
            return AdvisoryLevel.NONE, _no_advisory, None
        assessment = entry.assessment() if type(entry) is Advisory else entry[0].assessment(entry[1])
        return self.records.states.level_of(key), partial(advisory_of, entry), assessment

    def datum_mismatch_keys(self) -> list[IntruderKey]:
        """The intruders whose latest assessment compared altitudes across datums."""
        states = self.records.states
        return [k for k in self.records.latest if states.mismatch[states.row(k)]]

    def active_view(self):
        return self.records.active_view()

    def ownship_state(self) -> OwnshipState | None:
        return self._last_ownship


def _ra_fields(r, threat) -> dict:
    return dict(ra_sense=r.sense_against(threat).value, ra_strength=r.strength.value, ra_words=r.words(),
                target_vertical_rate_mps=r.target_rate_mps, ra_reversed=r.reversed, ra_crossing=r.crossing,
                ra_separation_m=r.separation_against(threat), ra_composite=r.composite)
