"""ArduPlane's side of the MAVLink contract (fixed-wing GUIDED), for the guidance stage (contract.py, stage.py).

A plane cannot hover nor fly a velocity setpoint: ArduPlane GUIDED loiters around a target point (entering GUIDED
sets it to where the plane is, ArduPlane/mode_guided.cpp ModeGuided::_enter), and of SET_POSITION_TARGET_GLOBAL_INT
it uses the altitude only (GCS_Mavlink.cpp handle_set_position_target_global_int; the velocity is ignored). The
RA's vertical manoeuvre is therefore flown as two GUIDED commands, each answered by COMMAND_ACK:
- MAV_CMD_GUIDED_CHANGE_HEADING (43002) in COMMAND_INT, param1 HEADING_TYPE_COURSE_OVER_GROUND (0), param2 the
  course at the manoeuvre's start in [0, 360), param3 the lateral acceleration limit: the plane keeps its course
  instead of turning onto the loiter circle around the point where it entered GUIDED;
- MAV_CMD_GUIDED_CHANGE_ALTITUDE (43001) in COMMAND_INT, frame MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, z the target
  altitude above home in metres, param3 the rate to slew the altitude demand at (m/s, positive; 0 would mean
  "maximum", never sent). The target is the present height plus the RA's rate times ALTITUDE_HORIZON_S, clamped to
  the floor and ceiling, resent every guidance.setpoint_period_s while the rate is not level (so the target stays
  ahead of the plane for as long as the RA lasts); level (holding, a composite RA, the floor) is the present
  height, sent once.
Both are accepted only in GUIDED (MAV_RESULT_FAILED otherwise), an altitude of 0 or -1 is DENIED, a heading outside
[0, 360) is DENIED (GCS_Mavlink.cpp handle_command_int_guided_slew_commands, built when
AP_PLANE_OFFBOARD_GUIDED_SLEW_ENABLED, 1 by default in ArduPlane/config.h). Unlike ArduCopter's setpoints they do
not time out: ArduPlane flies the last one until the mode changes. MAV_CMD_GUIDED_CHANGE_SPEED (43000) is not
sent: the mission's airspeed is kept.

Sources (ArduPilot master): ArduPlane/mode.h `enum Number` (AUTO 10, RTL 11, LOITER 12, GUIDED 15, ...);
ArduPlane/GCS_Mavlink.cpp; ArduPlane/mode_guided.cpp; common.xml MAV_CMD_GUIDED_CHANGE_ALTITUDE/HEADING/SPEED and
HEADING_TYPE. Mode changes are MAV_CMD_DO_SET_MODE as for ArduCopter (GCS_Common.cpp). docs/integration.md,
"Closing the loop: ArduPlane", says what was not verified on real firmware.
"""

from __future__ import annotations

import avionics.io  # noqa: F401  (MAVLink 2)
from avionics.base.units import track_deg
from avionics.guidance.ardupilot import set_mode
from avionics.io.dialect import daa as mavlink2

MANUAL, CIRCLE, STABILIZE, AUTO, RTL, LOITER, TAKEOFF, GUIDED = 0, 1, 2, 10, 11, 12, 13, 15
# Every ArduPlane mode number (ArduPlane/mode.h; Q modes only on QuadPlanes): the simulated autopilot refuses others
PLANE_MODES = {0: "MANUAL", 1: "CIRCLE", 2: "STABILIZE", 3: "TRAINING", 4: "ACRO", 5: "FBWA", 6: "FBWB", 7: "CRUISE",
               8: "AUTOTUNE", 10: "AUTO", 11: "RTL", 12: "LOITER", 13: "TAKEOFF", 14: "AVOID_ADSB", 15: "GUIDED",
               16: "INITIALISING", 17: "QSTABILIZE", 18: "QHOVER", 19: "QLOITER", 20: "QLAND", 21: "QRTL",
               22: "QAUTOTUNE", 23: "QACRO", 24: "THERMAL", 25: "LOITER2QLAND", 26: "AUTOLAND"}
CHANGE_SPEED = mavlink2.MAV_CMD_GUIDED_CHANGE_SPEED  # 43000
CHANGE_ALTITUDE = mavlink2.MAV_CMD_GUIDED_CHANGE_ALTITUDE  # 43001
CHANGE_HEADING = mavlink2.MAV_CMD_GUIDED_CHANGE_HEADING  # 43002
COURSE_OVER_GROUND = mavlink2.HEADING_TYPE_COURSE_OVER_GROUND
ALTITUDE_FRAME = mavlink2.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT  # z above home, as GLOBAL_POSITION_INT relative_alt
# The target altitude leads the plane by the RA's rate times this: twice TECS_TIME_CONST (5 s, AP_TECS.cpp), so
# that between two resends (guidance.setpoint_period_s < 3 s) the height error stays beyond the distance over which
# TECS's height loop comes off the commanded rate (rate x time constant).
ALTITUDE_HORIZON_S = 10.0
# CHANGE_HEADING param3: the lateral acceleration the course is held with. g tan(ROLL_LIMIT_DEG 45): ArduPlane
# turns it into a bank limit atan(accel / g), itself capped by ROLL_LIMIT_DEG (mode_guided.cpp).
HEADING_ACCEL_MPS2 = 9.80665
LEVEL_MPS = 0.05  # as vertical.py's: below this a target rate is level


def mode_name(custom_mode: int | None) -> str:
    if custom_mode is None:
        return "UNKNOWN"
    return PLANE_MODES.get(custom_mode, f"MODE{custom_mode}")


def command_int(command: int, target_system: int, target_component: int, frame: int = 0, param1: float = 0.0,
                param2: float = 0.0, param3: float = 0.0, z: float = 0.0):
    return mavlink2.MAVLink_command_int_message(target_system, target_component, frame, command, 0, 0,
                                                float(param1), float(param2), float(param3), 0.0, 0, 0, float(z))


def change_altitude(height_m: float, rate_mps: float, target_system: int, target_component: int):
    """MAV_CMD_GUIDED_CHANGE_ALTITUDE to height_m above home at rate_mps (> 0); 0 and -1 m (DENIED by ArduPlane as
    "default" and "dangerous" values) are moved by a centimetre."""
    if height_m in (0.0, -1.0):
        height_m += 0.01
    return command_int(CHANGE_ALTITUDE, target_system, target_component, ALTITUDE_FRAME, param3=abs(rate_mps),
                       z=height_m)


def change_heading(course_deg: float, target_system: int, target_component: int):
    """MAV_CMD_GUIDED_CHANGE_HEADING: hold this course over ground."""
    course = course_deg % 360.0
    return command_int(CHANGE_HEADING, target_system, target_component, param1=COURSE_OVER_GROUND,
                       param2=course if course < 360.0 else 0.0, param3=HEADING_ACCEL_MPS2)  # -1e-17 % 360 is 360


def change_speed(airspeed_mps: float, accel_mps2: float, target_system: int, target_component: int):
    """MAV_CMD_GUIDED_CHANGE_SPEED (airspeed): not used by the guidance; for integrators and the simulator's tests."""
    return command_int(CHANGE_SPEED, target_system, target_component, param1=mavlink2.SPEED_TYPE_AIRSPEED,
                       param2=airspeed_mps, param3=accel_mps2)


def altitude_target(height_m: float, up_mps: float, floor_m: float, ceiling_m: float) -> float:
    """Where the manoeuvre's altitude command points: the present height when level, else ALTITUDE_HORIZON_S of
    the rate ahead, never below the floor (unless already lower: then level) nor above the ceiling (0 = none)."""
    if abs(up_mps) <= LEVEL_MPS:
        return height_m
    target = height_m + up_mps * ALTITUDE_HORIZON_S
    if up_mps < 0:
        return max(target, min(floor_m, height_m))
    return min(target, max(ceiling_m, height_m)) if ceiling_m > 0 else target


class _Pending:
    """A GUIDED command in flight: resent every ack_timeout_s until COMMAND_ACK, at most retries times."""

    def __init__(self, message, now_s: float):
        self.message, self.sent_s, self.attempts = message, now_s, 1


class PlaneCommands:
    """The manoeuvre as ArduPlane GUIDED commands (the stage's `_setpoint` for this contract): the course held once
    per manoeuvre, the altitude target at each change of the rate and every period while it climbs or descends;
    each acknowledged, resent when not, and a refusal or silence after the retries is the stage's failure."""

    def __init__(self, config, system: int, component: int):
        self.config, self.system, self.component = config, system, component
        self.course_sent = False
        self.last: tuple[float, float] | None = None  # (time, rate) of the last altitude command
        self.pending: dict[int, _Pending] = {}  # command id -> the one in flight
        self.failure: str | None = None  # a refusal, reported by resend()

    def start(self) -> None:
        """A new manoeuvre (GUIDED asked for): the course is sent again once GUIDED is in force."""
        self.course_sent, self.last, self.pending, self.failure = False, None, {}, None

    def step(self, now_s: float, up_mps: float, north_mps: float, east_mps: float, height_m: float | None,
             climb_rate_mps: float, change_mps: float) -> list:
        """The commands due now (GUIDED accepted): the course first, then the altitude."""
        out = []
        if self.failure is not None:
            return out
        if not self.course_sent:
            self.course_sent = True
            out.append(self._send(change_heading(track_deg(east_mps, north_mps), self.system, self.component),
                                  now_s))
        if height_m is None:
            return out
        last, level = self.last, abs(up_mps) <= LEVEL_MPS
        due = last is None or abs(last[1] - up_mps) >= change_mps or \
            (not level and now_s - last[0] >= self.config.setpoint_period_s - 1e-9)
        if due:
            self.last = (now_s, up_mps)
            target = altitude_target(height_m, up_mps, self.config.floor_m, self.config.ceiling_m)
            # level: any nonzero rate (0 means "at once" to ArduPlane); the profile's climb rate
            out.append(self._send(change_altitude(target, up_mps if not level else climb_rate_mps, self.system,
                                                  self.component), now_s))
        return out

    def _send(self, message, now_s: float):
        self.pending[message.command] = _Pending(message, now_s)
        return message

    def acknowledge(self, command: int, result: int) -> None:
        """A COMMAND_ACK for one of ours: a refusal is kept as the failure ("CHANGE_ALTITUDE refused: result 4")."""
        if command not in self.pending or result == mavlink2.MAV_RESULT_IN_PROGRESS:
            return
        del self.pending[command]
        if result != mavlink2.MAV_RESULT_ACCEPTED and self.failure is None:
            self.failure = f"{_NAMES[command]} refused: result {result}"

    def resend(self, now_s: float) -> tuple[list, str | None]:
        """The commands not acknowledged within ack_timeout_s, again (COMMAND_INT has no confirmation field: the
        same message); the failure: a refusal, or one unanswered after guidance.retries resends."""
        out = []
        if self.failure is not None:
            self.pending.clear()
            return out, self.failure
        for command, pending in list(self.pending.items()):
            if now_s - pending.sent_s < self.config.ack_timeout_s:
                continue
            if pending.attempts > self.config.retries:
                self.pending.clear()
                self.failure = f"{_NAMES[command]} unconfirmed x{pending.attempts}"
                return out, self.failure
            pending.attempts += 1
            pending.sent_s = now_s
            out.append(pending.message)
        return out, None


_NAMES = {CHANGE_ALTITUDE: "CHANGE_ALTITUDE", CHANGE_HEADING: "CHANGE_HEADING", CHANGE_SPEED: "CHANGE_SPEED"}


def is_velocity_setpoint(msg) -> bool:
    """ArduPlane flies no velocity setpoint (only a SET_POSITION_TARGET_GLOBAL_INT's altitude, in GUIDED)."""
    return False


def _no_velocity_setpoint(*args, **kwargs):
    raise TypeError("ArduPlane flies no velocity setpoint: the guidance sends GUIDED commands (PlaneCommands)")


def _contract():
    from avionics.guidance.contract import Contract

    return Contract("ArduPlane", GUIDED, AUTO, (AUTO, GUIDED, LOITER), None, 0.0, mode_name, set_mode,
                    _no_velocity_setpoint, is_velocity_setpoint, guided_commands=PlaneCommands)


ARDUPLANE = _contract()
