"""Track lifecycle: one CV Kalman track per intruder key, initiation, plausibility gate, coasting, deletion.

Reports are applied in time order per track: an out-of-order or duplicate report is counted and dropped.
A report that no aircraft could have produced from the track's state is not merged: it is counted, and
after three in a row the track is restarted from the new reports (two aircraft under one address must
never become one silent average).
"""

from __future__ import annotations

import math
from collections import Counter
from dataclasses import dataclass, field

import numpy as np

from avionics.config import TrackingConfig
from avionics.core.types import AddressSource, IntruderKey, IntruderReport
from avionics.tracking.integrity import IntegrityMonitor
from avionics.tracking.kalman_cv import CvKalman, Measurement
from avionics.tracking.record import (DUPLICATE_WINDOW_S, REJECTS_BEFORE_RESTART, UNKNOWN_ALT_SIGMA_M,
                                      UNKNOWN_SPEED_SIGMA_MPS, UNKNOWN_VRATE_SIGMA_MPS, TrackRecord)


@dataclass
class IntruderTrack(TrackRecord):
    kf: CvKalman = field(kw_only=True)


class IntruderTracker:
    def __init__(self, config: TrackingConfig, counters: Counter):
        self.config = config
        self.counters = counters
        self.tracks: dict[IntruderKey, IntruderTrack] = {}
        self.integrity = IntegrityMonitor(config.velocity_sigma_mps)  # per key, sees every report

    # -- measurement model -------------------------------------------------------------------------------
    def _measurement(self, report: IntruderReport, east: float, north: float) -> Measurement:
        cfg = self.config
        pos_sigma = cfg.position_sigma_uat_m if report.key.source is AddressSource.UAT else cfg.position_sigma_1090es_m
        index, value, sigma = [0, 1], [east, north], [pos_sigma, pos_sigma]
        if report.altitude_m is not None:
            index.append(2), value.append(report.altitude_m), sigma.append(cfg.altitude_sigma_m)
        if report.velocity_en_mps is not None:
            index += [3, 4]
            value += list(report.velocity_en_mps)
            sigma += [cfg.velocity_sigma_mps] * 2
        if report.vertical_rate_mps is not None:
            index.append(5), value.append(report.vertical_rate_mps), sigma.append(cfg.vertical_rate_sigma_mps)
        return Measurement(tuple(index), np.array(value, float), np.array(sigma, float))

    def _initiate(self, report: IntruderReport, z: Measurement) -> IntruderTrack:
        """Initial state from one report: measured components at their noise, the rest at honest priors."""
        x = np.zeros(6)
        var = np.array([UNKNOWN_ALT_SIGMA_M] * 3 + [UNKNOWN_SPEED_SIGMA_MPS] * 2 + [UNKNOWN_VRATE_SIGMA_MPS]) ** 2
        x[list(z.index)] = z.value
        var[list(z.index)] = z.sigma**2
        kf = CvKalman(report.time_s, x, np.diag(var), self.config.horizontal_accel_sigma_mps2,
                      self.config.vertical_accel_sigma_mps2)
        track = IntruderTrack(report.key, report.altitude_datum, report.time_s, report.time_s,
                              report.time_s if report.altitude_m is not None else None, kf=kf)
        track.copy_identity(report)
        self.counters["track.initiated"] += 1
        return track

    def reframe(self, change) -> None:
        """The tangent plane moved (avionics/core/frame.py): carry every track's state into it."""
        self.integrity.reframe(change)
        tracks = list(self.tracks.values())
        if not tracks:
            return
        xs, ps, _ = change.carry(np.array([t.kf.x for t in tracks]), np.array([t.kf.p for t in tracks]), vectors=(3,))
        for track, x, p in zip(tracks, xs, ps):
            track.kf.x, track.kf.p = x, p

    def mode_infos(self, keys: list[IntruderKey], t_s: float | None = None) -> list[None]:
        """The IMM tracker's mode outputs; a single-model filter has none."""
        return [None] * len(keys)

    # -- lifecycle ---------------------------------------------------------------------------------------
    def ingest_many(self, reports: list[IntruderReport], easts, norths) -> list[bool]:
        """The IMM tracker's batch interface: the reports one at a time, in arrival order."""
        return [self.ingest(r, float(e), float(n)) for r, e, n in zip(reports, easts, norths)]

    def ingest(self, report: IntruderReport, east: float, north: float) -> bool:
        """Apply one report; True when it updated or started a track, False when it was counted and dropped."""
        track = self.tracks.get(report.key)
        if track is not None:
            dt = report.time_s - track.last_report_s
            if abs(dt) <= DUPLICATE_WINDOW_S:
                self.counters["report.duplicate"] += 1
                return False
            if dt < 0:
                self.counters["report.out_of_order"] += 1
                return False
        took = self._apply(report, east, north, track, self._observe(report, east, north))
        track = self.tracks[report.key]  # the key's track carries the key's integrity (also after a restart)
        track.integrity = self.integrity.status(report.key)
        track.report_offset = (east - float(track.kf.x[0]), north - float(track.kf.x[1]), report.altitude_m)
        return took

    def _observe(self, report: IntruderReport, east: float, north: float) -> bool:
        """The integrity monitor sees every report of the key before the plausibility gate; True when the report
        repeats a stale position (then only its velocity and altitude are used)."""
        cfg = self.config
        sigma = cfg.position_sigma_uat_m if report.key.source is AddressSource.UAT else cfg.position_sigma_1090es_m
        track = self.tracks.get(report.key)
        previous = None  # the previous report in today's plane: the track's state (carried by reframe) + offset
        if track is not None and track.report_offset is not None:
            previous = [(track.kf.x[0] + track.report_offset[0], track.kf.x[1] + track.report_offset[1])]
        return bool(self.integrity.observe([report.key], [report.time_s], [report.received_s], [east], [north],
                                           [report.velocity_en_mps or (math.nan, math.nan)], [sigma], previous)[0])

    def _apply(self, report: IntruderReport, east: float, north: float, track: IntruderTrack | None,
               stale: bool) -> bool:
        z = self._measurement(report, east, north)
        if track is None:
            self.tracks[report.key] = self._initiate(report, z)
            return True
        dt = report.time_s - track.last_report_s
        if stale:  # the position repeats a stale value: not a measurement (integrity.py, `inconsistent`)
            z = Measurement(z.index[2:], z.value[2:], z.sigma[2:])
        if report.altitude_m is not None and report.altitude_datum is not track.datum:
            # The sender switched altitude source: the old vertical state is in another datum.
            self.counters["track.datum_change"] += 1
            track.kf.reset_vertical(None, UNKNOWN_ALT_SIGMA_M, None, UNKNOWN_VRATE_SIGMA_MPS)
            track.datum = report.altitude_datum
        if not stale and not self._plausible(track, report, z, dt):
            track.consecutive_rejects += 1
            self.counters["track.implausible_jump"] += 1
            if track.consecutive_rejects >= REJECTS_BEFORE_RESTART:
                self.counters["track.restarted"] += 1
                self.tracks[report.key] = self._initiate(report, z)
                return True
            return False
        track.kf.update(report.time_s, z)
        track.consecutive_rejects = 0
        track.last_report_s = report.time_s
        track.n_updates += 1
        if report.altitude_m is not None:
            track.last_altitude_s = report.time_s
        track.copy_identity(report)
        return True

    def _plausible(self, track: IntruderTrack, report: IntruderReport, z: Measurement, dt: float) -> bool:
        """Could the tracked aircraft be where this report says? Distance beyond max speed x time + 5 sigma."""
        innovation, s = track.kf.innovation(report.time_s, Measurement(z.index[:2], z.value[:2], z.sigma[:2]))
        allowed = self.config.max_innovation_speed_mps * max(dt, 1.0) + 5.0 * math.sqrt(np.trace(s))
        return float(np.hypot(*innovation)) <= allowed

    def prune(self, now_s: float) -> list[IntruderKey]:
        """Delete tracks silent for longer than delete_after_s."""
        dead = [k for k, t in self.tracks.items() if now_s - t.last_report_s > self.config.delete_after_s]
        for key in dead:
            del self.tracks[key]
            self.integrity.forget(key)
            self.counters["track.deleted"] += 1
        for key in self.integrity.check_silence(now_s):  # position loss while the track lives
            if key in self.tracks:
                self.tracks[key].integrity = self.integrity.status(key)
        return dead

    def predict(self, keys: list[IntruderKey], t_s: float) -> tuple[np.ndarray, np.ndarray]:
        """States (N, 6) and covariances (N, 6, 6) of the given tracks at t_s."""
        xs = np.empty((len(keys), 6))
        ps = np.empty((len(keys), 6, 6))
        for i, key in enumerate(keys):
            xs[i], ps[i] = self.tracks[key].kf.predict_to(t_s)
        return xs, self.integrity.widen(keys, ps)  # a degraded track's position is widened by its fault size
