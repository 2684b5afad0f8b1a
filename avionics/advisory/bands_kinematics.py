"""Ownship manoeuvre trajectories and the recovery cylinder for the DAIDALUS bands (avionics/advisory/bands.py).

Everything is in the local ENU frame (x east, y north, z up; metres, seconds), vectorised over arrays of times
and, for the altitude bands, of target altitudes. The formulas follow NASA DAIDALUS v2.0.4's Util classes:

- turn:      Kinematics.turn / ProjectedKinematics.turn (constant ground speed, turn radius R = gs / omega, so
             the track changes at exactly the configured turn rate: Kinematics.bankAngle then turnRadius);
- gs_accel:  Kinematics.gsAccel (constant track, ground speed changing at a);
- vs_accel:  Kinematics.vsAccel (vertical speed changing at a);
- level-out: Kinematics.vsLevelOutTimes / vsLevelOutTimesAD1 / vsLevelOutCalc (accelerate to the climb rate,
             climb, decelerate to level at the target altitude), as DaidalusAltBands uses them.

The recovery detector CDCylinder (DAIDALUS CDCylinder / CD3D: a cylinder of radius D and half-height H, strict
inequalities) is here too, in the same (s, v) interface as avionics/advisory/wcv.py.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from avionics.base import almost as _almost
from avionics.base import jit
from avionics.conflict.probability import as_c

kernels = jit.lazy(__name__, "avionics.advisory.kernels")  # the module, once jit.load() ran (jit.py)

# DaidalusParameters.ALMOST_ = Util.PRECISION5: the bands compare at about 5 significant digits (2^40 ULPs; at
# zero, below 1e-5), with Util's semantics (base/almost.py).


def almost_equals(a, b):
    """Util.almost_equals(a, b, PRECISION5)."""
    return _almost.almost_equals(a, b, _almost.PRECISION5)


def almost_less(a, b):
    """Util.almost_less(a, b, PRECISION5)."""
    return _almost.almost_less(a, b, _almost.PRECISION5)


def almost_leq(a, b):
    """Util.almost_leq(a, b, PRECISION5)."""
    return _almost.almost_leq(a, b, _almost.PRECISION5)


# --- horizontal and vertical manoeuvres -----------------------------------------------------------------------

def turn(p0, v0, t, omega: float, right: bool):
    """Kinematics.turn: position (K, 3) and velocity (K, 3) after turning for times t (K,) at |omega| rad/s
    (right = clockwise seen from above = track increasing), ground speed and vertical speed constant."""
    t = np.asarray(t, float)
    gs = float(np.hypot(v0[0], v0[1]))
    trk0 = float(np.arctan2(v0[0], v0[1]))
    w = omega if right else -omega
    trk = trk0 + w * t
    pos = np.empty(t.shape + (3,))
    vel = np.empty(t.shape + (3,))
    if gs == 0.0 or omega == 0.0:
        pos[..., 0] = p0[0] + v0[0] * t
        pos[..., 1] = p0[1] + v0[1] * t
    else:
        r = gs / w  # signed radius
        pos[..., 0] = p0[0] + r * (np.cos(trk0) - np.cos(trk))
        pos[..., 1] = p0[1] + r * (np.sin(trk) - np.sin(trk0))
    pos[..., 2] = p0[2] + v0[2] * t
    vel[..., 0] = gs * np.sin(trk)
    vel[..., 1] = gs * np.cos(trk)
    vel[..., 2] = v0[2]
    return pos, vel


def gs_accel(p0, v0, t, a: float):
    """Kinematics.gsAccel: along the current track, ground speed gs + a t, position gs t + a t^2 / 2."""
    t = np.asarray(t, float)
    gs = float(np.hypot(v0[0], v0[1]))
    trk = float(np.arctan2(v0[0], v0[1]))
    dist = gs * t + 0.5 * a * t * t
    ngs = gs + a * t
    pos = np.stack([p0[0] + dist * np.sin(trk), p0[1] + dist * np.cos(trk), p0[2] + v0[2] * t], -1)
    # Velocity.mkGs keeps the track (a negative speed points backwards, as mkGs scales the unit vector)
    vel = np.stack([ngs * np.sin(trk), ngs * np.cos(trk), np.full_like(t, v0[2])], -1)
    return pos, vel


def vs_accel(p0, v0, t, a: float):
    """Kinematics.vsAccel: horizontal motion straight on, vertical speed vz + a t."""
    t = np.asarray(t, float)
    pos = np.stack([p0[0] + v0[0] * t, p0[1] + v0[1] * t, p0[2] + v0[2] * t + 0.5 * a * t * t], -1)
    vel = np.stack([np.full_like(t, v0[0]), np.full_like(t, v0[1]), v0[2] + a * t], -1)
    return pos, vel


# --- level-out (altitude bands) -------------------------------------------------------------------------------

def _s1(v, a, t):
    return v * t + 0.5 * a * t * t


def _t3(v, a):
    return -v / a


def _s3(v, a):
    return _s1(v, a, _t3(v, a))


def _root(a, b, c, eps):
    """Util.root: the root (-b + eps sqrt(b^2 - 4ac)) / 2a (NaN where none, -c/b where a == 0)."""
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        disc = b * b - 4 * a * c
        r = np.where(disc >= 0, (-b + eps * np.sqrt(np.maximum(disc, 0.0))) / (2 * np.where(a == 0, 1, a)),
                     np.nan)
        return np.where(a == 0, np.where(b != 0, -c / np.where(b == 0, 1, b), np.nan), r)


def _level_out_ad1(s0z, v0z, climb_rate, target, accel_up, accel_down):
    """Kinematics.vsLevelOutTimesAD1 (allowClimbRateChange = true), vectorised: (T1, T2, T3, a1, a2)."""
    alt_dir = np.where(target >= s0z, 1.0, -1.0)
    cr = alt_dir * np.maximum(abs(climb_rate), np.abs(v0z))
    s = target - s0z
    a1 = np.where(cr >= v0z, accel_up, accel_down)
    a2 = np.where(target >= s0z, accel_down, accel_up)
    t1 = (cr - v0z) / a1
    v1 = v0z + a1 * t1
    reach = np.abs(s) >= np.abs(_s1(v0z, a1, t1) + _s3(v1, a2))
    with np.errstate(divide="ignore", invalid="ignore"):
        t2 = (s - _s1(v0z, a1, t1) - _s3(v1, a2)) / cr
    case1 = (t1, t1 + t2, t1 + t2 + _t3(cr, a2))
    aa = 0.5 * a1 * (1 - a1 / a2)
    bb = v0z * (1 - a1 / a2)
    cc = -v0z * v0z / (2 * a2) - s
    r1, r2 = _root(aa, bb, cc, 1), _root(aa, bb, cc, -1)
    t1b = np.where(r1 < 0, r2, np.where(r2 < 0, r1, np.minimum(r1, r2)))
    case2 = (t1b, t1b, t1b + _t3(v0z + a1 * t1b, a2))
    out = tuple(np.where(reach, c1, c2) for c1, c2 in zip(case1, case2))
    return out + (a1, a2)


def level_out_times(s0z: float, v0z: float, climb_rate: float, target, accel: float):
    """Kinematics.vsLevelOutTimes(s0z, v0z, climbRate, targetAlt, a, -a, true) for target altitudes (M,):
    (T1 end of first acceleration, T2 end of the constant climb, T3 level, a1, a2), each (M,). The compiled
    loop (advisory/kernels.py level_out_times_targets: this arithmetic target by target) when the kernels are
    ready."""
    target = np.asarray(target, float)
    if jit.ready() and target.ndim == 1 and accel > 0:
        return tuple(kernels.level_out_times_targets(float(s0z), float(v0z), float(climb_rate), as_c(target),
                                                     float(accel), bool(almost_equals(v0z, 0.0))))
    up, down = accel, -accel
    sgnv = 1.0 if v0z >= 0 else -1.0
    alt_dir = np.where(target >= s0z, 1.0, -1.0)
    a1 = np.where(target >= s0z, up, down)
    a2 = np.where(target >= s0z, down, up)
    s = target - s0z
    same = (sgnv == alt_dir) | bool(almost_equals(v0z, 0.0))
    # case 1.1: enough room to decelerate; 1.2: overshoot, first stop; 2: moving away, first stop
    c11 = _level_out_ad1(s0z, v0z, climb_rate, target, up, down)
    over_z = s0z + _s3(v0z, a2)
    c12 = _level_out_ad1(over_z, 0.0 * target, climb_rate, target, up, down)
    stop_z = s0z + _s3(v0z, a1)
    c2 = _level_out_ad1(stop_z, 0.0 * target, climb_rate, target, up, down)
    room = np.abs(s) >= np.abs(_s3(v0z, a2))
    res = []
    for i in range(5):
        shift12 = -v0z / a2 if i < 3 else 0.0
        shift2 = -v0z / a1 if i < 3 else 0.0
        r_same = np.where(room, c11[i], c12[i] + shift12)
        res.append(np.where(same, r_same, c2[i] + shift2))
    return tuple(res)


def level_out_state(p0, v0, t, climb_rate: float, target, accel: float, tstep: float, times=None):
    """DaidalusAltBands.trajectory for target altitudes (M,) at times t (M, Q): position (M, Q, 3) and velocity
    (M, Q, 3). Until the level-out time plus one time step, Kinematics.vsLevelOut (vsLevelOutCalc); after that
    level at the target with the horizontal motion straight on. times: level_out_times' result for these
    arguments, when the caller has it already."""
    target = np.asarray(target, float)
    t = np.asarray(t, float)
    t1, t2, t3, a1, a2 = times if times is not None else \
        level_out_times(float(p0[2]), float(v0[2]), climb_rate, target, accel)
    tsqj = np.where(t1 < 0, -1.0, t3) + tstep  # ProjectedKinematics.vsLevelOutTime (-1 when not achieved)
    e = lambda x: x[:, None]  # noqa: E731
    T1, T2, T3, A1, A2 = e(t1), e(t2), e(t3), e(a1), e(a2)
    voz, soz = float(v0[2]), float(p0[2])
    v1 = voz + A1 * T1
    z_a = soz + _s1(voz, A1, t)
    z_b = soz + _s1(voz, A1, T1) + v1 * (t - T1)
    z_c = soz + _s1(voz, A1, T1) + v1 * (T2 - T1) + _s1(v1, A2, t - T2)
    vz_a, vz_b, vz_c = voz + A1 * t, v1 + 0 * t, v1 + A2 * (t - T2)
    tgt = e(target) + 0 * t
    z = np.where(t <= T1, z_a, np.where(t <= T2, z_b, np.where(t <= T3, z_c, tgt)))
    vz = np.where(t <= T1, vz_a, np.where(t <= T2, vz_b, np.where(t <= T3, vz_c, 0.0)))
    after = t > e(tsqj)
    z = np.where(after, tgt, z)
    vz = np.where(after, 0.0, vz)
    pos = np.stack([p0[0] + v0[0] * t, p0[1] + v0[1] * t, z], -1)
    vel = np.stack([v0[0] + 0 * t, v0[1] + 0 * t, vz], -1)
    return pos, vel, (t1, t2, t3)


# --- recovery cylinder ------------------------------------------------------------------------------------------

@dataclass(frozen=True, slots=True)
class Cylinder:
    """DAIDALUS CDCylinder: loss is |s_xy| < D and |s_z| < H (CD3D.LoS)."""

    d_m: float
    h_m: float


def cylinder_lines(s, v, cyl: Cylinder, t_end: float):
    """cylinder_interval on the lines (s, v), each (..., 3): (t_in, t_out), each (...). The compiled loop
    (advisory/kernels.py cylinder_lines: cylinder_interval line by line) when the kernels are loaded."""
    if jit.ready():
        shape = np.broadcast_shapes(np.shape(s), np.shape(v))
        out = kernels.cylinder_lines(as_c(np.broadcast_to(s, shape).reshape(-1, 3)),
                                     as_c(np.broadcast_to(v, shape).reshape(-1, 3)), cyl.d_m**2, cyl.h_m,
                                     float(t_end))
        return out[:, 0].reshape(shape[:-1]), out[:, 1].reshape(shape[:-1])
    return cylinder_interval(s[..., :2], v[..., :2], s[..., 2], v[..., 2], cyl, t_end)


def cylinder_interval(s_xy, v_xy, sz, vz, cyl: Cylinder, t_end: float):
    """(t_in, t_out) of loss of the cylinder within [0, t_end] for straight-line relative motion, as
    CD3D.detection computes it: on an axis without relative motion (Util.almost_equals(v, 0) here, per
    component horizontally; DAIDALUS compares the two aircraft's velocities, which differs only for relative
    velocities between 1e-13 and ~1e-10 m/s) the loss is every time when inside by more than almost-equal
    (Horizontal.almost_horizontal_los, Vertical.almost_vertical_los: |sz| < H and not almost equal), none
    otherwise; with motion, the entry and exit roots (Horizontal.Theta_D where Delta > 0, Vertical.Theta_H).
    Intervals are clipped to [0, t_end]; a conflict is `wcv.conflict` (LossData.conflict)."""
    a = v_xy[..., 0] ** 2 + v_xy[..., 1] ** 2
    b = s_xy[..., 0] * v_xy[..., 0] + s_xy[..., 1] * v_xy[..., 1]
    sqs = s_xy[..., 0] ** 2 + s_xy[..., 1] ** 2
    d2 = cyl.d_m**2
    with np.errstate(divide="ignore", invalid="ignore"):
        delta = b * b - a * (sqs - d2)  # Horizontal.Delta
        sq = np.sqrt(np.maximum(delta, 0.0))
        still = _almost.almost_equals(v_xy[..., 0], 0.0) & _almost.almost_equals(v_xy[..., 1], 0.0)
        h_los = ~_almost.almost_equals(sqs, d2) & (sqs < d2)
        crossing = (delta > 0) & (a > 0)
        safe_a = np.where(a > 0, a, 1.0)
        h_in = np.where(still & h_los, -np.inf, np.where(crossing, (-b - sq) / safe_a, np.inf))
        h_out = np.where(still & h_los, np.inf, np.where(crossing, (-b + sq) / safe_a, -np.inf))
        level = _almost.almost_equals(vz, 0.0)
        abs_sz = np.abs(sz)
        v_los = ~_almost.almost_equals(abs_sz, cyl.h_m) & (abs_sz < cyl.h_m)
        safe = np.where(level, 1.0, vz)
        sign = np.where(safe >= 0.0, 1.0, -1.0)
        v_in = np.where(level, np.where(v_los, -np.inf, np.inf), (-sign * cyl.h_m - sz) / safe)
        v_out = np.where(level, np.where(v_los, np.inf, -np.inf), (sign * cyl.h_m - sz) / safe)
    t_in = np.maximum(np.maximum(h_in, v_in), 0.0)
    t_out = np.minimum(np.minimum(h_out, v_out), t_end)
    return t_in, t_out
