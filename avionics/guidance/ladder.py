"""The mode ladder for simple vehicles (guidance.ladder): an autopilot mode per alert level, issued once per
escalation, instead of the RA's manoeuvre (stage.py), as PX4's DAA module does.

PX4 (navigator's detect_and_avoid library, docs/en/advanced_features/detect_and_avoid.md of PX4-Autopilot, PR 26815):
each F3442 conflict level has an action (DAA_LVL_*_ACT: Disabled, Warn only, Hold, Return, Land, Terminate), ordered
by severity Disabled < Warn < Hold < Return < Land < Terminate; a level set to Disabled falls back to the next
broader breached level with an action; "automatic actions are one-shot per conflict escalation"; an action is sent
only when it is more severe than the mode the vehicle is in (Mission and Takeoff: none; Hold/Loiter/Orbit: Hold;
Return: Return; Land and the manual modes: Land, so a manually flown vehicle is never switched; Offboard and
unknown modes: never); de-escalation is conservative: the mission is not resumed after the conflict clears.

Here the alert levels are the advisories' (Advisory.alert(): TA 1, RA 2 for the TCAS-like profiles; PREVENTIVE 1,
CORRECTIVE 2, WARNING 3 for DO-365), the most severe over the intruders that are not suspected spoofs (a degraded
ADS-B integrity is still an aircraft: stage.py). Terminate is not offered. The modes, per autopilot contract (contract.py):
ArduCopter Hold = LOITER (5; position hold, ArduCopter/mode.h), Return = RTL (6), Land = LAND (9); PX4 Hold =
AUTO.LOITER, Return = AUTO.RTL, Land = AUTO.LAND (px4_custom_mode.h); ArduPlane Hold = LOITER (12), Return = RTL
(11) and no Land (a plane has no plain landing mode: Land is flown as Return, and the reason says so).

States (GuidanceDecision.state): idle (no alert, an interlock, or the conflict over: the vehicle stays in the mode
it was put in); advising (the action is Warn, or guidance.mode = "advise", or the vehicle is already in as severe a
mode): a STATUSTEXT, nothing sent; commanding (the mode asked for, DO_SET_MODE retried as stage.py's until HEARTBEAT
shows it); overridden (the mode changed under us after ours was confirmed: nothing more until the conflict ends);
failed (the mode refused or never confirmed). The interlocks are stage.py's: DAA unavailable, the link not
authenticated while guidance.require_signing, no HEARTBEAT yet.
"""

from __future__ import annotations

from typing import Iterable, Mapping

from avionics.base.types import AdvisoryLevel, AutopilotHeartbeat, CommandAck
from avionics.guidance import ardupilot, arduplane, px4
from avionics.guidance.ardupilot import ARDUCOPTER
from avionics.guidance.params import LADDER_ACTIONS, GuidanceConfig
from avionics.guidance.stage import GuidanceDecision, GuidanceOutput, contract_for

SEVERITY = {action: k for k, action in enumerate(LADDER_ACTIONS)}  # none 0, warn 1, hold 2, return 3, land 4
NEVER = len(LADDER_ACTIONS)  # a mode no action is more severe than (someone else's offboard control, GUIDED)

# Per contract: the mode of each action, and the action each mode already is (PX4's navigator-state equivalence)
_MODES = {
    "ArduCopter": ({"hold": ardupilot.LOITER, "return": ardupilot.RTL, "land": ardupilot.LAND},
                   {3: 0, 5: 2, 16: 2, 17: 2, 6: 3, 21: 3, 27: 3, 9: 4, 0: 4, 1: 4, 2: 4, 11: 4, 13: 4}),
    "PX4": ({"hold": px4.HOLD, "return": px4.RTL, "land": px4.LAND},
            {px4.MISSION: 0, px4.custom_mode(px4.AUTO, 2): 0, px4.HOLD: 2, px4.RTL: 3, px4.LAND: 4,
             **{px4.custom_mode(m): 4 for m in (px4.MANUAL, px4.ALTCTL, px4.POSCTL, px4.ACRO, px4.STABILIZED)}}),
    "ArduPlane": ({"hold": arduplane.LOITER, "return": arduplane.RTL},
                  {10: 0, 13: 0, 12: 2, 1: 2, 11: 3, **{m: 4 for m in (0, 2, 3, 4, 5, 6, 7)}}),
}


class ModeLadder:
    """update(now, ...) -> GuidanceOutput, as GuidanceStage's (daa.py uses one or the other)."""

    def __init__(self, config: GuidanceConfig, system: int, component: int = 1):
        self.config, self.execute = config, config.mode == "execute"
        self.system, self.component = system, component
        self.contract = ARDUCOPTER
        self.state, self.since_s, self.reason, self.action = "idle", 0.0, "no_conflict", "none"
        self.mode: int | None = None
        self.issued = 0  # the severity issued in this conflict (once per escalation)
        self.ours: int | None = None  # the mode we asked for, once HEARTBEAT showed it
        self.request: tuple[int, float, int] | None = None  # (mode, sent at, attempts) of a DO_SET_MODE in flight

    def update(self, now_s: float, active: Mapping, unavailable_reason: str | None, own, autopilot_inputs: Iterable = (),
               spoofed: frozenset = frozenset(), link_authenticated: bool = False, bands=None,
               return_conflict=None) -> GuidanceOutput:
        """bands, return_conflict: the stage's signature (stage.py); the ladder switches modes and flies no track
        resolution or vertical manoeuvre to come back from."""
        before, commands = (self.state, self.action), []
        for item in autopilot_inputs:
            self._absorb(item, now_s)
        alerts = [a for a in active.values() if a.level > AdvisoryLevel.NONE]
        usable = [a for a in alerts if a.intruder not in spoofed]  # degraded ADS-B is still an aircraft (stage.py)
        if not alerts:  # the conflict is over; the vehicle stays where it was put (no automatic resume)
            self.issued, self.ours, self.request, self.action = 0, None, None, "none"
            self._enter("idle", now_s, "no_conflict")
        elif self.state == "commanding" and self.ours is not None and self.mode != self.ours:
            self._enter("overridden", now_s, f"mode {self.contract.mode_name(self.mode)} not ours")
            self.request = None
        elif self.state not in ("overridden", "failed"):
            interlock = self._interlock(unavailable_reason, usable, link_authenticated)
            if interlock is not None:
                if self.state == "idle":
                    self.reason = interlock
            else:
                self._escalate(now_s, max(a.alert()[0] for a in usable), commands)
        self._handshake(now_s, commands)
        decision = GuidanceDecision(now_s, self.state, self.action if self.state != "idle" else "none", None,
                                    self.reason, self.contract.mode_name(self.mode), self.since_s)
        # a change of state or of action is announced (STATUSTEXT): each escalation, also advising to advising
        return GuidanceOutput(decision, (self.state, self.action) != before, tuple(commands))

    def _interlock(self, unavailable_reason, usable, link_authenticated) -> str | None:
        if unavailable_reason is not None:
            return f"daa_unavailable {unavailable_reason}"
        if not usable:
            return "spoof_suspected"
        if self.execute and self.config.require_signing and not link_authenticated:
            return "link_not_authenticated"
        if self.execute and self.mode is None:
            return "no_autopilot_heartbeat"
        return None

    def _escalate(self, now_s: float, level: int, commands: list) -> None:
        """The action of this alert level (falling back to a lower level's over "none"), once, if more severe."""
        ladder = self.config.ladder
        action = next((ladder[k] for k in range(min(level, len(ladder)) - 1, -1, -1) if ladder[k] != "none"), "none")
        if SEVERITY[action] <= self.issued:
            return
        self.issued = SEVERITY[action]
        modes, equivalent = _MODES[self.contract.name]
        why = f"level {level}"
        if action not in ("none", "warn") and action not in modes:  # ArduPlane: no Land mode
            action, why = "return", f"level {level} land_as_return"
        self.action = action
        present = equivalent.get(self.mode, NEVER) if self.mode is not None else NEVER
        if action == "warn" or not self.execute:
            self._enter("advising", now_s, why)
        elif SEVERITY[action] <= present:  # already as severe (or someone else's control): a warning only
            self._enter("advising", now_s, f"{why} mode {self.contract.mode_name(self.mode)} kept")
        else:
            self._enter("commanding", now_s, why)
            self.ours = None
            self.request = (modes[action], now_s, 1)
            commands.append(self.contract.set_mode(modes[action], self.system, self.component))

    def _absorb(self, item, now_s: float) -> None:
        if isinstance(item, AutopilotHeartbeat):
            if self.state == "idle":
                self.contract = contract_for(item)
            self.mode, self.component = item.custom_mode, item.component
            if self.request is not None and item.custom_mode == self.request[0]:
                self.ours, self.request = item.custom_mode, None
        elif isinstance(item, CommandAck) and item.command == ardupilot.DO_SET_MODE and self.request is not None:
            if item.result not in (ardupilot.ACCEPTED, ardupilot.IN_PROGRESS):
                wanted = self.contract.mode_name(self.request[0])
                self.request = None
                self._enter("failed", now_s, f"{wanted} refused: result {item.result}")

    def _handshake(self, now_s: float, commands: list) -> None:
        if self.request is None or now_s - self.request[1] < self.config.ack_timeout_s:
            return
        mode, _, attempts = self.request
        if attempts > self.config.retries:
            self.request = None
            self._enter("failed", now_s, f"{self.contract.mode_name(mode)} unconfirmed x{attempts}")
            return
        commands.append(self.contract.set_mode(mode, self.system, self.component, confirmation=attempts))
        self.request = (mode, now_s, attempts + 1)

    def _enter(self, state: str, now_s: float, reason: str) -> None:
        if state != self.state:
            self.since_s = now_s
        self.state, self.reason = state, reason

    @property
    def failed(self) -> bool:
        return self.state == "failed"
