"""The assessment of the intruders due in a step (schedule.py): each track predicted to now, its geometry against
the ownship in a common altitude datum, the alerter's detection, the Pc of the TA and RA volumes and of the
[conflict] zone, the alert gate's criterion, and the ADS-B integrity floor. Vectorised over intruders, each
stage call inside a fault boundary (containment.py); what comes out is finite."""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from avionics.advisory.alerting import Encounter
from avionics.compose import Components
from avionics.config import Config
from avionics.conflict.cpa import PairGeometry, hmd_sigma_m, pair_geometry
from avionics.conflict.pc_at_cpa import pc_at_cpa
from avionics.base.types import AddressSource, Advisory, AdvisoryLevel, AltitudeDatum, IntruderKey
from avionics.base.uncertainty import errors_from_covariance
from avionics.pipeline.containment import Containment
from avionics.pipeline.intake import Intake
from avionics.tracking.interface import Tracker
from avionics.tracking.ownship import OwnshipState
from avionics.tracking.range_tracker import horizontal_miss_m


@dataclass(frozen=True, slots=True)
class Evaluation:
    """The numbers of one assessment, one row per intruder (keys)."""

    keys: list[IntruderKey]
    xs: np.ndarray  # (N, 6) predicted states
    tracks: list  # tracking/record.py track records
    has_alt: np.ndarray  # (N,) the intruder's altitude is known
    coasted: np.ndarray  # (N,) no report for max_coast_s, an altitude before: its altitude is dead-reckoned
    coasted_sz_m: np.ndarray  # (N,) intruder - ownship altitude: known, or dead-reckoned where coasted; else 0
    mismatch: np.ndarray  # (N,) altitudes compared across datums
    geometry: PairGeometry
    threat_eligible: np.ndarray
    encounter: Encounter
    candidates: np.ndarray  # (N,) the alert level each would get now (before persistence and continuation)
    pc_ta: np.ndarray
    pc_ra: np.ndarray
    pc: dict  # the conflict stage's probabilities of the [conflict] zone
    within_age: np.ndarray
    finite: np.ndarray  # (N,) every number of the row is finite


SENSOR = AddressSource.SENSOR
HMD_SIGMAS = 2.0  # a sensor-only track's miss distance, as the alerter reads it: this many sigmas below the estimate


class Assessor:
    def __init__(self, config: Config, parts: Components, tracker: Tracker, intake: Intake, containment: Containment):
        """parts: compose.py Components (profile, alerter, hysteresis, gate, conflict)."""
        self.config = config
        self.profile = parts.profile
        self.alerter = parts.alerter
        self.hysteresis = parts.hysteresis
        self.gate = parts.gate
        self.conflict = parts.conflict
        self.tracker = tracker
        self.intake = intake  # the stated uncertainties
        self.containment = containment

    def predicted(self, now_s: float, keys: list[IntruderKey], changes: list[Advisory]):
        """The prediction stage: keys that went through, states (N, 6), covariances (N, 6, 6), all finite."""
        def run(rows):
            return self.tracker.predict([keys[i] for i in rows], now_s)

        rows, res = self.containment.contained("predict", now_s, keys, changes, run,
                                               combine=lambda parts: tuple(np.concatenate(a) for a in zip(*parts)))
        if res is None:
            return [], np.empty((0, 6)), np.empty((0, 6, 6))
        xs, ps = res
        finite = np.isfinite(xs).all(axis=1) & np.isfinite(ps).all(axis=(1, 2))
        if not finite.all():
            for i in np.flatnonzero(~finite):
                self.containment.fail(now_s, keys[rows[i]], "predict",
                                      FloatingPointError("predicted state is not finite"), changes)
            rows, xs, ps = rows[finite], xs[finite], ps[finite]
        return [keys[i] for i in rows], xs, ps

    def evaluated(self, now_s, keys, xs, ps, own, level, ra_allowed, periodic, changes) -> Evaluation | None:
        """The conflict stage (geometry, detection, probabilities, the criterion) for the intruders whose
        numbers go through it finite; None when none does."""
        def run(rows):
            return self._evaluate(now_s, [keys[i] for i in rows], xs[rows], ps[rows], own, level, ra_allowed,
                                  periodic)

        rows, ev = self.containment.contained("conflict", now_s, keys, changes, run)
        if ev is not None and not ev.finite.all():
            for i in np.flatnonzero(~ev.finite):
                self.containment.fail(now_s, keys[rows[i]], "conflict",
                                      FloatingPointError("conflict geometry is not finite"), changes)
            rows = rows[ev.finite]
            ev = run(rows) if len(rows) else None  # raises again only if the rest fails together: the step fails
        return ev

    def _evaluate(self, now_s, keys, xs, ps, own, level, ra_allowed, periodic) -> Evaluation:
        tracks, has_alt, mismatch, own_alt, margin, geometry, threat_eligible, encounter = \
            self._encounter(now_s, keys, xs, ps, own)
        candidates = self.alerter.alert(encounter, level, None if ra_allowed else self.alerter.highest_without_ra,
                                        previous=self.hysteresis.last(keys))
        pc_ta, pc_ra, pc = self._conflict_probabilities(now_s, keys, xs, ps, own, geometry, level, has_alt, margin,
                                                        periodic)
        within_age = self.conflict.within_age(now_s, keys)
        candidates = self.gate.admit(candidates, pc_ta, pc_ra, geometry, level, has_alt, ra_allowed)
        # ADS-B integrity (docs/tracking.md, "Integrity monitor"): a degraded track inside DMOD and ZTHR by its last
        # reported position gets at least a TA, whatever its (possibly wrong) track says; unknown altitude counts
        # as inside ZTHR, as TCAS treats a non-altitude-reporting intruder.
        for i, track in enumerate(tracks):
            if not track.integrity.degraded:
                continue
            rep = track.last_reported_enu  # a posterior of its own: only for the degraded ones
            if rep is not None and \
                    math.hypot(rep[0] - own.x[0], rep[1] - own.x[1]) <= level.ta_dmod_m and \
                    (rep[2] is None or abs(rep[2] - own_alt[i]) <= level.ta_zthr_m + margin[i]):
                candidates[i] = max(int(candidates[i]), int(AdvisoryLevel.TA))
        g = geometry  # taus may be infinite (not closing), never NaN; everything else is finite
        finite = np.isfinite(np.stack([g.range_m, g.s_dot_v, g.closure_rate_mps, g.t_cpa_s, g.hmd_m, g.sz_m, g.vz_mps,
                                       g.vmd_m, pc_ta, pc_ra, pc["pc_now"], pc["pc_max"], pc["t_pc_max_s"]])).all(axis=0)
        finite &= ~np.isnan(np.stack([g.range_tau_s, g.vertical_tau_s])).any(axis=0)
        # A track whose reports stopped (a lost threat's: advisory/logic.py lost_hold) is held on its coasted state,
        # its altitude too: the RA logic and the guidance bands read it where the alerter counts the altitude as
        # unknown, not the geometry's placeholder 0, which read as co-altitude reversed RAs into the intruder.
        max_coast = self.config.tracking.max_coast_s
        coasted = np.zeros(len(tracks), bool)
        for i in np.flatnonzero(~has_alt):  # rare: the rows' own loop, not one more over every track
            coasted[i] = tracks[i].last_altitude_s is not None and now_s - tracks[i].last_report_s > max_coast
        coasted_sz = np.where(coasted, xs[:, 2] - own_alt, geometry.sz_m)
        return Evaluation(keys=keys, xs=xs, tracks=tracks, has_alt=has_alt, coasted=coasted, coasted_sz_m=coasted_sz,
                          mismatch=mismatch, geometry=geometry,
                          threat_eligible=threat_eligible, encounter=encounter, candidates=candidates,
                          pc_ta=pc_ta, pc_ra=pc_ra, pc=pc, within_age=within_age, finite=finite)

    def _encounter(self, now_s, keys, xs, ps, own):
        """What the alerter reads of each intruder against ownship `own`: the tracks, which have an altitude, the
        datum mismatches, ownship's altitude in each one's datum and its margin, the geometry, which are eligible
        threats, and the alerter's Encounter."""
        cfg = self.config
        tracks = [self.tracker.tracks[k] for k in keys]
        own_alt = np.empty(len(keys))
        mismatch = np.zeros(len(keys), bool)
        has_alt = np.array([t.altitude_valid(now_s, cfg.tracking.max_coast_s) for t in tracks], bool)
        for i, track in enumerate(tracks):
            own_alt[i], mismatch[i] = ownship_altitude(own, track.datum)
        mismatch &= has_alt
        # Unknown intruder altitude: zeros keep the arithmetic finite; has_alt masks them in detect().
        geometry = pair_geometry(xs[:, 0:2] - own.x[0:2], xs[:, 3:5] - own.x[3:5],
                                 np.where(has_alt, xs[:, 2] - own_alt, 0.0), np.where(has_alt, xs[:, 5] - own.x[5], 0.0))
        margin = np.where(mismatch, cfg.altitude.datum_mismatch_margin_m, 0.0)
        threat_eligible = np.abs(xs[:, 5]) <= self.profile.max_threat_vertical_rate_mps
        # which alerter judges each intruder (DAIDALUS's per-intruder alerter): one seen only by a sensor is
        # non-cooperative (tracking/surveillance.py); an ADS-B track, fused with a sensor's or not, is cooperative
        sensed = np.fromiter((k.source is SENSOR for k in keys), bool, len(keys))
        non_coop = sensed if self.alerter.non_cooperative is not None else False
        encounter = Encounter(self._resolvable(now_s, keys, geometry, sensed, ps, own), has_alt, margin,
                              threat_eligible, self._pair_errors(keys, ps, own), non_coop)
        return tracks, has_alt, mismatch, own_alt, margin, geometry, threat_eligible, encounter

    def ra_threatened(self, now_s, keys, xs, ps, own, level) -> bool:
        """Whether the alerter's detectors alone (no persistence, hysteresis, gate or inhibit: a geometry, not an
        advisory) put any intruder at a level that raises an RA against ownship `own`; the guidance asks it of
        the ownship it would fly back to its mission (GuidanceStage: mission_altitude_in_conflict)."""
        if not len(keys):
            return False
        encounter = self._encounter(now_s, keys, xs, ps, own)[-1]
        return bool((np.asarray(self.alerter.alert(encounter, level)) > self.alerter.highest_without_ra).any())

    def _resolvable(self, now_s, keys, geometry: PairGeometry, sensed: np.ndarray, ps: np.ndarray,
                    own) -> PairGeometry:
        """The geometry the alerter reads: an intruder seen only by the ownship's sensors (sensed) has its horizontal miss
        distance taken HMD_SIGMAS below the estimate (not below 0), so that TCAS's HMD filter (alerting.TCAS3D)
        suppresses an RA only on a miss the track resolves. Active surveillance measures bearing to 9-15 deg:
        its track's cross-range velocity is off by metres per second, its HMD by hundreds of metres, and the
        filter fed the estimate held RAs back 4-8 s on NASA's encounters (avionics_eval.reports.noncoop); a run
        of bearing errors can make it kilometres too wide, with a covariance that does not say so. So an active-
        surveillance track's miss is also the smaller of that and its range track's (range_tracker.py, TCAS II's
        miss distance filter). An ADS-B track's miss is resolved to a few metres and is judged as DAIDALUS judges
        it, by the estimate."""
        if not sensed.any():
            return geometry
        hmd = np.where(sensed, np.maximum(geometry.hmd_m - HMD_SIGMAS * hmd_sigma_m(geometry, ps + own.p), 0.0),
                       geometry.hmd_m)
        rows = np.flatnonzero(sensed)
        ranging = self.tracker.ranging([keys[i] for i in rows], now_s)
        for i, range_x in zip(rows, ranging):
            if np.isfinite(range_x).all():
                hmd[i] = min(hmd[i], horizontal_miss_m(range_x, geometry.sz_m[i], geometry.vz_mps[i]))
        return replace(geometry, hmd_m=hmd)

    def _pair_errors(self, keys: list[IntruderKey], ps: np.ndarray, own) -> np.ndarray | None:
        """(N, 4) ownship's + each intruder's errors for a SUM detector (Encounter.uncertainty): the stated ones
        (a report's), and with advisory.sum_from_tracks the track's covariance (ps, own.p: predicted to now,
        the integrity monitor's widening included) for an aircraft that states none; None when there are none."""
        from_tracks = self.config.advisory.sum_from_tracks
        own_errors, stated_errors = self.intake.own_errors, self.intake.stated_errors
        if not from_tracks and own_errors is None and not stated_errors:
            return None
        if own_errors is not None:
            own_e = np.asarray(own_errors, float)
        else:
            own_e = errors_from_covariance(own.p) if from_tracks else np.zeros(4)
        tracked = errors_from_covariance(ps) if from_tracks else np.zeros((len(keys), 4))
        stated = [stated_errors.get(k) for k in keys]
        intr = np.array([tracked[i] if s is None else s for i, s in enumerate(stated)], float).reshape(-1, 4)
        return own_e + intr

    def _conflict_probabilities(self, now_s, keys, xs, ps, own, geometry, level, has_alt, margin, periodic):
        """Pc of the TA and RA volumes at the predicted CPA (advisory/gating.py), for gating; and the conflict
        stage's probabilities of the [conflict] zone (conflict/assess.py: now, max over the lookahead and
        its time, within the lookahead) for the outputs, under Hwang's scheduling conditions."""
        rel_x = xs - own.x
        rel_x[:, 2] = geometry.sz_m  # the datum-matched relative altitude
        rel_p = ps + own.p
        zone = self._zone_probabilities(now_s, keys, rel_x, rel_p, has_alt, margin, own.x[3:5], periodic)
        # a datum mismatch widens the vertical uncertainty: the margin is added as a 1-sigma term
        rel_p[:, 2, 2] += margin**2
        t = geometry.t_cpa_s
        # the conflict stage's prediction noise (relative white acceleration, [conflict]); the [tracking] values
        # are the CV filter's process noise only
        sigma_h, sigma_v = self.config.conflict.accel_sigma_h_mps2, self.config.conflict.accel_sigma_v_mps2
        volumes = [(level.ta_dmod_m, level.ta_zthr_m)]
        if level.ra_tau_s is not None:
            volumes.append((level.ra_hmd_m if level.ra_hmd_m is not None else level.ra_dmod_m, level.alim_m))
        pc = pc_at_cpa(rel_x, rel_p, t, volumes, sigma_h, sigma_v, has_alt)
        pc_ra = pc[1] * has_alt if level.ra_tau_s is not None else np.zeros(len(keys))
        return pc[0], pc_ra, zone

    def _zone_probabilities(self, now_s, keys, rel_x, rel_p, has_alt, margin, own_velocity, periodic) -> dict:
        """The conflict stage runs for the intruders of the re-assessment pass (its scheduler then decides which
        pairs are due); an assessment between them, for a fresh report, reuses the intruder's last values."""
        if not periodic:
            return self.conflict.last(keys)
        due = np.array([k in periodic for k in keys], bool)
        if due.all():
            return self.conflict.assess(now_s, keys, rel_x, rel_p, has_alt, margin, own_vel=own_velocity)
        zone = self.conflict.last(keys)
        i = np.flatnonzero(due)
        if len(i):
            fresh = self.conflict.assess(now_s, [keys[j] for j in i], rel_x[i], rel_p[i], has_alt[i], margin[i],
                                         own_vel=own_velocity)
            for name, values in zone.items():
                values[i] = fresh[name]
        return zone


def ownship_altitude(own: OwnshipState, datum: AltitudeDatum | None) -> tuple[float, bool]:
    """Ownship altitude in the intruder's datum, and whether it had to be taken from the other datum."""
    if datum is AltitudeDatum.PRESSURE:
        if own.pressure_altitude_m is not None:
            return own.pressure_altitude_m, False
        return float(own.x[2]), True
    return float(own.x[2]), False
