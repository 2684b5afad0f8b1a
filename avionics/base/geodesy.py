"""WGS-84 geodetic <-> local East-North tangent plane. Only the horizontal plane is projected: altitude stays
an altitude in its own datum, so the tangent plane's tilt never leaks into vertical separation."""

from __future__ import annotations

import numpy as np

WGS84_A = 6378137.0
WGS84_F = 1.0 / 298.257223563
WGS84_E2 = WGS84_F * (2.0 - WGS84_F)


def geodetic_to_ecef(lat_deg, lon_deg, h_m):
    lat, lon = np.radians(lat_deg), np.radians(lon_deg)
    n = WGS84_A / np.sqrt(1.0 - WGS84_E2 * np.sin(lat) ** 2)
    x = (n + h_m) * np.cos(lat) * np.cos(lon)
    y = (n + h_m) * np.cos(lat) * np.sin(lon)
    z = (n * (1.0 - WGS84_E2) + h_m) * np.sin(lat)
    return x, y, z


def ecef_to_geodetic(x, y, z):
    """Bowring's method with two iterations: sub-millimetre for aircraft altitudes."""
    lon = np.arctan2(y, x)
    p = np.hypot(x, y)
    lat = np.arctan2(z, p * (1.0 - WGS84_E2))
    for _ in range(3):
        n = WGS84_A / np.sqrt(1.0 - WGS84_E2 * np.sin(lat) ** 2)
        h = p / np.cos(lat) - n
        lat = np.arctan2(z, p * (1.0 - WGS84_E2 * n / (n + h)))
    n = WGS84_A / np.sqrt(1.0 - WGS84_E2 * np.sin(lat) ** 2)
    h = p / np.cos(lat) - n
    return np.degrees(lat), np.degrees(lon), h


def horizontal_axes(lat_deg, lon_deg) -> np.ndarray:
    """ECEF unit vectors of local true east (row 0) and north (row 1) at points: shape (..., 2, 3)."""
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
        east_m, north_m = np.asarray(east_m, float), np.asarray(north_m, float)
        e_axis, n_axis, u_axis = self._rot
        c = self._origin[:, None] + np.outer(e_axis, east_m.reshape(-1)) + np.outer(n_axis, north_m.reshape(-1))
        b2 = (WGS84_A * (1.0 - WGS84_F)) ** 2
        d = np.array([1.0 / WGS84_A**2, 1.0 / WGS84_A**2, 1.0 / b2])
        qa = np.sum(d * u_axis * u_axis)
        qb = np.sum(d[:, None] * c * u_axis[:, None], axis=0)
        qc = np.sum(d[:, None] * c * c, axis=0) - 1.0
        with np.errstate(invalid="ignore"):  # a point off the Earth's disc has no surface point: NaN
            u = (-qb + np.sqrt(qb * qb - qa * qc)) / qa  # the intersection nearest the plane
        lat, lon, _ = ecef_to_geodetic(*(c + np.outer(u_axis, u)))
        return lat.reshape(east_m.shape), lon.reshape(east_m.shape)
