"""The frame the filters work in: an East-North tangent plane that follows the ownship (docs/architecture.md,
"The tracking frame").

A plane fixed where the process started drifts from the truth as the ownship flies away: plane distances shrink
radially by cos(d / R_earth) and a true east/north velocity, used as is, is rotated against plane positions by
the meridian convergence (about the longitude difference x sin latitude: 3 degrees after 250 km at 47 N). So:

- positions are `LocalTangentPlane.to_en` of the surface point below the aircraft (altitude stays an altitude);
- velocities are turned from true east/north at the aircraft into the plane's axes (`velocity_matrix`), so a
  track's velocity is the rate of change of its plane position and a straight flight stays straight;
- when the ownship is more than RECENTRE_M from the plane's origin, the plane moves to the ownship and every
  filter's state is carried into the new plane (FrameChange): positions exactly, through geodetic coordinates;
  velocities, accelerations and covariances through the Jacobian of the plane-to-plane map at each point;
- a move is at most MAX_HOP_M: a plane can only hold the hemisphere around its origin, so one wild fix (a glitch,
  a corrupted message) must not take the plane, and every track carried with it, across the Earth. A real
  flight never needs more (MAX_HOP_M per fix is 50 km/s at 5 Hz); a fix far from a plane an intruder started
  is reached in a few fixes.

The ownship is therefore within RECENTRE_M of the origin, and the relative geometry of an intruder within 30 nm
is that of a plane tangent at the ownship to within the error budget in docs/architecture.md.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from avionics.base.geodesy import WGS84_A, LocalTangentPlane, geodetic_to_ecef

RECENTRE_M = 1000.0  # the ownship's largest distance from the plane's origin (error budget: docs/architecture.md)
MAX_HOP_M = 10_000.0  # the largest move of the plane at one fix (HMD error < 1 m at 30 nm even 10 km off)


@dataclass(frozen=True)
class FrameChange:
    """The map from one plane to the next, applied to filter states."""

    old: LocalTangentPlane
    new: LocalTangentPlane

    def points(self, east, north) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Old-plane points in the new plane, and the map's Jacobian A (..., 2, 2) at each of them."""
        lat, lon = self.old.to_geodetic(np.asarray(east, float), np.asarray(north, float))
        new_e, new_n = self.new.to_en(lat, lon)
        jacobian = self.new.velocity_matrix(lat, lon) @ np.linalg.inv(self.old.velocity_matrix(lat, lon))
        return new_e, new_n, jacobian

    def carry(self, x: np.ndarray, p: np.ndarray, vectors: tuple[int, ...]) -> tuple[np.ndarray, np.ndarray,
                                                                                       np.ndarray]:
        """States x (..., n) whose horizontal position is x[..., 0:2] and whose other horizontal vectors
        (velocity, acceleration) start at the indices in `vectors`, with their covariances p (..., n, n), in the
        new plane. Returns (x, p, T): T (..., n, n) is the linear part of the map, for other state-space vectors
        (e.g. residual means)."""
        new_e, new_n, a = self.points(x[..., 0], x[..., 1])
        n = x.shape[-1]
        t = np.broadcast_to(np.eye(n), x.shape[:-1] + (n, n)).copy()
        for i in (0,) + tuple(vectors):
            t[..., i:i + 2, i:i + 2] = a
        x_new = np.einsum("...ij,...j->...i", t, x)
        x_new[..., 0], x_new[..., 1] = new_e, new_n
        p_new = t @ p @ np.swapaxes(t, -1, -2)
        return x_new, 0.5 * (p_new + np.swapaxes(p_new, -1, -2)), t


class TrackingFrame:
    """The current plane, created at the first position it is given, moved to the ownship (see module doc)."""

    def __init__(self, recentre_m: float = RECENTRE_M, max_hop_m: float = MAX_HOP_M):
        self.recentre_m = recentre_m
        self.max_hop_m = max_hop_m
        self.plane: LocalTangentPlane | None = None

    def to_plane(self, lat_deg, lon_deg, velocity_en):
        """(east, north) of points, and their true east/north velocities (..., 2) in the plane's axes."""
        if self.plane is None:
            self.plane = LocalTangentPlane(float(np.ravel(lat_deg)[0]), float(np.ravel(lon_deg)[0]))
        east, north = self.plane.to_en(lat_deg, lon_deg)
        j = self.plane.velocity_matrix(lat_deg, lon_deg)
        return east, north, np.einsum("...ij,...j->...i", j, np.asarray(velocity_en, float))

    def to_true(self, east, north, velocity_plane):
        """Inverse of to_plane: (lat, lon) of plane points and their velocities in true east/north axes."""
        return true_of(self.plane, east, north, velocity_plane)

    def follow(self, lat_deg: float, lon_deg: float) -> FrameChange | None:
        """Called with each ownship position: the change to apply to every filter when the plane has to move
        (the ownship is more than recentre_m from its origin), else None."""
        if self.plane is None:
            self.plane = LocalTangentPlane(lat_deg, lon_deg)
            return None
        old = self.plane
        # the chord, not to_en: a point beyond the plane's hemisphere projects near the origin
        distance = math.dist(geodetic_to_ecef(lat_deg, lon_deg, 0.0), geodetic_to_ecef(old.lat0_deg, old.lon0_deg, 0.0))
        if distance <= self.recentre_m:
            return None
        if distance > self.max_hop_m:
            towards = _towards(old.lat0_deg, old.lon0_deg, lat_deg, lon_deg, self.max_hop_m)
            if towards is None:
                return None
            lat_deg, lon_deg = towards
        self.plane = LocalTangentPlane(lat_deg, lon_deg)
        return FrameChange(old, self.plane)


def true_of(plane: LocalTangentPlane, east, north, velocity_plane):
    """TrackingFrame.to_true on a given plane (one that may since have been replaced by a re-centring)."""
    lat, lon = plane.to_geodetic(east, north)
    j = plane.velocity_matrix(lat, lon)
    return lat, lon, np.linalg.solve(j, np.asarray(velocity_plane, float)[..., None])[..., 0]


def _towards(lat0_deg, lon0_deg, lat1_deg, lon1_deg, distance_m: float) -> tuple[float, float] | None:
    """The point distance_m along the great circle from point 0 towards point 1 (on the sphere of the ellipsoid
    normals: close enough for where to put a plane); None for an exact antipode, which has no direction."""
    def normal(lat, lon):
        lat, lon = math.radians(lat), math.radians(lon)
        return np.array([math.cos(lat) * math.cos(lon), math.cos(lat) * math.sin(lon), math.sin(lat)])

    n0, n1 = normal(lat0_deg, lon0_deg), normal(lat1_deg, lon1_deg)
    towards = n1 - (n0 @ n1) * n0
    norm = np.linalg.norm(towards)
    if not norm > 1e-12:
        return None
    angle = distance_m / WGS84_A
    n = math.cos(angle) * n0 + math.sin(angle) * towards / norm
    return math.degrees(math.atan2(n[2], math.hypot(n[0], n[1]))), math.degrees(math.atan2(n[1], n[0]))
