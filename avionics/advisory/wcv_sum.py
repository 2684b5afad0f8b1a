"""DO-365B sensor uncertainty mitigation (SUM): NASA DAIDALUS's WCV_TAUMOD_SUM detector and its inputs (SUMData).

Sources: DAIDALUS v2.0.4 Java, package gov.nasa.larcfm.ACCoRD: SUMData (each aircraft's uncertainties,
base/uncertainty.py), WCV_TAUMOD_SUM (the detector; method names below are its), TangentLine, WCV_TAUMOD /
WCV_tvar / WCV_TCOA (the well-clear tests it widens, advisory/wcv.py), and Util (comparisons, base/almost.py).
Parameters: Configurations/DO_365B_SUM.conf (the profile `daidalus-do365b-sum`).

Each aircraft states 1-sigma standard deviations (SUMData.set*Uncertainty): horizontal position per axis
(s_EW_std, s_NS_std) and the East/North term s_EN_std, vertical position sz_std, horizontal velocity (v_EW_std,
v_NS_std, v_EN_std) and vertical speed vz_std. SUMData.horizontal_uncertainty turns the horizontal triple into
one number, the square root of the larger eigenvalue of the covariance [[EW^2, c], [c, NS^2]] with the signed
c = sign(s_EN_std) s_EN_std^2 (its eigen_value_bound): the semi-major axis of the 1-sigma ellipse.

For a pair (conflictDetectionWithTrafficState), the relative errors are each aircraft's sum times a z-score:

    s_err  = h_pos_z (own + intruder horizontal position error)
    sz_err = v_pos_z (own + intruder sz_std)
    v_err  = z(r) (own + intruder horizontal velocity error), z(r) from h_vel_z_score_max at range 0 to
             h_vel_z_score_min at h_vel_z_distance and beyond, r = max(horizontal range - s_err, 0)
    vz_err = v_vel_z (own + intruder vz_std)

all zero: the plain WCV_TAUMOD detector; otherwise each at least MinError = 0.001 (SI) and the loss interval is
WCV_taumod_uncertain_interval: the vertical interval of the worst sz in [sz - sz_err, sz + sz_err] and vz in
[vz - vz_err, vz + vz_err] (vertical_WCV_uncertain_*), intersected with the horizontal one of the worst relative
position within s_err and velocity within v_err (horizontal_wcv_taumod_uncertain_entry/_exit: the s and v
rotated onto the pair of tangent directions that bring them closest, optimal_wcv_pair; the exit at the root of
(|v|^2 - v_err^2) t^2 + 2 (s.v - v_err (DTHR + s_err)) t + |s|^2 - (DTHR + s_err)^2, Theta_D_uncertain). A
conflict is time_in almost-less than time_out (LossData.conflict).

The scalar functions below follow the Java line by line and are the reference; `wcv_uncertain_intervals`
evaluates every branch over arrays (the alerter's pairs, the guidance bands' candidate manoeuvres) and is
checked against them. The pairs without uncertainty go through WCV_TAUMOD.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from avionics.advisory.wcv import WCV_TAUMOD, WcvThresholds, _horizontal_interval, _horizontal_wcv, \
    _vertical_interval, _vertical_wcv
from avionics.base.almost import almost_equals, almost_less

MIN_ERROR = 0.001  # WCV_TAUMOD_SUM.MinError (internal units: m, m/s): the floor of each relative error


@dataclass(frozen=True, slots=True)
class SumZScores:
    """DAIDALUS's SUM parameters (DaidalusParameters: h_pos_z_score, h_vel_z_score_min, h_vel_z_score_max,
    h_vel_z_distance, v_pos_z_score, v_vel_z_score): how many standard deviations widen each test."""

    h_pos: float
    h_vel_min: float
    h_vel_max: float
    h_vel_distance_m: float
    v_pos: float
    v_vel: float

    def weighted_h_vel(self, range_m: float) -> float:
        """WCV_TAUMOD_SUM.weighted_z_score: h_vel_min at h_vel_distance and beyond, rising linearly to h_vel_max
        at range 0."""
        if range_m >= self.h_vel_distance_m:
            return self.h_vel_min
        perc = range_m / self.h_vel_distance_m
        return (1.0 - perc) * self.h_vel_max + perc * self.h_vel_min


# --- 2-vector helpers (gov.nasa.larcfm.Util.Vect2) ------------------------------------------------------------

def _det(a, b) -> float:
    return a[0] * b[1] - a[1] * b[0]


def _dot(a, b) -> float:
    return a[0] * b[0] + a[1] * b[1]


def _norm(a) -> float:
    return math.sqrt(a[0] * a[0] + a[1] * a[1])


def _hat(a):
    n = _norm(a)
    return (0.0, 0.0) if n == 0.0 else (a[0] / n, a[1] / n)  # Vect2.Hat: zero stays zero


def _scal(k, a):
    return (k * a[0], k * a[1])


def _tangent_line(s, d: float, eps: int):
    """TangentLine(s, D, eps): the direction from s to the tangent point of the circle of radius D (its Q
    function); on the circle (|s|^2 almost equal to D^2) the perpendicular eps (s.y, -s.x)."""
    sq_s, sq_d = _dot(s, s), d * d
    if almost_equals(sq_s, sq_d):
        return (eps * s[1], -eps * s[0])
    delta = sq_s - sq_d
    if delta >= 0.0:
        alpha, beta = sq_d / sq_s, d * math.sqrt(max(delta, 0.0)) / sq_s
        q = (alpha * s[0] + eps * beta * s[1], alpha * s[1] - eps * beta * s[0])
        if q != (0.0, 0.0):
            return (q[0] - s[0], q[1] - s[1])
        return q
    return (0.0, 0.0)


def _sumof(v1, v2, w) -> bool:
    """WCV_TAUMOD_SUM.sumof: w lies in the cone spanned by v1 and v2."""
    d = _det(v2, v1)
    return _det(w, v1) * d >= 0.0 and _det(w, v2) * d <= 0.0


def _optimal_pair(v1, v2, w1, w2):
    """WCV_TAUMOD_SUM.optimal_pair: the directions of the two cones that are closest."""
    def avg(a, b):
        return _hat((a[0] + b[0], a[1] + b[1]))

    if _sumof(v1, v2, w1) and _sumof(v1, v2, w2):
        d = avg(w1, w2)
        return d, d
    if _sumof(w1, w2, v1) and _sumof(w1, w2, v2):
        d = avg(v1, v2)
        return d, d
    for a, b in ((v1, w1), (v1, w2), (v2, w1), (v2, w2)):
        if _sumof(w1, w2, a) and _sumof(v1, v2, b):
            d = avg(a, b)
            return d, d
    d11, d12, d21, d22 = _dot(v1, w1), _dot(v1, w2), _dot(v2, w1), _dot(v2, w2)
    if d11 >= d12 and d11 >= d21 and d11 >= d22:
        return v1, w1
    if d12 >= d11 and d12 >= d21 and d12 >= d22:
        return v1, w2
    if d21 >= d11 and d21 >= d12 and d21 >= d22:
        return v2, w1
    return v2, w2


def _optimal_wcv_pair(s, v, s_err: float, v_err: float):
    """WCV_TAUMOD_SUM.optimal_wcv_pair(s, v, s_err, v_err, -1, -1): the relative position |s| - s_err and
    velocity |v| + v_err along the optimal directions (optimal_wcv_pair_comp_init)."""
    v1, v2 = _hat(_tangent_line(s, s_err, -1)), _hat(_tangent_line(s, s_err, 1))
    w = (-v[0], -v[1])
    w1, w2 = _hat(_tangent_line(w, v_err, -1)), _hat(_tangent_line(w, v_err, 1))
    first, second = _optimal_pair(v1, v2, w1, w2)
    return _scal(_norm(s) - s_err, (-first[0], -first[1])), _scal(_norm(v) + v_err, second)


# --- the scalar well-clear tests of advisory/wcv.py -------------------------------------------------------------

def _h_wcv(s, v, thr) -> bool:
    return bool(_horizontal_wcv(np.array(s, float), np.array(v, float), thr))


def _h_interval(t: float, s, v, thr) -> tuple[float, float]:
    t_in, t_out = _horizontal_interval(np.array(s, float), np.array(v, float), thr, t)
    return float(t_in), float(t_out)


def _v_interval(sz: float, vz: float, thr, b: float, t: float) -> tuple[float, float]:
    low, up = _vertical_interval(np.float64(sz), np.float64(vz), thr, b, t)
    return float(low), float(up)


_EMPTY = (math.inf, -math.inf)  # LossData.EMPTY


# --- WCV_TAUMOD_SUM ---------------------------------------------------------------------------------------------

def _radial(s, v, s_err: float, v_err: float):
    """The head-on worst case where |v| <= v_err: s shortened by s_err, closing along s at |v| + v_err."""
    s_hat = _hat(s)
    return _scal(_norm(s) - s_err, s_hat), _scal(-(_norm(v) + v_err), s_hat)


def horizontal_wcv_uncertain(s, v, s_err: float, v_err: float, thr: WcvThresholds) -> bool:
    """WCV_TAUMOD_SUM.horizontal_wcv_taumod_uncertain."""
    if _h_wcv(s, v, thr) or _dot(s, s) <= (thr.dthr_m + s_err) ** 2:
        return True
    if _dot(v, v) <= v_err * v_err:
        return _h_wcv(*_radial(s, v, s_err, v_err), thr)
    return _h_wcv(*_optimal_wcv_pair(s, v, s_err, v_err), thr)


def vertical_wcv_uncertain(sz: float, vz: float, sz_err: float, vz_err: float, thr: WcvThresholds) -> bool:
    """WCV_TAUMOD_SUM.vertical_WCV_uncertain: sz moved toward 0 by sz_err (not past it), vz by vz_err toward
    closing."""
    sign = 1.0 if sz >= 0.0 else -1.0
    return bool(_vertical_wcv(np.float64(sz - sign * min(sz_err, abs(sz))), np.float64(vz - sign * vz_err), thr))


def _h_entry(s, v, s_err, v_err, t, thr) -> float:
    """WCV_TAUMOD_SUM.horizontal_wcv_taumod_uncertain_entry (T + 1: none)."""
    if _h_wcv(s, v, thr) or _dot(s, s) <= (thr.dthr_m + s_err) ** 2:
        return 0.0
    if _dot(v, v) <= v_err * v_err:
        t_in, t_out = _h_interval(t, *_radial(s, v, s_err, v_err), thr)
        return t + 1.0 if t_out < t_in else t_in
    first, second = _optimal_wcv_pair(s, v, s_err, v_err)
    if _dot(first, second) < 0.0:
        return min(_h_interval(t, s, v, thr)[0], _h_interval(t, first, second, thr)[0])
    return t + 1.0


def _theta_d_uncertain(s, v, s_err, v_err, eps: int, thr) -> float:
    """WCV_TAUMOD_SUM.Theta_D_uncertain: the root (Util.root) of the widened exit quadratic; -1 when none."""
    if _dot(v, v) <= v_err * v_err:
        return -1.0
    d = thr.dthr_m + s_err
    a = _dot(v, v) - v_err * v_err
    b = 2.0 * (_dot(s, v) - v_err * d)
    c = _dot(s, s) - d * d
    if a == 0.0 and b == 0.0:
        return -1.0
    if a == 0.0:
        return -c / b
    sqb, ac = b * b, 4.0 * a * c
    if almost_equals(sqb, ac) or sqb > ac:
        root = (-b + eps * math.sqrt(max(sqb - ac, 0.0))) / (2.0 * a)
        return root if math.isfinite(root) else -1.0
    return -1.0


def _h_exit(s, v, s_err, v_err, t, thr) -> float:
    """WCV_TAUMOD_SUM.horizontal_wcv_taumod_uncertain_exit (-1: none)."""
    slow = _dot(v, v) <= v_err * v_err
    if slow and _dot(s, s) <= (thr.dthr_m + s_err) ** 2:
        return t
    if slow:
        t_in, t_out = _h_interval(t, *_radial(s, v, s_err, v_err), thr)
        return -1.0 if t_out < t_in else t
    return _theta_d_uncertain(s, v, s_err, v_err, 1, thr)


def _h_uncertain_interval(s, v, s_err, v_err, t, thr) -> tuple[float, float]:
    """WCV_TAUMOD_SUM.horizontal_wcv_taumod_uncertain_interval."""
    entry, exit_ = _h_entry(s, v, s_err, v_err, t, thr), _h_exit(s, v, s_err, v_err, t, thr)
    if entry > t or exit_ < 0.0 or entry > exit_:
        return _EMPTY
    return max(0.0, entry), min(t, exit_)


def _v_full_szpos_vzneg(t, minsz, maxsz, minvz, maxvz, thr):
    entry = _v_interval(minsz, minvz, thr, 0.0, t)
    exit_ = _v_interval(maxsz, maxvz, thr, 0.0, t)
    if entry[0] > entry[1]:
        return _EMPTY
    if exit_[0] > exit_[1]:
        return entry[0], t
    return entry[0], exit_[1]


def _union(vel_only_a: bool, vel_only_b: bool, a, b):
    """The merge of two half-intervals as in vertical_WCV_uncertain_full_interval_szpos / _split."""
    if vel_only_a or b[0] > b[1]:
        return a
    if vel_only_b or a[0] > a[1]:
        return b
    return min(a[0], b[0]), max(a[1], b[1])


def _v_full_szpos(t, minsz, maxsz, minvz, maxvz, thr):
    """WCV_TAUMOD_SUM.vertical_WCV_uncertain_full_interval_szpos."""
    only_pos = minvz >= 0.0
    only_neg = not only_pos and maxvz <= 0.0
    pos = _EMPTY if only_neg else _v_interval(minsz, max(minvz, 0.0), thr, 0.0, t)
    neg = _EMPTY if only_pos else _v_full_szpos_vzneg(t, minsz, maxsz, minvz, min(maxvz, 0.0), thr)
    return _union(only_pos, only_neg, pos, neg)


def _v_uncertain_interval(b, t, sz, vz, sz_err, vz_err, thr):
    """WCV_TAUMOD_SUM.vertical_WCV_uncertain_interval (with vertical_WCV_uncertain_full_interval_split)."""
    minsz, maxsz, minvz, maxvz = sz - sz_err, sz + sz_err, vz - vz_err, vz + vz_err
    only_pos = minsz >= 0.0
    only_neg = not only_pos and maxsz <= 0.0
    pos = _EMPTY if only_neg else _v_full_szpos(t, max(minsz, 0.0), maxsz, minvz, maxvz, thr)
    neg = _EMPTY if only_pos else _v_full_szpos(t, -min(maxsz, 0.0), -minsz, -maxvz, -minvz, thr)
    low, up = _union(only_pos, only_neg, pos, neg)
    if low > up or up < b:
        return _EMPTY
    return max(b, low), min(t, up)


def wcv_uncertain_interval(b, t, s, v, sz, vz, s_err, sz_err, v_err, vz_err, thr) -> tuple[float, float]:
    """WCV_TAUMOD_SUM.WCV_taumod_uncertain_interval: (time_in, time_out) of the worst-case loss in [B, T]; s, v
    horizontal 2-tuples and sz, vz in DAIDALUS's sign convention (ownship - intruder)."""
    vint = _v_uncertain_interval(b, t, sz, vz, sz_err, vz_err, thr)
    if vint[0] > vint[1]:
        return vint
    hint = _h_uncertain_interval(s, v, s_err, v_err, t, thr)
    if hint[0] > hint[1]:
        return hint
    if hint[1] < b:
        return _EMPTY
    return max(vint[0], hint[0]), min(vint[1], hint[1])


def relative_errors(errors: np.ndarray, range_m: np.ndarray, z: SumZScores) -> np.ndarray:
    """(..., 4) relative (s_err, sz_err, v_err, vz_err) of the pairs from the (..., 4) sums of both aircraft's
    errors (SumData.errors) and their (...) horizontal ranges (WCV_TAUMOD_SUM.relativeHorizontalPositionError ...
    relativeVerticalSpeedError)."""
    errors = np.asarray(errors, float)
    s_err = z.h_pos * errors[..., 0]
    r = np.maximum(np.asarray(range_m, float) - s_err, 0.0)
    perc = r / z.h_vel_distance_m  # weighted_z_score, over arrays
    v_z = np.where(r >= z.h_vel_distance_m, z.h_vel_min, (1.0 - perc) * z.h_vel_max + perc * z.h_vel_min)
    return np.stack([s_err, z.v_pos * errors[..., 1], v_z * errors[..., 2], z.v_vel * errors[..., 3]], axis=-1)


@dataclass(frozen=True, slots=True)
class WCV_TAUMOD_SUM(WCV_TAUMOD):  # noqa: N801  (DAIDALUS's class name)
    """The well-clear detector with sensor uncertainty mitigation, as an alerter's Detector: the pairs whose
    Encounter.uncertainty is all zero are WCV_TAUMOD's; the others' conflict is WCV_taumod_uncertain_interval
    over [0, lookahead] with the relative errors of `relative_errors` (each floored at MIN_ERROR), beginning
    before time_s (ConflictData.conflictBefore). `violation` (now) stays WCV_TAUMOD's: DAIDALUS's alerting uses the
    conflict only. An intruder without altitude keeps WCV_TAUMOD's range-only test."""

    z_scores: SumZScores | None = None
    lookahead_s: float = 180.0  # DO_365B_SUM.conf lookahead_time: the detection interval [0, lookahead]

    def conflict(self, encounter, thresholds: WcvThresholds, time_s: float) -> np.ndarray:
        plain = WCV_TAUMOD.conflict(self, encounter, thresholds, time_s)
        errors = getattr(encounter, "uncertainty", None)
        if errors is None or self.z_scores is None:
            return plain
        g = encounter.geometry
        s_xy, v_xy = -np.asarray(g.s_xy_m, float), -np.asarray(g.v_xy_mps, float)  # ownship - intruder
        sz, vz = -np.asarray(encounter.separation_z_m(), float), -np.asarray(g.vz_mps, float)
        rel = relative_errors(errors, np.hypot(s_xy[:, 0], s_xy[:, 1]), self.z_scores)
        # all four zero: conflictDetection, the plain detector (conflictDetectionWithTrafficState)
        uncertain = np.flatnonzero((rel != 0.0).any(axis=1) & np.asarray(encounter.has_altitude, bool))
        if not len(uncertain):
            return plain
        out = plain.copy()
        horizon = max(self.lookahead_s, float(time_s))
        e = np.maximum(rel[uncertain], MIN_ERROR)
        t_in, t_out = wcv_uncertain_intervals(0.0, horizon, s_xy[uncertain], v_xy[uncertain], sz[uncertain],
                                              vz[uncertain], e[:, 0], e[:, 1], e[:, 2], e[:, 3], thresholds)
        # ConflictData.conflictBefore(alerting time) of the detection over [0, lookahead]
        out[uncertain] = ((t_in == 0.0) | almost_less(t_in, time_s)) & almost_less(t_in, t_out)
        return out


# --- the same, vectorised over any leading shape ----------------------------------------------------------------
# The functions above are the reference, line by line with DAIDALUS's; these evaluate every branch over arrays and
# pick with np.where / np.select in the same order (tests/test_do365_sum.py checks them against each other), so
# that the alerter's pairs and the guidance bands' candidate manoeuvres are one numpy evaluation each.

def _v2(x, y):
    return np.stack([x, y], axis=-1)


def _dot_v(a, b):
    return a[..., 0] * b[..., 0] + a[..., 1] * b[..., 1]


def _det_v(a, b):
    return a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]


def _norm_v(a):
    return np.sqrt(_dot_v(a, a))


def _hat_v(a):
    n = _norm_v(a)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where((n == 0.0)[..., None], 0.0, a / np.where(n == 0.0, 1.0, n)[..., None])


def _tangent_line_v(s, d, eps: int):
    sq_s, sq_d = _dot_v(s, s), d * d
    on = almost_equals(sq_s, sq_d)
    delta = sq_s - sq_d
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):  # a denormal |s|: a branch not taken
        safe = np.where(sq_s == 0.0, 1.0, sq_s)
        alpha, beta = sq_d / safe, d * np.sqrt(np.maximum(delta, 0.0)) / safe
        q = _v2(alpha * s[..., 0] + eps * beta * s[..., 1], alpha * s[..., 1] - eps * beta * s[..., 0])
    q_zero = ((q[..., 0] == 0.0) & (q[..., 1] == 0.0))[..., None]
    tangent = np.where(q_zero, q, q - s)
    out = np.where((delta >= 0.0)[..., None], tangent, 0.0)
    return np.where(np.asarray(on)[..., None], _v2(eps * s[..., 1], -eps * s[..., 0]), out)


def _sumof_v(v1, v2, w):
    d = _det_v(v2, v1)
    return (_det_v(w, v1) * d >= 0.0) & (_det_v(w, v2) * d <= 0.0)


def _optimal_pair_v(v1, v2, w1, w2):
    def avg(a, b):
        return _hat_v(a + b)

    conds = [_sumof_v(v1, v2, w1) & _sumof_v(v1, v2, w2), _sumof_v(w1, w2, v1) & _sumof_v(w1, w2, v2)]
    firsts, seconds = [avg(w1, w2), avg(v1, v2)], [avg(w1, w2), avg(v1, v2)]
    for a, b in ((v1, w1), (v1, w2), (v2, w1), (v2, w2)):
        conds.append(_sumof_v(w1, w2, a) & _sumof_v(v1, v2, b))
        firsts.append(avg(a, b))
        seconds.append(avg(a, b))
    d11, d12, d21, d22 = _dot_v(v1, w1), _dot_v(v1, w2), _dot_v(v2, w1), _dot_v(v2, w2)
    conds += [(d11 >= d12) & (d11 >= d21) & (d11 >= d22), (d12 >= d11) & (d12 >= d21) & (d12 >= d22),
              (d21 >= d11) & (d21 >= d12) & (d21 >= d22)]
    firsts += [v1, v1, v2]
    seconds += [w1, w2, w1]
    conds = [np.broadcast_to(c[..., None], v1.shape) for c in conds]
    return np.select(conds, firsts, v2), np.select(conds, seconds, w2)


def _optimal_wcv_pair_v(s, v, s_err, v_err):
    v1, v2 = _hat_v(_tangent_line_v(s, s_err, -1)), _hat_v(_tangent_line_v(s, s_err, 1))
    w1, w2 = _hat_v(_tangent_line_v(-v, v_err, -1)), _hat_v(_tangent_line_v(-v, v_err, 1))
    first, second = _optimal_pair_v(v1, v2, w1, w2)
    return (_norm_v(s) - s_err)[..., None] * -first, (_norm_v(v) + v_err)[..., None] * second


def _radial_v(s, v, s_err, v_err):
    s_hat = _hat_v(s)
    return (_norm_v(s) - s_err)[..., None] * s_hat, -(_norm_v(v) + v_err)[..., None] * s_hat


def _h_uncertain_interval_v(s, v, s_err, v_err, t, thr):
    """horizontal_wcv_taumod_uncertain_interval with its _entry and _exit, every branch evaluated."""
    inside_disk = _dot_v(s, s) <= (thr.dthr_m + s_err) ** 2
    slow = _dot_v(v, v) <= v_err * v_err
    rs, rv = _radial_v(s, v, s_err, v_err)
    r_in, r_out = _horizontal_interval(rs, rv, thr, t)
    first, second = _optimal_wcv_pair_v(s, v, s_err, v_err)
    n_in, _ = _horizontal_interval(s, v, thr, t)
    o_in, _ = _horizontal_interval(first, second, thr, t)
    entry = np.where(_horizontal_wcv(s, v, thr) | inside_disk, 0.0,
                     np.where(slow, np.where(r_out < r_in, t + 1.0, r_in),
                              np.where(_dot_v(first, second) < 0.0, np.minimum(n_in, o_in), t + 1.0)))
    # Theta_D_uncertain(eps = +1)
    d = thr.dthr_m + s_err
    a = _dot_v(v, v) - v_err * v_err
    b = 2.0 * (_dot_v(s, v) - v_err * d)
    c = _dot_v(s, s) - d * d
    sqb, ac = b * b, 4.0 * a * c
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        root = (-b + np.sqrt(np.maximum(sqb - ac, 0.0))) / (2.0 * np.where(a == 0.0, 1.0, a))
        linear = -c / np.where(b == 0.0, 1.0, b)
    real = almost_equals(sqb, ac) | (sqb > ac)
    theta = np.where((a == 0.0) & (b == 0.0), -1.0,
                     np.where(a == 0.0, linear, np.where(real & np.isfinite(root), root, -1.0)))
    exit_ = np.where(slow, np.where(inside_disk | ~(r_out < r_in), t, -1.0), theta)
    empty = (entry > t) | (exit_ < 0.0) | (entry > exit_)
    return np.where(empty, np.inf, np.maximum(0.0, entry)), np.where(empty, -np.inf, np.minimum(t, exit_))


def _v_int_v(sz, vz, thr, t):
    return _vertical_interval(sz, vz, thr, 0.0, t)


def _union_v(only_a, only_b, a, b):
    a_empty, b_empty = a[0] > a[1], b[0] > b[1]
    take_a = only_a | b_empty
    take_b = ~take_a & (only_b | a_empty)
    low = np.where(take_a, a[0], np.where(take_b, b[0], np.minimum(a[0], b[0])))
    up = np.where(take_a, a[1], np.where(take_b, b[1], np.maximum(a[1], b[1])))
    return low, up


def _v_full_szpos_v(t, minsz, maxsz, minvz, maxvz, thr):
    only_pos = minvz >= 0.0
    only_neg = ~only_pos & (maxvz <= 0.0)
    pos_l, pos_u = _v_int_v(minsz, np.maximum(minvz, 0.0), thr, t)
    pos = (np.where(only_neg, np.inf, pos_l), np.where(only_neg, -np.inf, pos_u))
    en_l, en_u = _v_int_v(minsz, minvz, thr, t)  # vertical_WCV_uncertain_full_interval_szpos_vzneg
    ex_l, ex_u = _v_int_v(maxsz, np.minimum(maxvz, 0.0), thr, t)
    neg_l = np.where(en_l > en_u, np.inf, en_l)
    neg_u = np.where(en_l > en_u, -np.inf, np.where(ex_l > ex_u, t, ex_u))
    neg = (np.where(only_pos, np.inf, neg_l), np.where(only_pos, -np.inf, neg_u))
    return _union_v(only_pos, only_neg, pos, neg)


def wcv_uncertain_intervals(b, t, s, v, sz, vz, s_err, sz_err, v_err, vz_err, thr) -> tuple[np.ndarray, np.ndarray]:
    """wcv_uncertain_interval over arrays: s, v (..., 2), the others (...) or scalars (t and b scalars); (time_in,
    time_out), and (inf, -inf) wherever the reference's time_in > time_out (no loss, in whichever form)."""
    s, v = np.asarray(s, float), np.asarray(v, float)
    sz, vz = np.asarray(sz, float), np.asarray(vz, float)
    s_err, sz_err, v_err, vz_err = (np.asarray(e, float) for e in (s_err, sz_err, v_err, vz_err))
    minsz, maxsz, minvz, maxvz = sz - sz_err, sz + sz_err, vz - vz_err, vz + vz_err
    only_pos = minsz >= 0.0
    only_neg = ~only_pos & (maxsz <= 0.0)
    pl, pu = _v_full_szpos_v(t, np.maximum(minsz, 0.0), maxsz, minvz, maxvz, thr)
    nl, nu = _v_full_szpos_v(t, -np.minimum(maxsz, 0.0), -minsz, -maxvz, -minvz, thr)
    pos = (np.where(only_neg, np.inf, pl), np.where(only_neg, -np.inf, pu))
    neg = (np.where(only_pos, np.inf, nl), np.where(only_pos, -np.inf, nu))
    low, up = _union_v(only_pos, only_neg, pos, neg)
    v_empty = (low > up) | (up < b)
    h_in, h_out = _h_uncertain_interval_v(s, v, s_err, v_err, t, thr)
    t_in, t_out = np.maximum(np.maximum(b, low), h_in), np.minimum(np.minimum(t, up), h_out)
    empty = v_empty | (h_in > h_out) | (h_out < b) | (t_in > t_out)
    return np.where(empty, np.inf, t_in), np.where(empty, -np.inf, t_out)
