"""PX4's side of the MAVLink contract (multicopter OFFBOARD), for the guidance stage (contract.py).

Sources (PX4 v1.13-v1.16 documentation and source; docs/integration.md, "Closing the loop: PX4 OFFBOARD"):
- custom_mode: src/modules/commander/px4_custom_mode.h, main mode in bits 16-23 and sub mode in bits 24-31
  (main: MANUAL 1, ALTCTL 2, POSCTL 3, AUTO 4, ACRO 5, OFFBOARD 6, STABILIZED 7; AUTO sub: READY 1, TAKEOFF 2,
  LOITER 3 (Hold), MISSION 4, RTL 5, LAND 6); MAV_CMD_DO_SET_MODE param1 MAV_MODE_FLAG_CUSTOM_MODE_ENABLED,
  param2 the main mode, param3 the sub mode;
- OFFBOARD ("Offboard Mode", docs.px4.io/main/en/flight_modes/offboard.html): the setpoint stream must be running
  (> 2 Hz) before the mode is engaged, "PX4 enables offboard control only after receiving the signal for more
  than a second", and the vehicle leaves OFFBOARD (COM_OBL_RC_ACT, Hold by default) when none came for
  COM_OF_LOSS_T (1 s); multicopter velocity setpoints: SET_POSITION_TARGET_LOCAL_NED, MAV_FRAME_LOCAL_NED, vx vy vz
  only (type mask 3527).
"""

from __future__ import annotations

import avionics.io  # noqa: F401  (MAVLink 2)
from avionics.guidance.ardupilot import DO_SET_MODE
from avionics.io.dialect import daa as mavlink2

MANUAL, ALTCTL, POSCTL, AUTO, ACRO, OFFBOARD_MAIN, STABILIZED = 1, 2, 3, 4, 5, 6, 7
AUTO_SUBS = {1: "READY", 2: "TAKEOFF", 3: "LOITER", 4: "MISSION", 5: "RTL", 6: "LAND"}
MAIN_NAMES = {1: "MANUAL", 2: "ALTCTL", 3: "POSCTL", 4: "AUTO", 5: "ACRO", 6: "OFFBOARD", 7: "STABILIZED"}


def custom_mode(main: int, sub: int = 0) -> int:
    return (main << 16) | (sub << 24)


OFFBOARD = custom_mode(OFFBOARD_MAIN)
MISSION = custom_mode(AUTO, 4)
HOLD = custom_mode(AUTO, 3)
RTL = custom_mode(AUTO, 5)
LAND = custom_mode(AUTO, 6)
OFFBOARD_LOSS_S = 1.0  # COM_OF_LOSS_T default
PRESTREAM_S = 1.2  # > "more than a second" of stream before OFFBOARD is asked for
STREAM_PERIOD_S = 0.2  # 5 Hz, well above the 2 Hz PX4 needs: a lost setpoint never leaves a 0.5 s gap
PX4_MODES = {custom_mode(m) for m in MAIN_NAMES if m != AUTO} | {custom_mode(AUTO, s) for s in AUTO_SUBS}


def split(mode: int) -> tuple[int, int]:
    return (mode >> 16) & 0xFF, (mode >> 24) & 0xFF


def mode_name(mode: int | None) -> str:
    if mode is None:
        return "UNKNOWN"
    main, sub = split(mode)
    name = MAIN_NAMES.get(main, f"MAIN{main}")
    return f"{name}.{AUTO_SUBS.get(sub, f'SUB{sub}')}" if main == AUTO else name


def set_mode(mode: int, target_system: int, target_component: int, confirmation: int = 0):
    main, sub = split(mode)
    return mavlink2.MAVLink_command_long_message(
        target_system, target_component, DO_SET_MODE, min(confirmation, 255),
        float(mavlink2.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED), float(main), float(sub), 0.0, 0.0, 0.0, 0.0)


def mode_of(msg) -> int:
    """The custom mode a DO_SET_MODE asks for."""
    return custom_mode(int(msg.param2), int(msg.param3))


def velocity_setpoint(north_mps: float, east_mps: float, up_mps: float, target_system: int, target_component: int,
                      time_boot_ms: int):
    """SET_POSITION_TARGET_LOCAL_NED, velocity only (type mask 3527), MAV_FRAME_LOCAL_NED (down positive)."""
    return mavlink2.MAVLink_set_position_target_local_ned_message(
        time_boot_ms & 0xFFFFFFFF, target_system, target_component, mavlink2.MAV_FRAME_LOCAL_NED, 0b110111000111,
        0.0, 0.0, 0.0, float(north_mps), float(east_mps), float(-up_mps), 0.0, 0.0, 0.0, 0.0, 0.0)


def is_velocity_setpoint(msg) -> bool:
    mask = msg.type_mask
    return msg.get_type() == "SET_POSITION_TARGET_LOCAL_NED" and msg.coordinate_frame == mavlink2.MAV_FRAME_LOCAL_NED \
        and mask & 0b111 == 0b111 and mask & 0b111000000 == 0b111000000 and not mask & 0b111000


def _contract():
    from avionics.guidance.contract import Contract

    # never from OFFBOARD: someone else is flying it (PX4's own DAA module does not act in OFFBOARD either)
    return Contract("PX4", OFFBOARD, MISSION, (MISSION, HOLD), STREAM_PERIOD_S, PRESTREAM_S,
                    mode_name, set_mode, velocity_setpoint, is_velocity_setpoint)


PX4 = _contract()
