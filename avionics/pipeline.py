"""The functional core: step(now, inputs) -> StepResult, with no I/O, clocks or sockets inside.

ingest (validated inputs) -> track (ownship filter, one track per intruder) -> assess (CPA, tau)
-> advise (sensitivity level, TA/RA tests, advisory state per intruder).

The live runner and fast-time replay both drive this object, so what was evaluated is what flies.
Intruders updated in a step are assessed in that step (report-to-advisory latency is one step); every
intruder is re-assessed at assessment_hz so that coasting tracks and timeouts are seen too.
"""

from __future__ import annotations

import math
from collections import Counter
from dataclasses import dataclass, field
from typing import Iterable

import numpy as np

from avionics.advisory.gating import AlertGate
from avionics.advisory.inhibits import LowAltitudeInhibits
from avionics.advisory.logic import AdvisoryState, detect, ra_continues
from avionics.advisory.resolution import ResolutionLogic, Threat
from avionics.advisory.tables import LevelSelector, SensitivityLevel, load_profile
from avionics.config import Config
from avionics.conflict.assess import ConflictAssessor
from avionics.conflict.cpa import pair_geometry
from avionics.conflict.pc_at_cpa import pc_at_cpa
from avionics.core.geodesy import LocalTangentPlane
from avionics.core.types import (
    Advisory, AdvisoryLevel, AltitudeDatum, Input, IntruderKey, IntruderReport, OwnshipFix, OwnshipPressure,
)
from avionics.tracking.ownship import OwnshipFilter, OwnshipState
from avionics.tracking.imm_tracker import make_tracker


TIME_EPSILON_S = 1e-6  # steps on a 0.1 s grid must not miss a tick to floating-point rounding


@dataclass(frozen=True, slots=True)
class StepResult:
    time_s: float
    changes: list[Advisory]  # advisories whose level, RA sense or RA strength changed in this step
    assessed: list[Advisory]  # the advisory of every intruder assessed in this step


@dataclass
class _Assessment:
    advisory: Advisory
    state: AdvisoryState = field(default_factory=AdvisoryState)


class DaaCore:
    def __init__(self, config: Config, counters: Counter | None = None):
        self.config = config
        self.counters = counters if counters is not None else Counter()
        self.profile = load_profile(config.advisory.profile, config.advisory.profile_overrides)
        self.levels = LevelSelector(self.profile)
        self.resolution = ResolutionLogic(self.profile)
        self.inhibits = LowAltitudeInhibits(self.profile)
        self._ra_threats: dict[IntruderKey, Threat] = {}
        self.gate = AlertGate(config.advisory)
        self.conflict = ConflictAssessor(config.conflict)
        self.plane: LocalTangentPlane | None = None
        self.ownship = OwnshipFilter(config.altitude, config.input)
        self.tracker = make_tracker(config.tracking, self.counters)  # tracking.filter: cv or an IMM
        self.assessments: dict[IntruderKey, _Assessment] = {}
        self.level: SensitivityLevel | None = None
        self._last_full_assessment_s = -math.inf
        self._last_ownship: OwnshipState | None = None

    # -- ingest --------------------------------------------------------------------------------------------
    def _en(self, lat_deg: float, lon_deg: float) -> tuple[float, float]:
        if self.plane is None:
            self.plane = LocalTangentPlane(lat_deg, lon_deg)
        east, north = self.plane.to_en(lat_deg, lon_deg)
        return float(east), float(north)

    def _ingest_reports(self, reports: list[tuple[IntruderReport, float, float]], dirty: set[IntruderKey]) -> None:
        """A step's intruder reports in one vectorised tracker call: under load the live link hands over a
        backlog at once, and the per-call cost is paid once per step instead of once per report."""
        if not reports:
            return
        items, easts, norths = zip(*reports)
        took = self.tracker.ingest_many(list(items), easts, norths)
        dirty.update(r.key for r, ok in zip(items, took) if ok)

    def _ingest(self, item: Input, reports: list[tuple[IntruderReport, float, float]]) -> None:
        if isinstance(item, IntruderReport):  # positions in arrival order: the first of any aircraft fixes the plane
            reports.append((item, *self._en(item.lat_deg, item.lon_deg)))
        elif isinstance(item, OwnshipFix):
            if not self.ownship.update_fix(item, *self._en(item.lat_deg, item.lon_deg)):
                self.counters["ownship.out_of_order"] += 1
        elif isinstance(item, OwnshipPressure):
            if not self.ownship.update_pressure(item):
                self.counters["ownship_pressure.before_first_fix"] += 1
        else:
            raise TypeError(f"not a core input: {item!r}")

    # -- step ------------------------------------------------------------------------------------------------
    def step(self, now_s: float, inputs: Iterable[Input] = ()) -> StepResult:
        dirty: set[IntruderKey] = set()
        reports: list[tuple[IntruderReport, float, float]] = []
        for item in inputs:
            self._ingest(item, reports)
        self._ingest_reports(reports, dirty)
        changes: list[Advisory] = []
        period = 1.0 / self.config.advisory.assessment_hz
        if now_s - self._last_full_assessment_s >= period - TIME_EPSILON_S:
            self._last_full_assessment_s = now_s
            for key in self.tracker.prune(now_s):
                self._ra_threats.pop(key, None)
                self.gate.forget(key)
                self.conflict.forget(key)
                gone = self.assessments.pop(key, None)
                if gone is not None and gone.state.level is not AdvisoryLevel.NONE:
                    changes.append(_with_level(gone.advisory, now_s, AdvisoryLevel.NONE, "deleted"))
            keys = sorted(self.tracker.tracks)
        else:
            keys = sorted(dirty)
        assessed = self._assess(now_s, keys, changes, dirty) if keys else []
        return StepResult(now_s, changes, assessed)

    def _ownship_altitudes(self, own: OwnshipState, datum: AltitudeDatum | None) -> tuple[float, bool]:
        """Ownship altitude in the intruder's datum, and whether it had to be taken from the other datum."""
        if datum is AltitudeDatum.PRESSURE:
            if own.pressure_altitude_m is not None:
                return own.pressure_altitude_m, False
            return float(own.x[2]), True
        return float(own.x[2]), False

    def _assess(self, now_s: float, keys: list[IntruderKey], changes: list[Advisory],
                updated: set[IntruderKey] = frozenset()) -> list[Advisory]:
        own = self.ownship.state_at(now_s)
        self._last_ownship = own
        if own is None:
            self.level = None  # no ownship altitude: no sensitivity level either
            return self._drop_all(now_s, keys, "no_ownship", changes)
        cfg = self.config
        agl = (float(own.x[2]) - cfg.advisory.ground_elevation_m if cfg.advisory.ground_elevation_m is not None
               else own.height_above_home_m)
        sl_altitude = own.pressure_altitude_m if own.pressure_altitude_m is not None else float(own.x[2])
        self.level = level = self.levels.select(agl, sl_altitude)
        inhibits = self.inhibits.update(agl)
        ra_allowed = cfg.advisory.ra_enabled and not inhibits.ra

        xs, ps = self.tracker.predict(keys, now_s)
        tracks = [self.tracker.tracks[k] for k in keys]
        own_alt = np.empty(len(keys))
        mismatch = np.zeros(len(keys), bool)
        has_alt = np.array([t.altitude_valid(now_s, cfg.tracking.max_coast_s) for t in tracks], bool)
        for i, track in enumerate(tracks):
            own_alt[i], mismatch[i] = self._ownship_altitudes(own, track.datum)
        mismatch &= has_alt
        self.counters["assessment.datum_mismatch"] += int(mismatch.sum())
        # Unknown intruder altitude: zeros keep the arithmetic finite; has_alt masks them in detect().
        geometry = pair_geometry(xs[:, 0:2] - own.x[0:2], xs[:, 3:5] - own.x[3:5],
                                 np.where(has_alt, xs[:, 2] - own_alt, 0.0), np.where(has_alt, xs[:, 5] - own.x[5], 0.0))
        margin = np.where(mismatch, cfg.altitude.datum_mismatch_margin_m, 0.0)
        threat_eligible = np.abs(xs[:, 5]) <= self.profile.max_threat_vertical_rate_mps
        candidates = detect(geometry, level, has_alt, margin, ra_allowed, cfg.advisory.hmd_filter, threat_eligible)
        pc_ta, pc_ra, pc = self._conflict_probabilities(now_s, keys, xs, ps, own, geometry, level, has_alt, margin)
        within_age = self.conflict.within_age(now_s, keys)
        candidates = self.gate.criterion(candidates, pc_ta, pc_ra, geometry, level, has_alt, ra_allowed)
        candidates = self.gate.persist(keys, candidates, pc_ta, pc_ra, updated)
        was_ra = np.array([(e := self.assessments.get(k)) is not None and e.state.level is AdvisoryLevel.RA
                           for k in keys], bool)
        continued = np.zeros(len(keys), bool)  # RA threats kept although the RA tests no longer hold
        if ra_allowed and level.ra_tau_s is not None:
            continued = ra_continues(geometry, level, was_ra, cfg.advisory.hmd_filter) & has_alt & threat_eligible
            continued &= candidates < int(AdvisoryLevel.RA)
            candidates = np.where(continued, int(AdvisoryLevel.RA), candidates)
        stale = np.array([now_s - t.last_report_s > cfg.tracking.max_coast_s for t in tracks], bool)

        mod_tau = {AdvisoryLevel.RA: geometry.mod_tau(level.ra_dmod_m) if level.ra_dmod_m else None,
                   AdvisoryLevel.TA: geometry.mod_tau(level.ta_dmod_m)}
        mod_tau[AdvisoryLevel.NONE] = mod_tau[AdvisoryLevel.TA]
        states = []
        for i, key in enumerate(keys):
            entry = self.assessments.get(key)
            state = entry.state if entry else AdvisoryState()
            candidate = AdvisoryLevel(NONE if stale[i] else int(candidates[i]))
            state.next(now_s, candidate, cfg.advisory.ta_min_duration_s, force=bool(stale[i]))
            states.append((state, candidate, entry.advisory if entry else None))
            if state.level is AdvisoryLevel.RA:
                self._ra_threats[key] = Threat(float(geometry.sz_m[i]), float(xs[i, 5]), float(geometry.t_cpa_s[i]))
            else:
                self._ra_threats.pop(key, None)
        resolution = self.resolution.resolve(now_s, list(self._ra_threats.values()), float(own.x[5]),
                                             level.alim_m or 0.0, inhibits, float(own.x[2]))
        blocked = self.resolution.blocked if resolution is None else ""
        out = []
        for i, key in enumerate(keys):
            state, candidate, previous = states[i]
            if blocked and state.level is AdvisoryLevel.RA:  # no RA would help: the threat stays a TA
                state.level = AdvisoryLevel.TA
            threat = self._ra_threats.get(key) if state.level is AdvisoryLevel.RA else None
            dmod = level.ra_dmod_m if state.level is AdvisoryLevel.RA else level.ta_dmod_m
            advisory = Advisory(
                intruder=key, level=state.level, time_s=now_s,
                reason=(blocked if blocked and key in self._ra_threats else
                        resolution.reason if threat is not None and resolution.reason else
                        "closing" if threat is not None and continued[i] else
                        self._reason(state.level, candidate, stale[i], geometry.s_dot_v[i], geometry.range_m[i], dmod)),
                sensitivity_level=level.sl,
                range_m=float(geometry.range_m[i]), closure_rate_mps=float(geometry.closure_rate_mps[i]),
                t_cpa_s=float(geometry.t_cpa_s[i]), hmd_m=float(geometry.hmd_m[i]),
                vmd_m=float(geometry.vmd_m[i]) if has_alt[i] else None,
                range_tau_s=float(geometry.range_tau_s[i]), mod_tau_s=float(mod_tau[state.level][i]),
                vertical_tau_s=float(geometry.vertical_tau_s[i]) if has_alt[i] else math.inf,
                altitude_datum=tracks[i].datum if has_alt[i] else None, datum_mismatch=bool(mismatch[i]),
                pc_ta=float(pc_ta[i]), pc_ra=float(pc_ra[i]) if level.ra_tau_s is not None else None,
                pc_now=float(pc["pc_now"][i]), pc_max=float(pc["pc_max"][i]),
                t_pc_max_s=float(pc["t_pc_max_s"][i]), pc_within=_finite_or_none(pc["pc_within"][i]),
                pc_within_age_s=_finite_or_none(within_age[i]),
                **(_ra_fields(resolution, threat) if threat is not None and resolution else {}),
            )
            self.assessments[key] = _Assessment(advisory, state)
            if previous is None and advisory.level is not AdvisoryLevel.NONE or \
                    previous is not None and previous.ra_key() != advisory.ra_key():
                changes.append(advisory)
            out.append(advisory)
        return out

    def _conflict_probabilities(self, now_s, keys, xs, ps, own, geometry, level, has_alt, margin):
        """Pc of the TA and RA volumes at the predicted CPA (advisory/gating.py), for gating; and the conflict
        stage's probabilities of the [conflict] zone (conflict/assess.py: now, max over the lookahead and
        its time, within the lookahead) for the outputs, under Hwang's scheduling conditions."""
        rel_x = xs - own.x
        rel_x[:, 2] = geometry.sz_m  # the datum-matched relative altitude
        rel_p = ps + own.p
        zone = self._zone_probabilities(now_s, keys, rel_x, rel_p, has_alt, margin, own.x[3:5])
        # a datum mismatch widens the vertical uncertainty: the margin is added as a 1-sigma term
        rel_p[:, 2, 2] += margin**2
        t = geometry.t_cpa_s
        sigma_h, sigma_v = self.config.tracking.horizontal_accel_sigma_mps2, self.config.tracking.vertical_accel_sigma_mps2
        volumes = [(level.ta_dmod_m, level.ta_zthr_m)]
        if level.ra_tau_s is not None:
            volumes.append((level.ra_hmd_m if level.ra_hmd_m is not None else level.ra_dmod_m, level.alim_m))
        pc = pc_at_cpa(rel_x, rel_p, t, volumes, sigma_h, sigma_v, has_alt)
        pc_ra = pc[1] * has_alt if level.ra_tau_s is not None else np.zeros(len(keys))
        return pc[0], pc_ra, zone

    def _zone_probabilities(self, now_s, keys, rel_x, rel_p, has_alt, margin, own_velocity) -> dict:
        """The conflict stage runs on the full-assessment ticks only (its scheduler then decides which pairs
        are due); an assessment between ticks, for a fresh report, reuses the intruder's last values."""
        if len(keys) == len(self.tracker.tracks) and now_s == self._last_full_assessment_s:
            return self.conflict.assess(now_s, keys, rel_x, rel_p, has_alt, margin, own_vel=own_velocity)
        return self.conflict.last(keys)

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

    def _drop_all(self, now_s: float, keys: list[IntruderKey], reason: str, changes: list[Advisory]):
        """Without ownship there is no relative geometry: every advisory ends, with the reason."""
        out = []
        for key in keys:
            self._ra_threats.pop(key, None)
            entry = self.assessments.get(key)
            if entry is None:
                continue
            if entry.state.next(now_s, AdvisoryLevel.NONE, 0.0, force=True):
                entry.advisory = _with_level(entry.advisory, now_s, AdvisoryLevel.NONE, reason)
                changes.append(entry.advisory)
            out.append(entry.advisory)
        return out

    # -- views for the shell -------------------------------------------------------------------------------
    def advisories(self) -> dict[IntruderKey, Advisory]:
        return {k: a.advisory for k, a in self.assessments.items()}

    def ownship_state(self) -> OwnshipState | None:
        return self._last_ownship


NONE = int(AdvisoryLevel.NONE)


def _ra_fields(r, threat) -> dict:
    return dict(ra_sense=r.sense_against(threat).value, ra_strength=r.strength.value, ra_words=r.words(),
                target_vertical_rate_mps=r.target_rate_mps, ra_reversed=r.reversed, ra_crossing=r.crossing,
                ra_separation_m=r.separation_m)


def _finite_or_none(value: float) -> float | None:
    return float(value) if math.isfinite(value) else None


def _with_level(advisory: Advisory, now_s: float, level: AdvisoryLevel, reason: str) -> Advisory:
    from dataclasses import replace

    return replace(advisory, level=level, time_s=now_s, reason=reason, ra_sense=None, ra_strength=None,
                   ra_words=None, target_vertical_rate_mps=None, ra_reversed=False, ra_crossing=False,
                   ra_separation_m=None)
