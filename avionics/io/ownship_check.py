"""The ownship jump check: a GLOBAL_POSITION_INT must be where the previous accepted fix, flown with the two fixes'
velocities, says the aircraft is (docs/mavlink.md, "GLOBAL_POSITION_INT").

The rule is ArduPilot's GPS glitch protection (ArduCopter 3.1-3.2, AP_GPS_Glitch; ardupilot.org/copter/docs/
gps-failsafe-glitch-protection.html): a new position is compared with the previous one projected by its velocity,
and is good within a fixed radius or within 10 m/s^2 (GPS_GLITCH_ACCEL) x dt^2 / 2; glitching for 5 s is a
failsafe. Our fixes are the autopilot's navigation solution stamped at receipt, not the receiver's, so the radius
is wider (input.ownship_jump_m, 100 m: an EKF position reset to GNSS, EK3_GLITCH_RAD 25 m, with margin) and the
receipt-time jitter costs the speed x RECEIPT_JITTER_S. The velocities are integrated with the trapezoid rule
(exact at constant acceleration). A fix 50 km away (another sender's, or a corrupted one) is rejected, counted
(`gpi.jump`); rejections that last input.ownship_jump_persist_s (ArduPilot's 5 s) make DAA unavailable
(`ownship_inconsistent`). A real jump (an EKF reset beyond the radius) makes every later fix fail against the
last accepted one: after ownship_jump_persist_s without an accepted fix the check starts again from the next fix
(`gpi.jump_restart`); in between the ownship times out as for a silent autopilot.
"""

from __future__ import annotations

import math
from collections import Counter
from typing import TYPE_CHECKING

import numpy as np

from avionics.base.geodesy import geodetic_to_ecef, horizontal_axes
from avionics.base.types import OwnshipFix

if TYPE_CHECKING:
    from avionics.tracking.params import InputConfig

MAX_ACCEL_MPS2 = 10.0  # ArduPilot GPS_GLITCH_ACCEL_MAX_CMSS 1000: "the vehicle can accelerate at up to 10 m/s/s"
RECEIPT_JITTER_S = 0.5  # fixes are stamped when a read returns: a read is due every 0.1 s, late by up to this


def _enu_to_ecef(fix: OwnshipFix, east: float, north: float, up: float) -> np.ndarray:
    axes = horizontal_axes(fix.lat_deg, fix.lon_deg)
    lat, lon = math.radians(fix.lat_deg), math.radians(fix.lon_deg)
    normal = np.array([math.cos(lat) * math.cos(lon), math.cos(lat) * math.sin(lon), math.sin(lat)])
    return east * axes[0] + north * axes[1] + up * normal


class OwnshipJumpCheck:
    def __init__(self, config: InputConfig, counters: Counter):
        self.radius_m = config.ownship_jump_m
        self.persist_s = config.ownship_jump_persist_s
        self.counters = counters
        self.last: OwnshipFix | None = None  # the last accepted fix
        self._rejecting: tuple[float, float] | None = None  # (first, last) rejection of the current run

    def accept(self, fix: OwnshipFix) -> bool:
        last = self.last
        if last is not None and fix.time_s - last.time_s > self.persist_s:
            if self._rejecting is not None:
                self.counters["gpi.jump_restart"] += 1  # no fix accepted for that long: start again from this one
            last = None
        if last is not None and not self._consistent(last, fix):
            self.counters["gpi.jump"] += 1
            run = self._rejecting
            self._rejecting = (fix.time_s if run is None or fix.time_s - run[1] > self.persist_s else run[0],
                               fix.time_s)
            return False
        self.last = fix
        return True

    def failing(self, now_s: float) -> bool:
        """Have fixes been rejected for persist_s, the last of them within persist_s? (DAA unavailable)"""
        run = self._rejecting
        return run is not None and run[1] - run[0] >= self.persist_s and now_s - run[1] <= self.persist_s

    def _consistent(self, last: OwnshipFix, fix: OwnshipFix) -> bool:
        dt = max(fix.time_s - last.time_s, 0.0)
        (vn0, ve0, vd0), (vn1, ve1, vd1) = last.velocity_ned_mps, fix.velocity_ned_mps
        flown = _enu_to_ecef(last, 0.5 * (ve0 + ve1) * dt, 0.5 * (vn0 + vn1) * dt, -0.5 * (vd0 + vd1) * dt)
        moved = np.subtract(geodetic_to_ecef(fix.lat_deg, fix.lon_deg, fix.alt_msl_m),
                            geodetic_to_ecef(last.lat_deg, last.lon_deg, last.alt_msl_m))
        speed = max(math.hypot(ve0, vn0, vd0), math.hypot(ve1, vn1, vd1))
        allowed = max(self.radius_m, 0.5 * MAX_ACCEL_MPS2 * dt * dt) + speed * RECEIPT_JITTER_S
        return float(np.linalg.norm(moved - flown)) <= allowed
