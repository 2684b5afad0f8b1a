"""A range/bearing sensor's measurement (radar, active surveillance) and its conversion to the tracking frame.

A sensor reports, for each detection at one time of measurement, the slant range, the azimuth in the horizontal
plane (clockwise from the ownship's nose: a stabilised sensor), the elevation above the horizontal (radar) or the
intruder's reported pressure altitude (active surveillance: the Mode C or Mode S altitude reply), the range rate
where it measures one, each with its 1-sigma error, and the sensor's mounting and field of regard. Reports carry
no identity (a Mode S reply's address is kept when there is one).

The IMM banks (imm.py) measure the first components of their state linearly, so a polar measurement enters them
as a *converted* measurement: the unbiased conversion of Mo, Song, Zhou, Sun & Bar-Shalom ("Unbiased converted
measurements for tracking", IEEE TAES 34(3), 1998), with its covariance conditioned on the measurement. For an
angle error w ~ N(0, s^2), E[cos(a - w)] = lam cos a and E[cos^2(a - w)] = (1 + lam2 cos 2a) / 2 with
lam = exp(-s^2 / 2), lam2 = exp(-2 s^2); the classical conversion r (sin a, cos a) is biased towards the sensor
by (1 - lam) r (9 degrees of TCAS bearing error: 1.2 % of range, 230 m at 10 NM), the unbiased one divides lam
out, and its error covariance is the one conditioned on the measurement (`convert`: every moment a product of
the range's and the angles' moments, the errors being independent). Why converted rather than an EKF update: the bank's
linear measurement model (Hwang's C = [I 0]) and its compiled kernels stay as they are, and at 9 degrees the
EKF's linearisation about a cross-range error of 0.16 rad x range is the poor one (its residual is biased by the
same lam); the conditioned covariance is consistent where the linearised one is optimistic
(tests/test_polar_tracking.py checks R against a Monte Carlo of the converted error).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

SENSOR_KINDS = ("radar", "active")


@dataclass(frozen=True)
class SensorMount:
    """Where a sensor looks from: its kind, boresight azimuth relative to the ownship's nose (clockwise), its field
    of regard (half-width in azimuth about the boresight, elevation limits) and its range limits, its scan rate."""

    sensor_id: str
    kind: str
    boresight_deg: float = 0.0
    half_azimuth_deg: float = 180.0  # 180: all round
    elevation_min_deg: float = -90.0
    elevation_max_deg: float = 90.0
    min_range_m: float = 0.0
    max_range_m: float = math.inf
    rate_hz: float = 1.0

    def __post_init__(self) -> None:
        if self.kind not in SENSOR_KINDS:
            raise ValueError(f"sensor kind must be one of {SENSOR_KINDS}, got {self.kind!r}")
        if not (0.0 < self.half_azimuth_deg <= 180.0 and self.elevation_min_deg < self.elevation_max_deg
                and 0.0 <= self.min_range_m < self.max_range_m and self.rate_hz > 0.0):
            raise ValueError(f"sensor {self.sensor_id!r}: field of regard, range limits or rate out of range")

    def sees(self, range_m, azimuth_rad, elevation_rad) -> np.ndarray:
        """Whether targets at these body-frame (range, azimuth, elevation) are inside the field of regard."""
        off = np.degrees(np.angle(np.exp(1j * (np.asarray(azimuth_rad) - math.radians(self.boresight_deg)))))
        el = np.degrees(elevation_rad)
        r = np.asarray(range_m)
        return ((np.abs(off) <= self.half_azimuth_deg) & (el >= self.elevation_min_deg)
                & (el <= self.elevation_max_deg) & (r >= self.min_range_m) & (r <= self.max_range_m))


@dataclass(frozen=True)
class PolarMeasurement:
    """One detection. Angles in radians, azimuth clockwise from the ownship's nose in the horizontal plane;
    elevation (radar) or altitude_m (the reported pressure altitude of active surveillance), one of them; the
    sigmas are the 1-sigma errors the sensor declares (DEGAS's reported covariance: random and bias in quadrature).
    address: a Mode S reply's 24-bit address, None for a radar return or a Mode C reply."""

    mount: SensorMount
    time_s: float
    range_m: float
    azimuth_rad: float
    range_sigma_m: float
    azimuth_sigma_rad: float
    elevation_rad: float | None = None
    elevation_sigma_rad: float | None = None
    altitude_m: float | None = None
    altitude_sigma_m: float | None = None
    range_rate_mps: float | None = None
    range_rate_sigma_mps: float | None = None
    address: int | None = None

    def problem(self) -> str | None:
        """Why this measurement cannot be used (a counted rejection at the intake), or None."""
        values = {"time_s": self.time_s, "range_m": self.range_m, "azimuth_rad": self.azimuth_rad,
                  "range_sigma_m": self.range_sigma_m, "azimuth_sigma_rad": self.azimuth_sigma_rad}
        for name in ("elevation_rad", "elevation_sigma_rad", "altitude_m", "altitude_sigma_m", "range_rate_mps",
                     "range_rate_sigma_mps"):
            if getattr(self, name) is not None:
                values[name] = getattr(self, name)
        for name, v in values.items():
            if not isinstance(v, (int, float)) or not math.isfinite(v):
                return f"{name} not a finite number"
        if self.range_m <= 0.0:
            return "range_m not positive"
        if min(v for k, v in values.items() if k.endswith("sigma_m") or k.endswith("sigma_rad")
               or k.endswith("sigma_mps")) < 0.0:
            return "a sigma is negative"
        if (self.elevation_rad is None) == (self.altitude_m is None):
            return "exactly one of elevation_rad and altitude_m is required"
        if self.elevation_rad is not None and (self.elevation_sigma_rad is None or abs(self.elevation_rad) > math.pi / 2):
            return "elevation_rad needs elevation_sigma_rad and must be within +-90 degrees"
        if self.altitude_m is not None and self.altitude_sigma_m is None:
            return "altitude_m needs altitude_sigma_m"
        return None


# -- unbiased conversion ----------------------------------------------------------------------------------


def _trig_products(a: np.ndarray, lam: np.ndarray, lam2: np.ndarray) -> np.ndarray:
    """(B, 3, 3) expected products E[f_i f_j] of f = (sin, cos, 1) at a - w, w ~ N(0, s^2): the first harmonics
    scaled by lam = E[cos w] = exp(-s^2 / 2), the second by lam2 = E[cos 2w] = exp(-2 s^2)."""
    s1, c1 = lam * np.sin(a), lam * np.cos(a)
    ss, cc, sc = 0.5 * (1 - lam2 * np.cos(2 * a)), 0.5 * (1 + lam2 * np.cos(2 * a)), 0.5 * lam2 * np.sin(2 * a)
    one = np.ones_like(a)
    return np.stack([np.stack([ss, sc, s1], -1), np.stack([sc, cc, c1], -1), np.stack([s1, c1, one], -1)], axis=-2)


# east, north, up = r x (bearing factor) x (elevation factor): (sin b, cos e), (cos b, cos e), (1, sin e), as
# indices into f = (sin, cos, 1) of each angle
_B_FACTOR, _E_FACTOR = np.array([0, 1, 2]), np.array([1, 1, 0])


def convert(range_m, bearing_rad, elevation_rad, range_sigma_m, bearing_sigma_rad, elevation_sigma_rad):
    """Unbiased converted measurement (Mo et al. 1998) of (slant range, bearing clockwise from north, elevation) to
    the relative [east, north, up] position, vectorised over B: z (B, 3) and its covariance R (B, 3, 3).
    z = r (cos e sin b, cos e cos b, sin e) with each angle factor divided by its lam = E[cos w]. R is Mo et al.'s
    covariance conditioned on the measurement, E[(z - x)(z - x)^T | z] = z z^T - z m^T - m z^T + E[x x^T | z] with
    m = E[x | z], the moments those of the true angles about the measured ones (_trig_products); in 2-D
    R11 = (lam^-2 - 2) r^2 cos^2 b + (r^2 + s_r^2)(1 + lam2 cos 2b) / 2. A second moment, so positive definite
    for any error size, and consistent: the normalised error (z - x)^T R^-1 (z - x) averages the dimension (the
    unbiased estimate of the covariance at the true position is neither: it goes negative along range beyond about
    12 degrees of bearing error, and evaluated at the measured point it halves the normalised error at 9 degrees,
    as the truth lies off the measured line of sight)."""
    r, b, e, sr, sb, se = np.broadcast_arrays(*(np.atleast_1d(np.asarray(v, float)) for v in (
        range_m, bearing_rad, elevation_rad, range_sigma_m, bearing_sigma_rad, elevation_sigma_rad)))
    lam_b, lam_e = np.exp(-0.5 * sb**2), np.exp(-0.5 * se**2)  # E[cos w]
    unit = np.stack([np.cos(e) * np.sin(b), np.cos(e) * np.cos(b), np.sin(e)], axis=-1)
    scale = np.stack([lam_b * lam_e, lam_b * lam_e, lam_e], axis=-1)
    z = r[:, None] * unit / scale
    tb = _trig_products(b, lam_b, np.exp(-2.0 * sb**2))  # moments of the true angle about the measured one
    te = _trig_products(e, lam_e, np.exp(-2.0 * se**2))
    mean = r[:, None] * tb[:, _B_FACTOR, 2] * te[:, _E_FACTOR, 2]  # E[x | z]
    second = ((r**2 + sr**2)[:, None, None] * tb[:, _B_FACTOR[:, None], _B_FACTOR[None, :]]
              * te[:, _E_FACTOR[:, None], _E_FACTOR[None, :]])  # E[x x^T | z]
    cov = z[:, :, None] * z[:, None, :] - z[:, :, None] * mean[:, None, :] - mean[:, :, None] * z[:, None, :] + second
    return z, 0.5 * (cov + np.swapaxes(cov, 1, 2))


def convert_horizontal(ground_range_m, bearing_rad, range_sigma_m, bearing_sigma_rad):
    """The 2-D unbiased conversion (Mo et al. 1998) of (ground range, bearing clockwise from north) to the relative
    [east, north]: z (B, 2), R (B, 2, 2). The elevation-free case of convert."""
    z, r = convert(ground_range_m, bearing_rad, 0.0, range_sigma_m, bearing_sigma_rad, 0.0)
    return z[:, :2], r[:, :2, :2]


GROUND_RANGE_FLOOR = 0.1  # ground_range's floor near overhead, as a share of the slant range


def ground_range(slant_range_m, height_m, slant_sigma_m):
    """Horizontal range and its 1-sigma from a slant range and the height difference (active surveillance: the
    altitude reply gives the height): rho = sqrt(r^2 - h^2), sigma_rho = sigma_r r / rho to first order (floored
    where the geometry is near overhead: rho at least 10 % of r)."""
    r, h = np.asarray(slant_range_m, float), np.asarray(height_m, float)
    rho = np.sqrt(np.maximum(r**2 - h**2, (GROUND_RANGE_FLOOR * r) ** 2))
    return rho, np.asarray(slant_sigma_m, float) * r / rho


def about_prediction(rho, rho_sigma_m, bearing_rad, bearing_sigma_rad, predicted_en) -> tuple:
    """A ground range and bearing from the ownship (rho, bearing clockwise from north, their 1-sigma), as the
    position measurement (z (B, 2) east, north relative to the ownship, R (B, 2, 2)) whose linear update is the
    extended Kalman filter's update linearised at predicted_en (B, 2), the track's predicted relative position:
    with u_r the unit vector to it, u_b the unit vector of increasing bearing and rho_hat its range,
    z = p_hat + u_r (rho - rho_hat) + u_b rho_hat (bearing - bearing_hat),
    R = sigma_rho^2 u_r u_r^T + rho_hat^2 sigma_b^2 u_b u_b^T (J^-1 R_polar J^-T, J = d(rho, bearing)/d(e, n)).
    Why not the converted measurement: with a 9-15 deg bearing R is a needle along the measured line of sight,
    and the filter reads the range as the converted point's distance along it, r / lam, against the truth's
    r cos w: a range biased outwards by about r (sigma_b^2 / 2 + the error's variance / 2), 5 % of the range at
    15 deg declared and 9 deg true (active surveillance: 330 m at 6.7 km, 2-3 s of tau). Here the range
    innovation is rho - rho_hat, unbiased whatever the bearing's error."""
    p = np.asarray(predicted_en, float)
    rho_hat = np.maximum(np.hypot(p[:, 0], p[:, 1]), 1.0)
    u_r = p / rho_hat[:, None]
    u_b = np.stack([u_r[:, 1], -u_r[:, 0]], axis=1)
    d_b = (np.asarray(bearing_rad, float) - np.arctan2(p[:, 0], p[:, 1]) + np.pi) % (2.0 * np.pi) - np.pi
    z = p + u_r * (np.asarray(rho, float) - rho_hat)[:, None] + u_b * (rho_hat * d_b)[:, None]
    r = (np.asarray(rho_sigma_m, float) ** 2)[:, None, None] * u_r[:, :, None] * u_r[:, None, :] \
        + ((rho_hat * np.asarray(bearing_sigma_rad, float)) ** 2)[:, None, None] * u_b[:, :, None] * u_b[:, None, :]
    return z, r


UNMEASURED_SPEED_SIGMA_MPS = 1.0e4  # a velocity component a measurement does not see: no information (R -> inf)


def range_rate_about_prediction(range_rate_mps, range_rate_sigma_mps, elevation_rad, predicted_en, own_velocity_en,
                                vertical_rate_rel_mps, predicted_velocity_en, predicted_position_cov=None) -> tuple:
    """A radar's slant range rate as the horizontal velocity measurement (z (B, 2) east, north velocity of the
    intruder, R (B, 2, 2)) whose linear update is the extended Kalman filter's scalar update linearised at the
    track's prediction: with u the unit vector to the predicted relative position predicted_en and el the
    measured elevation, r_dot = cos(el) u . (v - v_own) + sin(el) vz_rel, so the line-of-sight speed
    u . v = (r_dot - sin(el) vz_rel) / cos(el) + u . v_own with sigma r_dot_sigma / cos(el). z carries it along u
    and the prediction across it; R is that sigma squared along u and UNMEASURED_SPEED_SIGMA_MPS squared across
    (the range rate says nothing of the cross-range speed), so the update is the scalar one to about 1e-6 of its
    gain. vertical_rate_rel_mps: the track's predicted vertical rate minus the ownship's. predicted_position_cov
    (B, 2, 2): the prediction's position covariance, whose bearing uncertainty s_theta = sqrt(u_b^T P u_b) / rho
    turns u by as much: the line-of-sight speed taken along the predicted u is off by the cross-range speed times
    that angle, added to sigma as (v_cross s_theta)^2 (the linearisation's own error; without it an exact range
    rate is trusted along a line of sight the prediction only estimates)."""
    p = np.asarray(predicted_en, float)
    u = p / np.maximum(np.hypot(p[:, 0], p[:, 1]), 1.0)[:, None]
    el = np.asarray(elevation_rad, float)
    along = (np.asarray(range_rate_mps, float) - np.sin(el) * np.asarray(vertical_rate_rel_mps, float)) / np.cos(el) \
        + np.einsum("bi,bi->b", u, np.asarray(own_velocity_en, float))
    v = np.asarray(predicted_velocity_en, float)
    z = v + u * (along - np.einsum("bi,bi->b", u, v))[:, None]
    uu = u[:, :, None] * u[:, None, :]
    var = (np.asarray(range_rate_sigma_mps, float) / np.cos(el)) ** 2
    if predicted_position_cov is not None:
        u_b = np.stack([u[:, 1], -u[:, 0]], axis=1)
        theta_var = np.einsum("bi,bij,bj->b", u_b, np.asarray(predicted_position_cov, float), u_b) \
            / np.maximum(np.einsum("bi,bi->b", p, p), 1.0)
        var = var + np.einsum("bi,bi->b", u_b, v) ** 2 * theta_var
    r = var[:, None, None] * uu + UNMEASURED_SPEED_SIGMA_MPS**2 * (np.eye(2) - uu)
    return z, r


def ground_polar(measurements: list[PolarMeasurement], own_enu, own_heading_rad) -> tuple:
    """Ground range, its 1-sigma, bearing (clockwise from north) and its 1-sigma of measurements that report an
    altitude instead of an elevation (active surveillance: ground range from the slant range and the height,
    ground_range)."""
    own = np.broadcast_to(np.asarray(own_enu, float), (len(measurements), 3))
    alt = np.array([m.altitude_m for m in measurements], float)
    rho, s_rho = ground_range(np.array([m.range_m for m in measurements], float), alt - own[:, 2],
                              np.array([m.range_sigma_m for m in measurements], float))
    bearing = np.asarray(own_heading_rad, float) + np.array([m.azimuth_rad for m in measurements], float)
    return rho, s_rho, bearing, np.array([m.azimuth_sigma_rad for m in measurements], float)


def to_tracking_frame(measurements: list[PolarMeasurement], own_enu: np.ndarray, own_heading_rad) -> tuple:
    """A batch of measurements as positions in the tracking frame: (z_h (B, 2) east, north, R_h (B, 2, 2),
    z_v (B,) altitude, r_v (B,) its variance). own_enu (B, 3) or (3,): the ownship's position at each time of
    measurement; own_heading_rad: its heading (clockwise from north). The radar's elevation gives the height
    through the 3-D conversion (its horizontal-vertical correlation is dropped: the banks are decoupled,
    Baek & Bang Fig. 2); active surveillance's reported altitude is measured directly."""
    b = len(measurements)
    own = np.broadcast_to(np.asarray(own_enu, float), (b, 3))
    heading = np.broadcast_to(np.asarray(own_heading_rad, float), (b,))
    rng = np.array([m.range_m for m in measurements], float)
    bearing = heading + np.array([m.azimuth_rad for m in measurements], float)
    s_r = np.array([m.range_sigma_m for m in measurements], float)
    s_b = np.array([m.azimuth_sigma_rad for m in measurements], float)
    z_h, r_h = np.empty((b, 2)), np.empty((b, 2, 2))
    z_v, r_v = np.empty(b), np.empty(b)
    radar = np.array([m.elevation_rad is not None for m in measurements], bool)
    if radar.any():
        idx = np.flatnonzero(radar)
        el = np.array([measurements[i].elevation_rad for i in idx])
        s_e = np.array([measurements[i].elevation_sigma_rad for i in idx])
        z, r = convert(rng[idx], bearing[idx], el, s_r[idx], s_b[idx], s_e)
        z_h[idx], r_h[idx] = z[:, :2] + own[idx, :2], r[:, :2, :2]
        z_v[idx], r_v[idx] = z[:, 2] + own[idx, 2], r[:, 2, 2]
    if (~radar).any():
        idx = np.flatnonzero(~radar)
        rho, s_rho, b_idx, s_b_idx = ground_polar([measurements[i] for i in idx], own[idx], heading[idx])
        z, r = convert_horizontal(rho, b_idx, s_rho, s_b_idx)
        z_h[idx], r_h[idx] = z + own[idx, :2], r
        z_v[idx] = np.array([measurements[i].altitude_m for i in idx])
        r_v[idx] = np.array([measurements[i].altitude_sigma_m for i in idx]) ** 2
    return z_h, r_h, z_v, r_v
