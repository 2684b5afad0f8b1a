"""The intake: a step's decoded inputs into the filters, in the tracking frame.

Positions and velocities go into the tracking frame here (base/frame.py: a tangent plane kept within 1 km of the
ownship, every filter carried along when it moves), so the geometry holds anywhere the ownship flies. Ownship
fixes and pressure go into the ownship filter one by one; intruder reports go to the tracker in one vectorised
call per step, through the identity resolver (one aircraft, one track); sensor scans go to the tracker after them,
each with the ownship's position and heading at its time (tracking/surveillance.py). No NaN or inf goes into a
filter. The stated uncertainties of the latest reports (DAIDALUS SUMData) are kept for the assessment.
"""

from __future__ import annotations

import math
from collections import Counter
from dataclasses import replace
from typing import Iterable

import numpy as np

from avionics.config import Config
from avionics.base.frame import FrameChange, TrackingFrame
from avionics.base.types import Advisory, Input, IntruderKey, IntruderReport, OwnshipFix, OwnshipPressure, SensorScan
from avionics.pipeline.containment import Containment
from avionics.tracking.identity import IdentityResolver
from avionics.tracking.interface import Tracker
from avionics.tracking.ownship import OwnshipFilter, OwnshipState


MAX_SCAN_EXTRAPOLATION_S = 2.0  # a scan is placed from an ownship fix (or hdg) at most this far from its time
MIN_TRACK_SPEED_MPS = 1.0  # below it the track angle says nothing of where the nose points
MAX_TURN_RATE_RPS = math.radians(60.0)  # a heading change between fixes faster than this is not extrapolated on


class Intake:
    def __init__(self, config: Config, counters: Counter, tracker: Tracker, containment: Containment):
        self.config = config
        self.counters = counters
        self.tracker = tracker
        self.containment = containment
        self.frame = TrackingFrame()  # the tangent plane of every filter, kept at the ownship
        self.ownship = OwnshipFilter(config.altitude, config.input, counters)
        self.identity = IdentityResolver(config.tracking, counters)  # one aircraft, one track (identity.py)
        # The surveillance's stated uncertainties (DAIDALUS SUMData, base/uncertainty.py) as errors before z-scores,
        # from each aircraft's latest report that carried them: what a SUM detector widens its tests by.
        self.stated_errors: dict[IntruderKey, tuple[float, float, float, float]] = {}
        self.own_errors: tuple[float, float, float, float] | None = None
        self._heading: tuple[float, float, float] | None = None  # (time, heading in the plane's axes, rad; rad/s)

    def take(self, now_s: float, inputs: Iterable[Input], changes: list[Advisory]) -> set[IntruderKey]:
        """A step's inputs into the filters; the intruders whose tracks a report or a scan updated."""
        dirty: set[IntruderKey] = set()
        reports: list[IntruderReport] = []
        scans: list[SensorScan] = []
        for item in inputs:
            if type(item) is SensorScan:
                scans.append(item)
            else:
                self._ingest(item, reports)
        self._ingest_reports(now_s, reports, dirty, changes)
        for scan in sorted(scans, key=lambda s: s.time_s):
            self._ingest_scan(scan, dirty)
        return dirty

    def ownship_at(self, now_s: float) -> OwnshipState | None:
        """The ownship predicted to now_s; None when unknown (or when the filter failed: restarted)."""
        try:
            return self.ownship.state_at(now_s)
        except Exception as exc:  # noqa: BLE001  (stage boundary: the ownship filter)
            self._ownship_failed(now_s, exc)
            return None

    def forget(self, key: IntruderKey) -> None:
        self.stated_errors.pop(key, None)

    def _in_plane(self, reports: list[IntruderReport]):
        """Reports with their velocities in the frame's plane axes, and their plane positions."""
        lats = np.fromiter((r.lat_deg for r in reports), float, len(reports))
        lons = np.fromiter((r.lon_deg for r in reports), float, len(reports))
        velocities = np.array([r.velocity_en_mps or (math.nan, math.nan) for r in reports], float)
        easts, norths, velocities = self.frame.to_plane(lats, lons, velocities)
        items = [r if r.velocity_en_mps is None else replace(r, velocity_en_mps=(float(v[0]), float(v[1])))
                 for r, v in zip(reports, velocities)]
        return items, easts.tolist(), norths.tolist()

    def _follow_ownship(self, fix: OwnshipFix) -> tuple[OwnshipFix, float, float]:
        """Move the plane to the ownship when it has flown RECENTRE_M from its origin (every filter carried
        along); the fix's position in the plane and its velocity in the plane's axes."""
        change = self.frame.follow(fix.lat_deg, fix.lon_deg)
        if change is not None:
            self._carry(change)
        if fix.heading_deg is not None:
            h = math.radians(fix.heading_deg)
            _, _, (he, hn) = self.frame.to_plane(fix.lat_deg, fix.lon_deg, (math.sin(h), math.cos(h)))
            h = math.atan2(float(he), float(hn))
            rate = 0.0
            if self._heading is not None and 0.0 < fix.time_s - self._heading[0] <= MAX_SCAN_EXTRAPOLATION_S:
                turned = (h - self._heading[1] + math.pi) % (2.0 * math.pi) - math.pi
                rate = max(-MAX_TURN_RATE_RPS, min(MAX_TURN_RATE_RPS, turned / (fix.time_s - self._heading[0])))
            self._heading = (fix.time_s, h, rate)
        vn, ve, vd = fix.velocity_ned_mps
        east, north, (ve, vn) = self.frame.to_plane(fix.lat_deg, fix.lon_deg, (ve, vn))
        return replace(fix, velocity_ned_mps=(float(vn), float(ve), vd)), float(east), float(north)

    def _ingest_scan(self, scan: SensorScan, dirty: set[IntruderKey]) -> None:
        """A sensor scan into the tracker, from where the ownship was, facing where its nose pointed, at the
        scan's time. Without the ownship then (no fix yet, or one far from it) the scan is counted and dropped:
        a detection is relative to the ownship and means nothing without it."""
        if not scan.measurements:
            return
        fix = self.ownship.last_fix
        own = self.ownship_at(scan.time_s) if fix is not None else None
        if own is None or abs(fix.time_s - scan.time_s) > MAX_SCAN_EXTRAPOLATION_S:
            self.counters["sensor.no_ownship"] += 1
            return
        heading = self._heading_at(scan.time_s, own)
        if heading is None:
            self.counters["sensor.no_heading"] += 1
            return
        altitude = float(own.x[2])  # the datum of the sensor's altitudes: active surveillance's are pressure
        if scan.measurements[0].mount.kind == "active" and own.pressure_altitude_m is not None:
            altitude = own.pressure_altitude_m
        try:
            dirty |= self.tracker.scan(scan, (float(own.x[0]), float(own.x[1]), altitude), heading, own.x[3:6])
        except Exception as exc:  # noqa: BLE001  (stage boundary: a scan's fault loses that scan, not the step)
            self.containment.batch_failed("sensor", exc)

    def _heading_at(self, t_s: float, own: OwnshipState) -> float | None:
        """The nose's heading (rad, clockwise from the plane's north) at t_s: GLOBAL_POSITION_INT's hdg when a
        recent fix had one, carried to t_s at the turn rate of the last two fixes (a scan between 5 Hz fixes of
        an aircraft turning at 3 deg/s would otherwise see the world 0.3 deg rotated: 7 m at 1.3 km); else the
        ownship's track angle while it moves (a stabilised sensor on an aircraft flying its track, as the
        simulator's sensors are mounted); None when neither is known (a hover without hdg)."""
        if self._heading is not None and abs(t_s - self._heading[0]) <= MAX_SCAN_EXTRAPOLATION_S:
            t0, h, rate = self._heading
            return h + rate * (t_s - t0)
        ve, vn = float(own.x[3]), float(own.x[4])
        return math.atan2(ve, vn) if math.hypot(ve, vn) >= MIN_TRACK_SPEED_MPS else None

    def _carry(self, change: FrameChange) -> None:
        self.tracker.reframe(change)
        self.ownship.reframe(change)
        self.counters["plane.recentred"] += 1

    def _ingest_reports(self, now_s: float, reports: list[IntruderReport], dirty: set[IntruderKey],
                        changes: list[Advisory]) -> None:
        """A step's intruder reports in one vectorised tracker call: under load the live link hands over a
        backlog at once, and the per-call cost is paid once per step instead of once per report. When that call
        raises, each intruder's reports go in alone and an intruder whose update still raises fails. Reports
        go into the plane here, after the step's ownship fixes may have moved it."""
        if not reports:
            return
        items, easts, norths = self._in_plane(reports)
        try:
            start = 0
            while start < len(items):  # one round, or more where identity.py must see a track first
                end = self.identity.round_end(items, start, self.tracker)
                e, n = easts[start:end], norths[start:end]
                items[start:end] = resolved = self.identity.resolve(items[start:end], e, n, self.tracker)
                took = self.tracker.ingest_many(resolved, e, n)
                self.identity.count(resolved, took)
                dirty.update(r.key for r, ok in zip(resolved, took) if ok)
                start = end
        except Exception as exc:  # noqa: BLE001  (stage boundary: isolate the intruder, below)
            self.containment.batch_failed("track", exc)
            self._ingest_alone(now_s, items, easts, norths, dirty, changes)

    def _ingest_alone(self, now_s, items, easts, norths, dirty, changes) -> None:
        by_key: dict[IntruderKey, list[int]] = {}
        for i, r in enumerate(items):
            by_key.setdefault(r.key, []).append(i)
        for key, idx in by_key.items():
            track = self.tracker.tracks.get(key)
            # the failed batch call may have applied some reports already: they are not applied twice
            idx = [i for i in idx if track is None or items[i].time_s > track.last_report_s + 1e-6]
            try:
                if idx:
                    self.tracker.ingest_many([items[i] for i in idx], [easts[i] for i in idx], [norths[i] for i in idx])
            except Exception as exc:  # noqa: BLE001
                self.containment.fail(now_s, key, "track", exc, changes)
                continue
            if key in self.tracker.tracks:
                dirty.add(key)

    def _ingest(self, item: Input, reports: list[IntruderReport]) -> None:
        if not _finite_input(item):  # no NaN or inf goes into a filter (the tangent plane included)
            self.counters["input.non_finite"] += 1
            return
        if isinstance(item, IntruderReport):
            reports.append(item)
            if item.uncertainty is not None:
                self.stated_errors[item.key] = item.uncertainty.errors()
        elif isinstance(item, OwnshipFix):
            if item.uncertainty is not None:
                self.own_errors = item.uncertainty.errors()
            try:
                if not self.ownship.update_fix(*self._follow_ownship(item)):
                    self.counters["ownship.out_of_order"] += 1
                self.containment.ownship_works()
            except Exception as exc:  # noqa: BLE001  (stage boundary: the ownship filter)
                self._ownship_failed(item.time_s, exc)
        elif isinstance(item, OwnshipPressure):
            try:
                if not self.ownship.update_pressure(item):
                    self.counters["ownship_pressure.before_first_fix"] += 1
            except Exception as exc:  # noqa: BLE001
                self._ownship_failed(item.time_s, exc)
        else:
            raise TypeError(f"not a core input: {item!r}")

    def _ownship_failed(self, now_s: float, exc: Exception) -> None:
        """The ownship filter raised: it restarts empty, so ownship is unknown (every advisory ends with reason
        no_ownship, DAA unavailable) until the next fix starts it again."""
        self.containment.ownship_failed(now_s, exc)
        self.ownship = OwnshipFilter(self.config.altitude, self.config.input, self.counters)


def _finite_input(item) -> bool:
    """Every number of a core input is finite (the decoder guarantees it for MAVLink; other callers may not)."""
    isfinite = math.isfinite
    if not isfinite(item.time_s):
        return False
    if isinstance(item, IntruderReport):
        return isfinite(item.lat_deg) and isfinite(item.lon_deg) and \
            (item.altitude_m is None or isfinite(item.altitude_m)) and \
            (item.vertical_rate_mps is None or isfinite(item.vertical_rate_mps)) and \
            (item.velocity_en_mps is None or all(isfinite(v) for v in item.velocity_en_mps))
    if isinstance(item, OwnshipFix):
        return isfinite(item.lat_deg) and isfinite(item.lon_deg) and isfinite(item.alt_msl_m) and \
            isfinite(item.height_above_home_m) and all(isfinite(v) for v in item.velocity_ned_mps)
    if isinstance(item, OwnshipPressure):
        return isfinite(item.pressure_altitude_m)
    return True  # not a core input: _ingest says so
