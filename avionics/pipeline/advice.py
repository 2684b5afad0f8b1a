"""The advisory logic over an assessment (assessment.py Evaluation): persistence, the levels' continuations and
hysteresis, staleness and the lost-threat hold, the advisory state's next level (advisory/logic.py), the RA
threats and their one manoeuvre (advisory/resolution.py), and each intruder's advisory with its reason, recorded
(records.py) and appended to the step's changes when its level, RA sense or strength changed."""

from __future__ import annotations

from collections.abc import Set as AbstractSet

import numpy as np

from avionics.advisory.logic import lost_hold
from avionics.advisory.resolution import Threat
from avionics.compose import Components
from avionics.config import Config
from avionics.base.types import LOST, Advisory, AdvisoryLevel, IntruderKey
from avionics.pipeline.assessment import Evaluation
from avionics.pipeline.containment import Containment
from avionics.pipeline.records import NONE, RA, AdvisoryRecords, AssessmentRows, Entry, advisory_of


class Adviser:
    def __init__(self, config: Config, parts: Components, records: AdvisoryRecords, containment: Containment):
        """parts: compose.py Components (alerter, hysteresis, gate, resolution, inhibits)."""
        self.config = config
        self.alerter = parts.alerter  # TA and RA: the tcas2 alerter's levels; or a DO-365 alerter's three
        self.alert_names = self.alerter.names()
        self.advisory_level = np.array([self.alerter.advisory_of(a) for a in range(self.alerter.most_severe + 1)])
        self.hysteresis = parts.hysteresis  # a DO-365 alerter's M of N and persistence (DAIDALUS HysteresisData)
        self.gate = parts.gate  # advisory.criterion and advisory.persistence
        self.resolution = parts.resolution
        self.inhibits = parts.inhibits
        self.records = records
        self.containment = containment

    def advise(self, now_s: float, ev: Evaluation, level, ra_allowed: bool, inhibits, own, agl_m: float | None,
               updated: AbstractSet[IntruderKey], changes: list[Advisory]) -> list:
        """The advisories of ev's intruders (`records.latest` entries), the changes appended to changes; updated:
        the intruders a report updated in this step (persistence counts their reports)."""
        keys, xs, geometry = ev.keys, ev.xs, ev.geometry
        records, states = self.records, self.records.states
        failed: set[IntruderKey] = set()
        candidates, continued, stale = self._decided(now_s, keys, ev, level, ra_allowed, updated, failed, changes)
        live = np.array([i for i, k in enumerate(keys) if k not in failed], np.intp) if failed else \
            np.arange(len(keys))
        rows = states.rows([keys[i] for i in live])
        previous_level = states.level[rows].astype(int)
        previous_alert = states.alert[rows].astype(int)
        # a stale track ends its alert at once, unless it is a lost threat whose coasted track still calls for it:
        # that alert is held at its level (advisory/logic.py lost_hold), with the DMOD of that level
        ra_dmod = level.ra_dmod_m if level.ra_dmod_m is not None else level.ta_dmod_m
        dmod = np.where(previous_level == RA, ra_dmod, level.ta_dmod_m)
        held, lost = lost_hold(previous_level, stale[live], geometry.s_dot_v[live] < 0.0, geometry.range_m[live], dmod)
        alerts = np.where(stale, NONE, candidates)
        alerts[live[held]] = previous_alert[held]
        ta_hold_s = self.alerter.level(int(AdvisoryLevel.TA)).min_duration_s  # TCAS II: a TA stays 8 s
        states.next(rows, now_s, self.advisory_level[alerts[live]], ta_hold_s, force=stale[live] & ~held)
        levels = states.level[rows].astype(int)
        own_levels = self.alerter.own_levels
        states.alert[rows] = alerts[live] if own_levels else levels
        states.mismatch[rows] = ev.mismatch[live]
        ra_rows = live[levels == int(AdvisoryLevel.RA)]
        ra_threats = records.ra_threats
        if ra_threats:  # an assessed intruder no longer at RA is no longer an RA threat
            assessed = set(keys)
            for key in [k for k in ra_threats if k in assessed and states.level_of(k) is not AdvisoryLevel.RA]:
                del ra_threats[key]
        for i in ra_rows:
            ra_threats[keys[i]] = Threat(float(ev.coasted_sz_m[i]), float(xs[i, 5]), float(geometry.t_cpa_s[i]), keys[i])
        try:
            resolution = self.resolution.resolve(now_s, list(ra_threats.values()), float(own.x[5]),
                                                 level.alim_m or 0.0, inhibits, float(own.x[2]),
                                                 self.inhibits.floors(float(own.x[2]), agl_m))
            blocked = self.resolution.blocked if resolution is None else ""
        except Exception as exc:  # noqa: BLE001  (one manoeuvre for every RA threat: they all fail with it)
            for key in sorted(ra_threats):
                self.containment.fail(now_s, key, "resolution", exc, changes, failed)
            resolution, blocked = None, ""
        step = AssessmentRows(now_s, keys, level, ev, stale, alerts, self.alert_names, own_levels)
        if len(ra_rows):  # modified tau at the RA's DMOD only when an intruder is at RA (the others read the TA's)
            step.mod_tau[AdvisoryLevel.RA] = geometry.mod_tau(level.ra_dmod_m)
        # an intruder alerting now or before (or with a DO-365 alert level) gets its advisory built now; the
        # others (most of them) are (step, row) until something reads them
        eager = (levels != NONE) | (previous_level != NONE)
        if own_levels:
            eager |= (alerts[live] != NONE) | (previous_alert != NONE)
        out: list[Entry] = []
        for j, i in enumerate(live):
            key = keys[i]
            if key in failed:  # the resolution failed for its RA
                continue
            if not eager[j]:
                records.latest[key] = entry = (step, i)
                out.append(entry)
                continue
            try:
                advisory = self._built(step, i, key, levels[j], candidates[i], stale[i], continued[i], level,
                                       resolution, blocked, lost[j])
            except Exception as exc:  # noqa: BLE001  (stage boundary: this intruder's advisory)
                self.containment.fail(now_s, key, "advisory", exc, changes, failed)
                continue
            previous = records.latest.get(key)
            previous = advisory_of(previous) if previous is not None else None
            records.remember(key, advisory)
            if previous is None and advisory.level is not AdvisoryLevel.NONE or \
                    previous is not None and previous.ra_key() != advisory.ra_key():
                changes.append(advisory)
            out.append(advisory)
        return out

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

    def _built(self, step: AssessmentRows, i, key, level_number, candidate_alert, stale, continued, level, resolution,
               blocked, lost) -> Advisory:
        """Intruder i's advisory from the step's arrays, with its level's reason and its RA. lost: a lost threat
        (held, or ending): its reason is LOST whatever else holds."""
        states, ra_threats = self.records.states, self.records.ra_threats
        state = AdvisoryLevel(int(level_number))
        if blocked and state is AdvisoryLevel.RA:  # no RA would help: the threat stays a TA
            state = AdvisoryLevel.TA
            states.level[states.row(key)] = int(state)
        threat = ra_threats.get(key) if state is AdvisoryLevel.RA else None
        if lost:
            reason = LOST
        elif blocked and key in ra_threats:
            reason = blocked
        elif threat is not None and resolution.reason:
            reason = resolution.reason
        elif threat is not None and continued:
            reason = "closing"
        else:
            candidate = AdvisoryLevel(self.alerter.advisory_of(NONE if stale else int(candidate_alert)))
            dmod = level.ra_dmod_m if state is AdvisoryLevel.RA else level.ta_dmod_m
            reason = _reason(state, candidate, stale, step.geometry.s_dot_v[i], step.geometry.range_m[i], dmod)
        return step.advisory(i, state, reason, _ra_fields(resolution, threat) if threat is not None and resolution
                             else None)


def _reason(level: AdvisoryLevel, candidate: AdvisoryLevel, stale: bool, s_dot_v: float, range_m: float,
            dmod_m: float) -> str:
    if stale:
        return "stale"
    if level is not candidate:
        return "hold"  # TA minimum duration
    if level is AdvisoryLevel.NONE:
        return "diverging" if s_dot_v > 0.0 else "clear"
    return "range" if range_m <= dmod_m else "tau"


def _ra_fields(r, threat) -> dict:
    return dict(ra_sense=r.sense_against(threat).value, ra_strength=r.strength.value, ra_words=r.words(),
                target_vertical_rate_mps=r.target_rate_mps, ra_reversed=r.reversed, ra_crossing=r.crossing,
                ra_separation_m=r.separation_against(threat), ra_composite=r.composite)
