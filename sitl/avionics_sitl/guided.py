"""The simulated ArduCopter of the guidance contract (avionics/guidance/ardupilot.py): modes, commands, setpoints.

It flies the scenario's ownship path as its mission in AUTO and answers as ArduCopter does:
- HEARTBEAT (MAV_TYPE_QUADROTOR, MAV_AUTOPILOT_ARDUPILOTMEGA) with the mode in custom_mode;
- MAV_CMD_DO_SET_MODE (COMMAND_LONG): an ArduCopter mode number is taken at once and ACCEPTED; any other
  number, or one in `refuse` (a test's stand-in for a mode whose checks fail), is DENIED;
- SET_POSITION_TARGET_GLOBAL_INT with a velocity-only mask: flown in GUIDED, ignored in every other mode (counted);
  with no setpoint for GUID_TIMEOUT (3 s), or in GUIDED before the first one, the vehicle stops (ArduCopter
  mode_guided.cpp: velocity control "stops" at the timeout); LOITER and the other modes stop too.
- Dynamics: the vehicle profile's (advisory/vehicle.py) vertical rates and acceleration and its horizontal
  acceleration, per axis toward the wanted velocity; outside the mission the wanted horizontal velocity's track
  also turns from the present one no faster than the profile's turn rate (a setpoint that jumps to a new track is
  flown as a turn, not through a stop).
- Back in AUTO it re-joins the mission where the scenario's ownship is now (the mission's current item at the
  current time): the offset from the path is flown out at a gain of RECOVERY_GAIN_PER_S, within the vehicle's climb
  and descent rates, so the altitude gained returns at the profile's rate, as AUTO flying back to the current
  waypoint's altitude does.
A pilot's mode change is `set_mode(mode, now)`.

Its mission, for the guidance to read (avionics/guidance/mission.py), is the scenario's ownship path as waypoints
(`load_mission`: the path sampled each second and simplified to within MISSION_TOLERANCE_M by Douglas-Peucker,
each vertex a MAV_CMD_NAV_WAYPOINT; ArduPilot's item 0 is home), served over the MAVLink mission protocol
(MISSION_REQUEST_LIST -> MISSION_COUNT, MISSION_REQUEST_INT -> MISSION_ITEM_INT); MISSION_CURRENT says the vertex
AUTO flies to (the first one ahead of the path's present time), kept while out of AUTO, and MISSION_SET_CURRENT
sets it (AUTO still re-joins the path where the scenario's ownship is now: the mission's timing is the encounter's).

firmware="px4" is a PX4 multicopter instead (avionics/guidance/px4.py): HEARTBEAT MAV_AUTOPILOT_PX4 with PX4's
custom_mode (main and sub mode), the mission in AUTO.MISSION, SET_POSITION_TARGET_LOCAL_NED velocity setpoints
taken in any mode and flown in OFFBOARD, OFFBOARD DENIED unless the stream has run for more than a second and is
alive, and OFFBOARD left for Hold (AUTO.LOITER) when no setpoint came for COM_OF_LOSS_T (1 s): PX4's failsafe
action depends on COM_OBL_RC_ACT and the RC; Hold is ours.
"""

from __future__ import annotations

import math
from collections import Counter
from dataclasses import replace

import avionics.io  # noqa: F401
from avionics.base.geodesy import MEAN_EARTH_RADIUS_M
from avionics.guidance import ardupilot, px4
from avionics.io.dialect import daa as mavlink2
from avionics_sitl.trajectory import KinematicState

TURN_MIN_SPEED_MPS = 0.5  # below this ground speed a multirotor has no track to turn (ours)
RECOVERY_GAIN_PER_S = 0.5  # AUTO's pull back onto the path (ours; AC_PosControl's position P is 1.0 per second)
MISSION_TOLERANCE_M = 1.0  # the waypoints stay this close to the sampled path (horizontally)
MISSION_SAMPLE_S = 1.0


class SimCopter:
    def __init__(self, vehicle, system_id: int = 1, component_id: int = 1, refuse: frozenset = frozenset(),
                 counters: Counter | None = None, position_lost_s: float | None = None, firmware: str = "ardupilot"):
        """vehicle: advisory/vehicle.py VehicleProfile. position_lost_s: from then on no GLOBAL_POSITION_INT or
        SCALED_PRESSURE is sent (a navigation failure: the DAA's ownship goes stale). firmware: "ardupilot"
        (ArduCopter: AUTO, GUIDED) or "px4" (PX4 multicopter: AUTO.MISSION, OFFBOARD; see px4.py)."""
        if firmware not in ("ardupilot", "px4"):
            raise ValueError(f"firmware {firmware!r}: ardupilot or px4")
        self.px4 = firmware == "px4"
        self.mission_mode = px4.MISSION if self.px4 else ardupilot.AUTO
        self.command_mode = px4.OFFBOARD if self.px4 else ardupilot.GUIDED
        self.stream: tuple[float, float] | None = None  # PX4: (first, last) time of the running setpoint stream
        self.vehicle = vehicle
        self.position_lost_s = position_lost_s
        self.system_id, self.component_id = system_id, component_id
        self.refuse = frozenset(refuse)
        self.counters = counters if counters is not None else Counter()
        self.mode = self.mission_mode
        self.offset = [0.0, 0.0, 0.0]  # east, north, up from the mission path
        self.velocity: list[float] | None = None  # east, north, up (None until the first fly())
        self.setpoint: tuple[float, float, float, float] | None = None  # east, north, up, time received
        self.modes: list[tuple[float, int]] = [(0.0, self.mission_mode)]  # (time, mode) at each change
        self._last_t: float | None = None
        self.min_guided_alt_msl_m = math.inf  # the lowest true altitude flown in GUIDED (the floor's check)
        self.waypoints: list[tuple[float, float, float]] = []  # (time on the path, lat, lon): load_mission
        self.first_item = 0 if self.px4 else 1  # ArduPilot's item 0 is home
        self.current_item = self.first_item  # MISSION_CURRENT's seq

    # -- the link ----------------------------------------------------------------------------------------------
    MAV_TYPE = mavlink2.MAV_TYPE_QUADROTOR  # what HEARTBEAT says this vehicle is (SimPlane: a fixed wing)

    def heartbeat(self):
        return mavlink2.MAVLink_heartbeat_message(
            self.MAV_TYPE, mavlink2.MAV_AUTOPILOT_PX4 if self.px4 else mavlink2.MAV_AUTOPILOT_ARDUPILOTMEGA,
            mavlink2.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED | mavlink2.MAV_MODE_FLAG_SAFETY_ARMED, self.mode,
            mavlink2.MAV_STATE_ACTIVE, 3)

    def receive(self, msg, now_s: float) -> list:
        """A message from the DAA process; the answers to send back."""
        kind = msg.get_type()
        if kind == "COMMAND_LONG" and self._for_us(msg):
            if msg.command != ardupilot.DO_SET_MODE:
                return [self._ack(msg, mavlink2.MAV_RESULT_UNSUPPORTED)]
            if self.px4:
                mode = px4.mode_of(msg) if msg.param2 == int(msg.param2) and msg.param3 == int(msg.param3) else -1
                known = mode in px4.PX4_MODES
            else:
                mode = int(msg.param2) if msg.param2 == int(msg.param2) else -1
                known = mode in ardupilot.COPTER_MODES
            if not known or mode in self.refuse or (mode == px4.OFFBOARD and self.px4 and
                                                    not self._stream_running(now_s)):
                self.counters["sim.mode_denied"] += 1
                return [self._ack(msg, mavlink2.MAV_RESULT_DENIED)]
            self.set_mode(mode, now_s)
            return [self._ack(msg, mavlink2.MAV_RESULT_ACCEPTED)]
        if kind.startswith("MISSION_") and self._for_us(msg):
            return self._mission(msg, kind)
        wanted = "SET_POSITION_TARGET_LOCAL_NED" if self.px4 else "SET_POSITION_TARGET_GLOBAL_INT"
        if kind == wanted and self._for_us(msg):
            if not (px4 if self.px4 else ardupilot).is_velocity_setpoint(msg):
                self.counters["sim.setpoint_ignored"] += 1
                return []
            if self.px4:  # PX4 takes the stream in any mode and flies it in OFFBOARD
                fresh = self.stream is not None and now_s - self.stream[1] <= px4.OFFBOARD_LOSS_S
                self.stream = (self.stream[0] if fresh else now_s, now_s)
            elif self.mode != self.command_mode:  # ArduCopter ignores setpoints outside GUIDED
                self.counters["sim.setpoint_ignored"] += 1
                return []
            self.counters["sim.setpoint" if self.mode == self.command_mode else "sim.setpoint_streamed"] += 1
            self.setpoint = (msg.vy, msg.vx, -msg.vz, now_s)  # NED -> east, north, up
        return []

    # -- the mission ---------------------------------------------------------------------------------------------
    def load_mission(self, trajectory, duration_s: float) -> None:
        """The path of trajectory (sitl/trajectory.py: enu_at(t), state_at(t)) over [0, duration_s] as this vehicle's
        mission (module docstring)."""
        steps = int(math.ceil(duration_s / MISSION_SAMPLE_S))
        times = [min(k * MISSION_SAMPLE_S, duration_s) for k in range(steps + 1)]
        xy = [trajectory.enu_at(t)[:2] for t in times]
        kept = (trajectory.state_at(times[i]) for i in _simplified(xy, MISSION_TOLERANCE_M))
        self.waypoints = [(s.t_s, s.lat_deg, s.lon_deg) for s in kept]

    def _items(self) -> list[tuple[float, float]]:
        """(lat, lon) of every item: home first on ArduPilot."""
        points = [(lat, lon) for _, lat, lon in self.waypoints]
        return points[:1] + points if not self.px4 and points else points

    def _mission(self, msg, kind: str) -> list:
        items = self._items()
        if kind == "MISSION_REQUEST_LIST":
            self.counters["sim.mission_list"] += 1
            return [mavlink2.MAVLink_mission_count_message(msg.get_srcSystem(), msg.get_srcComponent(), len(items))]
        if kind == "MISSION_REQUEST_INT" and 0 <= msg.seq < len(items):
            lat, lon = items[msg.seq]
            return [mavlink2.MAVLink_mission_item_int_message(
                msg.get_srcSystem(), msg.get_srcComponent(), msg.seq, mavlink2.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT,
                mavlink2.MAV_CMD_NAV_WAYPOINT, int(msg.seq == self.current_item), 1, 0.0, 0.0, 0.0, 0.0,
                int(round(lat * 1e7)), int(round(lon * 1e7)), 0.0)]
        if kind == "MISSION_SET_CURRENT" and 0 <= msg.seq < len(items):
            self.counters["sim.mission_set_current"] += 1
            self.current_item = msg.seq
            return [self.mission_current()]
        return []

    def mission_current(self):
        """MISSION_CURRENT (ArduPilot streams it with EXTENDED_STATUS; PX4 too)."""
        return mavlink2.MAVLink_mission_current_message(self.current_item, len(self._items()))

    def _advance_mission(self, t: float) -> None:
        """In AUTO: the item flown to is the first vertex ahead of the path's time t."""
        ahead = next((i for i, (tw, _, _) in enumerate(self.waypoints) if tw > t + 1e-9), len(self.waypoints) - 1)
        self.current_item = ahead + self.first_item

    def _stream_running(self, now_s: float) -> bool:
        """PX4 engages OFFBOARD only on a stream it has received for more than a second, still alive."""
        return self.stream is not None and now_s - self.stream[1] <= px4.OFFBOARD_LOSS_S and \
            self.stream[1] - self.stream[0] >= 1.0

    def reports_position(self, now_s: float) -> bool:
        return self.position_lost_s is None or now_s < self.position_lost_s

    def set_mode(self, mode: int, now_s: float) -> None:
        if mode != self.mode:
            self.modes.append((now_s, mode))
            if mode == ardupilot.GUIDED and not self.px4:
                self.setpoint = None  # GUIDED starts by holding until told otherwise
        self.mode = mode

    def _for_us(self, msg) -> bool:
        return msg.target_system == self.system_id and msg.target_component in (0, self.component_id)

    def _ack(self, msg, result: int):
        return mavlink2.MAVLink_command_ack_message(msg.command, result, 0, 0, msg.get_srcSystem(),
                                                    msg.get_srcComponent())

    # -- the flight --------------------------------------------------------------------------------------------
    def fly(self, mission: KinematicState) -> KinematicState:
        """Advance to mission.t_s (the scenario ownship's state then) and return the vehicle's true state."""
        t = mission.t_s
        path = (mission.vel_east_mps, mission.vel_north_mps, mission.vel_up_mps)
        if self.velocity is None:
            self.velocity = list(path)
        dt = 0.0 if self._last_t is None else max(t - self._last_t, 0.0)
        self._last_t = t
        v = self.vehicle
        if self.mode == self.mission_mode and self.waypoints:
            self._advance_mission(t)
        wanted = self._wanted(path, t)
        if self.mode != self.mission_mode:
            wanted[0], wanted[1] = self._turn_limited(wanted[0], wanted[1], dt)
        wanted[2] = min(max(wanted[2], -v.descent_rate_mps), v.climb_rate_mps) if self.mode != self.mission_mode \
            else wanted[2]
        new = list(self.velocity)
        dz = v.vertical_accel_mps2 * dt
        new[2] += min(max(wanted[2] - new[2], -dz), dz)
        new[0], new[1] = self._horizontal(new[0], new[1], wanted[0], wanted[1], dt)
        for i in range(3):
            self.offset[i] += (0.5 * (self.velocity[i] + new[i]) - path[i]) * dt
        self.velocity = new
        de, dn, du = self.offset
        if self.mode == self.command_mode:
            self.min_guided_alt_msl_m = min(self.min_guided_alt_msl_m, mission.alt_msl_m + du)
        lat = mission.lat_deg + math.degrees(dn / MEAN_EARTH_RADIUS_M)
        lon = mission.lon_deg + math.degrees(de / (MEAN_EARTH_RADIUS_M * math.cos(math.radians(mission.lat_deg))))
        return replace(mission, lat_deg=lat, lon_deg=lon, alt_msl_m=mission.alt_msl_m + du, vel_east_mps=new[0],
                       vel_north_mps=new[1], vel_up_mps=new[2])

    def _turn_limited(self, east: float, north: float, dt: float) -> tuple[float, float]:
        """The wanted horizontal velocity, its track at most turn_rate_deg_s * dt from the present one (both
        moving: from or to a hover there is no track to turn)."""
        e0, n0 = self.velocity[0], self.velocity[1]
        speed, wanted_speed = math.hypot(e0, n0), math.hypot(east, north)
        if speed < TURN_MIN_SPEED_MPS or wanted_speed < TURN_MIN_SPEED_MPS:
            return east, north
        d = math.atan2(e0 * north - n0 * east, e0 * east + n0 * north)  # the turn, left (counter-clockwise) positive
        limit = math.radians(self.vehicle.turn_rate_deg_s) * dt
        if abs(d) <= limit:
            return east, north
        a = math.atan2(n0, e0) + math.copysign(limit, d)
        return wanted_speed * math.cos(a), wanted_speed * math.sin(a)

    def _horizontal(self, east: float, north: float, want_east: float, want_north: float, dt: float):
        """The horizontal velocity after dt toward the wanted one, within the profile's acceleration."""
        de, dn = want_east - east, want_north - north
        norm = math.hypot(de, dn)
        step = self.vehicle.horizontal_accel_mps2 * dt
        if norm > step:
            de, dn = de * step / norm, dn * step / norm
        return east + de, north + dn

    def _wanted(self, path, t: float) -> list[float]:
        v = self.vehicle
        if self.mode == self.mission_mode:  # the mission, re-joined where it is now
            up = -RECOVERY_GAIN_PER_S * self.offset[2]
            east, north = path[0] - RECOVERY_GAIN_PER_S * self.offset[0], path[1] - RECOVERY_GAIN_PER_S * self.offset[1]
            # no faster than the vehicle flies (WPNAV_SPEED), or than the path itself where that is faster
            cap = max(v.max_ground_speed_mps, math.hypot(path[0], path[1]))
            speed = math.hypot(east, north)
            if speed > cap:
                east, north = east * cap / speed, north * cap / speed
            return [east, north, path[2] + min(max(up, -v.descent_rate_mps), v.climb_rate_mps)]
        if self.px4 and self.mode == px4.OFFBOARD and (self.setpoint is None or
                                                      t - self.setpoint[3] > px4.OFFBOARD_LOSS_S):
            self.counters["sim.offboard_lost"] += 1  # COM_OF_LOSS_T: the offboard-loss failsafe, Hold (ours)
            self.set_mode(px4.HOLD, t)
        if self.mode == self.command_mode and self.setpoint is not None and \
                t - self.setpoint[3] <= ardupilot.GUIDED_TIMEOUT_S:
            return list(self.setpoint[:3])
        if self.mode == ardupilot.GUIDED and not self.px4 and self.setpoint is not None:
            self.counters["sim.guided_timeout"] += 1
            self.setpoint = None
        return [0.0, 0.0, 0.0]  # stop: GUIDED without a (fresh) setpoint, LOITER, BRAKE, ...


def _simplified(xy: list[tuple[float, float]], tolerance_m: float) -> list[int]:
    """The indices Douglas-Peucker keeps of the polyline xy (every dropped point within tolerance_m of the kept
    polyline; the first and last always kept)."""
    keep = {0, len(xy) - 1}
    stack = [(0, len(xy) - 1)]
    while stack:
        i, j = stack.pop()
        (x0, y0), (x1, y1) = xy[i], xy[j]
        dx, dy = x1 - x0, y1 - y0
        norm2 = dx * dx + dy * dy
        worst, k = 0.0, None
        for m in range(i + 1, j):
            x, y = xy[m]
            u = min(max(((x - x0) * dx + (y - y0) * dy) / norm2, 0.0), 1.0) if norm2 > 0 else 0.0
            d = math.hypot(x - x0 - u * dx, y - y0 - u * dy)  # to the segment, not its line (out-and-back paths)
            if d > worst:
                worst, k = d, m
        if k is not None and worst > tolerance_m:
            keep.add(k)
            stack += [(i, k), (k, j)]
    return sorted(keep)
