"""An active-surveillance track's range and range rate from its ranges alone, as TCAS II's threat logic reads them.

Why: active surveillance (Appendix Q: a Mode C interrogator) measures slant range to 15 m and bearing to 9-15 deg.
The sensor track's IMM (sensor_tracker.py) takes both, linearised at its prediction; when a run of bearing errors
drags the track sideways, its range innovations are applied along the wrong line of sight, and the closure it
reports can be off by tens of m/s (docs/tracking.md, seed 1's `H0_0_120`: 85 m/s, every TA 7-9 s early). TCAS II
never reads closure from bearings: it tracks range and computes the closing rate from successive range replies,
and the bearing only places the traffic on the display (FAA, "Introduction to TCAS II Version 7.1", 2011,
"Surveillance" and "CAS logic": the range test is range / range rate; Honeywell CAS-100 manual, "Tracking
function": range, closing range rate, relative bearing when a directional antenna has one).

So each active-surveillance track also keeps a range track (`RangeTrack`, the parabolic range tracker of TCAS II's
miss distance filter: [r, r_dot, r_ddot], one scalar measurement of r a scan). `along_line_of_sight` puts its
range and range rate into the published state along the track's line of sight and keeps the IMM's cross-range
position and speed (the bearing's). The miss distance the alerter's HMD filter reads is the smaller of the
bearing-based one and the range track's (`horizontal_miss_m`), as that filter takes it: "the smaller of the two
calculated horizontal miss distances defines a projected horizontal miss distance which is compared with a
threshold" (Hammer, "Horizontal miss distance filter system for suppressing false resolution alerts", US patent
5,566,074, MITRE, 1996). A run of large bearing errors can make the bearing-based miss kilometres too wide
(seed 1's `H0_0_120`: 4-7 km against a true 930 m) and hold an RA back; the ranges cannot.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from avionics.tracking.measurement import GROUND_RANGE_FLOOR, ground_range
from avionics.tracking.record import UNKNOWN_SPEED_SIGMA_MPS

# The parabolic range tracker's jerk (Bar-Shalom et al. 2001, Sec. 6.2.3, the Wiener-process acceleration model:
# Q = q [[dt^5/20, dt^4/8, dt^3/6], [dt^4/8, dt^3/3, dt^2/2], [dt^3/6, dt^2/2, dt]]). The range acceleration is
# mostly geometry, v_t^2 / r, which changes slowly (a 150 m/s closure 930 m abeam: 0.16 m/s^2 at 5 km, 0.7 at
# 3 km), and the ownship's manoeuvres. With q = 0.05 m^2/s^5 and active surveillance's 15.24 m at 1 Hz, the
# steady 1-sigma is 9.5 m, 3.0 m/s and 0.62 m/s^2, and a 3 m/s^2 step of range acceleration is followed to 90 %
# in 13 s (measured; docs/tracking.md). The range acceleration is the weak part: at long range the range track's
# miss is mostly small, and the HMD filter, which takes the smaller miss, rarely suppresses an RA on it.
RANGE_JERK_PSD_M2PS5 = 0.05
# Priors before a second and a third range: two aircraft, each of unknown velocity (record.py's prior), and the
# geometric range acceleration of a fast close pass (300 m/s, 1 km abeam, at 2 km: 11 m/s^2).
RANGE_RATE_PRIOR_SIGMA_MPS = math.sqrt(2.0) * UNKNOWN_SPEED_SIGMA_MPS
RANGE_ACCEL_PRIOR_SIGMA_MPS2 = 10.0


@dataclass
class RangeTrack:
    """[slant range m, range rate m/s, range acceleration m/s^2] at t_s and its 3 x 3 covariance: the parabolic
    range tracker of TCAS II's miss distance filter (Hammer, US patent 5,566,074, 1996)."""

    t_s: float
    x: np.ndarray
    p: np.ndarray

    @classmethod
    def start(cls, t_s: float, range_m: float, sigma_m: float) -> RangeTrack:
        return cls(t_s, np.array([range_m, 0.0, 0.0]),
                   np.diag([sigma_m**2, RANGE_RATE_PRIOR_SIGMA_MPS**2, RANGE_ACCEL_PRIOR_SIGMA_MPS2**2]))

    def predicted(self, t_s: float) -> tuple[np.ndarray, np.ndarray]:
        dt = t_s - self.t_s
        f = np.array([[1.0, dt, dt * dt / 2.0], [0.0, 1.0, dt], [0.0, 0.0, 1.0]])
        q = RANGE_JERK_PSD_M2PS5 * np.array([[dt**5 / 20.0, dt**4 / 8.0, dt**3 / 6.0],
                                             [dt**4 / 8.0, dt**3 / 3.0, dt**2 / 2.0],
                                             [dt**3 / 6.0, dt**2 / 2.0, dt]])
        return f @ self.x, f @ self.p @ f.T + q

    def update(self, t_s: float, range_m: float, sigma_m: float) -> None:
        """The Kalman update with one slant range (H = [1, 0, 0], R = sigma^2), Joseph form."""
        x, p = self.predicted(t_s)
        k = p[:, 0] / (p[0, 0] + sigma_m**2)
        i_kh = np.eye(3) - np.outer(k, [1.0, 0.0, 0.0])
        self.x = x + k * (range_m - x[0])
        self.p = i_kh @ p @ i_kh.T + sigma_m**2 * np.outer(k, k)
        self.t_s = t_s


def horizontal_miss_m(range_x, h_m, h_dot_mps) -> float:
    """The horizontal miss distance from the range track alone (range_x [r, r_dot, r_ddot] at one time) and the
    height above the ownship h_m, h_dot_mps (the vertical track's; its acceleration taken as 0): the parabolic
    tracker's miss of the patent above. For straight relative flight at horizontal speed V with horizontal miss d,
    rho^2 = d^2 + V^2 (t - t_cpa)^2 with rho^2 = r^2 - h^2, so rho rho_dot = r r_dot - h h_dot = V^2 (t - t_cpa)
    and V^2 = rho_dot^2 + rho rho_ddot = r_dot^2 + r r_ddot - h_dot^2; hence d^2 = rho^2 - (rho rho_dot)^2 / V^2.
    Not closing (rho rho_dot >= 0): the miss is now, rho (as cpa.pair_geometry's, t_cpa = 0). A range
    acceleration too small for the closure (V^2 at most rho_dot^2: noise about a straight line of sight) is a miss
    of 0."""
    r, r_dot, r_ddot = (float(v) for v in range_x)
    rho2 = float(ground_range(r, h_m, 0.0)[0]) ** 2
    closing = r * r_dot - h_m * h_dot_mps
    if closing >= 0.0:
        return math.sqrt(rho2)
    v2 = r_dot * r_dot + r * r_ddot - h_dot_mps * h_dot_mps
    if v2 <= 0.0:
        return 0.0
    return math.sqrt(max(rho2 - closing * closing / v2, 0.0))


# the pipeline's [e, n, alt, ve, vn, vu]: the horizontal position and velocity rows
_H = np.array([0, 1, 3, 4])


def along_line_of_sight(x: np.ndarray, p: np.ndarray, range_x: np.ndarray, range_p: np.ndarray,
                        own_x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """One track's published state (x (6,), p (6, 6): [e, n, alt, ve, vn, vu]) with its horizontal range and range
    rate taken from its range track (range_x [r, r_dot, ...], range_p, at the same time) and its cross-range
    position and speed kept; own_x: the ownship's [e, n, alt, ve, vn, vu] then.

    With h and h_dot the track's height and vertical rate above the ownship, the ground range and its rate are
    rho = sqrt(r^2 - h^2) (measurement.ground_range: floored at 0.1 r overhead) and
    rho_dot = (r r_dot - h h_dot) / rho, their covariance J P_r J^T with J = d(rho, rho_dot) / d(r, r_dot)
    (h, h_dot held: they are the vertical bank's). With u the unit vector to the track's position and u_b across
    it, the position becomes own + rho u, the relative velocity rho_dot u + (its cross-range speed) u_b; the
    covariance, in the (along, across) basis of position and velocity, takes J P_r J^T along, the IMM's block
    across, and no correlation between the two."""
    x, p = np.array(x, float), np.array(p, float)
    r, r_dot = float(range_x[0]), float(range_x[1])
    range_p = np.asarray(range_p, float)[:2, :2]
    h, h_dot = x[2] - own_x[2], x[5] - own_x[5]
    rho = float(ground_range(r, h, 0.0)[0])
    rho_dot = (r * r_dot - h * h_dot) / rho
    floored = r * r - h * h < (GROUND_RANGE_FLOOR * r) ** 2  # ground_range's floor: rho = GROUND_RANGE_FLOOR r
    d_rho = GROUND_RANGE_FLOOR if floored else r / rho
    j = np.array([[d_rho, 0.0], [r_dot / rho - rho_dot * d_rho / rho, r / rho]])
    p_along = j @ range_p @ j.T

    rel = x[:2] - own_x[:2]
    u = rel / max(math.hypot(rel[0], rel[1]), 1e-9)
    u_b = np.array([u[1], -u[0]])
    v_rel = x[3:5] - own_x[3:5]
    x[:2] = own_x[:2] + rho * u
    x[3:5] = own_x[3:5] + rho_dot * u + float(v_rel @ u_b) * u_b

    t = np.zeros((4, 4))  # columns: along position, across position, along velocity, across velocity
    t[:2, 0], t[:2, 1], t[2:, 2], t[2:, 3] = u, u_b, u, u_b
    rot = t.T @ p[np.ix_(_H, _H)] @ t
    rot[np.ix_([0, 2], [1, 3])] = 0.0
    rot[np.ix_([1, 3], [0, 2])] = 0.0
    rot[np.ix_([0, 2], [0, 2])] = p_along
    p[np.ix_(_H, _H)] = t @ rot @ t.T
    return x, p
