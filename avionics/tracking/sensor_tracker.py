"""Tracks of aircraft seen only by a range/bearing sensor (radar, active surveillance): reports without identity.

Each scan's measurements (measurement.PolarMeasurement, one sensor, one time) are converted to the tracking frame
(measurement.to_tracking_frame: the unbiased conversion and its covariance), associated with the tracks by gate and
global nearest neighbour (association.py) and applied to the same IMM banks as ADS-B's (imm.ImmBank: horizontal
[x, y, vx, vy, ax, ay], vertical [z, vz]) with the converted measurement's full 2 x 2 covariance (ImmBank.update's
r_cov); a measurement without an elevation (active surveillance) updates as the EKF linearised at the track's
prediction (measurement.about_prediction), whose range is not biased by a wide bearing error. An active-
surveillance track with coarse bearings also keeps a range track (range_tracker.py: its published range and
closure) and, when its altitudes are Mode C's 100 ft levels, a level-transition altitude track
(altitude_tracker.py: its published altitude and vertical rate), as TCAS II reads them.

Lifecycle (Blackman & Popoli 1999, Sec. 3.3, M-of-N confirmation):
- an unassociated measurement starts a tentative track (position at its converted covariance, velocity at the
  ADS-B tracker's honest prior, record.UNKNOWN_SPEED_SIGMA_MPS);
- a tentative track is confirmed once it was detected in M of its last N scans (default 3 of 5: at the radar's
  10 Hz, half a second; at active surveillance's 1 Hz, five seconds), and dropped once it no longer can be;
- a confirmed track is deleted after delete_after_s (20 s, [tracking]'s) without a detection.
Only confirmed tracks are published (`confirmed`); `predict` gives them in the pipeline's [e, n, alt, ve, vn, vu].
A measurement that fails PolarMeasurement.problem() is counted `sensor.rejected` and goes no further.
"""

from __future__ import annotations

import itertools
import math
from collections import Counter, deque
from dataclasses import dataclass, field

import numpy as np

from avionics.base.chi2 import chi2_quantile
from avionics.tracking import models
from avionics.tracking.altitude_tracker import QuantisedAltitudeTrack, mode_c_quantum
from avionics.tracking.association import gnn
from avionics.tracking.imm import ImmBank, spd_inverse
from avionics.tracking.imm_tracker import assemble
from avionics.tracking.measurement import (PolarMeasurement, about_prediction, ground_polar,
                                           range_rate_about_prediction, to_tracking_frame)
from avionics.tracking.range_tracker import RangeTrack, along_line_of_sight
from avionics.tracking.record import UNKNOWN_SPEED_SIGMA_MPS, UNKNOWN_VRATE_SIGMA_MPS


@dataclass
class SensorTrack:
    track_id: int
    slot: int
    t_s: float  # time of the last detection applied
    started_s: float  # time of its first detection
    hits: deque = field(default_factory=deque)  # detected (True) or missed in each of the last N scans
    confirmed: bool = False
    n_updates: int = 1
    address: int | None = None  # a Mode S reply's address, if any report carried one
    detection_cov: np.ndarray | None = None  # (3, 3) [e, n, alt] covariance its last detection declared
    ranging: RangeTrack | None = None  # active surveillance: its slant range alone (range_tracker.py)
    vertical: QuantisedAltitudeTrack | None = None  # ... and its Mode C altitudes (altitude_tracker.py)


class SensorTracker:
    """Tracks of one sensor (or several of the same kind: merge their detections of one instant into one scan).
    h_modes, v_modes: the IMM's motion models (as the ADS-B tracker's, models.MotionModel objects); confirm (M, N);
    gate_probability: the chi-square gate of a report against a track's prediction (3 dof: east, north, altitude);
    switch_probability, gate_probability, delete_after_s and initial_accel_sigma_mps2 default to [tracking]'s
    imm_switch_probability, gate_probability, delete_after_s and imm_initial_accel_sigma_mps2 (a radar track must
    outlive the radar's 4000 ft blind zone, about 12 s of a head-on closing; a radar's switching is [tracking]
    radar_switch_probability, TrackingConfig.modes_for);
    turn_exit_probability: a fixed-rate turn mode's ([tracking] imm_turn_exit_probability, models.mode_switching);
    range_track_bearing_sigma_deg: a track started by a detection without an elevation whose declared bearing sigma
    is at least this keeps a range track ([tracking]'s);
    range_rate_correlation_s: a measured range rate's declared error is taken as one draw over this long
    ([tracking]'s; _range_rates)."""

    def __init__(self, h_modes, v_modes, *, switch_probability: float = 0.05, turn_exit_probability: float = 0.2,
                 confirm: tuple[int, int] = (3, 5),
                 gate_probability: float = 0.9999, delete_after_s: float = 20.0, initial_accel_sigma_mps2: float = 3.0,
                 range_track_bearing_sigma_deg: float = 2.0, range_rate_correlation_s: float = 1.0,
                 counters: Counter | None = None, capacity: int = 16):
        m, n = confirm
        if not 1 <= m <= n:
            raise ValueError(f"confirmation needs 1 <= M <= N, got {confirm}")
        self.m, self.n = m, n
        self.gate = chi2_quantile(gate_probability, 3)
        self.delete_after_s = delete_after_s
        self.initial_accel_sigma_mps2 = initial_accel_sigma_mps2
        self.range_track_bearing_rad = math.radians(range_track_bearing_sigma_deg)
        self.range_rate_correlation_s = range_rate_correlation_s
        self.counters = counters if counters is not None else Counter()
        m_h, m_v = models.bank_switching(h_modes, v_modes, switch_probability, turn_exit_probability)
        self.bank_h = ImmBank(list(h_modes), 4, m_h, capacity=capacity)
        self.bank_v = ImmBank(list(v_modes), 2, m_v, capacity=capacity)
        self.tracks: dict[int, SensorTrack] = {}
        self._free = list(range(capacity - 1, -1, -1))
        self._ids = itertools.count(1)
        self._own: tuple | None = None  # (t_s, [e, n, alt, ve, vn, vu]) of the ownship at the last scan

    @property
    def confirmed(self) -> list[SensorTrack]:
        return [t for t in self.tracks.values() if t.confirmed]

    # -- one scan --------------------------------------------------------------------------------------------
    def scan(self, t_s: float, measurements: list[PolarMeasurement], own_enu, own_heading_rad,
             own_velocity=None) -> list:
        """Apply one scan at t_s (its measurements; an empty scan counts as a miss for every track). own_velocity:
        the ownship's [v_east, v_north, v_up] at t_s, for a measured range rate (None: range rates unused).
        Returns, per measurement, the id of the track it updated or started (None: rejected)."""
        good = []
        for i, m in enumerate(measurements):
            why = m.problem()
            if why is None and abs(m.time_s - t_s) <= 1e-6:
                good.append(i)
            else:
                self.counters["sensor.rejected"] += 1
        out: list = [None] * len(measurements)
        if own_velocity is not None:
            self._own = (t_s, np.concatenate([np.asarray(own_enu, float), np.asarray(own_velocity, float)]))
        meas = [measurements[i] for i in good]
        tracks = [t for t in self.tracks.values() if t.t_s < t_s]
        pairs = []
        if meas:
            z_h, r_h, z_v, r_v = to_tracking_frame(meas, own_enu, own_heading_rad)
            if tracks:
                d2, xh, xv, ph = self._distances(tracks, t_s, z_h, r_h, z_v, r_v)
                pairs = gnn(d2, self.gate)
            taken = {j for _, j in pairs}
            if pairs:
                self._relinearise(pairs, xh, meas, z_h, r_h, own_enu, own_heading_rad)
                paired = [tracks[i] for i, _ in pairs]
                rates = self._range_rates(t_s, pairs, paired, xh, xv, ph, meas, own_enu, own_velocity)
                self._update(paired, t_s, *(a[[j for _, j in pairs]] for a in (z_h, r_h, z_v, r_v)), rates)
                for i, j in pairs:
                    out[good[j]] = tracks[i].track_id
                    if tracks[i].ranging is not None:
                        tracks[i].ranging.update(t_s, meas[j].range_m, meas[j].range_sigma_m)
                    if tracks[i].vertical is not None and meas[j].altitude_m is not None:
                        tracks[i].vertical.update(t_s, meas[j].altitude_m)
                    if meas[j].address is not None:
                        tracks[i].address = meas[j].address
            new = [j for j in range(len(meas)) if j not in taken]
            if new:
                for j, trk in zip(new, self._start(t_s, *(a[new] for a in (z_h, r_h, z_v, r_v)))):
                    trk.address = meas[j].address
                    out[good[j]] = trk.track_id
                    if meas[j].elevation_rad is None and meas[j].azimuth_sigma_rad >= self.range_track_bearing_rad:
                        trk.ranging = RangeTrack.start(t_s, meas[j].range_m, meas[j].range_sigma_m)
                        quantum = mode_c_quantum(meas[j].altitude_sigma_m)
                        if quantum is not None:
                            trk.vertical = QuantisedAltitudeTrack.start(t_s, meas[j].altitude_m, quantum)
        hit = {tracks[i].track_id for i, _ in pairs}
        for trk in tracks:
            trk.hits.append(trk.track_id in hit)
            while len(trk.hits) > self.n:
                trk.hits.popleft()
            self._review(trk, t_s)
        return out

    def _distances(self, tracks, t_s, z_h, r_h, z_v, r_v) -> tuple:
        """d^2 (T, M) of each measurement against each track's prediction at t_s (horizontal and altitude), and the
        tracks' horizontal (T, 6) and vertical (T, 2) predictions and the horizontal covariances (T, 6, 6)."""
        slots = np.array([t.slot for t in tracks])
        dt = t_s - np.array([t.t_s for t in tracks])
        xh, ph, _ = self.bank_h.predict(slots, dt)
        xv, pv, _ = self.bank_v.predict(slots, dt)
        rh = xh[:, None, :2] - z_h[None, :, :]  # (T, M, 2)
        s_inv, _ = spd_inverse(ph[:, None, :2, :2] + r_h[None])
        d_h = np.einsum("tmi,tmij,tmj->tm", rh, s_inv, rh)
        d_v = (xv[:, None, 0] - z_v[None, :]) ** 2 / (pv[:, None, 0, 0] + r_v[None, :])
        return d_h + d_v, xh, xv, ph

    def _range_rates(self, t_s, pairs, paired, xh, xv, ph, meas, own_enu, own_velocity):
        """The paired measurements' range rates (the radar's) as horizontal velocity measurements linearised at the
        tracks' predictions (measurement.range_rate_about_prediction): (rows of pairs that have one, z, R), or
        None. Without the ownship's velocity a range rate cannot be turned into the intruder's, and is unused.

        paired: the pairs' tracks, not yet updated at t_s. A range rate's declared sigma covers a white error and a
        bias that lasts (Appendix Q's radar: 3.0 m/s white, up to 2.4 m/s for the run); taken as white at 10 Hz, ten
        a second average to 1.2 m/s, under the bias, and the track runs tens of metres behind its detections until
        one falls out of the gate and the track splits (docs/tracking.md, "A radar track's range rates"). So the
        range rates of one correlation time (range_rate_correlation_s) are taken as one draw: each one's variance is
        scaled by the number of them the track has had in that time, min(range_rate_correlation_s, age) / since, at
        least 1 (age and since: the time since its first and its last detection; a variance inflation factor in
        place of a state for the correlated error: Kermarrec, Jain & Schoen, "Kalman filter and correlated
        measurement noise: the variance inflation factor", IEEE Trans. AES 58(2), 2022). A young track's first range
        rates keep their weight: its velocity comes from little else in its first second."""
        if own_velocity is None:
            return None
        rows = [k for k, (_, j) in enumerate(pairs) if meas[j].range_rate_mps is not None
                and meas[j].elevation_rad is not None]
        if not rows:
            return None
        ts, js = [pairs[k][0] for k in rows], [pairs[k][1] for k in rows]
        own = np.asarray(own_enu, float)
        v_own = np.asarray(own_velocity, float)
        since = t_s - np.array([paired[k].t_s for k in rows])
        age = t_s - np.array([paired[k].started_s for k in rows])
        shared = np.minimum(self.range_rate_correlation_s, age)  # the track's own range rates of one draw
        inflation = np.maximum(shared / np.maximum(since, 1e-6), 1.0)
        sigma = np.array([meas[j].range_rate_sigma_mps for j in js]) * np.sqrt(inflation)
        z, r = range_rate_about_prediction(
            [meas[j].range_rate_mps for j in js], sigma,
            [meas[j].elevation_rad for j in js], xh[ts, :2] - own[:2], np.broadcast_to(v_own[:2], (len(js), 2)),
            xv[ts, 1] - v_own[2], xh[ts, 2:4], ph[ts, :2, :2])
        return np.array(rows), z, r

    def _relinearise(self, pairs, xh, meas, z_h, r_h, own_enu, own_heading_rad) -> None:
        """A paired measurement without an elevation (active surveillance: a 9-15 deg bearing) updates its track as
        the extended Kalman filter linearised at the track's prediction (xh, the gate's) does
        (measurement.about_prediction), in place of its converted position, which biases the range outwards;
        gating and new tracks keep the converted one (there is no prediction to linearise at). The radar's 1 deg
        conversion is kept: its bias is r sigma^2 = 0.015 % of the range."""
        rows = [(i, j) for i, j in pairs if meas[j].elevation_rad is None]
        if not rows:
            return
        own = np.broadcast_to(np.asarray(own_enu, float), (len(meas), 3))
        ts, js = [i for i, _ in rows], [j for _, j in rows]
        rho, s_rho, bearing, s_b = ground_polar([meas[j] for j in js], own[js], own_heading_rad)
        z, r = about_prediction(rho, s_rho, bearing, s_b, xh[ts, :2] - own[js, :2])
        z_h[js], r_h[js] = z + own[js, :2], r

    def _update(self, tracks, t_s, z_h, r_h, z_v, r_v, rates=None) -> None:
        """rates: (rows, z, R) of the tracks that also measured their horizontal velocity (_range_rates)."""
        b = len(tracks)
        slots = np.array([t.slot for t in tracks])
        dt = t_s - np.array([t.t_s for t in tracks])
        zh = np.zeros((b, 4))
        zh[:, :2] = z_h
        mh = np.zeros((b, 4), bool)
        mh[:, :2] = True
        rc = np.tile(np.eye(4), (b, 1, 1))
        rc[:, :2, :2] = r_h
        if rates is not None:
            rows, z_rate, r_rate = rates
            zh[rows, 2:4], mh[rows, 2:4], rc[rows, 2:4, 2:4] = z_rate, True, r_rate
        zv = np.zeros((b, 2))
        zv[:, 0] = z_v
        mv = np.array([[True, False]] * b)
        self.bank_h.commit(self.bank_h.update(slots, dt, zh, mh, np.ones((b, 4)), r_cov=rc))
        self.bank_v.commit(self.bank_v.update(slots, dt, zv, mv, np.stack([r_v, np.ones(b)], axis=1)))
        for trk, cov in zip(tracks, _position_covariances(r_h, r_v)):
            trk.t_s = t_s
            trk.n_updates += 1
            trk.detection_cov = cov

    def _start(self, t_s, z_h, r_h, z_v, r_v) -> list[SensorTrack]:
        b = len(z_h)
        if len(self._free) < b:
            old = self.bank_h.capacity
            new = max(2 * old, old + b)
            self.bank_h.grow(new)
            self.bank_v.grow(new)
            self._free = list(range(new - 1, old - 1, -1)) + self._free
        slots = np.array([self._free.pop() for _ in range(b)])
        x = np.zeros((b, 6))
        x[:, :2] = z_h
        p = np.zeros((b, 6, 6))
        p[:, :2, :2] = r_h
        p[:, 2, 2] = p[:, 3, 3] = UNKNOWN_SPEED_SIGMA_MPS**2
        p[:, 4, 4] = p[:, 5, 5] = self.initial_accel_sigma_mps2**2
        self.bank_h.init(slots, x, p)
        xv = np.stack([z_v, np.zeros(b)], axis=1)
        pv = np.zeros((b, 2, 2))
        pv[:, 0, 0], pv[:, 1, 1] = r_v, UNKNOWN_VRATE_SIGMA_MPS**2
        self.bank_v.init(slots, xv, pv)
        out = []
        for s, cov in zip(slots, _position_covariances(r_h, r_v)):
            trk = SensorTrack(next(self._ids), int(s), t_s, t_s, deque([True]), confirmed=self.m == 1,
                              detection_cov=cov)
            self.tracks[trk.track_id] = trk
            self.counters["sensor.track_started"] += 1
            out.append(trk)
        return out

    def _review(self, trk: SensorTrack, t_s: float) -> None:
        """M-of-N confirmation of a tentative track, deletion of a hopeless or a silent one."""
        if not trk.confirmed:
            if sum(trk.hits) >= self.m:
                trk.confirmed = True
                self.counters["sensor.track_confirmed"] += 1
            elif sum(trk.hits) + (self.n - len(trk.hits)) < self.m:
                self.delete(trk, "sensor.tentative_dropped")
        elif t_s - trk.t_s > self.delete_after_s:
            self.delete(trk, "sensor.track_deleted")

    def delete(self, trk: SensorTrack, counter: str) -> None:
        del self.tracks[trk.track_id]
        self._free.append(trk.slot)
        self.counters[counter] += 1

    def ranging(self, track_ids, t_s: float) -> np.ndarray:
        """(N, 3) each track's range track [r, r_dot, r_ddot] predicted to t_s; NaN for a track without one."""
        out = np.full((len(track_ids), 3), np.nan)
        for k, track_id in enumerate(track_ids):
            ranging = self.tracks[track_id].ranging
            if ranging is not None:
                out[k] = ranging.predicted(t_s)[0]
        return out

    def reframe(self, change) -> None:
        """Carry the tracks and the ownship kept from the last scan into a new tangent plane (base/frame.py)."""
        self.bank_h.reframe(change, np.array([t.slot for t in self.tracks.values()], int))
        if self._own is not None:
            t_own, own = self._own
            h, _, _ = change.carry(own[[0, 1, 3, 4]], np.zeros((4, 4)), vectors=(2,))
            self._own = (t_own, np.array([h[0], h[1], own[2], h[2], h[3], own[5]]))

    # -- outputs ---------------------------------------------------------------------------------------------
    def predict(self, track_ids, t_s: float, consider_bias: bool = False) -> tuple[np.ndarray, np.ndarray]:
        """States (N, 6) [east, north, alt, v_east, v_north, v_up] and covariances (N, 6, 6) at t_s.

        consider_bias: add to the position block the covariance the track's last detection declared. A sensor
        declares its random error and its bias in quadrature (PolarMeasurement) and the banks take every detection
        as independent, so at 10 Hz a track's position covariance shrinks below the bias, which no averaging
        removes (Appendix Q's radar: range bias up to 15 m, angles 0.5 deg, 22 m at 2.5 km). Comparing the track
        with another sensor's (association with ADS-B, fusion) needs that bias back: this is Schmidt's "consider"
        covariance at its bound (all of one detection's declared error a bias; Bar-Shalom et al. 2001, Sec. 7.3
        on sensor bias)."""
        if not len(track_ids):
            return np.empty((0, 6)), np.empty((0, 6, 6))
        trks = [self.tracks[i] for i in track_ids]
        slots = np.array([t.slot for t in trks])
        dt = t_s - np.array([t.t_s for t in trks])
        xh, ph, _ = self.bank_h.predict(slots, dt)
        xv, pv, _ = self.bank_v.predict(slots, dt)
        x, p = assemble(xh, ph, xv, pv)
        own = None
        if self._own is not None:
            t_own, own = self._own
            own = np.concatenate([own[:3] + own[3:] * (t_s - t_own), own[3:]])
        for k, trk in enumerate(trks):
            if trk.vertical is not None:  # first: the line of sight reads the height and its rate
                x[k], p[k] = trk.vertical.into(x[k], p[k], t_s)
            if trk.ranging is not None and own is not None:
                x[k], p[k] = along_line_of_sight(x[k], p[k], *trk.ranging.predicted(t_s), own)
        if consider_bias:
            p[:, :3, :3] += np.array([t.detection_cov for t in trks])
        return x, p


def _position_covariances(r_h: np.ndarray, r_v: np.ndarray) -> np.ndarray:
    """(B, 3, 3) [e, n, alt] covariances of detections from their horizontal (B, 2, 2) and altitude (B,) parts."""
    cov = np.zeros((len(r_h), 3, 3))
    cov[:, :2, :2], cov[:, 2, 2] = r_h, r_v
    return cov

