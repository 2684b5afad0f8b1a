"""What an autopilot's MAVLink contract gives the guidance stage (ardupilot.py ARDUCOPTER, px4.py PX4): the mode
we fly in and how to ask for a mode, the velocity setpoint and how often it must come (or, for ArduPlane, its GUIDED
commands), the modes we may take the vehicle from. The stage picks one by the autopilot's HEARTBEAT (`autopilot` field)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable


@dataclass(frozen=True)
class Contract:
    name: str
    command_mode: int  # the custom mode we command in (ArduCopter GUIDED, PX4 OFFBOARD)
    return_mode: int  # the mode given back when the one before is unknown (the mission)
    takeover_modes: tuple[int, ...]  # modes we may take the vehicle from (others belong to a pilot or a failsafe)
    # the setpoint stream: at most this period whatever guidance.setpoint_period_s says (None: no limit of its
    # own), and streamed this long before the mode change (PX4 enters OFFBOARD only on a stream it has seen)
    max_setpoint_period_s: float | None
    prestream_s: float
    mode_name: Callable[[int | None], str]
    set_mode: Callable  # (custom_mode, target_system, target_component, confirmation=0) -> COMMAND_LONG
    velocity_setpoint: Callable  # (north, east, up m/s, target_system, target_component, time_boot_ms) -> message
    is_velocity_setpoint: Callable  # (message) -> bool: a setpoint this autopilot flies as a velocity
    # an autopilot that flies no velocity setpoint (ArduPlane): the class of its acknowledged GUIDED commands,
    # (guidance config, system, component) -> arduplane.py PlaneCommands, used instead of the setpoint stream
    guided_commands: Callable | None = None

