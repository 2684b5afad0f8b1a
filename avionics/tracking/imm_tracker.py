"""IMM intruder tracker: the Tracker interface (interface.py) over two vectorised IMM banks (horizontal, vertical),
under the shared lifecycle (lifecycle.py).

Each intruder key owns one slot in a horizontal bank ([x, y, vx, vy, ax, ay], the motion models it is given: the
composition root builds them from tracking.imm_horizontal_modes) and in a vertical bank ([z, vz], CH/CAD), Baek &
Bang's decoupled structure
(their Fig. 2). A report updates only its track's slot; `ingest_many` applies a batch of reports with one
vectorised IMM cycle per bank (at most one report per track per cycle, each key's reports in arrival order).

Lifecycle:
- **Initiation** from the first report: measured components at their measurement variance, unmeasured ones at
  honest priors (horizontal velocity 150 m/s, vertical rate 15 m/s, acceleration imm_initial_accel_sigma_mps2).
- **Ordering:** a report not newer than the track's last is counted (report.duplicate / report.out_of_order)
  and dropped; reports are applied at their time of applicability (receipt time back-dated by tslc).
- **Validation gate** (Radosavljevic eq 17): d^2 = r^T S^-1 r of the report against the track's prediction,
  taken for the most permissive mode hypothesis of each bank and summed over the banks, against the chi-square
  quantile for gate_probability and the number of measured components. Before that, a physical test: a
  position further than max_innovation_speed_mps x dt (+5 sigma) from the prediction is counted
  track.implausible_jump; one inside that but outside the chi-square gate is counted track.gate_miss. Either way
  the report is not merged: it starts (or updates) a competing track for the same key, kept out of `tracks`.
  When the main track has missed REJECTS_BEFORE_RESTART reports in a row and its competitor took them, the
  competitor replaces it (track.restarted). Two aircraft under one address are never averaged.
- **Coasting:** between reports nothing changes; predictions use the Markov chain alone for the modes.
- **Deletion** after delete_after_s without an accepted report (competitors after max_coast_s).
"""

from __future__ import annotations

import math
from collections import Counter
from dataclasses import dataclass, field
from types import SimpleNamespace

import numpy as np
from avionics.base import jit
from avionics.base.chi2 import chi2_quantile

from avionics.base.types import IntruderKey, IntruderReport
from avionics.tracking import models
from avionics.tracking.imm import ImmBank, VbParams
from avionics.tracking.lifecycle import TrackLifecycle
from avionics.tracking.record import (DUPLICATE_WINDOW_S, REJECTS_BEFORE_RESTART, UNKNOWN_ALT_SIGMA_M,
                                      UNKNOWN_SPEED_SIGMA_MPS, UNKNOWN_VRATE_SIGMA_MPS, TrackRecord)

kernels = jit.lazy(__name__, "avionics.tracking.kernels")  # the module, once jit.load() ran (jit.py)

H_MEAS = 4  # [x, y, vx, vy]
V_MEAS = 2  # [z, vz]
# state index maps between the pipeline's [e, n, alt, ve, vn, vu] and the banks
PIPE_FROM_H = np.array([0, 1, 3, 4])  # pipeline indices of bank-H [x, y, vx, vy]
PIPE_FROM_V = np.array([2, 5])  # pipeline indices of bank-V [z, vz]


@dataclass
class ImmTrack(TrackRecord):
    slot: int = field(kw_only=True)
    tracker: "ImmTracker | None" = field(default=None, kw_only=True, repr=False, compare=False)

    @property
    def kf(self) -> SimpleNamespace:
        """The combined posterior at the last accepted report, as x [e, n, alt, ve, vn, vu], p, t_s (the
        attributes of the CV tracker's filter that callers read)."""
        x, p = self.tracker._posterior(np.array([self.slot]))
        return SimpleNamespace(x=x[0], p=p[0], t_s=self.last_report_s)


class ImmTracker(TrackLifecycle):
    """The Tracker interface over two IMM banks: horizontal (models.MotionModel objects on [x, y, vx, vy, ax, ay])
    and vertical (on [z, vz]); likelihood "standard" or RMIMM's (imm.LIKELIHOODS), vb the variational-Bayes
    measurement noise or None; name the variant's label in the outputs. Plus mode_info and ingest (one report)."""

    vectorised = True
    track_type = ImmTrack

    def __init__(self, params, counters: Counter | None, horizontal: list[models.MotionModel],
                 vertical: list[models.MotionModel], *, likelihood: str = "standard", vb: VbParams | None = None,
                 name: str = "imm", capacity: int = 16, compiled: bool | None = None):
        super().__init__(params, counters, capacity)
        self.model = name
        self.h_modes = list(horizontal)
        self.v_modes = list(vertical)
        kw = dict(likelihood=likelihood, vb=vb, rmimm_floor=params.rmimm_floor, capacity=capacity,
                  yaw_time_constant_s=params.yaw_rate_time_constant_s, compiled=compiled)
        m_h, m_v = models.bank_switching(self.h_modes, self.v_modes, params.imm_switch_probability,
                                         params.imm_turn_exit_probability)
        self.bank_h = ImmBank(self.h_modes, H_MEAS, m_h, **kw)
        self.bank_v = ImmBank(self.v_modes, V_MEAS, m_v, **kw)
        self._t = np.zeros(capacity)  # time of each slot's last accepted report
        self._free = list(range(capacity - 1, -1, -1))
        self._gate = np.array([0.0] + [chi2_quantile(params.gate_probability, k) for k in range(1, H_MEAS + V_MEAS + 1)])

    @property
    def compiled(self) -> bool:
        """Both banks run the compiled kernels: the update, the prediction and the posterior are then one fused
        kernel call each (tracking/kernels.py); otherwise the numpy reference of imm.py."""
        return self.bank_h.compiled and self.bank_v.compiled

    @compiled.setter
    def compiled(self, value: bool | None) -> None:
        self.bank_h.compiled = value
        self.bank_v.compiled = value

    # -- slots -------------------------------------------------------------------------------------------
    def _take_slots(self, n: int) -> np.ndarray:
        if len(self._free) < n:
            old = self.bank_h.capacity
            new = max(2 * old, old + n)
            self.bank_h.grow(new)
            self.bank_v.grow(new)
            self._t = np.concatenate([self._t, np.zeros(new - old)])
            self._free = list(range(new - 1, old - 1, -1)) + self._free
        return np.array([self._free.pop() for _ in range(n)], int)

    def _release(self, track: ImmTrack) -> None:
        self._free.append(track.slot)

    def _check_slots(self) -> None:
        """Every live track and competitor owns a distinct slot, none of them free (for tests)."""
        used = [t.slot for t in self.tracks.values()] + [t.slot for t in self.competitors.values()]
        assert len(set(used)) == len(used) and not set(used) & set(self._free), "slot bookkeeping"
        assert len(set(self._free)) == len(self._free) and len(used) + len(self._free) == self.bank_h.capacity

    # -- measurement model -------------------------------------------------------------------------------
    def _measure(self, reports: list[IntruderReport], easts, norths, stale=None):
        """Measurement arrays of a batch: (z_h, mask_h, r_h) (B, 4) and (z_v, mask_v, r_v) (B, 2). stale (B,): the
        report repeats a stale position (integrity monitor): its position is not measured."""
        cfg = self.config
        b = len(reports)
        z_h = np.zeros((b, H_MEAS))
        z_h[:, 0] = easts
        z_h[:, 1] = norths
        m_h = np.zeros((b, H_MEAS), bool)
        m_h[:, :2] = True if stale is None else ~np.asarray(stale, bool)[:, None]
        z_v = np.zeros((b, V_MEAS))
        m_v = np.zeros((b, V_MEAS), bool)
        pos_sigma = np.empty(b)
        vel_sigma = np.empty(b)
        for i, rep in enumerate(reports):  # field extraction from the report objects
            pos_sigma[i] = self.position_sigma_m(rep)
            vel_sigma[i] = self.velocity_sigma_mps(rep)
            if rep.velocity_en_mps is not None:
                z_h[i, 2:4] = rep.velocity_en_mps
                m_h[i, 2:4] = True
            if rep.altitude_m is not None:
                z_v[i, 0] = rep.altitude_m
                m_v[i, 0] = True
            if rep.vertical_rate_mps is not None:
                z_v[i, 1] = rep.vertical_rate_mps
                m_v[i, 1] = True
        r_h = np.empty((b, H_MEAS))
        r_h[:, :2] = (pos_sigma**2)[:, None]
        r_h[:, 2:] = (vel_sigma**2)[:, None]
        r_v = np.empty((b, V_MEAS))
        r_v[:, 0] = cfg.altitude_sigma_m**2
        r_v[:, 1] = cfg.vertical_rate_sigma_mps**2
        return (z_h, m_h, r_h), (z_v, m_v, r_v)

    def _init_slots(self, slots: np.ndarray, meas_h, meas_v, vertical_only: bool = False) -> None:
        """Initial state from one report: measured components at their noise, the rest at honest priors."""
        z_h, m_h, r_h = meas_h
        z_v, m_v, r_v = meas_v
        b = len(slots)
        if not vertical_only:
            x = np.zeros((b, 6))
            x[:, :4] = z_h
            var = np.empty((b, 6))
            var[:, :4] = np.where(m_h, r_h, UNKNOWN_SPEED_SIGMA_MPS**2)
            var[:, 4:] = self.config.imm_initial_accel_sigma_mps2**2
            self.bank_h.init(slots, x, var[:, :, None] * np.eye(6), nominal_var=r_h)
        var_v = np.where(m_v, r_v, np.array([UNKNOWN_ALT_SIGMA_M, UNKNOWN_VRATE_SIGMA_MPS]) ** 2)
        self.bank_v.init(slots, z_v, var_v[:, :, None] * np.eye(2), nominal_var=r_v)

    # -- lifecycle (the filter's part) ---------------------------------------------------------------------
    def _positions(self, tracks: list[ImmTrack]) -> np.ndarray:
        x, _ = self._posterior(np.fromiter((t.slot for t in tracks), int, len(tracks)))
        return x[:, :2]

    def _update_round(self, upd: list[int], reports, easts, norths, stale: np.ndarray, out: np.ndarray) -> None:
        reps = [reports[i] for i in upd]
        tracks = [self.tracks[r.key] for r in reps]
        self._datum_changes(tracks, reps)
        accepted = self._update(tracks, reps, easts[upd], norths[upd], stale=stale)
        for k, (i, rep, track) in enumerate(zip(upd, reps, tracks)):
            if accepted[k]:
                out[i] = True
            else:
                out[i] = self._handle_miss(track, rep, easts[i], norths[i])

    def _init_filters(self, reps: list[IntruderReport], easts, norths) -> list[dict]:
        slots = self._take_slots(len(reps))
        self._init_slots(slots, *self._measure(reps, easts, norths))
        self._t[slots] = [rep.time_s for rep in reps]
        return [{"slot": int(slot), "tracker": self} for slot in slots]

    def _reset_vertical(self, track: ImmTrack) -> None:
        slot = np.array([track.slot])
        self.bank_v.init(slot, np.zeros((1, 2)), np.diag([UNKNOWN_ALT_SIGMA_M, UNKNOWN_VRATE_SIGMA_MPS]) ** 2,
                         nominal_var=np.array([[self.config.altitude_sigma_m**2, self.config.vertical_rate_sigma_mps**2]]))

    def _update(self, tracks: list[ImmTrack], reps: list[IntruderReport], easts, norths,
                count: bool = True, stale=None) -> np.ndarray:
        """One vectorised IMM cycle for these tracks (distinct), gated; accepted ones are stored."""
        slots = np.fromiter((t.slot for t in tracks), int, len(tracks))
        times = np.fromiter((r.time_s for r in reps), float, len(reps))
        dt = times - self._t[slots]
        (z_h, m_h, r_h), (z_v, m_v, r_v) = self._measure(reps, easts, norths, stale)
        if self.compiled:
            in_gate, plausible = self._update_compiled(slots, dt, z_h, m_h, r_h, z_v, m_v, r_v)
        else:
            in_gate, plausible = self._update_reference(slots, dt, z_h, m_h, r_h, z_v, m_v, r_v)
        self._t[slots[in_gate]] = times[in_gate]
        for k in np.flatnonzero(in_gate):
            self._accepted(tracks[k], reps[k])
        for k in np.flatnonzero(~in_gate) if count else ():
            self.counters["track.implausible_jump" if not plausible[k] else "track.gate_miss"] += 1
        return in_gate

    def _update_compiled(self, slots, dt, z_h, m_h, r_h, z_v, m_v, r_v):
        """_update_reference in one fused kernel call (kernels.tracker_update): both banks, the plausibility
        test, the gate and the commit of the accepted slots."""
        bh, bv, sh, sv = self.bank_h, self.bank_v, self.bank_h.spec, self.bank_v.spec
        b = len(slots)
        in_gate, plausible = np.empty(b, bool), np.empty(b, bool)
        status = kernels.tracker_update(
            bh.x, bh.p, bh.mu, bh.yaw, sh.codes, sh.sigma, sh.v, sh.vinv, sh.lam, sh.turn_mode, bh.yaw_time_constant_s,
            bv.x, bv.p, bv.mu, sv.codes, sv.sigma, sv.v, sv.vinv, sv.lam,
            kernels.arr(slots, np.int64), dt, z_h, m_h, r_h, z_v, m_v, r_v, self._gate,
            float(self.config.max_innovation_speed_mps), in_gate, plausible)
        if status != kernels.OK:
            raise np.linalg.LinAlgError("matrix is not positive definite")
        return in_gate, plausible

    def _update_reference(self, slots, dt, z_h, m_h, r_h, z_v, m_v, r_v):
        """Both banks' IMM cycles (imm.ImmBank.update), the plausibility test and the gate; the accepted slots
        are committed. Returns (in_gate, plausible) per slot."""
        pend_h = self.bank_h.update(slots, dt, z_h, m_h, r_h)
        pend_v = self.bank_v.update(slots, dt, z_v, m_v, r_v)
        # physical plausibility: could the tracked aircraft be where this report says?
        xp, var = pend_h.extra["x_prior"], pend_h.extra["var_prior"]
        jump = np.hypot(z_h[:, 0] - xp[:, 0], z_h[:, 1] - xp[:, 1])
        allowed = self.config.max_innovation_speed_mps * np.maximum(dt, 1.0) + 5.0 * np.sqrt(
            var.sum(axis=1) + r_h[:, 0] + r_h[:, 1])
        plausible = (jump <= allowed) | ~m_h[:, 0]  # a stale position is not measured
        d2 = pend_h.d2 + pend_v.d2
        in_gate = plausible & (d2 <= self._gate[pend_h.dof + pend_v.dof])
        self.bank_h.commit(pend_h, in_gate)
        self.bank_v.commit(pend_v, in_gate)
        return in_gate, plausible

    def _handle_miss(self, track: ImmTrack, rep: IntruderReport, east: float, north: float) -> bool:
        """A report outside the track's gate: it goes to the key's competing track (started if needed); the
        competitor replaces the track after REJECTS_BEFORE_RESTART misses in a row that it took."""
        track.consecutive_rejects += 1
        comp = self.competitors.get(rep.key)
        took = False
        if comp is not None and rep.time_s > comp.last_report_s + DUPLICATE_WINDOW_S:
            took = bool(self._update([comp], [rep], np.array([east]), np.array([north]), count=False)[0])
        if not took:
            if comp is not None:  # its slot is released by _start, which replaces it
                self.counters["track.competitor_replaced"] += 1
            comp = self._start([rep], np.array([east]), np.array([north]), self.competitors)[0]
            self.counters["track.competitor_started"] += 1
        if track.consecutive_rejects >= REJECTS_BEFORE_RESTART and comp.n_updates >= REJECTS_BEFORE_RESTART:
            del self.competitors[rep.key]
            self._release(track)
            self.tracks[rep.key] = comp
            self.counters["track.restarted"] += 1
            return True
        return False

    def reframe(self, change) -> None:
        """The tangent plane moved (avionics/base/frame.py): carry every track and competitor into it."""
        slots = np.array([t.slot for t in (*self.tracks.values(), *self.competitors.values())], int)
        self.bank_h.reframe(change, slots)
        self.integrity.reframe(change)

    # -- outputs -----------------------------------------------------------------------------------------
    def _assemble(self, xh, ph, xv, pv):
        return assemble(xh, ph, xv, pv)

    def _posterior(self, slots: np.ndarray):
        if self.compiled:
            xs, ps = np.empty((len(slots), 6)), np.empty((len(slots), 6, 6))
            bh, bv = self.bank_h, self.bank_v
            kernels.tracker_posterior(bh.x, bh.p, bh.mu, bv.x, bv.p, bv.mu, kernels.arr(slots, np.int64),
                                      xs, ps)
            return xs, ps
        xh, ph = self.bank_h.posterior(slots)
        xv, pv = self.bank_v.posterior(slots)
        return self._assemble(xh, ph, xv, pv)

    def predict(self, keys: list[IntruderKey], t_s: float) -> tuple[np.ndarray, np.ndarray]:
        """States (N, 6) [east, north, alt, v_east, v_north, v_up] and covariances (N, 6, 6) at t_s: the IMM
        trajectory prediction (interaction, mode-matched prediction, Markov modes, combination)."""
        if not keys:
            return np.empty((0, 6)), np.empty((0, 6, 6))
        slots = np.fromiter((self.tracks[k].slot for k in keys), int, len(keys))
        dt = t_s - self._t[slots]
        if self.compiled:
            bh, bv, sh, sv = self.bank_h, self.bank_v, self.bank_h.spec, self.bank_v.spec
            xs, ps = np.empty((len(slots), 6)), np.empty((len(slots), 6, 6))
            kernels.tracker_predict(bh.x, bh.p, bh.mu, sh.codes, sh.sigma, sh.v, sh.vinv, sh.lam,
                                    bv.x, bv.p, bv.mu, sv.codes, sv.sigma, sv.v, sv.vinv, sv.lam, slots, dt, xs, ps)
        else:
            xh, ph, _ = self.bank_h.predict(slots, dt)
            xv, pv, _ = self.bank_v.predict(slots, dt)
            xs, ps = self._assemble(xh, ph, xv, pv)
        return xs, self.integrity.widen(keys, ps)  # a degraded track's position is widened by its fault size

    def mode_info(self, key: IntruderKey, t_s: float | None = None) -> dict:
        return self.mode_infos([key], t_s)[0]

    def mode_infos(self, keys: list[IntruderKey], t_s: float | None = None) -> list[dict]:
        """Per track: mode probabilities by name (Markov-propagated to t_s if given, else at the last update),
        most likely modes, smoothed turn rate (Hwang eq 20 through 1/(11.9 s + 1); degrees per second, positive =
        right turn, clockwise), VB noise. One vectorised call for all the tracks of a publication."""
        slots = np.fromiter((self.tracks[k].slot for k in keys), int, len(keys))
        dt = 0.0 if t_s is None else t_s - self._t[slots]
        mu_h = self.bank_h.mode_probabilities(slots, dt)
        mu_v = self.bank_v.mode_probabilities(slots, dt)
        best_h, best_v = np.argmax(mu_h, axis=1), np.argmax(mu_v, axis=1)
        turn_dps = -np.degrees(self.bank_h.yaw[slots])
        names_h, names_v = self.bank_h.names, self.bank_v.names
        noise = [None] * len(keys)
        if self.bank_h.vb is not None:
            h = self.bank_h.noise_estimate(slots)
            v = self.bank_v.noise_estimate(slots)
            noise = [{"position_sigma_m": math.sqrt(0.5 * (hi[0] + hi[1])),
                      "velocity_sigma_mps": math.sqrt(0.5 * (hi[2] + hi[3])),
                      "altitude_sigma_m": math.sqrt(vi[0]), "vertical_rate_sigma_mps": math.sqrt(vi[1])}
                     for hi, vi in zip(h.tolist(), v.tolist())]
        return [{
            "model": self.model,
            "mode_probabilities": dict(zip(names_h, mh)),
            "most_likely_mode": names_h[bh],
            "turn_rate_dps": td,
            "vertical_mode_probabilities": dict(zip(names_v, mv)),
            "vertical_mode": names_v[bv],
            "vb_noise": nz,
        } for mh, mv, bh, bv, td, nz in zip(mu_h.tolist(), mu_v.tolist(), best_h.tolist(), best_v.tolist(),
                                             turn_dps.tolist(), noise)]


def assemble(xh, ph, xv, pv) -> tuple[np.ndarray, np.ndarray]:
    """The banks' combined horizontal [x, y, vx, vy, ...] and vertical [z, vz] states as the pipeline's
    [e, n, alt, ve, vn, vu] and 6 x 6 covariance (horizontal-vertical cross terms zero: decoupled banks)."""
    n = len(xh)
    xs = np.empty((n, 6))
    xs[:, PIPE_FROM_H] = xh[:, :4]
    xs[:, PIPE_FROM_V] = xv
    ps = np.zeros((n, 6, 6))
    ps[:, PIPE_FROM_H[:, None], PIPE_FROM_H[None, :]] = ph[:, :4, :4]
    ps[:, PIPE_FROM_V[:, None], PIPE_FROM_V[None, :]] = pv
    return xs, ps
