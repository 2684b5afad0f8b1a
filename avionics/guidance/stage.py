"""The guidance stage: from the step's RAs to what the autopilot is told, one state machine per vehicle.

States (GuidanceDecision.state):
- idle: nothing commanded (no RA, a preventive RA the mission already complies with, or an interlock: the
  decision's reason says which);
- advising (guidance.mode = "advise"): the manoeuvre is decided and published, nothing is sent;
- commanding: GUIDED (PX4: OFFBOARD) asked for (DO_SET_MODE, retried until COMMAND_ACK and HEARTBEAT confirm
  it) and the RA's vertical rate sent as a velocity setpoint whose horizontal velocity follows the mission's legs
  (the mission read over MAVLink, mission.py; without one, the horizontal velocity of the RA's start), every
  setpoint_period_s (PX4: 0.2 s, from before the mode change) and at each change; with a DO-365 alerter
  (HorizontalLimits), the track resolution of the guidance bands instead (horizontal.py), while an alert of a level
  that paints the corrective region or a more severe one (DO-365 corrective, warning) is active: level, at the
  ground speed of the manoeuvre's start, the setpoint's track stepped toward the resolution at the turn rate;
- holding: the RAs (the corrective alerts) ended, clear of conflict: level flight at that horizontal velocity (on
  the resolution track; along the mission's legs after a vertical manoeuvre) for quiet_time_s, counted from the
  last step at which flying back would meet the conflict again (the mission's track in a corrective band; after a
  vertical manoeuvre, an RA's geometry at the mission's altitude or on the way to it: `return_conflict`);
- returning: the mode the vehicle was in before is asked for again, the mission's current item first set to the one
  flown to along its legs (ArduCopter AUTO resumes the mission's current item), until HEARTBEAT shows it: then
  idle;
- overridden: the mode changed under us while we commanded (a pilot or a failsafe): nothing is sent until the
  conflict ends and a new one begins;
- failed: a mode change refused (COMMAND_ACK not accepted) or never confirmed after the retries: nothing is sent
  until the conflict ends; STATUSTEXT "DAA GUIDANCE FAILED ...".

Interlocks (never a command): DAA unavailable (no or stale ownship, a failed stage, a spoof suspected: daa.py),
the link not authenticated while guidance.require_signing, an RA only against intruders suspected of spoofing
(issue 27: "against an intruder whose track is flagged ... as spoofed"; a track whose ADS-B integrity is merely
degraded, tracking/integrity.py, is a real aircraft with a poorer position: the RA against it is flown, as TCAS
flies RAs whatever its surveillance quality), no HEARTBEAT from the autopilot yet, and a vehicle in a mode other than AUTO,
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

from avionics.base.types import (
    Advisory, AdvisoryLevel, AutopilotHeartbeat, CommandAck, MissionCount, MissionCurrent, MissionItem,
)
from avionics.guidance import ardupilot
from avionics.guidance.ardupilot import ARDUCOPTER
from avionics.guidance.horizontal import (
    closest_horizontal_m, horizontal_manoeuvre, track_resolution, turn_rates, turn_to,
)
from avionics.guidance.mission import MissionReader, set_current
from avionics.guidance.arduplane import ARDUPLANE
from avionics.guidance.px4 import PX4
from avionics.guidance.params import GuidanceConfig
from avionics.guidance.vertical import vertical_manoeuvre

STATES = ("idle", "advising", "commanding", "holding", "returning", "overridden", "failed")
MAV_AUTOPILOT_PX4 = 12  # HEARTBEAT autopilot (common.xml MAV_AUTOPILOT)
SETPOINT_CHANGE_MPS = 0.1  # a target that moved this much is sent at once, not at the next period
BANDS_MAX_AGE_S = 2.0  # bands come once a second (DAIDALUS's 1 Hz); older than two periods they are not used
# why no track is flown, where the RA's vertical manoeuvre is flown instead (not: no bands yet, or none in conflict)
NO_TRACK_TO_FLY = ("no_track_resolution", "track_resolution_closer")
# the vehicle this close to the mission's height needs no check before it is given back (a few metres: the
# altitude hold's own error, and far inside any RA's vertical threshold)
MISSION_HEIGHT_TOLERANCE_M = 3.0
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
    manoeuvre: str  # none | climb | descend | level | turn_right | turn_left | return
    target_vertical_rate_mps: float | None  # the commanded (or advised) vertical rate, up positive
    reason: str  # why: ra, preventive, composite, floor, ceiling, corrective, warning, recovery, clear_of_conflict,
    #              mission_resumed, an interlock
    autopilot_mode: str  # the mode the autopilot's HEARTBEAT says (ArduCopter's names), UNKNOWN before one
    since_s: float  # when this state began
    target_track_deg: float | None = None  # a horizontal manoeuvre's resolution track (degrees true), else None

    def text(self) -> str:
        """The STATUSTEXT of a change: "DAA GUIDANCE COMMANDING CLIMB +2.5 M/S ra"."""
        words = ["DAA GUIDANCE", self.state.upper()]
        if self.state in ("commanding", "holding", "advising"):
            words.append(self.manoeuvre.upper().removeprefix("TURN_"))
            if self.target_track_deg is not None:
                words.append(f"TRK{self.target_track_deg:03.0f}")
            elif self.target_vertical_rate_mps is not None and self.manoeuvre != "level":
                words.append(f"{self.target_vertical_rate_mps:+.1f} M/S")
        words.append(self.reason)
        return " ".join(words)[:50]  # STATUSTEXT's text

    def as_dict(self) -> dict:
        return {"time_s": self.time_s, "state": self.state, "manoeuvre": self.manoeuvre,
                "target_vertical_rate_mps": self.target_vertical_rate_mps, "reason": self.reason,
                "autopilot_mode": self.autopilot_mode, "since_s": self.since_s,
                "target_track_deg": self.target_track_deg}


@dataclass(frozen=True, slots=True)
class GuidanceOutput:
    decision: GuidanceDecision
    changed: bool  # the state changed at this step: announce it
    commands: tuple  # MAVLink messages for the autopilot (ardupilot.py, px4.py), in order
    reads: tuple = ()  # requests that read the autopilot's mission (mission.py): no command, no interlock holds them


class Ownship:
    """What the guidance needs of ownship: its velocity (north, east, up), height above home and position (the
    mission's legs are followed from there; None: unknown).

    `Ownship.converted` leaves the position and horizontal velocity in true axes to `true()`, asked for the first
    time one of them is read: a step without a conflict reads neither, and the tracking frame's inverse projection
    behind them (base/frame.py to_true) was most of such a step's guidance (docs/performance.md)."""

    __slots__ = ("up_mps", "height_above_home_m", "_true", "_values")

    def __init__(self, north_mps: float, east_mps: float, up_mps: float, height_above_home_m: float | None,
                 lat_deg: float | None = None, lon_deg: float | None = None):
        self.up_mps = up_mps
        self.height_above_home_m = height_above_home_m
        self._true = None
        self._values = (lat_deg, lon_deg, north_mps, east_mps)

    @classmethod
    def converted(cls, up_mps: float, height_above_home_m: float | None, true) -> "Ownship":
        """true: () -> (lat_deg, lon_deg, north_mps, east_mps), called once, when one of them is first read."""
        own = cls(math.nan, math.nan, up_mps, height_above_home_m)
        own._true, own._values = true, None
        return own

    def _read(self, i: int):
        if self._values is None:
            self._values = tuple(self._true())
        return self._values[i]

    lat_deg = property(lambda self: self._read(0))
    lon_deg = property(lambda self: self._read(1))
    north_mps = property(lambda self: self._read(2))
    east_mps = property(lambda self: self._read(3))


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


@dataclass(frozen=True, slots=True)
class HorizontalLimits:
    """A DO-365 alerter's horizontal manoeuvre (horizontal.py): the alert levels that call for one (those whose
    conflicts paint the corrective region or a more severe one: DO-365's corrective and warning, "a manoeuvre is
    needed"; not preventive), the bands' corrective region, and the turn rate of the bands' kinematics (the
    vehicle profile's when vehicle.profile is set), which the setpoint's track is stepped at, and the bands'
    lookahead."""

    levels: frozenset
    corrective_region: str
    turn_rate_deg_s: float
    lookahead_s: float

    @classmethod
    def of(cls, profile) -> "HorizontalLimits | None":
        """From an advisory/tables.py AlertProfile: None without a DO-365 alerter and its bands."""
        if profile.alerter is None or profile.bands is None:
            return None
        order = {"NONE": 0, "FAR": 1, "MID": 2, "NEAR": 3}
        corrective = profile.bands.corrective_region
        levels = frozenset(i for i, lv in enumerate(profile.alerter.levels, start=1)
                           if order.get(lv.region, 0) >= order[corrective])
        return cls(levels, corrective, profile.bands.turn_rate_deg_s, profile.bands.lookahead_s)


class _ModeRequest:
    """A DO_SET_MODE in flight: resent every ack_timeout_s until HEARTBEAT shows the mode, at most retries times."""

    def __init__(self, mode: int, now_s: float):
        self.mode, self.sent_s, self.attempts, self.acked = mode, now_s, 1, False


class GuidanceStage:
    """update(now, ...) -> GuidanceOutput. vehicle: VerticalLimits (or a VehicleProfile: the same names).
    horizontal: HorizontalLimits with a DO-365 alerter (its corrective and warning alerts are flown as the bands'
    track resolution), None for TCAS-like profiles (their RAs are flown vertically)."""

    def __init__(self, config: GuidanceConfig, vehicle, system: int, component: int = 1,
                 horizontal: HorizontalLimits | None = None):
        self.config, self.vehicle = config, vehicle
        self.turning = horizontal
        self.bands = None  # the last guidance bands (advisory/bands.py Bands), once a second
        self.turn_rates: list[float] = []  # each of their intruders' rate of turn (horizontal.py turn_rates)
        self.held = None  # the horizontal manoeuvre in progress (horizontal.py HorizontalManoeuvre)
        self.target_track: float | None = None  # its resolution track, degrees true
        self.track_cmd: float | None = None  # the setpoint's track, stepped toward target_track at the turn rate
        self.speed = 0.0  # the ground speed of the manoeuvre's start, kept on the new track
        self.turned_s: float | None = None  # when track_cmd was last stepped
        self.no_manoeuvre = "no_bands"  # why a horizontal manoeuvre could not be picked
        self.mission_track: float | None = None  # the track the vehicle flew when we took it (its mission's)
        self.mission_height: float | None = None  # its height above home then (AUTO flies back to it)
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
        # the autopilot's mission (mission.py), read once its HEARTBEAT names the contract: a vertical manoeuvre
        # follows its legs; the item the guidance has flown to (None: the mission is not followed)
        self.mission: MissionReader | None = None
        self.mission_item: int | None = None

    # -- the step ----------------------------------------------------------------------------------------------
    def update(self, now_s: float, active: Mapping, unavailable_reason: str | None, own: Ownship | None,
               autopilot_inputs: Iterable = (), spoofed: frozenset = frozenset(),
               link_authenticated: bool = False, bands=None, return_conflict=None) -> GuidanceOutput:
        """return_conflict(moves): whether some intruder would raise an RA were ownship moved by any of the
        (dz_m, vz_mps) moves, dz_m higher and flying at vz_mps (DaaCore.ra_threatened_if); None: a return after a
        vertical manoeuvre is not checked."""
        before = self.state
        commands: list = []
        self.own = own
        mission_inputs = []
        for item in autopilot_inputs:
            if isinstance(item, (MissionCount, MissionItem, MissionCurrent)):
                mission_inputs.append(item)
            else:
                self._absorb(item, now_s)
        if self.execute and self.mode is not None and self.contract is not ARDUPLANE:
            if self.mission is None:  # PX4's items start at 0; ArduPilot's item 0 is home
                self.mission = MissionReader(self.system, self.component, first_item=0 if self.contract is PX4 else 1)
            reads = self.mission.step(now_s, mission_inputs)
        else:
            reads = []
        if bands is not None:
            self.turn_rates = turn_rates(self.bands, bands)  # each intruder's turn, from the last bands' velocity
            self.bands = bands
        c = self.contract
        levels = self.turning.levels if self.turning is not None and self.contract is not ARDUPLANE else frozenset()
        ras = [a for a in active.values() if a.level is AdvisoryLevel.RA or a.alert_level in levels]
        usable = [a for a in ras if a.intruder not in spoofed]
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
            # the track resolution is flown as a velocity setpoint: multicopters (ArduPlane holds its course by
            # GUIDED_CHANGE_HEADING, arduplane.py: a plane flies a DO-365 warning's vertical RA, not the track yet)
            turning = self.turning is not None and self.contract is not ARDUPLANE
            if turning:
                manoeuvre = self._horizontal(now_s, usable)
            vertical = [a for a in usable if a.level is AdvisoryLevel.RA]
            if manoeuvre is None and vertical and (not turning or self.no_manoeuvre in NO_TRACK_TO_FLY):
                # no track resolution on either side (not merely no bands yet, or bands from before the conflict:
                # new ones come within a second): the RA's vertical manoeuvre
                manoeuvre = vertical_manoeuvre(
                    vertical, own.up_mps, own.height_above_home_m, self.vehicle.climb_rate_mps,
                    self.vehicle.descent_rate_mps, self.vehicle.vertical_accel_mps2, self.config.floor_m,
                    self.config.ceiling_m)
        if manoeuvre is not None and not (manoeuvre.complies and self.state in ("idle", "advising")):
            self.manoeuvre, self.target = manoeuvre.name, manoeuvre.target_mps
            self.held = manoeuvre if hasattr(manoeuvre, "target_track_deg") else None
            self.target_track = manoeuvre.target_track_deg if self.held is not None else None
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
            why = manoeuvre.reason + "_complies" if manoeuvre is not None else \
                (interlock or self.no_manoeuvre) if ras else "no_conflict"
            if self.state == "advising":
                self._enter("idle", now_s, why)
            elif self.since_s != now_s or self.reason == "no_conflict":  # keep the reason idle was entered with
                self.reason = why
        elif self.state == "commanding" and interlock is None:  # the RAs ended: clear of conflict
            self._enter("holding", now_s, "clear_of_conflict")
            self.manoeuvre, self.target, self.clear_s = "level", 0.0, now_s
        if self.state == "holding" and self.held is not None and self._mission_track_in_conflict(now_s):
            self.clear_s, self.reason = now_s, "mission_track_in_conflict"  # the quiet time counts from its end
        elif self.state == "holding" and self.held is None and self._mission_altitude_in_conflict(own, return_conflict):
            self.clear_s, self.reason = now_s, "mission_altitude_in_conflict"
        if self.state == "holding" and interlock is None and now_s - self.clear_s >= self.config.quiet_time_s:
            self._return(now_s, "quiet_time_over", commands)

        if self.execute:
            if self.state in ("commanding", "holding"):
                self._turn(now_s)
                self._follow_mission()
                self._setpoint(now_s, commands)  # a PX4 stream before its mode change
            if self.prestream_until is not None and now_s >= self.prestream_until:
                self.prestream_until = None
                if self.state in ("commanding", "holding") and self.mode != c.command_mode:
                    self._request(c.command_mode, now_s, commands)
            self._handshake(now_s, commands)
        flying = self.state in ("commanding", "holding", "advising")
        decision = GuidanceDecision(now_s, self.state, self.manoeuvre if self.state != "idle" else "none",
                                    self.target if flying else None, self.reason, c.mode_name(self.mode),
                                    self.since_s, self.target_track if flying else None)
        return GuidanceOutput(decision, self.state != before, tuple(commands), tuple(reads))

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
            return "spoof_suspected"
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
            self.speed = math.hypot(own.north_mps, own.east_mps)
            self.track_cmd = self.mission_track = math.degrees(math.atan2(own.east_mps, own.north_mps)) % 360.0
            self.mission_height = own.height_above_home_m
            self.turned_s = now_s
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
        self.held = self.target_track = None
        self._enter("returning", now_s, reason)
        self.prestream_until = None
        reader = self.mission
        if self.mission_item is not None and reader is not None and self.mission_item != reader.current:
            # the mission resumes at the item the vehicle has reached, not at the one it was flying to when taken
            commands.append(set_current(self.mission_item, self.system, self.component))
        self.mission_item = None
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
        north, east = self.horizontal
        if last is not None and now_s - last[0] < period - 1e-9 and \
                max(abs(last[1] - self.target), abs(last[2] - north), abs(last[3] - east)) < SETPOINT_CHANGE_MPS:
            return
        self.last_setpoint = (now_s, self.target, north, east)
        commands.append(self.contract.velocity_setpoint(north, east, self.target, self.system, self.component,
                                                        int(now_s * 1000)))

    def _horizontal(self, now_s: float, usable: list):
        """The track resolution of the last bands for the most severe alert (horizontal.py), the side of the
        manoeuvre in progress kept; the manoeuvre in progress while the present track needs none (DAIDALUS: NaN,
        the vehicle is on a conflict-free track) or the bands are too old; None when there is none to fly."""
        held = self.held if self.state in ("commanding", "holding", "advising") else None
        bands = self.bands
        if bands is None or now_s - bands.time_s > BANDS_MAX_AGE_S or not bands.track_deg:
            self.no_manoeuvre = "no_bands"
            return held
        ve, vn = bands.ownship_vel[0], bands.ownship_vel[1]
        track = math.degrees(math.atan2(ve, vn)) % 360.0
        if track_resolution(bands.track_deg, track, self.turning.corrective_region) is None:
            self.no_manoeuvre = "track_conflict_free"  # these bands see no conflict on the present track (yet)
            return held
        worst = max(usable, key=lambda a: a.alert_level or 0)

        def resolution(side):
            return horizontal_manoeuvre(bands.track_deg, track, worst.alert_name or "corrective",
                                        self.config.track_margin_deg, side, self.turning.corrective_region)

        found = resolution(held.right if held is not None else None)
        if found is None:
            self.no_manoeuvre = "no_track_resolution"
        elif held is not None and found.target_track_deg != held.target_track_deg and \
                self._closer(bands, track, found.target_track_deg):
            found = held  # the resolution moved toward an intruder (one turning into it): the track flown is kept
        elif held is None and self._closer(bands, track, found.target_track_deg):
            other = resolution(not found.right)  # the other side, or None
            found = other if other is not None and other.right != found.right and \
                not self._closer(bands, track, other.target_track_deg) else None
            if found is None:
                self.no_manoeuvre = "track_resolution_closer"
        return found if found is not None else held

    def _closer(self, bands, track_deg: float, target_deg: float) -> bool:
        """The target track, flown at the present speed, passes some intruder closer than the present track
        (horizontal.py closest_horizontal_m, over the bands' lookahead, each intruder on its present turn)."""
        speed = math.hypot(bands.ownship_vel[0], bands.ownship_vel[1])

        def closest(deg):
            rad = math.radians(deg)
            return closest_horizontal_m(bands.ownship_pos, (speed * math.sin(rad), speed * math.cos(rad)),
                                        bands.traffic, self.turning.lookahead_s, self.turn_rates)
        return closest(target_deg) < closest(track_deg)

    def _mission_track_in_conflict(self, now_s: float) -> bool:
        """The mission's track lies in a band at least as severe as the corrective region of fresh bands: the
        mission given back now would turn the vehicle into the conflict again (ICAROUS returns to the mission only
        when the turn back is conflict free: TrafficMonitor::CheckSafeToTurn)."""
        bands = self.bands
        if self.mission_track is None or bands is None or now_s - bands.time_s > BANDS_MAX_AGE_S:
            return False
        order = {"FAR": 1, "MID": 2, "NEAR": 3}
        region = bands.region_at("track_deg", self.mission_track)
        return order.get(region, 0) >= order[self.turning.corrective_region]

    def _mission_altitude_in_conflict(self, own: Ownship | None, return_conflict) -> bool:
        """After a vertical manoeuvre: the mission given back now (AUTO climbs or descends to the mission's height
        at the vehicle's rate) would raise an RA again, at the mission's height level or on the way to it at the
        vehicle's rate. The vertical counterpart of _mission_track_in_conflict (ICAROUS returns to the mission
        only when the way back is conflict free: TrafficMonitor::CheckSafeToTurn); without it a multirotor that
        climbed clear of a loitering rotorcraft flew back down into it two seconds after each RA ended."""
        if return_conflict is None or own is None or own.height_above_home_m is None or self.mission_height is None:
            return False
        dz = self.mission_height - own.height_above_home_m
        if abs(dz) < MISSION_HEIGHT_TOLERANCE_M:
            return False
        rate = self.vehicle.climb_rate_mps if dz > 0 else -self.vehicle.descent_rate_mps
        return return_conflict(((dz, 0.0), (0.0, rate)))

    def _follow_mission(self) -> None:
        """A vertical manoeuvre's horizontal velocity: along the mission's legs from where the vehicle is, at the
        ground speed of the manoeuvre's start (mission.py MissionPath.velocity), the item flown to advanced as
        the vehicle reaches it; without a mission read (or a position) the velocity of the start is kept, until
        one is: a mission read during the manoeuvre is followed from the autopilot's current item then (GUIDED
        keeps the item AUTO was flying to)."""
        own, reader = self.own, self.mission
        if self.held is not None or reader is None or reader.path is None or own is None or own.lat_deg is None \
                or not reader.path.waypoints:
            return
        if self.mission_item is None:
            if reader.current is None:
                return
            self.mission_item = reader.current
        north, east, self.mission_item = reader.path.velocity(self.mission_item, own.lat_deg, own.lon_deg, self.speed)
        self.horizontal = (north, east)

    def _turn(self, now_s: float) -> None:
        """The setpoint's track stepped toward the resolution at the turn rate, on the manoeuvre's side (the long
        way round only when the resolution lies more than a quarter turn behind it)."""
        if self.target_track is None or self.track_cmd is None:
            return
        dt = now_s - self.turned_s if self.turned_s is not None else 0.0
        self.turned_s = now_s
        d = turn_to(self.track_cmd, self.target_track)
        if self.held is not None and self.held.right and d < -90.0:
            d += 360.0
        elif self.held is not None and not self.held.right and d > 90.0:
            d -= 360.0
        step = self.turning.turn_rate_deg_s * max(dt, 0.0)
        self.track_cmd = (self.track_cmd + min(max(d, -step), step)) % 360.0
        rad = math.radians(self.track_cmd)
        self.horizontal = (self.speed * math.cos(rad), self.speed * math.sin(rad))
    def _plane_failed(self, now_s: float, failure: str, commands: list) -> None:
        """An ArduPlane GUIDED command refused or never acknowledged: failed, and the mode it was in asked for
        again (a plane left in GUIDED circles around where it entered it)."""
        self._enter("failed", now_s, failure)
        self._request(self.prior_mode if self.prior_mode is not None else self.contract.return_mode, now_s, commands)

    @property
    def failed(self) -> bool:
        return self.state == "failed"
