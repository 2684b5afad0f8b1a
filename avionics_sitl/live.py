"""Live SITL: flies a scenario in real time over a MAVLink link and records what the DAA process sends back."""

from __future__ import annotations

import time
from collections import Counter
from dataclasses import dataclass, field

from avionics.io.link import MavlinkLink
from avionics_sitl.autopilot import AutopilotConfig, Packer, schedule
from avionics_sitl.impairments import AdsbImpairments
from avionics_sitl.scenario import Scenario


@dataclass(frozen=True, slots=True)
class Received:
    time_s: float  # scenario time at receipt
    msg: object


@dataclass
class Recording:
    received: list[Received] = field(default_factory=list)
    sent: int = 0
    counters: Counter = field(default_factory=Counter)

    def of_type(self, kind: str) -> list[Received]:
        return [r for r in self.received if r.msg.get_type() == kind]


def fly(scenario: Scenario, connection: str, impairments: AdsbImpairments, seed: int = 0,
        start_s: float = 0.0, duration_s: float | None = None, autopilot: AutopilotConfig = AutopilotConfig(),
        on_receive=None, stop=None) -> Recording:
    """Send the schedule from scenario time start_s in real time; receive until the end. on_receive(Received)
    is called for each message from the DAA side (e.g. to print COLLISION as it arrives)."""
    end_s = scenario.duration_s if duration_s is None else min(scenario.duration_s, start_s + duration_s)
    events = [e for e in schedule(scenario, impairments, seed, autopilot, duration_s=end_s) if e.deliver_s >= start_s]
    recording = Recording()
    link = MavlinkLink(connection, recording.counters, autopilot.system_id, autopilot.component_id)
    packer = Packer(autopilot)
    wall0 = time.monotonic() - start_s
    i = 0
    try:
        while True:
            now = time.monotonic() - wall0
            if now >= end_s or (stop is not None and stop.is_set()):
                break
            while i < len(events) and events[i].deliver_s <= now:
                link.conn.write(packer.pack(events[i].msg))
                recording.sent += 1
                i += 1
            next_due = events[i].deliver_s if i < len(events) else end_s
            for msg in link.receive(max(0.0, min(next_due, end_s) - (time.monotonic() - wall0))):
                if msg.get_srcComponent() == autopilot.component_id and msg.get_srcSystem() == autopilot.system_id \
                        and msg.get_type() != "COLLISION":
                    continue  # our own echo on a shared link
                received = Received(time.monotonic() - wall0, msg)
                recording.received.append(received)
                if on_receive is not None:
                    on_receive(received)
    finally:
        link.close()
    return recording
