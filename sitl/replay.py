"""Fast-time replay: the scenario's MAVLink schedule, framed and de-framed, drives DaaNode on simulated time.

Same decoder, core and output policy as `avionics run`; no sockets, no waiting. The node is stepped at every
message delivery and on the assessment grid between them, as the live loop does.
"""

from __future__ import annotations

import csv
import math
from collections import Counter
from dataclasses import dataclass, field
from pathlib import Path

import avionics.io  # noqa: F401
from pymavlink.dialects.v20 import common as mavlink2

from avionics.config import Config
from avionics.core.types import Advisory
from avionics.io.framing import FrameScanner
from avionics.node import DaaNode
from sitl.autopilot import AutopilotConfig, Packer, schedule
from sitl.impairments import AdsbImpairments
from sitl.scenario import Scenario

CSV_COLUMNS = ("time_s", "intruder", "advisory", "name", "reason", "sensitivity_level", "range_m",
               "closure_rate_mps", "t_cpa_s", "hmd_m", "vmd_m", "range_tau_s", "mod_tau_s", "vertical_tau_s")


@dataclass
class ReplayResult:
    changes: list[Advisory]
    names: dict[int, str]  # ICAO address -> scenario aircraft name
    collisions: list[tuple[float, object]] = field(default_factory=list)  # COLLISION as the autopilot got them
    counters: Counter = field(default_factory=Counter)

    def rows(self) -> list[dict]:
        def num(v):
            return "" if v is None or (isinstance(v, float) and math.isinf(v)) else f"{v:.3f}"

        return [{
            "time_s": f"{a.time_s:.2f}", "intruder": str(a.intruder), "advisory": a.level.name,
            "name": self.names.get(a.intruder.address, ""), "reason": a.reason,
            "sensitivity_level": a.sensitivity_level, "range_m": num(a.range_m),
            "closure_rate_mps": num(a.closure_rate_mps), "t_cpa_s": num(a.t_cpa_s), "hmd_m": num(a.hmd_m),
            "vmd_m": num(a.vmd_m), "range_tau_s": num(a.range_tau_s), "mod_tau_s": num(a.mod_tau_s),
            "vertical_tau_s": num(a.vertical_tau_s),
        } for a in self.changes]

    def write_csv(self, path: str | Path) -> None:
        with open(path, "w", newline="") as fh:
            writer = csv.DictWriter(fh, fieldnames=CSV_COLUMNS)
            writer.writeheader()
            writer.writerows(self.rows())


def replay(scenario: Scenario, config: Config, impairments: AdsbImpairments, seed: int = 0,
           autopilot: AutopilotConfig = AutopilotConfig()) -> ReplayResult:
    counters: Counter = Counter()
    node = DaaNode(config, counters)
    scanner = FrameScanner(counters)
    packer = Packer(autopilot)
    # The autopilot's side of the link: what the DAA process sends back is framed and decoded too.
    daa_side = mavlink2.MAVLink(None, srcSystem=config.mavlink.source_system,
                                srcComponent=config.mavlink.source_component)
    autopilot_rx = FrameScanner(Counter())
    result = ReplayResult([], {a.icao_address: a.name for a in scenario.intruders}, counters=counters)

    def step(msgs, now_s: float) -> None:
        result.changes.extend(node.handle(msgs, now_s).changes)
        for out in node.mavlink_out:
            for back in autopilot_rx.feed(bytes(out.pack(daa_side)), end_of_datagram=True):
                if back.get_type() == "COLLISION":
                    result.collisions.append((now_s, back))
        node.mavlink_out.clear()
        node.zenoh_out.clear()

    tick = 1.0 / config.advisory.assessment_hz
    events = schedule(scenario, impairments, seed, autopilot)
    n_ticks = int(math.floor(scenario.duration_s / tick))
    i = 0
    for k in range(n_ticks + 1):
        t_tick = k * tick
        while i < len(events) and events[i].deliver_s <= t_tick + 1e-9:
            event = events[i]
            step(scanner.feed(packer.pack(event.msg), end_of_datagram=True), event.deliver_s)
            i += 1
        step([], t_tick)
    return result
