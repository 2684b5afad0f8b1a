"""The guidance stage: from the step's RAs to what the autopilot is told, one state machine per vehicle.

States (GuidanceDecision.state):
- idle: nothing commanded (no RA, a preventive RA the mission already complies with, or an interlock: the
  decision's reason says which);
- advising (guidance.mode = "advise"): the manoeuvre is decided and published, nothing is sent;
- commanding: GUIDED (PX4: OFFBOARD) asked for (DO_SET_MODE, retried until COMMAND_ACK and HEARTBEAT confirm
  it) and the RA's vertical rate sent as a velocity setpoint with the horizontal velocity of the RA's start, every
  setpoint_period_s (PX4: 0.2 s, from before the mode change) and at each change;
- holding: the RAs ended (clear of conflict): level flight at that horizontal velocity for quiet_time_s;
- returning: the mode the vehicle was in before is asked for again (ArduCopter AUTO resumes the mission's current
  item), until HEARTBEAT shows it: then idle;
- overridden: the mode changed under us while we commanded (a pilot or a failsafe): nothing is sent until the
  conflict ends and a new one begins;
- failed: a mode change refused (COMMAND_ACK not accepted) or never confirmed after the retries: nothing is sent
  until the conflict ends; STATUSTEXT "DAA GUIDANCE FAILED ...".

Interlocks (never a command): DAA unavailable (no or stale ownship, a failed stage, a spoof suspected: daa.py),
the link not authenticated while guidance.require_signing, an RA only against intruders whose ADS-B integrity is
degraded (tracking/integrity.py), no HEARTBEAT from the autopilot yet, and a vehicle in a mode other than AUTO,
GUIDED or LOITER for ArduCopter, AUTO.MISSION or AUTO.LOITER for PX4 (RTL, LAND and the manual modes belong to a
failsafe or a pilot; PX4 OFFBOARD to someone else's offboard control). An interlock that arises while commanding
gives the vehicle back at once (returning).

The autopilot's contract (contract.py) is ArduCopter's (GUIDED, ardupilot.py) or, when its HEARTBEAT says
MAV_AUTOPILOT_PX4, PX4's (OFFBOARD after a setpoint stream of more than a second, px4.py), or, when it says
MAV_AUTOPILOT_ARDUPILOTMEGA and MAV_TYPE_FIXED_WING, ArduPlane's (GUIDED, flown by acknowledged GUIDED_CHANGE_HEADING
and GUIDED_CHANGE_ALTITUDE commands instead of a setpoint stream, arduplane.py; a refused or unanswered one is a
failure that also asks for the mode the plane was in, so it does not stay circling in GUIDED)."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Iterable, Mapping

from avionics.core.types import Advisory, AdvisoryLevel, AutopilotHeartbeat, CommandAck
from avionics.guidance import ardupilot
from avionics.guidance.ardupilot import ARDUCOPTER
from avionics.guidance.arduplane import ARDUPLANE
from avionics.guidance.px4 import PX4
from avionics.guidance.params import GuidanceConfig
from avionics.guidance.vertical import vertical_manoeuvre

STATES = ("idle", "advising", "commanding", "holding", "returning", "overridden", "failed")
MAV_AUTOPILOT_PX4 = 12  # HEARTBEAT autopilot (common.xml MAV_AUTOPILOT)
SETPOINT_CHANGE_MPS = 0.1  # a target that moved this much is sent at once, not at the next period
MAV_TYPE_FIXED_WING = 1  # HEARTBEAT type (common.xml MAV_TYPE) ArduPlane sends for a plane (not a QuadPlane)


def contract_for(heartbeat):
    """The contract (contract.py) of the autopilot whose HEARTBEAT this is: PX4's for MAV_AUTOPILOT_PX4, ArduPlane's
    for an ArduPilot MAV_TYPE_FIXED_WING, else ArduCopter's."""
    if heartbeat.autopilot == MAV_AUTOPILOT_PX4:
        return PX4
    return ARDUPLANE if heartbeat.mav_type == MAV_TYPE_FIXED_WING else ARDUCOPTER


@dataclass(frozen=True, slots=True)
class GuidanceDecision:
    """What the guidance decided at a step (DaaResult.guidance): published on zenoh (`guidance`), in the CSV and,
    at each change of state, as a STATUSTEXT."""

    time_s: float
    state: str  # one of STATES
    manoeuvre: str  # none | climb | descend | level | return
    target_vertical_rate_mps: float | None  # the commanded (or advised) vertical rate, up positive
    reason: str  # why: ra, preventive, composite, floor, ceiling, clear_of_conflict, mission_resumed, an interlock
    autopilot_mode: str  # the mode the autopilot's HEARTBEAT says (ArduCopter's names), UNKNOWN before one
    since_s: float  # when this state began

    def text(self) -> str:
        """The STATUSTEXT of a change: "DAA GUIDANCE COMMANDING CLIMB +2.5 M/S ra"."""
        words = ["DAA GUIDANCE", self.state.upper()]
        if self.state in ("commanding", "holding", "advising"):
            words.append(self.manoeuvre.upper())
            if self.target_vertical_rate_mps is not None and self.manoeuvre != "level":
                words.append(f"{self.target_vertical_rate_mps:+.1f} M/S")
        words.append(self.reason)
        return " ".join(words)[:50]  # STATUSTEXT's text

    def as_dict(self) -> dict:
        return {"time_s": self.time_s, "state": self.state, "manoeuvre": self.manoeuvre,
                "target_vertical_rate_mps": self.target_vertical_rate_mps, "reason": self.reason,
                "autopilot_mode": self.autopilot_mode, "since_s": self.since_s}


@dataclass(frozen=True, slots=True)
class GuidanceOutput:
    decision: GuidanceDecision
    changed: bool  # the state changed at this step: announce it
    commands: tuple  # MAVLink messages for the autopilot (ardupilot.py, px4.py), in order


@dataclass(frozen=True, slots=True)
class Ownship:
    """What the guidance needs of ownship: its velocity (north, east, up) and height above home."""

    north_mps: float
    east_mps: float
    up_mps: float
    height_above_home_m: float | None


@dataclass(frozen=True, slots=True)
class VerticalLimits:
    """The rates and acceleration a manoeuvre is flown within: the RA response model in force, i.e. the vehicle
    profile's when vehicle.profile is set (advisory/vehicle.py), so the guidance asks for what the logic assumed."""

    climb_rate_mps: float
    descent_rate_mps: float
    vertical_accel_mps2: float

    @classmethod
    def of(cls, response) -> "VerticalLimits":
        """From an advisory/tables.py ResponseModel."""
        descent = response.descent_rate_mps if response.descent_rate_mps is not None else response.rate_mps
        return cls(response.rate_mps, descent, response.accel_mps2)


class _ModeRequest:
    """A DO_SET_MODE in flight: resent every ack_timeout_s until HEARTBEAT shows the mode, at most retries times."""

    def __init__(self, mode: int, now_s: float):
        self.mode, self.sent_s, self.attempts, self.acked = mode, now_s, 1, False


class GuidanceStage:
    """update(now, ...) -> GuidanceOutput. vehicle: VerticalLimits (or a VehicleProfile: the same names)."""

    def __init__(self, config: GuidanceConfig, vehicle, system: int, component: int = 1):
        self.config, self.vehicle = config, vehicle
        self.execute = config.mode == "execute"
        self.system, self.component = system, component  # the autopilot's ids (component from its HEARTBEAT)
        self.state, self.since_s, self.reason = "idle", 0.0, "no_conflict"
        self.manoeuvre, self.target = "none", None
        self.mode: int | None = None  # the autopilot's custom mode, from its last HEARTBEAT
        self.prior_mode: int | None = None  # the mode we took the vehicle from
        self.request: _ModeRequest | None = None
        self.guided_confirmed = False  # HEARTBEAT showed GUIDED since we asked for it
        self.horizontal = (0.0, 0.0)  # north, east m/s kept while commanding
        self.last_setpoint: tuple[float, float] | None = None  # (time, vertical rate) sent last
        self.clear_s: float | None = None  # when the RAs ended (holding)
        self.conflict = False  # an RA was active at the last step
        self.contract = ARDUCOPTER  # PX4 once a HEARTBEAT says MAV_AUTOPILOT_PX4 (contract.py)
        self.prestream_until: float | None = None  # PX4: OFFBOARD is asked for once the stream has run until then
        self.plane = None  # ArduPlane: its GUIDED commands in flight (arduplane.py PlaneCommands)
        self.own: Ownship | None = None  # ownship at this step (ArduPlane's commands need its course and height)

    # -- the step ----------------------------------------------------------------------------------------------
    def update(self, now_s: float, active: Mapping, unavailable_reason: str | None, own: Ownship | None,
               autopilot_inputs: Iterable = (), spoofed: frozenset = frozenset(),
               link_authenticated: bool = False) -> GuidanceOutput:
        before = self.state
        commands: list = []
        self.own = own
        for item in autopilot_inputs:
            self._absorb(item, now_s)
        c = self.contract
        ras = [a for a in active.values() if a.level is AdvisoryLevel.RA]
        usable = [a for a in ras if a.integrity == "ok" and a.intruder not in spoofed]
        self.conflict = bool(ras)
        interlock = self._interlock(unavailable_reason, own, ras, usable, link_authenticated)

        if self.state in ("overridden", "failed") and not ras:  # the conflict is over: the next one is commanded
            self._enter("idle", now_s, "no_conflict")
        if self.state in ("commanding", "holding"):
            if self.guided_confirmed and self.mode is not None and self.mode != c.command_mode:
                self._enter("overridden", now_s, f"mode {c.mode_name(self.mode)} not ours")
                self.request = None
            elif interlock is not None:
                self._return(now_s, interlock, commands)
        if self.state == "returning" and self.request is None and self.mode == self.prior_mode:
            self._enter("idle", now_s, "mission_resumed")
        if self.state == "returning" and self.mode not in (c.command_mode, self.prior_mode, None) \
                and self.request is not None and self.request.acked:
            self._enter("overridden", now_s, f"mode {c.mode_name(self.mode)} not ours")
            self.request = None

        manoeuvre = None
        if usable and interlock is None and self.state not in ("overridden", "failed"):
            manoeuvre = vertical_manoeuvre(
                usable, own.up_mps, own.height_above_home_m, self.vehicle.climb_rate_mps,
                self.vehicle.descent_rate_mps, self.vehicle.vertical_accel_mps2, self.config.floor_m,
                self.config.ceiling_m)
        if manoeuvre is not None and not (manoeuvre.complies and self.state in ("idle", "advising")):
            self.manoeuvre, self.target = manoeuvre.name, manoeuvre.target_mps
            if not self.execute:
                self._enter("advising", now_s, manoeuvre.reason)
            elif self.state in ("idle", "returning"):
                self._take(now_s, own, manoeuvre.reason, commands)
            else:
                if self.state == "holding":
                    self._enter("commanding", now_s, manoeuvre.reason)
                self.reason = manoeuvre.reason
        elif self.state in ("idle", "advising"):
            self.manoeuvre, self.target = "none", None
            why = manoeuvre.reason + "_complies" if manoeuvre is not None else interlock if ras else "no_conflict"
            if self.state == "advising":
                self._enter("idle", now_s, why)
            elif self.since_s != now_s or self.reason == "no_conflict":  # keep the reason idle was entered with
                self.reason = why
        elif self.state == "commanding" and interlock is None:  # the RAs ended: clear of conflict
            self._enter("holding", now_s, "clear_of_conflict")
            self.manoeuvre, self.target, self.clear_s = "level", 0.0, now_s
        if self.state == "holding" and interlock is None and now_s - self.clear_s >= self.config.quiet_time_s:
            self._return(now_s, "quiet_time_over", commands)

        if self.execute:
            if self.state in ("commanding", "holding"):
                self._setpoint(now_s, commands)  # a PX4 stream before its mode change
            if self.prestream_until is not None and now_s >= self.prestream_until:
                self.prestream_until = None
                if self.state in ("commanding", "holding") and self.mode != c.command_mode:
                    self._request(c.command_mode, now_s, commands)
            self._handshake(now_s, commands)
        decision = GuidanceDecision(now_s, self.state, self.manoeuvre if self.state != "idle" else "none",
                                    self.target if self.state in ("commanding", "holding", "advising") else None,
                                    self.reason, c.mode_name(self.mode), self.since_s)
        return GuidanceOutput(decision, self.state != before, tuple(commands))

    # -- the parts ---------------------------------------------------------------------------------------------
    def _absorb(self, item, now_s: float) -> None:
        if isinstance(item, AutopilotHeartbeat):
            if self.state == "idle":  # never in the middle of a manoeuvre
                self.contract = contract_for(item)
            self.mode, self.component = item.custom_mode, item.component
            if self.request is not None and item.custom_mode == self.request.mode:
                if self.request.mode == self.contract.command_mode:
                    self.guided_confirmed = True
                self.request = None  # confirmed by the mode in force (an ACK lost on the way changes nothing)
        elif isinstance(item, CommandAck) and item.command == ardupilot.DO_SET_MODE and self.request is not None:
            if item.result == ardupilot.ACCEPTED:
                self.request.acked = True
            elif item.result != ardupilot.IN_PROGRESS:
                wanted = self.contract.mode_name(self.request.mode)
                self.request = None
                self._enter("failed", now_s, f"{wanted} refused: result {item.result}")
        elif isinstance(item, CommandAck) and self.plane is not None and self.state in ("commanding", "holding"):
            self.plane.acknowledge(item.command, item.result)  # a refusal is the failure _handshake reports

    def _interlock(self, unavailable_reason, own, ras, usable, link_authenticated) -> str | None:
        if unavailable_reason is not None or own is None:
            return f"daa_unavailable {unavailable_reason or 'no_ownship'}"
        if not self.execute:
            return None
        if self.config.require_signing and not link_authenticated:
            return "link_not_authenticated"
        if ras and not usable:
            return "integrity_degraded"
        if self.mode is None:
            return "no_autopilot_heartbeat"
        c = self.contract
        ours = self.state == "returning" and self.mode in (c.command_mode, self.prior_mode)  # still ours
        if self.state in ("idle", "returning") and self.mode not in c.takeover_modes and not ours:
            return f"mode {c.mode_name(self.mode)} not ours to take"
        return None

    def _enter(self, state: str, now_s: float, reason: str) -> None:
        if state != self.state:
            self.since_s = now_s
        self.state, self.reason = state, reason

    def _take(self, now_s: float, own: Ownship, reason: str, commands: list) -> None:
        """Start commanding: GUIDED asked for (unless the vehicle is in it by our doing), the horizontal kept."""
        if self.state == "idle":
            c = self.contract
            self.prior_mode = self.mode if self.mode != c.command_mode else c.return_mode
            self.horizontal = (own.north_mps, own.east_mps)
            self.guided_confirmed = self.mode == c.command_mode
            if c.guided_commands is not None:
                self.plane = c.guided_commands(self.config, self.system, self.component)
        if self.plane is not None:
            self.plane.start()
        self.last_setpoint = None
        self._enter("commanding", now_s, reason)
        if self.mode != self.contract.command_mode:
            self.guided_confirmed = False
            if self.contract.prestream_s > 0:  # the stream first, the mode change once it has run long enough
                self.prestream_until = now_s + self.contract.prestream_s
            else:
                self._request(self.contract.command_mode, now_s, commands)

    def _return(self, now_s: float, reason: str, commands: list) -> None:
        self.manoeuvre, self.target = "return", None
        self._enter("returning", now_s, reason)
        self.prestream_until = None
        self._request(self.prior_mode if self.prior_mode is not None else self.contract.return_mode, now_s, commands)

    def _request(self, mode: int, now_s: float, commands: list) -> None:
        self.request = _ModeRequest(mode, now_s)
        commands.append(self.contract.set_mode(mode, self.system, self.component))

    def _handshake(self, now_s: float, commands: list) -> None:
        if self.plane is not None and self.state in ("commanding", "holding"):
            again, failure = self.plane.resend(now_s)
            commands.extend(again)
            if failure is not None:
                self._plane_failed(now_s, failure, commands)
        request = self.request
        if request is None or now_s - request.sent_s < self.config.ack_timeout_s:
            return
        if request.attempts > self.config.retries:
            self.request = None
            self._enter("failed", now_s, f"{self.contract.mode_name(request.mode)} unconfirmed x{request.attempts}")
            return
        commands.append(self.contract.set_mode(request.mode, self.system, self.component,
                                               confirmation=request.attempts))
        request.attempts += 1
        request.sent_s = now_s

    def _setpoint(self, now_s: float, commands: list) -> None:
        """The velocity setpoint, once GUIDED is accepted (ArduCopter ignores setpoints in other modes), or from
        the start for PX4 (OFFBOARD needs the stream before it is engaged)."""
        if not (self.guided_confirmed or (self.request is not None and self.request.acked)
                or self.contract.prestream_s > 0):
            return
        if self.plane is not None:  # ArduPlane: GUIDED commands, not a velocity stream (arduplane.py)
            own = self.own
            commands.extend(self.plane.step(now_s, self.target, own.north_mps, own.east_mps, own.height_above_home_m,
                                            self.vehicle.climb_rate_mps, SETPOINT_CHANGE_MPS))
            return
        period = min(self.config.setpoint_period_s, self.contract.max_setpoint_period_s or math.inf)
        last = self.last_setpoint
        if last is not None and now_s - last[0] < period - 1e-9 and \
                abs(last[1] - self.target) < SETPOINT_CHANGE_MPS:
            return
        self.last_setpoint = (now_s, self.target)
        north, east = self.horizontal
        commands.append(self.contract.velocity_setpoint(north, east, self.target, self.system, self.component,
                                                        int(now_s * 1000)))

    def _plane_failed(self, now_s: float, failure: str, commands: list) -> None:
        """An ArduPlane GUIDED command refused or never acknowledged: failed, and the mode it was in asked for
        again (a plane left in GUIDED circles around where it entered it)."""
        self._enter("failed", now_s, failure)
        self._request(self.prior_mode if self.prior_mode is not None else self.contract.return_mode, now_s, commands)

    @property
    def failed(self) -> bool:
        return self.state == "failed"
