"""The simulated ArduPlane of the guidance contract (avionics/guidance/arduplane.py): modes, GUIDED commands, TECS.

It flies the scenario's ownship path as its mission in AUTO (as SimCopter, sitl/avionics_sitl/guided.py, whose
link and flight it shares) and answers as ArduPlane does:
- HEARTBEAT MAV_TYPE_FIXED_WING, MAV_AUTOPILOT_ARDUPILOTMEGA, the mode in custom_mode (ArduPlane/mode.h numbers);
- MAV_CMD_DO_SET_MODE (COMMAND_LONG): an ArduPlane mode number is taken at once and ACCEPTED; any other, or one in
  `refuse`, is DENIED;
- COMMAND_INT MAV_CMD_GUIDED_CHANGE_ALTITUDE / _HEADING / _SPEED (ArduPlane/GCS_Mavlink.cpp
  handle_command_int_guided_slew_commands): FAILED outside GUIDED; DENIED for an altitude of 0 or -1 m or a frame
  that is not a global one, a heading outside [0, 360) or a heading type other than course, heading or default
  (default cancels the heading), a speed type other than airspeed or an airspeed outside [AIRSPEED_MIN, the
  profile's maximum]; else ACCEPTED and flown until the mode changes (no timeout). `refuse_commands` (command ids)
  stands in for a firmware built without AP_PLANE_OFFBOARD_GUIDED_SLEW_ENABLED: UNSUPPORTED;
- SET_POSITION_TARGET_GLOBAL_INT in GUIDED: its altitude only, when not ignored by the mask; a velocity-only one
  changes nothing (counted sim.setpoint_ignored), as ArduPlane's handler ignores the velocity; outside GUIDED
  ignored (counted);
- GUIDED (and LOITER, RTL, every other mode but AUTO): entered, it loiters clockwise around the point where it
  entered at WP_LOITER_RAD (60 m) and holds the altitude it had, unless a heading command holds a course; an
  altitude command is flown at its rate, within the profile's climb and sink rates (TECS_CLMB_MAX, TECS_SINK_MAX),
  coming off the rate over TECS_TIME_CONST near the target; it never stops (a plane keeps flying): the speed
  changes within the profile's horizontal acceleration and the course within its turn rate.
A pilot's mode change is `set_mode(mode, now)`.
"""

from __future__ import annotations

import math
from collections import Counter

import avionics.io  # noqa: F401
from avionics.guidance import arduplane, ardupilot
from avionics.io.dialect import daa as mavlink2
from avionics.base.geodesy import flat_offset_m
from avionics_sitl.guided import SimCopter

LOITER_RADIUS_M = 60.0  # WP_LOITER_RAD default (ArduPlane/Parameters.cpp)
TECS_TIME_CONST_S = 5.0  # TECS_TIME_CONST default (libraries/AP_TECS/AP_TECS.cpp): the height loop's time constant
AIRSPEED_MIN_MPS = 9.0  # AIRSPEED_MIN default (ArduPlane/Parameters.cpp)
GLOBAL_FRAMES = {mavlink2.MAV_FRAME_GLOBAL, mavlink2.MAV_FRAME_GLOBAL_RELATIVE_ALT, mavlink2.MAV_FRAME_GLOBAL_INT,
                 mavlink2.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, mavlink2.MAV_FRAME_GLOBAL_TERRAIN_ALT,
                 mavlink2.MAV_FRAME_GLOBAL_TERRAIN_ALT_INT}
ABOVE_HOME_FRAMES = {mavlink2.MAV_FRAME_GLOBAL_RELATIVE_ALT, mavlink2.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT}
Z_IGNORE = 0b100  # POSITION_TARGET_TYPEMASK_Z_IGNORE


class SimPlane(SimCopter):
    MAV_TYPE = mavlink2.MAV_TYPE_FIXED_WING  # the stage picks ArduPlane's contract from it

    def __init__(self, vehicle, system_id: int = 1, component_id: int = 1, refuse: frozenset = frozenset(),
                 counters: Counter | None = None, position_lost_s: float | None = None, home_alt_msl_m: float = 0.0,
                 refuse_commands: frozenset = frozenset()):
        """home_alt_msl_m: where relative altitudes count from (the scenario's ground, as GLOBAL_POSITION_INT's
        relative_alt). The other arguments as SimCopter's."""
        super().__init__(vehicle, system_id, component_id, refuse, counters, position_lost_s)
        self.mission_mode, self.command_mode = arduplane.AUTO, arduplane.GUIDED
        self.mode = arduplane.AUTO
        self.modes = [(0.0, arduplane.AUTO)]
        self.home_alt_msl_m = home_alt_msl_m
        self.refuse_commands = frozenset(refuse_commands)
        self.here: tuple[float, float, float] | None = None  # east, north (m from the first mission point), alt MSL
        self._origin: tuple[float, float] | None = None  # lat, lon of the first mission point
        self.loiter_centre: tuple[float, float] | None = None  # east, north: where the mode was entered
        self.course_deg: float | None = None  # a heading command's course over ground
        self.alt_target: tuple[float, float] | None = None  # (alt MSL, rate m/s) held or commanded
        self.airspeed_mps: float | None = None  # a speed command's (no wind: the ground speed)

    # -- the link ----------------------------------------------------------------------------------------------
    def receive(self, msg, now_s: float) -> list:
        kind = msg.get_type()
        if kind == "COMMAND_LONG" and self._for_us(msg):
            if msg.command != ardupilot.DO_SET_MODE:
                return [self._ack(msg, mavlink2.MAV_RESULT_UNSUPPORTED)]
            mode = int(msg.param2) if msg.param2 == int(msg.param2) else -1
            if mode not in arduplane.PLANE_MODES or mode in self.refuse:
                self.counters["sim.mode_denied"] += 1
                return [self._ack(msg, mavlink2.MAV_RESULT_DENIED)]
            self.set_mode(mode, now_s)
            return [self._ack(msg, mavlink2.MAV_RESULT_ACCEPTED)]
        if kind == "COMMAND_INT" and self._for_us(msg):
            result = self._guided_command(msg)
            self.counters[f"sim.command_int.{result}"] += 1
            return [self._ack(msg, result)]
        if kind == "SET_POSITION_TARGET_GLOBAL_INT" and self._for_us(msg):
            if self.mode != arduplane.GUIDED or msg.type_mask & Z_IGNORE or \
                    msg.coordinate_frame not in GLOBAL_FRAMES:
                self.counters["sim.setpoint_ignored"] += 1
            else:
                self.alt_target = (self._alt_msl(msg.coordinate_frame, msg.alt), math.inf)
                self.counters["sim.setpoint_altitude"] += 1
        elif kind == "SET_POSITION_TARGET_LOCAL_NED" and self._for_us(msg):
            self.counters["sim.setpoint_ignored"] += 1  # only MAV_FRAME_LOCAL_OFFSET_NED's z in GUIDED: not modelled
        return []

    def _alt_msl(self, frame: int, z: float) -> float:
        return z + self.home_alt_msl_m if frame in ABOVE_HOME_FRAMES else z  # terrain: flat ground at home

    def _guided_command(self, msg) -> int:
        if msg.command not in (arduplane.CHANGE_ALTITUDE, arduplane.CHANGE_HEADING, arduplane.CHANGE_SPEED) or \
                msg.command in self.refuse_commands:
            return mavlink2.MAV_RESULT_UNSUPPORTED
        if self.mode != arduplane.GUIDED:
            return mavlink2.MAV_RESULT_FAILED
        if msg.command == arduplane.CHANGE_ALTITUDE:
            if msg.z in (0.0, -1.0) or msg.frame not in GLOBAL_FRAMES:
                return mavlink2.MAV_RESULT_DENIED
            self.alt_target = (self._alt_msl(msg.frame, msg.z), abs(msg.param3) if msg.param3 else math.inf)
        elif msg.command == arduplane.CHANGE_HEADING:
            if not 0.0 <= msg.param2 < 360.0 or int(msg.param1) not in (0, 1, 2):
                return mavlink2.MAV_RESULT_DENIED
            self.course_deg = None if int(msg.param1) == mavlink2.HEADING_TYPE_DEFAULT else msg.param2  # no wind
        else:
            if int(msg.param1) != mavlink2.SPEED_TYPE_AIRSPEED or \
                    not AIRSPEED_MIN_MPS <= msg.param2 <= self.vehicle.max_ground_speed_mps:
                return mavlink2.MAV_RESULT_DENIED
            self.airspeed_mps = msg.param2
        return mavlink2.MAV_RESULT_ACCEPTED

    def set_mode(self, mode: int, now_s: float) -> None:
        if mode != self.mode:
            self.modes.append((now_s, mode))
            # every mode but AUTO: loiter where it was entered, at the altitude it had; GUIDED's commands are gone
            self.course_deg, self.airspeed_mps = None, None
            if self.here is not None:
                self.loiter_centre = self.here[:2]
                self.alt_target = (self.here[2], self.vehicle.climb_rate_mps)
        self.mode = mode

    # -- the flight --------------------------------------------------------------------------------------------
    def fly(self, mission):
        if self._origin is None:
            self._origin = (mission.lat_deg, mission.lon_deg)
        state = super().fly(mission)
        lat0, lon0 = self._origin
        north, east = flat_offset_m(lat0, lon0, state.lat_deg, state.lon_deg)
        self.here = (east, north, state.alt_msl_m)
        if self.mode != self.mission_mode and self.loiter_centre is None:
            self.loiter_centre = self.here[:2]
        return state

    def _wanted(self, path, t: float) -> list[float]:
        if self.mode == self.mission_mode or self.here is None:
            return super()._wanted(path, t)
        v, (east, north, up) = self.vehicle, self.velocity
        speed = self.airspeed_mps if self.airspeed_mps is not None else math.hypot(east, north)
        if self.course_deg is not None:
            course = math.radians(self.course_deg)
        else:  # the loiter circle, clockwise: the tangent, pulled onto the radius
            ce, cn = self.loiter_centre
            re, rn = self.here[0] - ce, self.here[1] - cn
            r = math.hypot(re, rn)
            if r < 1.0:
                course = math.atan2(east, north)
            else:
                tangent = math.atan2(rn, -re)  # clockwise: the velocity (rn, -re) east, north
                course = tangent + math.atan(2.0 * (r - LOITER_RADIUS_M) / LOITER_RADIUS_M)  # the centre is right
        rate = 0.0
        if self.alt_target is not None:
            target, max_rate = self.alt_target
            rate = (target - self.here[2]) / TECS_TIME_CONST_S
            rate = min(max(rate, -min(max_rate, v.descent_rate_mps)), min(max_rate, v.climb_rate_mps))
        return [speed * math.sin(course), speed * math.cos(course), rate]

    def _horizontal(self, east: float, north: float, want_east: float, want_north: float, dt: float):
        """A plane's: the speed within the horizontal acceleration, the course within the turn rate."""
        speed, want = math.hypot(east, north), math.hypot(want_east, want_north)
        step = self.vehicle.horizontal_accel_mps2 * dt
        speed += min(max(want - speed, -step), step)
        course, want_course = math.atan2(east, north), math.atan2(want_east, want_north)
        turn = (want_course - course + math.pi) % (2 * math.pi) - math.pi
        limit = math.radians(self.vehicle.turn_rate_deg_s) * dt
        course += min(max(turn, -limit), limit)
        return speed * math.sin(course), speed * math.cos(course)


FIRMWARES = ("ardupilot", "px4", "arduplane")  # ArduCopter, PX4 multicopter, ArduPlane


def default_firmware(vehicle_name: str) -> str:
    """The simulated autopilot a vehicle profile flies by default: ArduPlane for the fixed-wing, else ArduCopter."""
    return "arduplane" if vehicle_name == "fixed-wing" else "ardupilot"


def simulated_autopilot(vehicle, firmware: str | None = None, home_alt_msl_m: float = 0.0, **options):
    """The simulated autopilot of the closed loop through the guidance: SimPlane for "arduplane", SimCopter for
    "ardupilot" and "px4" (None: the vehicle profile's default). options: SimCopter's (system_id, counters, ...)."""
    firmware = firmware or default_firmware(vehicle.name)
    if firmware not in FIRMWARES:
        raise ValueError(f"autopilot {firmware!r}: one of {', '.join(FIRMWARES)}")
    if firmware == "arduplane":
        return SimPlane(vehicle, home_alt_msl_m=home_alt_msl_m, **options)
    return SimCopter(vehicle, firmware=firmware, **options)


def mode_name(mode: int, firmware: str) -> str:
    from avionics.guidance import px4

    return (px4 if firmware == "px4" else arduplane if firmware == "arduplane" else ardupilot).mode_name(mode)
