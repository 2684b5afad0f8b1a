"""The autopilot's mission, read over MAVLink, and its horizontal path flown during a vertical manoeuvre.

Why: a vertical RA is flown in GUIDED (ArduCopter) or OFFBOARD (PX4), where the autopilot no longer flies its
mission. Holding the horizontal velocity of the RA's start flew a survey multirotor straight on while its mission
turned, into the intruder the RA was avoiding (docs/evaluation.md: one encounter carried 72 % of the guided do365
run's induced NMAC weight). A TCAS pilot keeps the lateral navigation while flying the vertical manoeuvre; here
the guidance does: the setpoint's horizontal velocity follows the mission's legs (MissionPath.velocity), and the
mission is given back at the waypoint the vehicle has reached (MISSION_SET_CURRENT).

MissionReader downloads the mission with the MAVLink mission protocol (mavlink.io/en/services/mission.html,
"Download a Mission from the Vehicle"): MISSION_REQUEST_LIST, answered by MISSION_COUNT; MISSION_REQUEST_INT for
each item, answered by MISSION_ITEM_INT; MISSION_ACK to end. A request that gets no answer within TIMEOUT_S is
sent again, at most RETRIES times (the protocol page's defaults); then the download has failed and is tried again
RESTART_S later. MISSION_CURRENT (ArduPilot and PX4 stream it) gives the item the vehicle flies to; a `total`
that differs from the mission read means it was changed: it is read again.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import avionics.io  # noqa: F401  (MAVLink 2)
from avionics.base.geodesy import flat_offset_m
from avionics.base.types import MissionCount, MissionCurrent, MissionItem
from avionics.io.dialect import daa as mavlink2

TIMEOUT_S = 1.5  # a request's answer (the mission protocol's default timeout)
RETRIES = 5  # resends of one request before the download fails (the protocol's default)
RESTART_S = 10.0  # a failed download is started again after this
# An item is reached within this horizontal distance (ArduCopter WPNAV_RADIUS default, 200 cm: AC_WPNav.cpp) or
# once the vehicle is past it along its leg
REACHED_M = 2.0
CROSS_TRACK_GAIN_PER_S = 0.5  # the pull back onto the leg, m/s per m off it (AC_PosControl's position P is 1/s)
# navigation items with a position the vehicle flies to (common.xml MAV_CMD): WAYPOINT, LOITER_UNLIM, LOITER_TURNS,
# LOITER_TIME, SPLINE_WAYPOINT; anything else (DO_ commands, takeoff, land, RTL) is not a point of the path
NAV_POSITION_COMMANDS = frozenset({16, 17, 18, 19, 82})
GLOBAL_FRAMES = frozenset({mavlink2.MAV_FRAME_GLOBAL, mavlink2.MAV_FRAME_GLOBAL_RELATIVE_ALT,
                           mavlink2.MAV_FRAME_GLOBAL_INT, mavlink2.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT,
                           mavlink2.MAV_FRAME_GLOBAL_TERRAIN_ALT, mavlink2.MAV_FRAME_GLOBAL_TERRAIN_ALT_INT})


@dataclass(frozen=True, slots=True)
class Waypoint:
    seq: int
    lat_deg: float
    lon_deg: float


class MissionPath:
    """The mission's horizontal path: its positional items in order (seq 0, ArduPilot's home, is not one)."""

    def __init__(self, waypoints: list[Waypoint]):
        self.waypoints = waypoints

    def after(self, seq: int) -> int | None:
        """The index of the first waypoint at or after item seq (the item flown to); None past the last."""
        return next((i for i, w in enumerate(self.waypoints) if w.seq >= seq), None)

    def velocity(self, seq: int, lat_deg: float, lon_deg: float, speed_mps: float) -> tuple[float, float, int]:
        """(north, east) m/s along the leg to item seq (or the first positional one after it) at speed_mps, pulled
        back onto the leg at CROSS_TRACK_GAIN_PER_S, within speed_mps; and the item flown to, advanced past those
        reached. Past the last waypoint: toward it, slowing to a stop on it."""
        i = self.after(seq)
        if i is None:
            i = len(self.waypoints) - 1
        while True:
            target = self.waypoints[i]
            n, e = flat_offset_m(lat_deg, lon_deg, target.lat_deg, target.lon_deg)  # from the vehicle to the target
            leg = (n, e)  # the first waypoint: straight to it
            if i > 0:
                before = self.waypoints[i - 1]
                pn, pe = flat_offset_m(lat_deg, lon_deg, before.lat_deg, before.lon_deg)
                if math.hypot(n - pn, e - pe) >= 1e-6:
                    leg = (n - pn, e - pe)
            length = math.hypot(*leg)
            un, ue = (leg[0] / length, leg[1] / length) if length >= 1e-6 else (0.0, 0.0)
            along = n * un + e * ue  # distance still to go along the leg
            right = e * un - n * ue  # how far the leg's line lies to the right of the vehicle
            last = i == len(self.waypoints) - 1
            if (math.hypot(n, e) <= REACHED_M or along <= 0.0) and not last:
                i += 1
                continue
            break
        if length < 1e-6 or speed_mps <= 0.0:  # on its last waypoint, or a hover kept
            return 0.0, 0.0, target.seq
        speed = min(speed_mps, CROSS_TRACK_GAIN_PER_S * max(along, 0.0)) if last else speed_mps
        # along the leg, plus the pull onto it: the right-hand normal of the leg is (-ue, un)
        vn = speed * un - CROSS_TRACK_GAIN_PER_S * right * ue
        ve = speed * ue + CROSS_TRACK_GAIN_PER_S * right * un
        norm = math.hypot(vn, ve)
        if norm > speed_mps:
            vn, ve = vn * speed_mps / norm, ve * speed_mps / norm
        return vn, ve, target.seq


def _positional(item: MissionItem) -> bool:
    """A navigation item with a global position the vehicle flies to (not a DO_ command, not a local frame)."""
    return item.command in NAV_POSITION_COMMANDS and item.frame in GLOBAL_FRAMES and \
        -90.0 <= item.lat_deg <= 90.0 and -180.0 <= item.lon_deg <= 180.0 and (item.lat_deg, item.lon_deg) != (0, 0)


class MissionReader:
    """The mission download (module docstring). step(now, inputs) -> the requests to send; path: the mission
    read (None until one is); current: the item the autopilot flies to (MISSION_CURRENT)."""

    def __init__(self, system: int, component: int, first_item: int = 1):
        """first_item: the first item that is a point of the path (ArduPilot's item 0 is home: 1; PX4: 0)."""
        self.system, self.component, self.first_item = system, component, first_item
        self.path: MissionPath | None = None
        self.current: int | None = None
        self._total: int | None = None  # items in the mission read
        self._items: dict[int, Waypoint | None] = {}
        self._count: int | None = None  # items of the download in progress
        self._pending: tuple[str, int] | None = None  # ("list", 0) or ("item", seq) awaiting its answer
        self._sent_s = 0.0
        self._attempts = 0
        self._retry_at: float | None = 0.0  # start (again) at this time; None: not to be started
        self.failures = 0

    def step(self, now_s: float, inputs=()) -> list:
        out = []
        for item in inputs:
            if isinstance(item, MissionCurrent):
                self.current = item.seq
                if item.total and self._total is not None and item.total != self._total and self._pending is None:
                    self._retry_at = now_s  # the mission changed: read it again
            elif isinstance(item, MissionCount) and self._pending == ("list", 0):
                self._count, self._items = item.count, {}
                out += self._next(now_s)
            elif isinstance(item, MissionItem) and self._pending == ("item", item.seq):
                self._items[item.seq] = Waypoint(item.seq, item.lat_deg, item.lon_deg) if _positional(item) else None
                out += self._next(now_s)
        if self._pending is None and self._retry_at is not None and now_s >= self._retry_at:
            self._retry_at = None
            out.append(self._send(("list", 0), now_s))
        elif self._pending is not None and now_s - self._sent_s >= TIMEOUT_S:
            if self._attempts > RETRIES:
                self._pending, self.failures, self._retry_at = None, self.failures + 1, now_s + RESTART_S
            else:
                out.append(self._request(self._pending))
                self._sent_s, self._attempts = now_s, self._attempts + 1
        return out

    def _next(self, now_s: float) -> list:
        """The next item's request, or the end of the download (its MISSION_ACK)."""
        seq = len(self._items)
        if seq < self._count:
            return [self._send(("item", seq), now_s)]
        self._pending, self._total = None, self._count
        points = (self._items[i] for i in range(self._count))
        self.path = MissionPath([w for w in points if w is not None and w.seq >= self.first_item])
        return [mavlink2.MAVLink_mission_ack_message(self.system, self.component, mavlink2.MAV_MISSION_ACCEPTED)]

    def _send(self, pending: tuple[str, int], now_s: float):
        self._pending, self._sent_s, self._attempts = pending, now_s, 1
        return self._request(pending)

    def _request(self, pending: tuple[str, int]):
        kind, seq = pending
        if kind == "list":
            return mavlink2.MAVLink_mission_request_list_message(self.system, self.component)
        return mavlink2.MAVLink_mission_request_int_message(self.system, self.component, seq)


def set_current(seq: int, system: int, component: int):
    """MISSION_SET_CURRENT: the item AUTO resumes at (ArduPilot GCS_Common.cpp handle_mission_set_current; PX4
    MavlinkMissionManager)."""
    return mavlink2.MAVLink_mission_set_current_message(system, component, seq)
