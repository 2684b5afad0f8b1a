"""ArduCopter's side of the MAVLink contract, in one place: what we send to it and how its answers read.

Sources (ArduPilot master; docs/integration.md, "Closing the loop: ArduCopter"):
- custom modes: ArduCopter/mode.h `enum class Number` (AUTO 3, GUIDED 4, LOITER 5, RTL 6, LAND 9);
- mode change: MAV_CMD_DO_SET_MODE in COMMAND_LONG, param1 MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, param2 the custom
  mode (GCS_MAVLink/GCS_Common.cpp handle_command_do_set_mode), answered by COMMAND_ACK; the mode in force is
  HEARTBEAT custom_mode;
- velocity setpoint: SET_POSITION_TARGET_GLOBAL_INT with only the velocity used (type mask 0b110111000111 = 3527,
  "Copter Commands in Guided Mode", ardupilot.org/dev/docs/copter-commands-in-guided-mode.html), NED m/s; the
  frame MAV_FRAME_GLOBAL_RELATIVE_ALT_INT; ArduCopter stops the vehicle when no setpoint came for GUID_TIMEOUT
  (3 s; ArduCopter/mode_guided.cpp).
"""

from __future__ import annotations

import avionics.io  # noqa: F401  (MAVLink 2)
from avionics.io.dialect import daa as mavlink2

AUTO, GUIDED, LOITER, RTL, LAND = 3, 4, 5, 6, 9
# Every ArduCopter mode number (ArduCopter/mode.h): the simulated autopilot refuses any other (MAV_RESULT_DENIED)
COPTER_MODES = {0: "STABILIZE", 1: "ACRO", 2: "ALT_HOLD", 3: "AUTO", 4: "GUIDED", 5: "LOITER", 6: "RTL",
                7: "CIRCLE", 9: "LAND", 11: "DRIFT", 13: "SPORT", 14: "FLIP", 15: "AUTOTUNE", 16: "POSHOLD",
                17: "BRAKE", 18: "THROW", 19: "AVOID_ADSB", 20: "GUIDED_NOGPS", 21: "SMART_RTL", 22: "FLOWHOLD",
                23: "FOLLOW", 24: "ZIGZAG", 25: "SYSTEMID", 26: "AUTOROTATE", 27: "AUTO_RTL", 28: "TURTLE"}
GUIDED_TIMEOUT_S = 3.0  # GUID_TIMEOUT default (ArduCopter/Parameters.cpp; GUIDED_POSVEL_TIMEOUT_MS before it)
# SET_POSITION_TARGET type mask: ignore position (1|2|4), acceleration (64|128|256), yaw (1024), yaw rate (2048)
VELOCITY_ONLY = 0b110111000111
ACCEPTED = mavlink2.MAV_RESULT_ACCEPTED
IN_PROGRESS = mavlink2.MAV_RESULT_IN_PROGRESS
DO_SET_MODE = mavlink2.MAV_CMD_DO_SET_MODE


def mode_name(custom_mode: int | None) -> str:
    if custom_mode is None:
        return "UNKNOWN"
    return COPTER_MODES.get(custom_mode, f"MODE{custom_mode}")


def set_mode(custom_mode: int, target_system: int, target_component: int, confirmation: int = 0):
    """COMMAND_LONG MAV_CMD_DO_SET_MODE to an ArduCopter custom mode (confirmation counts the retries)."""
    return mavlink2.MAVLink_command_long_message(
        target_system, target_component, DO_SET_MODE, min(confirmation, 255),
        float(mavlink2.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED), float(custom_mode), 0.0, 0.0, 0.0, 0.0, 0.0)


def velocity_setpoint(north_mps: float, east_mps: float, up_mps: float, target_system: int, target_component: int,
                      time_boot_ms: int):
    """SET_POSITION_TARGET_GLOBAL_INT, velocity only (NED: down positive), MAV_FRAME_GLOBAL_RELATIVE_ALT_INT."""
    return mavlink2.MAVLink_set_position_target_global_int_message(
        time_boot_ms & 0xFFFFFFFF, target_system, target_component, mavlink2.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT,
        VELOCITY_ONLY, 0, 0, 0.0, float(north_mps), float(east_mps), float(-up_mps), 0.0, 0.0, 0.0, 0.0, 0.0)


def is_velocity_setpoint(msg) -> bool:
    """A setpoint ArduCopter flies as a velocity: the velocity used, position and acceleration ignored."""
    mask = msg.type_mask
    return msg.get_type() == "SET_POSITION_TARGET_GLOBAL_INT" and mask & 0b111 == 0b111 and \
        mask & 0b111000000 == 0b111000000 and not mask & 0b111000


def _contract():
    from avionics.guidance.contract import Contract

    return Contract("ArduCopter", GUIDED, AUTO, (AUTO, GUIDED, LOITER), None, 0.0, mode_name, set_mode,
                    velocity_setpoint, is_velocity_setpoint)


ARDUCOPTER = _contract()
