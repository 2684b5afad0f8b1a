"""WGS-84 geodetic <-> local East-North tangent plane. Only the horizontal plane is projected: altitude stays
an altitude in its own datum, so the tangent plane's tilt never leaks into vertical separation."""

from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np

WGS84_A = 6378137.0
WGS84_F = 1.0 / 298.257223563
WGS84_E2 = WGS84_F * (2.0 - WGS84_F)
# the ellipsoid as x^2/a^2 + y^2/a^2 + z^2/b^2 = 1: its coefficients
_QUADRIC = (1.0 / WGS84_A**2, 1.0 / WGS84_A**2, 1.0 / (WGS84_A * (1.0 - WGS84_F)) ** 2)
MEAN_EARTH_RADIUS_M = 6371008.8  # IUGG mean radius, for flat-earth differences over a few kilometres


def flat_offset_m(lat0_deg: float, lon0_deg: float, lat_deg: float, lon_deg: float) -> tuple[float, float]:
    """(north, east) metres from (lat0, lon0) to (lat, lon) on a flat earth at lat0, the longitude difference
    taken across the antimeridian the short way: exact enough over a few kilometres, and cheap (no ECEF)."""
    dlon = (lon_deg - lon0_deg + 180.0) % 360.0 - 180.0
    return (math.radians(lat_deg - lat0_deg) * MEAN_EARTH_RADIUS_M,
            math.radians(dlon) * MEAN_EARTH_RADIUS_M * math.cos(math.radians(lat0_deg)))


def geodetic_to_ecef(lat_deg, lon_deg, h_m):
    lat, lon = np.radians(lat_deg), np.radians(lon_deg)
    n = WGS84_A / np.sqrt(1.0 - WGS84_E2 * np.sin(lat) ** 2)
    x = (n + h_m) * np.cos(lat) * np.cos(lon)
    y = (n + h_m) * np.cos(lat) * np.sin(lon)
    z = (n * (1.0 - WGS84_E2) + h_m) * np.sin(lat)
    return x, y, z


def ecef_to_geodetic(x, y, z):
    """Bowring's method with two iterations: sub-millimetre for aircraft altitudes. Scalars go through math:
    numpy's per-call cost is most of a single point's, and the flight loop converts one point a step."""
    m = _math_of(x, y, z)
    lon = m.atan2(y, x)
    p = m.hypot(x, y)
    lat = m.atan2(z, p * (1.0 - WGS84_E2))
    for _ in range(3):
        n = WGS84_A / m.sqrt(1.0 - WGS84_E2 * m.sin(lat) ** 2)
        h = p / m.cos(lat) - n
        lat = m.atan2(z, p * (1.0 - WGS84_E2 * n / (n + h)))
    n = WGS84_A / m.sqrt(1.0 - WGS84_E2 * m.sin(lat) ** 2)
    h = p / m.cos(lat) - n
    return m.degrees(lat), m.degrees(lon), h


def _scalar_sqrt(v: float) -> float:
    return math.sqrt(v) if v >= 0.0 else math.nan  # as np.sqrt under errstate(invalid="ignore")


_SCALAR = SimpleNamespace(atan2=math.atan2, hypot=math.hypot, sqrt=_scalar_sqrt, sin=math.sin, cos=math.cos,
                          degrees=math.degrees)
_ARRAY = SimpleNamespace(atan2=np.arctan2, hypot=np.hypot, sqrt=np.sqrt, sin=np.sin, cos=np.cos, degrees=np.degrees)


def _math_of(*values):
    """The functions for these operands: math's for plain numbers, numpy's for anything else."""
    return _SCALAR if all(isinstance(v, float) for v in values) else _ARRAY


def horizontal_axes(lat_deg, lon_deg) -> np.ndarray:
    """ECEF unit vectors of local true east (row 0) and north (row 1) at points: shape (..., 2, 3)."""
    if _math_of(lat_deg, lon_deg) is _SCALAR:
        lat, lon = math.radians(lat_deg), math.radians(lon_deg)
        sl, cl, so, co = math.sin(lat), math.cos(lat), math.sin(lon), math.cos(lon)
        return np.array([[-so, co, 0.0], [-sl * co, -sl * so, cl]])
    lat, lon = np.radians(lat_deg), np.radians(lon_deg)
    sl, cl, so, co = np.sin(lat), np.cos(lat), np.sin(lon), np.cos(lon)
    # filled in place: the nested np.stack it replaces cost more than the arithmetic for one point
    axes = np.empty(np.shape(sl) + (2, 3), np.result_type(sl, cl, so, co))
    axes[..., 0, 0], axes[..., 0, 1], axes[..., 0, 2] = -so, co, 0.0
    axes[..., 1, 0], axes[..., 1, 1], axes[..., 1, 2] = -sl * co, -sl * so, cl
    return axes


class LocalTangentPlane:
    """East/North metres on the tangent plane at a reference point (on the ellipsoid surface).

    Plane axes are true east/north at the reference point only: elsewhere a true east/north velocity must be
    turned into the plane's axes with velocity_matrix (by the meridian convergence, about the longitude
    difference x sin(latitude), and scaled by the projection) before it is used with plane positions."""

    def __init__(self, lat0_deg: float, lon0_deg: float):
        self.lat0_deg = float(lat0_deg)
        self.lon0_deg = float(lon0_deg)
        lat0, lon0 = np.radians(lat0_deg), np.radians(lon0_deg)
        self._origin = np.array(geodetic_to_ecef(lat0_deg, lon0_deg, 0.0))
        sl, cl, so, co = np.sin(lat0), np.cos(lat0), np.sin(lon0), np.cos(lon0)
        # Rows: east, north, up unit vectors in ECEF.
        self._rot = np.array([[-so, co, 0.0], [-sl * co, -sl * so, cl], [cl * co, cl * so, sl]])
        self._origin_xyz = tuple(float(v) for v in self._origin)  # plain floats: to_geodetic's scalar path
        self._axes_xyz = tuple(tuple(float(v) for v in row) for row in self._rot)
        self._qa = sum(dk * uk * uk for dk, uk in zip(_QUADRIC, self._axes_xyz[2]))

    def to_en(self, lat_deg, lon_deg):
        """Horizontal (east, north) in metres of points at the ellipsoid surface below them."""
        ecef = np.array(geodetic_to_ecef(lat_deg, lon_deg, 0.0))
        d = ecef - self._origin.reshape((3,) + (1,) * (ecef.ndim - 1))
        enu = np.dot(self._rot, d.reshape(3, -1)).reshape(d.shape)  # np.tensordot(rot, d, axes=1)'s own dot call
        return enu[0], enu[1]

    def velocity_matrix(self, lat_deg, lon_deg) -> np.ndarray:
        """The Jacobian J of to_en at surface points (..., 2, 2): plane velocity = J @ true (east, north) velocity.

        to_en is the point's ECEF offset dotted with the plane's axes, so its derivative along the local true
        east/north unit vectors is those vectors dotted with the plane's axes: exact, not a small-angle rotation."""
        return self._rot[:2] @ np.swapaxes(horizontal_axes(lat_deg, lon_deg), -1, -2)

    def to_geodetic(self, east_m, north_m):
        """Inverse of to_en: the surface point whose projection onto the plane is (east, north).

        That point lies on the line through the plane point along the local vertical; intersecting the line
        with the ellipsoid is a quadratic in the distance u along the vertical (exact, no iteration).
        """
        scalar = isinstance(east_m, (int, float)) and isinstance(north_m, (int, float))
        east_m, north_m = (float(east_m), float(north_m)) if scalar else (np.asarray(east_m, float),
                                                                          np.asarray(north_m, float))
        m = _SCALAR if scalar else _ARRAY
        # component by component, so that one point is plain floats and many are arrays
        c = [o + ea * east_m + na * north_m for o, ea, na in zip(self._origin_xyz, *self._axes_xyz[:2])]
        u_axis = self._axes_xyz[2]
        qb = sum(dk * ck * uk for dk, ck, uk in zip(_QUADRIC, c, u_axis))
        qc = sum(dk * ck * ck for dk, ck in zip(_QUADRIC, c)) - 1.0
        with np.errstate(invalid="ignore"):  # a point off the Earth's disc has no surface point: NaN
            u = (-qb + m.sqrt(qb * qb - self._qa * qc)) / self._qa  # the intersection nearest the plane
        lat, lon, _ = ecef_to_geodetic(*(ck + uk * u for ck, uk in zip(c, u_axis)))
        return lat, lon
