"""The DO-365 well-clear volume: NASA DAIDALUS's WCV_TAUMOD detector (horizontal: modified tau, WCV_tvar /
WCV_TAUMOD; vertical: time to co-altitude, WCV_TCOA), vectorised over any leading shape.

Sources: Munoz, Narkawicz, Hagen, Upchurch, Dutle, Consiglio, Chamberlain, "DAIDALUS: Detect and Avoid Alerting
Logic for Unmanned Systems", DASC 2015, and the DAIDALUS v2.0.4 Java classes (gov.nasa.larcfm.ACCoRD) named at
each function. Thresholds are data: a profile's [[alerter.levels]] (advisory/profiles/*.toml, read by
advisory/tables.py), e.g. RTCA DO-365B Phase I DWC: DTHR 4000 ft (0.66 nmi), ZTHR 450 ft, TTHR (modified tau)
35 s, TCOA 0 s (`daidalus-do365b-no-sum`, `do365`).

With s the relative position and v the relative velocity (horizontal 2-vectors; sz, vz vertical), the volume
is violated now when (WCV_tvar.violation)

    horizontal:  |s| <= DTHR, or dcpa(s, v) <= DTHR and 0 <= taumod <= TTHR,
                 taumod = (DTHR^2 - |s|^2) / (s.v) for s.v < 0 (else -1)            (WCV_TAUMOD.horizontal_tvar)
    vertical:    |sz| <= ZTHR, or vz != 0, sz vz <= 0 and tcoa = -sz / vz <= TCOA   (WCV_TCOA.vertical_WCV)

and the interval of its loss in [B, T] of straight-line motion is the vertical interval (WCV_TCOA
.vertical_WCV_interval) intersected with the horizontal one from there (WCV_TAUMOD.horizontal_WCV_interval:
the first root of |v|^2 t^2 + (2 s.v + TTHR |v|^2) t + |s|^2 + TTHR s.v - DTHR^2 = 0, the time at which taumod
reaches TTHR, to the exit from the DTHR disk, Horizontal.Theta_D). A conflict is time_in < time_out, not
almost equal (LossData.conflict). Ties are DAIDALUS's (Util.almost_equals and its zero special case, base/almost.py):
"no motion" on an axis is almost_equals(v, 0), an instant of loss is almost_equals(low, up).
The sign convention of s (intruder - ownship here, ownship - intruder in
DAIDALUS) does not matter: every test is even in (s, v) and (sz, vz).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from avionics.base import jit
from avionics.base.almost import almost_equals, almost_less
from avionics.conflict.probability import as_c

kernels = jit.lazy(__name__, "avionics.advisory.kernels")  # the module, once jit.load() ran (jit.py)


@dataclass(frozen=True, slots=True)
class WcvThresholds:
    """DAIDALUS WCVTable: DTHR (m), ZTHR (m), TTHR (s, the modified-tau threshold) and TCOA (s)."""

    dthr_m: float
    zthr_m: float
    tthr_s: float
    tcoa_s: float = 0.0




def _dot(a, b):
    return a[..., 0] * b[..., 0] + a[..., 1] * b[..., 1]


def _cross(a, b):
    return a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]


def _horizontal_wcv(s_xy, v_xy, thr: WcvThresholds):
    """WCV_tvar.horizontal_WCV with WCV_TAUMOD.horizontal_tvar."""
    sqs, sdotv, a = _dot(s_xy, s_xy), _dot(s_xy, v_xy), _dot(v_xy, v_xy)
    d2 = thr.dthr_m**2
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):  # tiny s.v: taumod is +-inf, not a fault
        tcpa = np.where(a > 0.0, -sdotv / np.where(a > 0.0, a, 1.0), 0.0)  # Horizontal.tcpa
        taumod = np.where(sdotv < 0.0, (d2 - sqs) / np.where(sdotv < 0.0, sdotv, -1.0), -1.0)
    cpa = s_xy + tcpa[..., None] * v_xy
    dcpa2 = _dot(cpa, cpa)
    return (sqs <= d2) | ((dcpa2 <= d2) & (taumod >= 0.0) & (taumod <= thr.tthr_s))


def _vertical_wcv(sz, vz, thr: WcvThresholds):
    """WCV_TCOA.vertical_WCV (|sz| <= ZTHR as written; "moving" is not Util.almost_equals(vz, 0))."""
    moving = ~almost_equals(vz, 0.0)
    with np.errstate(divide="ignore", invalid="ignore"):
        tcoa = np.where(moving, -sz / np.where(moving, vz, 1.0), np.inf)  # Vertical.time_coalt
    return (np.abs(sz) <= thr.zthr_m) | (moving & (sz * vz <= 0.0) & (tcoa <= thr.tcoa_s))


def wcv_violation(s_xy, v_xy, sz, vz, thr: WcvThresholds) -> np.ndarray:
    """(...) bool: the well-clear volume is violated now (WCV_tvar.violation)."""
    s_xy, v_xy = np.asarray(s_xy, float), np.asarray(v_xy, float)
    sz, vz = np.asarray(sz, float), np.asarray(vz, float)
    return _horizontal_wcv(s_xy, v_xy, thr) & _vertical_wcv(sz, vz, thr)


def _vertical_interval(sz, vz, thr: WcvThresholds, b_s, t_s):
    """WCV_TCOA.vertical_WCV_interval: (low, up) within [B, T]; low > up where there is none (level: Util.almost_equals(
    vz, 0), |vz| < 1e-13 by its zero special case)."""
    level = almost_equals(vz, 0.0)
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        safe = np.where(level, 1.0, vz)
        sign = np.where(safe >= 0.0, 1.0, -1.0)
        act_h = np.maximum(thr.zthr_m, np.abs(vz) * thr.tcoa_s)
        t_entry = (-sign * act_h - sz) / safe  # Vertical.Theta_H(sz, vz, -1, H) = (eps sign(vz) H - sz) / vz
        t_exit = (sign * thr.zthr_m - sz) / safe
    none = level & (np.abs(sz) > thr.zthr_m) | ~level & ((t_s < t_entry) | (t_exit < b_s))
    low = np.where(level, b_s, np.maximum(b_s, t_entry))
    up = np.where(level, t_s, np.minimum(t_s, t_exit))
    return np.where(none, t_s, low), np.where(none, b_s, up)


def _horizontal_interval(s_xy, v_xy, thr: WcvThresholds, t_s):
    """WCV_TAUMOD.horizontal_WCV_interval(T, s, v): (time_in, time_out) within [0, T]; (T, 0) where none."""
    sqs, sdotv, a = _dot(s_xy, s_xy), _dot(s_xy, v_xy), _dot(v_xy, v_xy)
    d2, tthr = thr.dthr_m**2, thr.tthr_s
    b = 2.0 * sdotv + tthr * a
    c = sqs + tthr * sdotv - d2
    delta = d2 * a - _cross(s_xy, v_xy) ** 2  # Horizontal.Delta
    with np.errstate(divide="ignore", invalid="ignore"):
        safe_a = np.where(a > 0.0, a, 1.0)
        theta_out = (-sdotv + np.sqrt(np.maximum(delta, 0.0))) / safe_a  # Horizontal.Theta_D(s, v, +1, D)
        discr = b * b - 4.0 * a * c
        t_first = (-b - np.sqrt(np.maximum(discr, 0.0))) / (2.0 * safe_a)
    t_s = np.broadcast_to(np.asarray(t_s, float), sqs.shape)
    inside = sqs <= d2
    still = almost_equals(a, 0.0) & inside  # Util.almost_equals(a, 0): no relative horizontal motion
    entering = ~inside & (sdotv < 0.0) & (discr >= 0.0) & (delta >= 0.0) & (t_first <= t_s)
    t_in = np.where(still | inside, 0.0, np.where(entering, np.maximum(0.0, t_first), t_s))
    t_out = np.where(still, t_s, np.where(inside | entering, np.minimum(t_s, theta_out), 0.0))
    return t_in, t_out


def wcv_interval(s_xy, v_xy, sz, vz, thr: WcvThresholds, b_s: float, t_s: float) -> tuple[np.ndarray, np.ndarray]:
    """(t_in, t_out), each (...): the interval of loss of well clear within [B, T] of straight-line relative
    motion (WCV_tvar.WCV_interval); no loss where not `conflict(t_in, t_out)`."""
    s_xy, v_xy = np.asarray(s_xy, float), np.asarray(v_xy, float)
    sz, vz = np.asarray(sz, float), np.asarray(vz, float)
    if jit.ready():  # the compiled loop (advisory/kernels.py wcv_interval_lines): this function line by line
        shape = np.broadcast_shapes(s_xy.shape[:-1], v_xy.shape[:-1], sz.shape, vz.shape)

        def rows(a, width):
            return as_c(np.broadcast_to(a, shape + width).reshape((-1,) + width))

        out = kernels.wcv_interval_lines(rows(s_xy, (2,)), rows(v_xy, (2,)), rows(sz, ()), rows(vz, ()),
                                         thr.dthr_m**2, thr.zthr_m, thr.tthr_s, thr.tcoa_s, float(b_s), float(t_s))
        return out[:, 0].reshape(shape), out[:, 1].reshape(shape)
    low, up = _vertical_interval(sz, vz, thr, b_s, t_s)
    vertical_none = low > up
    low_c = np.where(vertical_none, b_s, low)
    up_c = np.where(vertical_none, t_s, up)
    step = s_xy + low_c[..., None] * v_xy  # the horizontal state at the vertical entry
    instant = almost_equals(low_c, up_c)  # WCV_tvar.WCV_interval: Util.almost_equals(ii.low, ii.up)
    h_in, h_out = _horizontal_interval(step, v_xy, thr, up_c - low_c)
    point = _horizontal_wcv(step, v_xy, thr)
    t_in = np.where(instant, np.where(point, low_c, t_s), h_in + low_c)
    t_out = np.where(instant, np.where(point, up_c, b_s), h_out + low_c)
    return np.where(vertical_none, t_s, t_in), np.where(vertical_none, b_s, t_out)


def conflict(t_in, t_out) -> np.ndarray:
    """LossData.conflict: Util.almost_less(time_in, time_out), with the zero special case: a loss that ends within
    1e-13 s of its start at 0 is none (base/almost.py)."""
    return np.asarray(almost_less(t_in, t_out), bool)


@dataclass(frozen=True, slots=True)
class WCV_TAUMOD:  # noqa: N801  (DAIDALUS's class name)
    """The well-clear detector as an alerter's Detector (advisory/alerting.py) over an Encounter's pairs:
    `violation` now, `conflict` = a loss of well clear beginning before time_s (DAIDALUS
    ConflictData.conflictBefore(alerting_time) of the detection over [0, lookahead]: the same pairs as a
    conflict within [0, time_s]). The vertical separation has the datum margin taken off. An intruder without
    altitude passes the vertical test (shown on range alone, as a non-altitude-reporting intruder is), unless
    altitude_required (levels that lead to a vertical manoeuvre need the intruder's altitude)."""

    altitude_required: bool = False

    def violation(self, encounter, thresholds: WcvThresholds) -> np.ndarray:
        g = encounter.geometry
        horizontal = _horizontal_wcv(g.s_xy_m, g.v_xy_mps, thresholds)
        vertical = _vertical_wcv(encounter.separation_z_m(), g.vz_mps, thresholds)
        return self._with_altitude(encounter, horizontal & vertical, horizontal)

    def conflict(self, encounter, thresholds: WcvThresholds, time_s: float) -> np.ndarray:
        g = encounter.geometry
        t_in, t_out = wcv_interval(g.s_xy_m, g.v_xy_mps, encounter.separation_z_m(), g.vz_mps, thresholds,
                                   0.0, time_s)
        # without altitude: the horizontal interval alone (the vertical test passes at every time)
        h_in, h_out = _horizontal_interval(g.s_xy_m, g.v_xy_mps, thresholds, time_s)
        return self._with_altitude(encounter, conflict(t_in, t_out), conflict(h_in, h_out))

    def _with_altitude(self, encounter, with_alt, without_alt) -> np.ndarray:
        has_alt = np.asarray(encounter.has_altitude, bool)
        if self.altitude_required:
            return with_alt & has_alt
        return np.where(has_alt, with_alt, without_alt)
