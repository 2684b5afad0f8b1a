"""The CV intruder tracker: one CV Kalman track per intruder key under the shared lifecycle (lifecycle.py:
ordering, integrity, initiation, record keeping, deletion), with a plausibility gate.

A report that no aircraft could have produced from the track's state is not merged: it is counted, and
after three in a row the track is restarted from the new reports (two aircraft under one address must
never become one silent average).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from avionics.base.types import IntruderKey, IntruderReport
from avionics.tracking.kalman_cv import CvKalman, Measurement
from avionics.tracking.lifecycle import TrackLifecycle
from avionics.tracking.record import (REJECTS_BEFORE_RESTART, UNKNOWN_ALT_SIGMA_M, UNKNOWN_SPEED_SIGMA_MPS,
                                      UNKNOWN_VRATE_SIGMA_MPS, TrackRecord)


@dataclass
class IntruderTrack(TrackRecord):
    kf: CvKalman = field(kw_only=True)


class IntruderTracker(TrackLifecycle):
    """The Tracker interface (interface.py) over one CvKalman per key, reports applied one at a time."""

    vectorised = False
    track_type = IntruderTrack

    # -- measurement model -------------------------------------------------------------------------------
    def _measurement(self, report: IntruderReport, east: float, north: float) -> Measurement:
        cfg = self.config
        pos_sigma = self.position_sigma_m(report)
        index, value, sigma = [0, 1], [east, north], [pos_sigma, pos_sigma]
        if report.altitude_m is not None:
            index.append(2), value.append(report.altitude_m), sigma.append(cfg.altitude_sigma_m)
        if report.velocity_en_mps is not None:
            index += [3, 4]
            value += list(report.velocity_en_mps)
            sigma += [self.velocity_sigma_mps(report)] * 2
        if report.vertical_rate_mps is not None:
            index.append(5), value.append(report.vertical_rate_mps), sigma.append(cfg.vertical_rate_sigma_mps)
        return Measurement(tuple(index), np.array(value, float), np.array(sigma, float))

    def _init_filters(self, reps: list[IntruderReport], easts, norths) -> list[dict]:
        """Initial state from one report: measured components at their noise, the rest at honest priors."""
        out = []
        for report, east, north in zip(reps, easts, norths):
            z = self._measurement(report, float(east), float(north))
            x = np.zeros(6)
            var = np.array([UNKNOWN_ALT_SIGMA_M] * 3 + [UNKNOWN_SPEED_SIGMA_MPS] * 2 + [UNKNOWN_VRATE_SIGMA_MPS]) ** 2
            x[list(z.index)] = z.value
            var[list(z.index)] = z.sigma**2
            out.append({"kf": CvKalman(report.time_s, x, np.diag(var), self.config.horizontal_accel_sigma_mps2,
                                       self.config.vertical_accel_sigma_mps2)})
        return out

    def _positions(self, tracks: list[IntruderTrack]) -> np.ndarray:
        return np.array([t.kf.x[:2] for t in tracks]).reshape(-1, 2)

    def _reset_vertical(self, track: IntruderTrack) -> None:
        track.kf.reset_vertical(None, UNKNOWN_ALT_SIGMA_M, None, UNKNOWN_VRATE_SIGMA_MPS)

    def reframe(self, change) -> None:
        """The tangent plane moved (avionics/base/frame.py): carry every track's state into it."""
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

    # -- update ------------------------------------------------------------------------------------------
    def _update_round(self, upd: list[int], reports, easts, norths, stale: np.ndarray, out: np.ndarray) -> None:
        reps = [reports[i] for i in upd]
        tracks = [self.tracks[r.key] for r in reps]
        self._datum_changes(tracks, reps)
        for k, (i, rep, track) in enumerate(zip(upd, reps, tracks)):
            out[i] = self._apply(rep, float(easts[i]), float(norths[i]), track, bool(stale[k]))

    def _apply(self, report: IntruderReport, east: float, north: float, track: IntruderTrack, stale: bool) -> bool:
        z = self._measurement(report, east, north)
        dt = report.time_s - track.last_report_s
        if stale:  # the position repeats a stale value: not a measurement (integrity.py, `inconsistent`)
            z = Measurement(z.index[2:], z.value[2:], z.sigma[2:])
        if not stale and not self._plausible(track, report, z, dt):
            track.consecutive_rejects += 1
            self.counters["track.implausible_jump"] += 1
            if track.consecutive_rejects >= REJECTS_BEFORE_RESTART:
                self.counters["track.restarted"] += 1
                self._start([report], [east], [north], self.tracks)
                return True
            return False
        track.kf.update(report.time_s, z)
        self._accepted(track, report)
        return True

    def _plausible(self, track: IntruderTrack, report: IntruderReport, z: Measurement, dt: float) -> bool:
        """Could the tracked aircraft be where this report says? Distance beyond max speed x time + 5 sigma."""
        innovation, s = track.kf.innovation(report.time_s, Measurement(z.index[:2], z.value[:2], z.sigma[:2]))
        allowed = self.config.max_innovation_speed_mps * max(dt, 1.0) + 5.0 * math.sqrt(np.trace(s))
        return float(np.hypot(*innovation)) <= allowed

    def predict(self, keys: list[IntruderKey], t_s: float) -> tuple[np.ndarray, np.ndarray]:
        """States (N, 6) and covariances (N, 6, 6) of the given tracks at t_s."""
        xs = np.empty((len(keys), 6))
        ps = np.empty((len(keys), 6, 6))
        for i, key in enumerate(keys):
            xs[i], ps[i] = self.tracks[key].kf.predict_to(t_s)
        return xs, self.integrity.widen(keys, ps)  # a degraded track's position is widened by its fault size
