"""ADS-B integrity monitor: per intruder key, is the reported position still telling the truth?

Dai et al. (Sec. 3.7) inject four ADS-B failure modes (data loss, step, ramp, oscillation) and locate them by the
divergence of the noise estimate (their eqs 17-25). A noise estimate absorbs a slow fault (a ramp raises the VB
sigma until the ramp looks like noise), so this monitor tests what a fault breaks instead: ADS-B sends a position
and a velocity from the same navigation source, and the displacement between two reports must equal the integral
of the reported velocity. The per-interval residual

    u_k = (p_k - p_k-1) - (v_k-1 + v_k) dt_k / 2                       (trapezoid: exact for constant acceleration)

is summed into the dead-reckoning residual D_k = sum u_i. Over a window of W reports, U = D_k - D_k-W is an
innovation of the velocity-driven position predictor with covariance (per axis, plus the along-track jitter term)

    C = (2 sigma_p^2 + sigma_v^2 sum dt_i^2 / 2 + (b_v T)^2) I + sigma_t^2 (v_k v_k^T + v_k-W v_k-W^T)

(position noise at both ends, white velocity noise through the trapezoid, a velocity bias b_v over the window's
span T, receipt-time jitter sigma_t moving each end along its velocity). The normalised innovation squared
q = U^T C^-1 U is chi-square with 2 dof for a healthy source; a window fires when q > chi2_2(1 - ALPHA). Windows
of 1 ... 128 reports cover a step (one interval) to a ramp (grows with W). It uses neither the filter's prior nor
its noise estimate, so a manoeuvre (velocity reported) or a VB sigma inflated by the fault (Dai eq 22) cannot hide
it, and it sees every report of the key, also those the tracker's gate sends to a competing track.

Modes (classification of a firing; a degraded key stays degraded until no window fires for HOLD_S):
- `position_loss`: no report for LOSS_AFTER_S while the track lives (Dai's data loss; a report without a valid
  position is dropped by the decoder, so a missing position field is a missing report here);
- `inconsistent`: the position repeats to the centimetre while the velocity moves (a frozen position), or the
  window's displacement is consistent with zero against a significant velocity integral;
- `oscillation`: a window fires against the direction of the previous firing (the residual reversed);
- `step`: the last interval alone carries most of the window's residual;
- `ramp`: otherwise (the residual grew over several intervals).

Thresholds and sizes (docs/tracking.md, "Integrity monitor", for the derivations and the measured rates).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from avionics.base.chi2 import chi2_quantile

RC_NIC7_M = 370.4  # DO-260B NIC 7 containment radius (0.2 NM): the least integrity 14 CFR 91.227 accepts
ALPHA = 1e-7  # false-alarm probability per window test per report (8 windows x 3600 reports/h -> ~3e-3 per hour)
Q_THRESHOLD = chi2_quantile(1.0 - ALPHA, 2)  # 32.2: the NIS bound of one window
WINDOWS = np.array([1, 2, 4, 8, 16, 32, 64, 128])  # reports; 128 s at 1 Hz (the slowest ramp it can see)
RING = int(WINDOWS[-1]) + 1
_WINDOWS = WINDOWS.tolist()  # the same, as Python ints (the one-report path)
TIME_JITTER_S = 0.1  # 1-sigma receipt-time jitter (tslc is whole seconds: reports are stamped at receipt)
VELOCITY_BIAS_MPS = 0.3  # a velocity error that does not average out: ~half the 1 kt LSB of DO-260B velocity
FROZEN_M = 0.05  # a position repeated within 5 cm (4 LSB of MAVLink's 1e-7 deg) is a repeated value, not noise
MOVING_M = 1.0  # ... unless the reported velocity moved the aircraft less than this in the interval
LOSS_AFTER_S = 4.35  # 1 Hz reports: 4 lost in a row (3 lost span <= 4.3 s with the 0.3 s latency spread); 5 % dropouts: 6e-6 per report
HOLD_S = 10.0  # a degraded key is ok again after this long without a firing (no flicker at the threshold)
STEP_SHARE = 0.6  # a firing whose last interval carries this share of the window residual is a step

MODES = ("position_loss", "step", "ramp", "oscillation", "inconsistent")  # DAA_INTEGRITY 1..5 (daa.xml)
_CODE = {m: i + 1 for i, m in enumerate(MODES)}


@dataclass(frozen=True, slots=True)
class IntegrityStatus:
    """A key's integrity: mode None is ok; fault_m is the 1-sigma position widening of a degraded track."""

    mode: str | None = None
    since_s: float | None = None
    fault_m: float = 0.0

    @property
    def degraded(self) -> bool:
        return self.mode is not None

    @property
    def label(self) -> str:
        return "ok" if self.mode is None else f"degraded:{self.mode}"

    @property
    def code(self) -> int:
        """DAA_INTEGRITY value on MAVLink: 0 ok, 1.. the MODES."""
        return 0 if self.mode is None else _CODE[self.mode]


OK = IntegrityStatus()


class IntegrityMonitor:
    """One per tracker. `observe` takes a batch of reports of distinct keys (vectorised), `check_silence` the
    position-loss test at an assessment time, `status` / `widen` serve the tracker's outputs, `forget` a deleted
    key. The window sums come from a ring of D_k, sum dt^2/2, times and velocities per key."""

    def __init__(self, velocity_sigma_mps: float, capacity: int = 16):
        self.velocity_sigma_mps = velocity_sigma_mps
        self._rows: dict = {}
        self._free: list[int] = []
        self._alloc(capacity)

    def _alloc(self, c: int) -> None:
        old = getattr(self, "_cap", 0)
        arrays = {
            "t": (RING,), "d": (RING, 2), "vv": (RING,), "miss": (RING,), "v": (RING, 2),
            "count": (), "last_p": (2,), "last_v": (2,), "last_rx": (), "frozen_run": (),
            "mode": (), "since": (), "last_fire": (), "fault": (), "dir": (2,),
        }
        for name, shape in arrays.items():
            new = np.zeros((c,) + shape)
            if old:
                new[:old] = getattr(self, "_" + name)
            setattr(self, "_" + name, new)
        self._free = list(range(c - 1, old - 1, -1)) + self._free
        self._cap = c

    def _row(self, key) -> int:
        row = self._rows.get(key)
        if row is None:
            if not self._free:
                self._alloc(2 * self._cap)
            row = self._rows[key] = self._free.pop()
            for name in ("count", "frozen_run", "mode", "fault", "dir", "last_v"):
                getattr(self, "_" + name)[row] = 0.0
        return row

    def forget(self, key) -> None:
        row = self._rows.pop(key, None)
        if row is not None:
            self._free.append(row)

    # -- the tests -------------------------------------------------------------------------------------------
    def observe(self, keys, t, received, east, north, velocity, position_sigma, previous=None) -> np.ndarray:
        """Reports (B) of distinct keys: times of applicability, receipt times, plane positions, plane velocities
        (B, 2; NaN when not reported), 1-sigma position noise per axis; previous (B, 2): where each key's previous
        report is in the current plane (the tracker knows it across a re-centred plane; NaN: the stored one).
        Returns, per report, whether its position is a stale repeat (the tracker then uses its velocity and
        altitude only)."""
        if len(keys) == 1:  # a lone report (the usual step): the same arithmetic on Python floats
            return self._observe_one(keys[0], t, received, east, north, velocity, position_sigma, previous)
        rows = np.fromiter((self._row(k) for k in keys), int, len(keys))
        t, received = np.asarray(t, float), np.asarray(received, float)
        p = np.empty((len(t), 2))  # (B, 2): filled, not np.stack (a fixed cost per call that a lone report pays)
        p[:, 0], p[:, 1] = east, north
        v = np.asarray(velocity, float).reshape(-1, 2)
        has_v = np.isfinite(v).all(axis=1)
        v0 = np.where(has_v[:, None], v, 0.0)
        count = self._count[rows].astype(int)
        first = count == 0
        k_prev = (count - 1) % RING
        dt = t - self._t[rows, k_prev]
        last = self._last_p[rows]
        if previous is not None:
            previous = np.asarray(previous, float).reshape(-1, 2)
            last = np.where(np.isfinite(previous), previous, last)
        disp = p - last
        prev_v = self._last_v[rows]
        interval_ok = ~first & has_v & np.isfinite(prev_v).all(axis=1)
        # prev_v is finite or NaN (stored so below): nan_to_num's result, without its fixed cost per call
        integral = 0.5 * (np.where(np.isnan(prev_v), 0.0, prev_v) + v0) * dt[:, None]
        u = np.where(interval_ok[:, None], disp - integral, 0.0)
        moving = np.hypot(*integral.T) > MOVING_M
        stale = ~first & (np.hypot(*disp.T) < FROZEN_M) & moving & interval_ok
        d_new = np.where(first[:, None], 0.0, self._d[rows, k_prev] + u)
        vv_new = np.where(first, 0.0, self._vv[rows, k_prev] + 0.5 * dt**2)
        miss_new = np.where(first, 0.0, self._miss[rows, k_prev] + ~interval_ok)
        k = count % RING
        self._t[rows, k], self._d[rows, k], self._vv[rows, k], self._miss[rows, k] = t, d_new, vv_new, miss_new
        self._v[rows, k] = v0
        self._count[rows] = count + 1
        self._last_p[rows], self._last_rx[rows] = p, received
        self._last_v[rows] = np.where(has_v[:, None], v, np.nan)
        self._frozen_run[rows] = np.where(stale, self._frozen_run[rows] + 1, 0)

        # window statistics, all windows at once: (B, nW)
        j = (count[:, None] - WINDOWS[None, :]) % RING
        flat = rows[:, None] * RING + j  # one flat index for the ring gathers (cheaper than a pair per gather)
        valid = (count[:, None] >= WINDOWS[None, :]) & (miss_new[:, None] == self._miss.reshape(-1)[flat])
        big_u = d_new[:, None, :] - self._d.reshape(-1, 2)[flat]
        span = t[:, None] - self._t.reshape(-1)[flat]
        iso = (2.0 * np.asarray(position_sigma, float)[:, None] ** 2
               + self.velocity_sigma_mps**2 * (vv_new[:, None] - self._vv.reshape(-1)[flat])
               + (VELOCITY_BIAS_MPS * span) ** 2)
        vj = self._v.reshape(-1, 2)[flat]
        # the jitter term's three distinct entries, element for element the outer products' (B, nW, 2, 2) sums
        ve, vn, vje, vjn = v0[:, None, 0], v0[:, None, 1], vj[..., 0], vj[..., 1]
        c00 = iso + TIME_JITTER_S**2 * (ve * ve + vje * vje)
        c01 = TIME_JITTER_S**2 * (ve * vn + vje * vjn)
        c11 = iso + TIME_JITTER_S**2 * (vn * vn + vjn * vjn)
        q = (c11 * big_u[..., 0] ** 2 - 2 * c01 * big_u[..., 0] * big_u[..., 1] + c00 * big_u[..., 1] ** 2) / (
            c00 * c11 - c01**2)
        q = np.where(valid, q, 0.0)
        fired = (q > Q_THRESHOLD).any(axis=1) | (self._frozen_run[rows] >= 2)

        mode = self._mode[rows]
        # position_loss ends with the next report (unless a window fires); other modes after HOLD_S quiet
        ended = (mode == _CODE["position_loss"]) | (t - self._last_fire[rows] > HOLD_S)
        self._mode[rows] = np.where(~fired & ended, 0, mode)
        self._fault[rows] = np.where(~fired & ended, 0.0, self._fault[rows])
        for b in np.flatnonzero(fired):  # rare: only reports that fire
            self._classify(rows[b], t[b], big_u[b], q[b], u[b], disp[b], bool(stale[b]))
        return stale

    def _observe_one(self, key, t, received, east, north, velocity, position_sigma, previous) -> np.ndarray:
        """observe() for one report, operation for operation the vectorised arithmetic above on Python floats
        (IEEE doubles: the same values; squares as products, as numpy's ** 2 is; hypot by numpy's), without a
        numpy call per operation on one-element arrays."""
        row = self._row(key)
        t, received = float(np.asarray(t, float).reshape(-1)[0]), float(np.asarray(received, float).reshape(-1)[0])
        pe, pn = float(np.asarray(east, float).reshape(-1)[0]), float(np.asarray(north, float).reshape(-1)[0])
        vx, vy = np.asarray(velocity, float).reshape(-1, 2)[0].tolist()
        has_v = math.isfinite(vx) and math.isfinite(vy)
        v0x, v0y = (vx, vy) if has_v else (0.0, 0.0)
        count = int(self._count[row])
        first = count == 0
        k_prev = (count - 1) % RING
        js = [(count - w) % RING for w in _WINDOWS]
        ring = [k_prev] + js
        ts, vvs, misses = self._t[row, ring].tolist(), self._vv[row, ring].tolist(), self._miss[row, ring].tolist()
        ds, vjs = self._d[row, ring].tolist(), self._v[row, js].tolist()
        dt = t - ts[0]
        lx, ly = self._last_p[row].tolist()
        if previous is not None:
            px, py = np.asarray(previous, float).reshape(-1, 2)[0].tolist()
            lx, ly = (px if math.isfinite(px) else lx), (py if math.isfinite(py) else ly)
        dx, dy = pe - lx, pn - ly
        pvx, pvy = self._last_v[row].tolist()
        interval_ok = not first and has_v and math.isfinite(pvx) and math.isfinite(pvy)
        ix = 0.5 * ((0.0 if math.isnan(pvx) else pvx) + v0x) * dt
        iy = 0.5 * ((0.0 if math.isnan(pvy) else pvy) + v0y) * dt
        ux, uy = (dx - ix, dy - iy) if interval_ok else (0.0, 0.0)
        moving = float(np.hypot(ix, iy)) > MOVING_M
        stale = not first and float(np.hypot(dx, dy)) < FROZEN_M and moving and interval_ok
        if first:
            dnx, dny, vv_new, miss_new = 0.0, 0.0, 0.0, 0.0
        else:
            dnx, dny = ds[0][0] + ux, ds[0][1] + uy
            vv_new = vvs[0] + 0.5 * (dt * dt)
            miss_new = misses[0] + (0.0 if interval_ok else 1.0)
        k = count % RING
        self._t[row, k], self._vv[row, k], self._miss[row, k] = t, vv_new, miss_new
        self._d[row, k] = dnx, dny
        self._v[row, k] = v0x, v0y
        self._count[row] = count + 1
        self._last_p[row] = pe, pn
        self._last_rx[row] = received
        self._last_v[row] = (vx, vy) if has_v else (math.nan, math.nan)
        frozen = (float(self._frozen_run[row]) + 1.0) if stale else 0.0
        self._frozen_run[row] = frozen

        sig = float(np.asarray(position_sigma, float).reshape(-1)[0])
        two_sig2, vs2, tj2 = 2.0 * (sig * sig), self.velocity_sigma_mps**2, TIME_JITTER_S**2
        qs, big_u, fired = [], [], frozen >= 2
        for i, w in enumerate(_WINDOWS):
            bux, buy = dnx - ds[i + 1][0], dny - ds[i + 1][1]
            big_u.append((bux, buy))
            if not (count >= w and miss_new == misses[i + 1]):
                qs.append(0.0)
                continue
            span = VELOCITY_BIAS_MPS * (t - ts[i + 1])
            iso = two_sig2 + vs2 * (vv_new - vvs[i + 1]) + span * span
            vje, vjn = vjs[i]
            c00 = iso + tj2 * (v0x * v0x + vje * vje)
            c01 = tj2 * (v0x * v0y + vje * vjn)
            c11 = iso + tj2 * (v0y * v0y + vjn * vjn)
            num = c11 * (bux * bux) - 2 * c01 * bux * buy + c00 * (buy * buy)
            den = c00 * c11 - c01 * c01
            q = num / den if den != 0.0 else float(np.float64(num) / np.float64(den))
            qs.append(q)
            fired = fired or q > Q_THRESHOLD

        mode = float(self._mode[row])
        ended = mode == _CODE["position_loss"] or t - float(self._last_fire[row]) > HOLD_S
        if not fired and ended:
            self._mode[row], self._fault[row] = 0.0, 0.0
        if fired:
            self._classify(row, t, np.array(big_u), np.array(qs), np.array([ux, uy]), np.array([dx, dy]), stale)
        return np.array([stale])

    def _classify(self, row: int, t: float, big_u: np.ndarray, q: np.ndarray, u: np.ndarray, disp: np.ndarray,
                  stale: bool) -> None:
        w = int(np.argmax(q))
        vec = big_u[w]
        size = float(np.hypot(*vec))
        unit = vec / size if size > 0 else np.zeros(2)
        current = int(self._mode[row])
        if stale or self._frozen_run[row] >= 1:
            mode = "inconsistent"
        elif current in (_CODE["step"], _CODE["ramp"], _CODE["oscillation"]) and float(unit @ self._dir[row]) < -0.5:
            mode = "oscillation"  # the residual reversed: it goes back and forth
        elif current in (_CODE["step"], _CODE["oscillation"], _CODE["inconsistent"]):
            mode = MODES[current - 1]  # a step stays a step while the windows that contain it fire
        elif size > 0 and float(u @ unit) >= STEP_SHARE * size:
            mode = "step"
        else:
            mode = "ramp"
        if current == 0 or current == _CODE["position_loss"]:
            self._since[row] = t
        self._mode[row] = _CODE[mode]
        self._last_fire[row] = t
        self._fault[row] = max(self._fault[row], size, RC_NIC7_M)
        if size > 0:
            self._dir[row] = unit

    def reframe(self, change) -> None:
        """The tangent plane moved (avionics/base/frame.py FrameChange): carry each key's last position into it.
        D_k and the stored velocities are differences and vectors: the planes differ by a fraction of a degree,
        which over a window is well inside C. Called from the trackers' reframe."""
        if not self._rows:
            return
        rows = np.fromiter(self._rows.values(), int, len(self._rows))
        e, n, _ = change.points(self._last_p[rows, 0], self._last_p[rows, 1])
        self._last_p[rows, 0], self._last_p[rows, 1] = e, n

    def check_silence(self, now_s: float) -> list:
        """Position loss: keys with no report for LOSS_AFTER_S (vectorised over all keys); returns them."""
        if not self._rows:
            return []
        keys = list(self._rows)
        rows = np.fromiter(self._rows.values(), int, len(keys))
        silent = (now_s - self._last_rx[rows] > LOSS_AFTER_S) & (self._mode[rows] == 0)
        for b in np.flatnonzero(silent):
            r = rows[b]
            self._mode[r], self._since[r], self._fault[r] = _CODE["position_loss"], now_s, RC_NIC7_M
        return [keys[b] for b in np.flatnonzero(silent)]

    # -- outputs ---------------------------------------------------------------------------------------------
    def status(self, key) -> IntegrityStatus:
        row = self._rows.get(key)
        if row is None or self._mode[row] == 0:
            return OK
        return IntegrityStatus(MODES[int(self._mode[row]) - 1], float(self._since[row]), float(self._fault[row]))

    def widen(self, keys, p: np.ndarray) -> np.ndarray:
        """Predicted covariances (N, 6, 6) of these keys with a degraded key's horizontal position variance
        raised by fault_m^2 per axis (the detected inconsistency, at least the NIC 7 containment radius)."""
        if not len(keys):
            return p
        rows = np.array([self._rows.get(k, -1) for k in keys])
        known = rows >= 0
        fault = np.zeros(len(keys))
        fault[known] = np.where(self._mode[rows[known]] > 0, self._fault[rows[known]], 0.0)
        if not fault.any():
            return p
        p = p.copy()
        p[:, 0, 0] += fault**2
        p[:, 1, 1] += fault**2
        return p


def position_sigma_per_axis(nacp_epu_m: float) -> float:
    """A NACp 95 % horizontal bound as a per-axis sigma (circular Gaussian: 95 % within 2.4477 sigma)."""
    return nacp_epu_m / math.sqrt(-2.0 * math.log(0.05))
