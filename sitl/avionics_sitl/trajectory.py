"""Truth trajectories of the simulated world: where an aircraft is, exactly, at any time.

Two kinds, both answering `state_at(t_s)` deterministically:

- `LegTrajectory`: a leg program (constant turn rate / vertical rate / along-track acceleration per leg)
  integrated in closed form in the East-North plane of a `LocalTangentPlane`. Constant-rate turns are exact
  circles (the turn rate steps at leg boundaries, with no roll-in, as in the coordinated-turn models of the
  seed papers); with acceleration the arc is integrated exactly too, so there is no step-size error.
- `SampledTrajectory`: time-stamped samples (a DAIDALUS .daa file), cubic Hermite in position using the
  sample velocities, linear in velocity, straight-line extrapolation outside the samples.

Altitude is never projected: it stays an altitude in the aircraft's own datum (see avionics.base.geodesy).

Velocities in a KinematicState (and headings in an AircraftSpec) are true: east/north at the aircraft, as
ADS-B and MAVLink report them. Inside, the plane's east/north axes drift from true ones by the meridian
convergence (about 0.5 deg at 60 km east of the origin at 47 deg N) and the plane's scale from the
surface's (1e-4 at 70 km), so velocities are mapped between the two frames with the exact Jacobian of
LocalTangentPlane.to_en: the reported velocity is the rate of change of the reported position.
"""

from __future__ import annotations

import bisect
import math
from dataclasses import dataclass
from typing import Protocol, Sequence

import numpy as np

from avionics.base import units
from avionics.base.geodesy import LocalTangentPlane
from avionics_sitl.aircraft import AircraftSpec, Leg


@dataclass(frozen=True, slots=True)
class KinematicState:
    """Truth state of one aircraft at time t_s: WGS-84 position, altitude in the aircraft's datum, ENU velocity."""

    t_s: float
    lat_deg: float
    lon_deg: float
    alt_msl_m: float
    vel_east_mps: float
    vel_north_mps: float
    vel_up_mps: float

    @property
    def ground_speed_mps(self) -> float:
        return units.ground_speed_mps(self.vel_east_mps, self.vel_north_mps)

    @property
    def track_deg(self) -> float:
        """True track in [0, 360): 0 north, 90 east. 0 when not moving horizontally."""
        return units.track_deg(self.vel_east_mps, self.vel_north_mps)


class Trajectory(Protocol):
    plane: LocalTangentPlane

    def state_at(self, t_s: float) -> KinematicState: ...

    def enu_at(self, t_s: float) -> tuple[float, float, float]:
        """(east m, north m, altitude m) in `plane`; cheaper than state_at (no geodetic conversion)."""
        ...


# --- plane <-> true (local) horizontal velocity ---------------------------------------------------------


def true_velocity_to_plane(plane: LocalTangentPlane, lat_deg: float, lon_deg: float,
                           v_east: float, v_north: float) -> tuple[float, float]:
    ve, vn = plane.velocity_matrix(lat_deg, lon_deg) @ np.array([v_east, v_north])
    return float(ve), float(vn)


def plane_velocity_to_true(plane: LocalTangentPlane, lat_deg: float, lon_deg: float,
                           v_east: float, v_north: float) -> tuple[float, float]:
    """Inverse of true_velocity_to_plane (solving with the same J, so the two round-trip)."""
    ve, vn = np.linalg.solve(plane.velocity_matrix(lat_deg, lon_deg), np.array([v_east, v_north]))
    return float(ve), float(vn)


# --- closed-form integration of one leg ------------------------------------------------------------------


def _arc_integrals(theta: float) -> tuple[float, float, float, float]:
    """S = ∫0^1 cos(θu) du, C = ∫0^1 sin(θu) du, S2 = ∫0^1 u cos(θu) du, C2 = ∫0^1 u sin(θu) du.

    These turn the position integral of a constant-turn, constant-acceleration leg into closed form without
    the 1/ω and 1/ω² cancellation of the textbook formulas: near θ = 0 they use their Taylor series."""
    if abs(theta) < 0.05:  # series truncation < 1e-16 here; the closed form loses ~1e-16/theta^2 below
        t2 = theta * theta
        s = 1.0 - t2 / 6.0 + t2 * t2 / 120.0 - t2**3 / 5040.0
        c = theta * (0.5 - t2 / 24.0 + t2 * t2 / 720.0 - t2**3 / 40320.0)
        s2 = 0.5 - t2 / 8.0 + t2 * t2 / 144.0 - t2**3 / 5760.0
        c2 = theta * (1.0 / 3.0 - t2 / 30.0 + t2 * t2 / 840.0 - t2**3 / 45360.0)
        return s, c, s2, c2
    sin_t, cos_t = math.sin(theta), math.cos(theta)
    s = sin_t / theta
    c = 2.0 * math.sin(0.5 * theta) ** 2 / theta  # (1 - cos θ)/θ without cancellation
    s2 = (theta * sin_t + cos_t - 1.0) / (theta * theta)
    c2 = (sin_t - theta * cos_t) / (theta * theta)
    return s, c, s2, c2


@dataclass(frozen=True, slots=True)
class _Segment:
    """One leg in plane coordinates: initial state at t0 and the constant rates flown from there."""

    t0: float
    east0: float
    north0: float
    alt0: float
    heading0_rad: float  # clockwise from north
    speed0: float
    turn_rate_rps: float  # positive clockwise (right turn)
    vertical_rate: float
    acceleration: float

    def at(self, t_s: float) -> tuple[float, float, float, float, float, float]:
        """(east, north, alt, vel_east, vel_north, vel_up) at t_s (any t_s, not only inside the leg)."""
        tau = t_s - self.t0
        psi0, v0, a = self.heading0_rad, self.speed0, self.acceleration
        theta = self.turn_rate_rps * tau
        s, c, s2, c2 = _arc_integrals(theta)
        sin0, cos0 = math.sin(psi0), math.cos(psi0)
        # Position = ∫0^τ (v0 + aσ)(sin ψ, cos ψ) dσ with ψ = ψ0 + ωσ; expanding sin/cos(ψ0 + θu) by the
        # angle-sum formulas leaves the four integrals S, C, S2, C2 of _arc_integrals.
        east = self.east0 + v0 * tau * (sin0 * s + cos0 * c) + a * tau * tau * (sin0 * s2 + cos0 * c2)
        north = self.north0 + v0 * tau * (cos0 * s - sin0 * c) + a * tau * tau * (cos0 * s2 - sin0 * c2)
        psi = psi0 + theta
        speed = v0 + a * tau
        return (
            east,
            north,
            self.alt0 + self.vertical_rate * tau,
            speed * math.sin(psi),
            speed * math.cos(psi),
            self.vertical_rate,
        )


class LegKinematics:
    """A leg program flown from a point of a flat East-North plane (no geodesy).

    Before t = 0 the aircraft is on the straight line of its initial velocity; after the last leg it flies
    straight, level, at the speed it has reached. With no legs it flies straight at `vertical_rate_mps`
    forever (a DAIDALUS snapshot extrapolation)."""

    def __init__(
        self,
        east_m: float,
        north_m: float,
        alt_m: float,
        heading_deg: float,
        speed_mps: float,
        vertical_rate_mps: float = 0.0,
        legs: Sequence[Leg] = (),
    ):
        psi = math.radians(heading_deg)
        first_vs = legs[0].vertical_rate_mps if legs else vertical_rate_mps
        self._before = _Segment(0.0, east_m, north_m, alt_m, psi, speed_mps, 0.0, first_vs, 0.0)
        segments: list[_Segment] = []
        t, e, n, z, v = 0.0, east_m, north_m, alt_m, speed_mps
        for i, leg in enumerate(legs):
            seg = _Segment(
                t, e, n, z, psi, v, math.radians(leg.turn_rate_dps), leg.vertical_rate_mps, leg.acceleration_mps2
            )
            segments.append(seg)
            t_end = t + leg.duration_s
            v_end = v + leg.acceleration_mps2 * leg.duration_s
            if v_end < -1e-9:
                raise ValueError(f"leg {i}: speed would become negative ({v_end:.3f} m/s at t={t_end:g} s)")
            e, n, z, _, _, _ = seg.at(t_end)
            psi = (psi + seg.turn_rate_rps * leg.duration_s) % (2.0 * math.pi)
            t, v = t_end, max(v_end, 0.0)
        tail_vs = 0.0 if legs else vertical_rate_mps  # after the last leg: straight and level
        segments.append(_Segment(t, e, n, z, psi, v, 0.0, tail_vs, 0.0))
        self._segments = segments
        self._starts = [seg.t0 for seg in segments]

    @property
    def legs_end_s(self) -> float:
        """Time at which the last leg ends (0 with no legs)."""
        return self._starts[-1]

    def at(self, t_s: float) -> tuple[float, float, float, float, float, float]:
        """(east, north, alt, vel_east, vel_north, vel_up) at t_s."""
        t_s = float(t_s)
        if not math.isfinite(t_s):
            raise ValueError(f"time must be finite, got {t_s}")
        if t_s < 0.0:
            return self._before.at(t_s)
        i = bisect.bisect_right(self._starts, t_s) - 1
        return self._segments[i].at(t_s)


class LegTrajectory:
    """An `AircraftSpec`'s leg program on the tangent plane `plane`, converted to WGS-84 on output.

    The spec's true heading and speed become the plane's at the start point; turn rates and accelerations
    act in the plane."""

    def __init__(self, spec: AircraftSpec, plane: LocalTangentPlane):
        self.spec = spec
        self.plane = plane
        east, north = plane.to_en(spec.lat_deg, spec.lon_deg)
        psi = math.radians(spec.heading_deg)
        ue, un = true_velocity_to_plane(plane, spec.lat_deg, spec.lon_deg, math.sin(psi), math.cos(psi))
        self.kinematics = LegKinematics(
            float(east), float(north), spec.alt_msl_m, math.degrees(math.atan2(ue, un)),
            spec.speed_mps * math.hypot(ue, un), spec.vertical_rate_mps, spec.legs,
        )

    def enu_at(self, t_s: float) -> tuple[float, float, float]:
        e, n, z, _, _, _ = self.kinematics.at(t_s)
        return e, n, z

    def state_at(self, t_s: float) -> KinematicState:
        e, n, z, ve, vn, vu = self.kinematics.at(t_s)
        return _state(self.plane, t_s, e, n, z, ve, vn, vu)


def _state(plane: LocalTangentPlane, t_s: float, e: float, n: float, z: float, ve: float, vn: float,
           vu: float) -> KinematicState:
    """KinematicState from plane coordinates and plane velocity."""
    lat_a, lon_a = plane.to_geodetic(e, n)
    lat, lon = float(lat_a), float(lon_a)
    ve_true, vn_true = plane_velocity_to_true(plane, lat, lon, ve, vn)
    return KinematicState(float(t_s), lat, lon, float(z), ve_true, vn_true, float(vu))


class SampledTrajectory:
    """Trajectory through time-stamped samples (velocities true east/north/up at each sample).

    Position: cubic Hermite per interval using the sample velocities as end slopes (so exact for
    constant-velocity flight, C1 at the samples). Velocity: linear between samples (what a .daa file states;
    it is not the Hermite derivative). Outside [first, last] sample: straight line with the end sample's
    velocity. East/north and velocities are interpolated on `plane` (default: tangent plane at the first
    sample)."""

    def __init__(self, times, lat, lon, alt, vel_e, vel_n, vel_u, plane: LocalTangentPlane | None = None):
        cols = [np.atleast_1d(np.asarray(x, dtype=float)) for x in (times, lat, lon, alt, vel_e, vel_n, vel_u)]
        n = len(cols[0])
        if n == 0:
            raise ValueError("a sampled trajectory needs at least one sample")
        if any(c.ndim != 1 or len(c) != n for c in cols):
            raise ValueError("times, lat, lon, alt, vel_e, vel_n, vel_u must be 1-D of equal length")
        if not all(np.all(np.isfinite(c)) for c in cols):
            raise ValueError("sample values must be finite")
        t = cols[0]
        if n > 1 and not np.all(np.diff(t) > 0):
            raise ValueError("sample times must be strictly increasing")
        self.plane = plane if plane is not None else LocalTangentPlane(cols[1][0], cols[2][0])
        east, north = self.plane.to_en(cols[1], cols[2])
        plane_vel = [true_velocity_to_plane(self.plane, la, lo, ve, vn)
                     for la, lo, ve, vn in zip(cols[1], cols[2], cols[4], cols[5])]
        self.times = t
        # (east, north, up) per sample as Python floats: one interpolation is a few dozen float operations, which
        # numpy would make as many calls on 3-vectors (the simulated autopilot asks for one every 0.1 s)
        self._t = t.tolist()
        self._pos = np.stack([np.asarray(east, float), np.asarray(north, float), cols[3]], axis=1).tolist()
        self._vel = np.column_stack([np.array(plane_vel).reshape(n, 2), cols[6]]).tolist()

    def _interpolate(self, t_s: float) -> tuple[tuple, tuple]:
        """(position, velocity) at t_s, each (east, north, up) in the plane."""
        t_s = float(t_s)
        if not math.isfinite(t_s):
            raise ValueError(f"time must be finite, got {t_s}")
        times, pos, vel = self._t, self._pos, self._vel
        if t_s <= times[0] or t_s >= times[-1]:  # the straight line of the end sample's velocity
            end = 0 if t_s <= times[0] else -1
            dt = t_s - times[end]
            return tuple(p + v * dt for p, v in zip(pos[end], vel[end])), tuple(vel[end])
        i = bisect.bisect_right(times, t_s) - 1
        h = times[i + 1] - times[i]
        u = (t_s - times[i]) / h
        # Cubic Hermite basis on [0, 1]; slopes scaled by the interval length.
        h00 = (1.0 + 2.0 * u) * (1.0 - u) ** 2
        h10 = u * (1.0 - u) ** 2
        h01 = u * u * (3.0 - 2.0 * u)
        h11 = u * u * (u - 1.0)
        p = tuple(h00 * p0 + h10 * h * v0 + h01 * p1 + h11 * h * v1
                  for p0, v0, p1, v1 in zip(pos[i], vel[i], pos[i + 1], vel[i + 1]))
        v = tuple((1.0 - u) * v0 + u * v1 for v0, v1 in zip(vel[i], vel[i + 1]))
        return p, v

    def enu_at(self, t_s: float) -> tuple[float, float, float]:
        return self._interpolate(t_s)[0]

    def state_at(self, t_s: float) -> KinematicState:
        p, v = self._interpolate(t_s)
        return _state(self.plane, t_s, *p, *v)
