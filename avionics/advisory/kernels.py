"""Compiled kernels of the DO-365 alerter (issue 29 item 4): one call over every pair and every alert level.

The numpy code is the reference and stays beside: advisory/wcv.py (WCV_TAUMOD, WCV_tvar, WCV_TCOA), advisory/
wcv_sum.py (WCV_TAUMOD_SUM: its scalar functions, line by line with DAIDALUS's, are what the SUM kernels follow),
base/almost.py (Util.almost_equals) and advisory/alerting.py (Alerter.alert, AlertLevel.fires). Each kernel below
is one of those functions for one pair, with the same formulas in the same order, so that the decisions are the
reference's and the numbers agree to the last bits (tests/test_kernels_alerting.py holds them to 1e-9 and every
decision identical, compiled kernels on and off). The DAIDALUS v2.0.4 Java methods (gov.nasa.larcfm.ACCoRD, Util)
are named at each kernel as the reference names them.

Why: the numpy alerter costs ~600 us per one-intruder call (3.3 ms with SUM) in per-call numpy overhead (dozens
of small array operations per level, `almost_equals` alone 37 %), where DAIDALUS's whole step costs 33 us;
docs/performance.md has the measurements.

Squares of thresholds (DTHR^2) are computed by the caller as the reference computes them (a Python float's
`** 2`), so that no tie at the threshold can round differently here.
"""

from __future__ import annotations

import math

import numpy as np

from avionics.base.jit import kernel
from avionics.base.kernels import almost_equals_one

PRECISION13 = 16348  # = base/almost.py PRECISION13 (Util.PRECISION13)
ZERO_13 = 1e-13  # = base/almost.py ZERO_COMPARISON[PRECISION13]
MIN_ERROR = 0.001  # = wcv_sum.MIN_ERROR (WCV_TAUMOD_SUM.MinError)

# the columns of `wcv_alert_pairs`' per-level parameters and its SUM parameters
LEVEL_COLUMNS = ("dthr_m", "dthr_sq_m2", "zthr_m", "tthr_s", "tcoa_s", "alerting_time_s", "early_alerting_time_s",
                 "altitude_required")
SUM_COLUMNS = ("on", "h_pos", "h_vel_min", "h_vel_max", "h_vel_distance_m", "v_pos", "v_vel", "lookahead_s")

_F2 = "UniTuple(float64, 2)"
_F4 = "UniTuple(float64, 4)"
_F5 = "UniTuple(float64, 5)"


# --- Util.almost_equals (base/almost.py) ------------------------------------------------------------------------

@kernel("boolean(float64, float64)")
def almost_equals(a, b):
    """Util.almost_equals(a, b, PRECISION13) (base/kernels.py almost_equals_one)."""
    return almost_equals_one(a, b, PRECISION13, ZERO_13)


@kernel("boolean(float64, float64)")
def almost_less(a, b):
    """Util.almost_less: a < b and not almost equal."""
    return a < b and not almost_equals(a, b)


# --- WCV_TAUMOD (advisory/wcv.py) -------------------------------------------------------------------------------

@kernel("boolean(float64, float64, float64, float64, float64, float64)")
def horizontal_wcv(sx, sy, vx, vy, d2, tthr):
    """WCV_tvar.horizontal_WCV with WCV_TAUMOD.horizontal_tvar (wcv._horizontal_wcv)."""
    sqs = sx * sx + sy * sy
    sdotv = sx * vx + sy * vy
    a = vx * vx + vy * vy
    tcpa = -sdotv / a if a > 0.0 else 0.0  # Horizontal.tcpa
    taumod = (d2 - sqs) / sdotv if sdotv < 0.0 else -1.0
    cx = sx + tcpa * vx
    cy = sy + tcpa * vy
    dcpa2 = cx * cx + cy * cy
    return sqs <= d2 or (dcpa2 <= d2 and taumod >= 0.0 and taumod <= tthr)


@kernel("boolean(float64, float64, float64, float64)")
def vertical_wcv(sz, vz, zthr, tcoa):
    """WCV_TCOA.vertical_WCV (wcv._vertical_wcv)."""
    moving = not almost_equals(vz, 0.0)
    t = -sz / vz if moving else np.inf  # Vertical.time_coalt
    return abs(sz) <= zthr or (moving and sz * vz <= 0.0 and t <= tcoa)


@kernel(f"{_F2}(float64, float64, float64, float64, float64, float64)")
def vertical_interval(sz, vz, zthr, tcoa, b, t):
    """WCV_TCOA.vertical_WCV_interval (wcv._vertical_interval): (low, up) in [B, T]; (T, B) where none."""
    level = almost_equals(vz, 0.0)
    safe = 1.0 if level else vz
    sign = 1.0 if safe >= 0.0 else -1.0
    act_h = max(zthr, abs(vz) * tcoa)
    t_entry = (-sign * act_h - sz) / safe  # Vertical.Theta_H
    t_exit = (sign * zthr - sz) / safe
    if level:
        if abs(sz) > zthr:
            return t, b
        return b, t
    if t < t_entry or t_exit < b:
        return t, b
    return max(b, t_entry), min(t, t_exit)


@kernel(f"{_F2}(float64, float64, float64, float64, float64, float64, float64)")
def horizontal_interval(sx, sy, vx, vy, d2, tthr, t):
    """WCV_TAUMOD.horizontal_WCV_interval (wcv._horizontal_interval): (time_in, time_out) in [0, T]; (T, 0) none."""
    sqs = sx * sx + sy * sy
    sdotv = sx * vx + sy * vy
    a = vx * vx + vy * vy
    b = 2.0 * sdotv + tthr * a
    c = sqs + tthr * sdotv - d2
    cross = sx * vy - sy * vx
    delta = d2 * a - cross * cross  # Horizontal.Delta
    safe_a = a if a > 0.0 else 1.0
    theta_out = (-sdotv + math.sqrt(max(delta, 0.0))) / safe_a  # Horizontal.Theta_D(s, v, +1, D)
    discr = b * b - 4.0 * a * c
    t_first = (-b - math.sqrt(max(discr, 0.0))) / (2.0 * safe_a)
    inside = sqs <= d2
    if inside and almost_equals(a, 0.0):  # no relative horizontal motion
        return 0.0, t
    if inside:
        return 0.0, min(t, theta_out)
    if sdotv < 0.0 and discr >= 0.0 and delta >= 0.0 and t_first <= t:
        return max(0.0, t_first), min(t, theta_out)
    return t, 0.0


@kernel(f"{_F2}(float64, float64, float64, float64, float64, float64, float64, float64, float64, float64, "
        "float64, float64)")
def wcv_interval(sx, sy, vx, vy, sz, vz, d2, zthr, tthr, tcoa, b, t):
    """WCV_tvar.WCV_interval (wcv.wcv_interval): the loss interval within [B, T]."""
    low, up = vertical_interval(sz, vz, zthr, tcoa, b, t)
    if low > up:
        return t, b
    stx = sx + low * vx  # the horizontal state at the vertical entry
    sty = sy + low * vy
    if almost_equals(low, up):
        if horizontal_wcv(stx, sty, vx, vy, d2, tthr):
            return low, up
        return t, b
    h_in, h_out = horizontal_interval(stx, sty, vx, vy, d2, tthr, up - low)
    return h_in + low, h_out + low


@kernel("float64[:, ::1](float64[:, ::1], float64[:, ::1], float64[::1], float64[::1], float64, float64, float64, "
        "float64, float64, float64)")
def wcv_interval_lines(s_xy, v_xy, sz, vz, d2, zthr, tthr, tcoa, b, t):
    """wcv.wcv_interval over M lines (the guidance bands' samples): (M, 2) of (t_in, t_out)."""
    m = sz.shape[0]
    out = np.empty((m, 2))
    for i in range(m):
        out[i, 0], out[i, 1] = wcv_interval(s_xy[i, 0], s_xy[i, 1], v_xy[i, 0], v_xy[i, 1], sz[i], vz[i], d2, zthr,
                                            tthr, tcoa, b, t)
    return out


# --- WCV_TAUMOD_SUM (advisory/wcv_sum.py, its scalar functions) --------------------------------------------------

@kernel(f"{_F2}(float64, float64)")
def _hat(x, y):
    """Vect2.Hat: zero stays zero."""
    n = math.sqrt(x * x + y * y)
    if n == 0.0:
        return 0.0, 0.0
    return x / n, y / n


@kernel(f"{_F2}(float64, float64, float64, float64)")
def _tangent_line(sx, sy, d, eps):
    """TangentLine(s, D, eps) (wcv_sum._tangent_line)."""
    sq_s = sx * sx + sy * sy
    sq_d = d * d
    if almost_equals(sq_s, sq_d):
        return eps * sy, -eps * sx
    delta = sq_s - sq_d
    if delta >= 0.0:
        alpha = sq_d / sq_s
        beta = d * math.sqrt(max(delta, 0.0)) / sq_s
        qx = alpha * sx + eps * beta * sy
        qy = alpha * sy - eps * beta * sx
        if qx != 0.0 or qy != 0.0:
            return qx - sx, qy - sy
        return qx, qy
    return 0.0, 0.0


@kernel("boolean(float64, float64, float64, float64, float64, float64)")
def _sumof(v1x, v1y, v2x, v2y, wx, wy):
    """WCV_TAUMOD_SUM.sumof: w lies in the cone spanned by v1 and v2."""
    d = v2x * v1y - v2y * v1x
    return (wx * v1y - wy * v1x) * d >= 0.0 and (wx * v2y - wy * v2x) * d <= 0.0


@kernel(f"{_F4}(float64, float64, float64, float64, float64, float64, float64, float64)")
def _optimal_pair(v1x, v1y, v2x, v2y, w1x, w1y, w2x, w2y):
    """WCV_TAUMOD_SUM.optimal_pair (wcv_sum._optimal_pair): the directions of the two cones that are closest."""
    if _sumof(v1x, v1y, v2x, v2y, w1x, w1y) and _sumof(v1x, v1y, v2x, v2y, w2x, w2y):
        dx, dy = _hat(w1x + w2x, w1y + w2y)
        return dx, dy, dx, dy
    if _sumof(w1x, w1y, w2x, w2y, v1x, v1y) and _sumof(w1x, w1y, w2x, w2y, v2x, v2y):
        dx, dy = _hat(v1x + v2x, v1y + v2y)
        return dx, dy, dx, dy
    for k in range(4):  # one direction of each cone in the other's: (v1, w1), (v1, w2), (v2, w1), (v2, w2)
        ax, ay = (v1x, v1y) if k < 2 else (v2x, v2y)
        bx, by = (w1x, w1y) if k % 2 == 0 else (w2x, w2y)
        if _sumof(w1x, w1y, w2x, w2y, ax, ay) and _sumof(v1x, v1y, v2x, v2y, bx, by):
            dx, dy = _hat(ax + bx, ay + by)
            return dx, dy, dx, dy
    d11 = v1x * w1x + v1y * w1y
    d12 = v1x * w2x + v1y * w2y
    d21 = v2x * w1x + v2y * w1y
    d22 = v2x * w2x + v2y * w2y
    if d11 >= d12 and d11 >= d21 and d11 >= d22:
        return v1x, v1y, w1x, w1y
    if d12 >= d11 and d12 >= d21 and d12 >= d22:
        return v1x, v1y, w2x, w2y
    if d21 >= d11 and d21 >= d12 and d21 >= d22:
        return v2x, v2y, w1x, w1y
    return v2x, v2y, w2x, w2y


@kernel(f"{_F4}(float64, float64, float64, float64, float64, float64)")
def _optimal_wcv_pair(sx, sy, vx, vy, s_err, v_err):
    """WCV_TAUMOD_SUM.optimal_wcv_pair(s, v, s_err, v_err, -1, -1) (wcv_sum._optimal_wcv_pair): the worst relative
    position and velocity, (s'x, s'y, v'x, v'y)."""
    t1x, t1y = _tangent_line(sx, sy, s_err, -1.0)
    v1x, v1y = _hat(t1x, t1y)
    t2x, t2y = _tangent_line(sx, sy, s_err, 1.0)
    v2x, v2y = _hat(t2x, t2y)
    t3x, t3y = _tangent_line(-vx, -vy, v_err, -1.0)
    w1x, w1y = _hat(t3x, t3y)
    t4x, t4y = _tangent_line(-vx, -vy, v_err, 1.0)
    w2x, w2y = _hat(t4x, t4y)
    fx, fy, gx, gy = _optimal_pair(v1x, v1y, v2x, v2y, w1x, w1y, w2x, w2y)
    ks = math.sqrt(sx * sx + sy * sy) - s_err
    kv = math.sqrt(vx * vx + vy * vy) + v_err
    return ks * -fx, ks * -fy, kv * gx, kv * gy


@kernel(f"{_F4}(float64, float64, float64, float64, float64, float64)")
def _radial(sx, sy, vx, vy, s_err, v_err):
    """wcv_sum._radial: s shortened by s_err, closing along s at |v| + v_err."""
    hx, hy = _hat(sx, sy)
    ks = math.sqrt(sx * sx + sy * sy) - s_err
    kv = -(math.sqrt(vx * vx + vy * vy) + v_err)
    return ks * hx, ks * hy, kv * hx, kv * hy


@kernel(f"{_F2}(float64, float64, float64, float64, float64, float64, float64, float64, float64, float64)")
def h_uncertain_interval(sx, sy, vx, vy, s_err, v_err, t, dthr, d2, tthr):
    """WCV_TAUMOD_SUM.horizontal_wcv_taumod_uncertain_interval with its _entry, _exit and Theta_D_uncertain
    (wcv_sum._h_uncertain_interval); (inf, -inf) where none."""
    sqs = sx * sx + sy * sy
    vv = vx * vx + vy * vy
    dd = dthr + s_err
    inside_disk = sqs <= dd * dd
    slow = vv <= v_err * v_err
    # horizontal_wcv_taumod_uncertain_entry (T + 1: none)
    if horizontal_wcv(sx, sy, vx, vy, d2, tthr) or inside_disk:
        entry = 0.0
    elif slow:
        rsx, rsy, rvx, rvy = _radial(sx, sy, vx, vy, s_err, v_err)
        r_in, r_out = horizontal_interval(rsx, rsy, rvx, rvy, d2, tthr, t)
        entry = t + 1.0 if r_out < r_in else r_in
    else:
        fx, fy, gx, gy = _optimal_wcv_pair(sx, sy, vx, vy, s_err, v_err)
        if fx * gx + fy * gy < 0.0:
            n_in = horizontal_interval(sx, sy, vx, vy, d2, tthr, t)[0]
            o_in = horizontal_interval(fx, fy, gx, gy, d2, tthr, t)[0]
            entry = min(n_in, o_in)
        else:
            entry = t + 1.0
    # horizontal_wcv_taumod_uncertain_exit (-1: none)
    if slow and inside_disk:
        exit_ = t
    elif slow:
        rsx, rsy, rvx, rvy = _radial(sx, sy, vx, vy, s_err, v_err)
        r_in, r_out = horizontal_interval(rsx, rsy, rvx, rvy, d2, tthr, t)
        exit_ = -1.0 if r_out < r_in else t
    else:  # Theta_D_uncertain(eps = +1)
        a = vv - v_err * v_err
        b = 2.0 * ((sx * vx + sy * vy) - v_err * dd)
        c = sqs - dd * dd
        if a == 0.0 and b == 0.0:
            exit_ = -1.0
        elif a == 0.0:
            exit_ = -c / b
        else:
            sqb = b * b
            ac = 4.0 * a * c
            if almost_equals(sqb, ac) or sqb > ac:
                root = (-b + math.sqrt(max(sqb - ac, 0.0))) / (2.0 * a)
                exit_ = root if math.isfinite(root) else -1.0
            else:
                exit_ = -1.0
    if entry > t or exit_ < 0.0 or entry > exit_:
        return np.inf, -np.inf
    return max(0.0, entry), min(t, exit_)


@kernel(f"{_F2}(float64, float64, float64, float64, float64, float64, float64)")
def _v_full_szpos(t, minsz, maxsz, minvz, maxvz, zthr, tcoa):
    """WCV_TAUMOD_SUM.vertical_WCV_uncertain_full_interval_szpos with its _vzneg (wcv_sum._v_full_szpos)."""
    only_pos = minvz >= 0.0
    only_neg = not only_pos and maxvz <= 0.0
    pos_l, pos_u = np.inf, -np.inf
    if not only_neg:
        pos_l, pos_u = vertical_interval(minsz, max(minvz, 0.0), zthr, tcoa, 0.0, t)
    neg_l, neg_u = np.inf, -np.inf
    if not only_pos:
        en_l, en_u = vertical_interval(minsz, minvz, zthr, tcoa, 0.0, t)
        ex_l, ex_u = vertical_interval(maxsz, min(maxvz, 0.0), zthr, tcoa, 0.0, t)
        if not en_l > en_u:
            neg_l = en_l
            neg_u = t if ex_l > ex_u else ex_u
    if only_pos or neg_l > neg_u:  # wcv_sum._union
        return pos_l, pos_u
    if only_neg or pos_l > pos_u:
        return neg_l, neg_u
    return min(pos_l, neg_l), max(pos_u, neg_u)


@kernel(f"{_F2}(float64, float64, float64, float64, float64, float64, float64, float64)")
def v_uncertain_interval(b, t, sz, vz, sz_err, vz_err, zthr, tcoa):
    """WCV_TAUMOD_SUM.vertical_WCV_uncertain_interval with vertical_WCV_uncertain_full_interval_split
    (wcv_sum._v_uncertain_interval); (inf, -inf) where none."""
    minsz = sz - sz_err
    maxsz = sz + sz_err
    minvz = vz - vz_err
    maxvz = vz + vz_err
    only_pos = minsz >= 0.0
    only_neg = not only_pos and maxsz <= 0.0
    pos_l, pos_u = np.inf, -np.inf
    if not only_neg:
        pos_l, pos_u = _v_full_szpos(t, max(minsz, 0.0), maxsz, minvz, maxvz, zthr, tcoa)
    neg_l, neg_u = np.inf, -np.inf
    if not only_pos:
        neg_l, neg_u = _v_full_szpos(t, -min(maxsz, 0.0), -minsz, -maxvz, -minvz, zthr, tcoa)
    if only_pos or neg_l > neg_u:
        low, up = pos_l, pos_u
    elif only_neg or pos_l > pos_u:
        low, up = neg_l, neg_u
    else:
        low, up = min(pos_l, neg_l), max(pos_u, neg_u)
    if low > up or up < b:
        return np.inf, -np.inf
    return max(b, low), min(t, up)


@kernel(f"{_F2}(float64, float64, float64, float64, float64, float64, float64, float64, float64, float64, "
        "float64, float64, float64, float64, float64, float64, float64)")
def wcv_uncertain_interval(b, t, sx, sy, vx, vy, sz, vz, s_err, sz_err, v_err, vz_err, dthr, d2, zthr, tthr, tcoa):
    """WCV_TAUMOD_SUM.WCV_taumod_uncertain_interval (wcv_sum.wcv_uncertain_interval, in the form of
    wcv_uncertain_intervals: (inf, -inf) wherever there is no loss); s, v, sz, vz ownship - intruder."""
    v_low, v_up = v_uncertain_interval(b, t, sz, vz, sz_err, vz_err, zthr, tcoa)
    if v_low > v_up:
        return np.inf, -np.inf
    h_in, h_out = h_uncertain_interval(sx, sy, vx, vy, s_err, v_err, t, dthr, d2, tthr)
    if h_in > h_out or h_out < b:
        return np.inf, -np.inf
    t_in = max(v_low, h_in)
    t_out = min(v_up, h_out)
    if t_in > t_out:
        return np.inf, -np.inf
    return t_in, t_out


# --- one pair, one level: WCV_TAUMOD.conflict, WCV_TAUMOD_SUM.conflict ------------------------------------------

@kernel("boolean(float64, float64, float64, float64, float64, float64, boolean, float64, float64, float64, float64, "
        "float64[::1], float64[::1], float64, boolean)")
def wcv_conflict(sx, sy, vx, vy, sz, vz, has_alt, e_h, e_z, e_v, e_vz, lv, sp, time_s, altitude_required):
    """One pair's conflict within time_s at one level (`lv` a row of LEVEL_COLUMNS, `sp` SUM_COLUMNS): sz the
    separation with the datum margin taken off (Encounter.separation_z_m); e_* the sums of both aircraft's errors
    (Encounter.uncertainty). WCV_TAUMOD.conflict, or WCV_TAUMOD_SUM.conflict where SUM is on and the pair's
    relative errors are not all zero (conflictDetectionWithTrafficState)."""
    dthr, d2, zthr, tthr, tcoa = lv[0], lv[1], lv[2], lv[3], lv[4]
    if not has_alt:  # the horizontal interval alone (the vertical test passes at every time)
        if altitude_required:
            return False
        h_in, h_out = horizontal_interval(sx, sy, vx, vy, d2, tthr, time_s)
        return almost_less(h_in, h_out)  # LossData.conflict
    if sp[0] != 0.0:  # WCV_TAUMOD_SUM.relativeHorizontalPositionError ... relativeVerticalSpeedError
        s_err = sp[1] * e_h
        r = max(np.hypot(-sx, -sy) - s_err, 0.0)
        perc = r / sp[4]
        z_v = sp[2] if r >= sp[4] else (1.0 - perc) * sp[3] + perc * sp[2]  # weighted_z_score
        sz_err = sp[5] * e_z
        v_err = z_v * e_v
        vz_err = sp[6] * e_vz
        if s_err != 0.0 or sz_err != 0.0 or v_err != 0.0 or vz_err != 0.0:
            horizon = max(sp[7], time_s)
            t_in, t_out = wcv_uncertain_interval(0.0, horizon, -sx, -sy, -vx, -vy, -sz, -vz, max(s_err, MIN_ERROR),
                                                 max(sz_err, MIN_ERROR), max(v_err, MIN_ERROR),
                                                 max(vz_err, MIN_ERROR), dthr, d2, zthr, tthr, tcoa)
            # ConflictData.conflictBefore(alerting time) of the detection over [0, lookahead]
            return (t_in == 0.0 or almost_less(t_in, time_s)) and almost_less(t_in, t_out)
    t_in, t_out = wcv_interval(sx, sy, vx, vy, sz, vz, d2, zthr, tthr, tcoa, 0.0, time_s)
    return almost_less(t_in, t_out)


@kernel("int64[::1](float64[:, ::1], float64[:, ::1], float64[::1], float64[::1], boolean[::1], float64[::1], "
        "float64[:, ::1], int64[::1], float64[:, ::1], float64[::1], int64)")
def wcv_alert_pairs(s_xy, v_xy, sz, vz, has_alt, margin, errors, previous, levels, sum_params, max_level):
    """Alerter.alert of a well-clear alerter (advisory/alerting.py; DAIDALUS DaidalusCore.alert_level) for N pairs:
    per pair the most severe level 1..max_level whose detector's conflict begins within its alerting time (its
    early alerting time where the pair's previous alert is that level: DaidalusCore.check_alerting_thresholds);
    0 where none. s_xy, v_xy, sz, vz: intruder - ownship; margin: the datum margin off |sz|; errors (N, 4): the
    pairs' summed errors (zeros without uncertainty); levels (L, 8) rows of LEVEL_COLUMNS; sum_params
    SUM_COLUMNS."""
    n = s_xy.shape[0]
    out = np.zeros(n, np.int64)
    for i in range(n):
        z = sz[i]
        sep = np.sign(z) * max(abs(z) - margin[i], 0.0)  # Encounter.separation_z_m
        for k in range(min(max_level, levels.shape[0])):
            lv = levels[k]
            early = lv[6]
            time_s = early if early == early and previous[i] == k + 1 else lv[5]
            if wcv_conflict(s_xy[i, 0], s_xy[i, 1], v_xy[i, 0], v_xy[i, 1], sep, vz[i], has_alt[i], errors[i, 0],
                            errors[i, 1], errors[i, 2], errors[i, 3], lv, sum_params, time_s, lv[7] != 0.0):
                out[i] = k + 1
    return out


# --- Kinematics.vsLevelOutTimes (advisory/bands_kinematics.py level_out_times), the altitude bands' targets ------

@kernel("float64(float64, float64)")
def _ieee_div(a, b):
    """a / b as numpy divides (inf, NaN for b = 0), where numba's Python error model would raise."""
    if b != 0.0:
        return a / b
    if a != a or a == 0.0:
        return np.nan
    return math.copysign(math.inf, a) * math.copysign(1.0, b)


@kernel("float64(float64, float64)")
def _maximum(a, b):
    """np.maximum: NaN propagates; a on ties."""
    return a if (a >= b or a != a) else b


@kernel("float64(float64, float64, float64)")
def _s1(v, a, t):
    return v * t + 0.5 * a * t * t


@kernel("float64(float64, float64)")
def _s3(v, a):
    return _s1(v, a, -v / a)


@kernel("float64(float64, float64, float64, float64)")
def _root(a, b, c, eps):
    """bands_kinematics._root: Util.root, (-b + eps sqrt(b^2 - 4ac)) / 2a; NaN where none, -c/b where a == 0."""
    if a == 0.0:
        return -c / b if b != 0.0 else np.nan
    disc = b * b - 4 * a * c
    if not disc >= 0:
        return np.nan
    return (-b + eps * np.sqrt(_maximum(disc, 0.0))) / (2 * a)


@kernel(f"{_F5}(float64, float64, float64, float64, float64, float64)")
def _level_out_ad1(s0z, v0z, climb_rate, target, accel_up, accel_down):
    """bands_kinematics._level_out_ad1 for one target: Kinematics.vsLevelOutTimesAD1 (T1, T2, T3, a1, a2)."""
    alt_dir = 1.0 if target >= s0z else -1.0
    cr = alt_dir * _maximum(abs(climb_rate), abs(v0z))
    s = target - s0z
    a1 = accel_up if cr >= v0z else accel_down
    a2 = accel_down if target >= s0z else accel_up
    t1 = (cr - v0z) / a1
    v1 = v0z + a1 * t1
    if abs(s) >= abs(_s1(v0z, a1, t1) + _s3(v1, a2)):
        t2 = _ieee_div(s - _s1(v0z, a1, t1) - _s3(v1, a2), cr)
        return t1, t1 + t2, t1 + t2 + -cr / a2, a1, a2
    aa = 0.5 * a1 * (1 - a1 / a2)
    bb = v0z * (1 - a1 / a2)
    cc = -v0z * v0z / (2 * a2) - s
    r1, r2 = _root(aa, bb, cc, 1.0), _root(aa, bb, cc, -1.0)
    if r1 < 0:
        t1b = r2
    elif r2 < 0:
        t1b = r1
    else:
        t1b = r1 if (r1 <= r2 or r1 != r1) else r2  # np.minimum: NaN propagates, r1 on ties
    return t1b, t1b, t1b + -(v0z + a1 * t1b) / a2, a1, a2


@kernel("float64[:, ::1](float64, float64, float64, float64[::1], float64, boolean)")
def level_out_times_targets(s0z, v0z, climb_rate, targets, accel, level):
    """bands_kinematics.level_out_times for targets (M,): (5, M) rows T1, T2, T3, a1, a2; level: the ownship's
    vertical speed is almost 0 (Util.almost_equals at PRECISION5, the caller's)."""
    up = accel
    down = -accel
    sgnv = 1.0 if v0z >= 0 else -1.0
    out = np.empty((5, targets.shape[0]))
    for j in range(targets.shape[0]):
        target = targets[j]
        alt_dir = 1.0 if target >= s0z else -1.0
        a1 = up if target >= s0z else down
        a2 = down if target >= s0z else up
        zero = 0.0 * target  # as the reference's: its sign too
        if sgnv == alt_dir or level:
            if abs(target - s0z) >= abs(_s3(v0z, a2)):  # case 1.1: room to decelerate
                r = _level_out_ad1(s0z, v0z, climb_rate, target, up, down)
                shift = 0.0
                add = False
            else:  # 1.2: an overshoot, first stop
                r = _level_out_ad1(s0z + _s3(v0z, a2), zero, climb_rate, target, up, down)
                shift = -v0z / a2
                add = True
        else:  # 2: moving away, first stop
            r = _level_out_ad1(s0z + _s3(v0z, a1), zero, climb_rate, target, up, down)
            shift = -v0z / a1
            add = True
        for i in range(5):
            out[i, j] = (r[i] + (shift if i < 3 else 0.0)) if add else r[i]
    return out


# --- the recovery cylinder (advisory/bands_kinematics.py cylinder_interval, advisory/bands.py _lines) -------------

@kernel("float64(float64, float64)")
def _minimum(a, b):
    """np.minimum: NaN propagates; a on ties."""
    return a if (a <= b or a != a) else b


@kernel(f"{_F2}(float64, float64, float64, float64, float64, float64, float64, float64, float64)")
def cylinder_interval(sx, sy, vx, vy, sz, vz, d2, h, t_end):
    """bands_kinematics.cylinder_interval for one line: CD3D.detection's (t_in, t_out) within [0, t_end]."""
    a = vx * vx + vy * vy
    b = sx * vx + sy * vy
    sqs = sx * sx + sy * sy
    delta = b * b - a * (sqs - d2)  # Horizontal.Delta
    sq = math.sqrt(_maximum(delta, 0.0))
    still = almost_equals(vx, 0.0) and almost_equals(vy, 0.0)
    h_los = not almost_equals(sqs, d2) and sqs < d2
    if still and h_los:
        h_in, h_out = -math.inf, math.inf
    elif delta > 0 and a > 0:
        h_in, h_out = (-b - sq) / a, (-b + sq) / a
    else:
        h_in, h_out = math.inf, -math.inf
    abs_sz = abs(sz)
    if almost_equals(vz, 0.0):
        v_los = not almost_equals(abs_sz, h) and abs_sz < h
        v_in, v_out = (-math.inf, math.inf) if v_los else (math.inf, -math.inf)
    else:
        sign = 1.0 if vz >= 0.0 else -1.0
        v_in, v_out = (-sign * h - sz) / vz, (sign * h - sz) / vz
    return _maximum(_maximum(h_in, v_in), 0.0), _minimum(_minimum(h_out, v_out), t_end)


@kernel("float64[:, ::1](float64[:, ::1], float64[:, ::1], float64, float64, float64)")
def cylinder_lines(s, v, d2, h, t_end):
    """cylinder_interval over M lines (M, 3) (the bands' recovery and NMAC cylinders): (M, 2) of (t_in, t_out)."""
    m = s.shape[0]
    out = np.empty((m, 2))
    for i in range(m):
        out[i, 0], out[i, 1] = cylinder_interval(s[i, 0], s[i, 1], v[i, 0], v[i, 1], s[i, 2], v[i, 2], d2, h, t_end)
    return out
