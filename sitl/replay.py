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
from avionics.io.dialect import daa as mavlink2

from avionics.config import Config
from avionics.core.types import Advisory, IntruderKey
from avionics.io.framing import FrameScanner
from avionics.node import DaaNode
from sitl.autopilot import AutopilotConfig, Packer, ownship_messages, schedule
from sitl.impairments import AdsbImpairments
from sitl.response import RaResponder
from sitl.scenario import Scenario

CSV_COLUMNS = ("time_s", "intruder", "advisory", "ra", "ra_sense", "target_vertical_rate_mps", "name", "reason",
               "sensitivity_level", "range_m", "closure_rate_mps", "t_cpa_s", "hmd_m", "vmd_m", "range_tau_s",
               "mod_tau_s", "vertical_tau_s", "ra_separation_m")
# One row per intruder: true miss at the true horizontal CPA, without and with the RAs flown (equal open loop).
MISS_COLUMNS = ("intruder", "name", "t_cpa_s", "hmd_m", "vmd_unflown_m", "vmd_flown_m")


@dataclass
class ReplayResult:
    changes: list[Advisory]
    names: dict[int, str]  # ICAO address -> scenario aircraft name
    collisions: list[tuple[float, object]] = field(default_factory=list)  # COLLISION as the autopilot got them
    counters: Counter = field(default_factory=Counter)
    misses: list = field(default_factory=list)  # VerticalMiss per intruder

    def rows(self) -> list[dict]:
        def num(v):
            return "" if v is None or (isinstance(v, float) and math.isinf(v)) else f"{v:.3f}"

        return [{
            "time_s": f"{a.time_s:.2f}", "intruder": str(a.intruder), "advisory": a.level.name,
            "ra": a.ra_words or "", "ra_sense": a.ra_sense or "", "target_vertical_rate_mps": num(a.target_vertical_rate_mps),
            "ra_separation_m": num(a.ra_separation_m),
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

    def miss_rows(self) -> list[dict]:
        return [{
            "intruder": str(m.key) if m.key is not None else "", "name": m.intruder, "t_cpa_s": f"{m.t_cpa_s:.3f}",
            "hmd_m": f"{m.hmd_m:.3f}", "vmd_unflown_m": f"{m.vmd_without_m:.3f}", "vmd_flown_m": f"{m.vmd_with_m:.3f}",
        } for m in self.misses]

    def write_misses_csv(self, path: str | Path) -> None:
        with open(path, "w", newline="") as fh:
            writer = csv.DictWriter(fh, fieldnames=MISS_COLUMNS)
            writer.writeheader()
            writer.writerows(self.miss_rows())


def replay(scenario: Scenario, config: Config, impairments: AdsbImpairments, seed: int = 0,
           autopilot: AutopilotConfig = AutopilotConfig(), respond: bool = False) -> ReplayResult:
    """Fly the encounter through DaaNode in fast time. respond=True closes the loop: ownship flies the RAs
    it receives (sitl.response) and the result records the vertical miss with and without the response."""
    counters: Counter = Counter()
    node = DaaNode(config, counters)
    scanner = FrameScanner(counters)
    packer = Packer(autopilot)
    # The autopilot's side of the link: what the DAA process sends back is framed and decoded too.
    daa_side = mavlink2.MAVLink(None, srcSystem=config.mavlink.source_system,
                                srcComponent=config.mavlink.source_component)
    autopilot_rx = FrameScanner(Counter())
    result = ReplayResult([], {a.icao_address: a.name for a in scenario.intruders}, counters=counters)
    responder = RaResponder(node.core.profile.response) if respond else None
    own_traj, intruder_trajs = scenario.trajectories()

    def step(msgs, now_s: float) -> None:
        result.changes.extend(node.handle(msgs, now_s).changes)
        for out in node.mavlink_out:
            for back in autopilot_rx.feed(bytes(out.pack(daa_side)), end_of_datagram=True):
                if back.get_type() == "COLLISION":
                    result.collisions.append((now_s, back))
                elif back.get_type() == "DAA_ADVISORY" and responder is not None:
                    responder.receive(back, now_s)
        node.mavlink_out.clear()
        node.zenoh_out.clear()

    tick = 1.0 / config.advisory.assessment_hz
    events = schedule(scenario, impairments, seed, autopilot, ownship=not respond)
    own_period = 1.0 / autopilot.ownship_hz
    n_ticks = int(math.floor(scenario.duration_s / tick))
    offsets = []  # (t, ownship altitude offset from the response)
    i = 0
    for k in range(n_ticks + 1):
        t_tick = k * tick
        while i < len(events) and events[i].deliver_s <= t_tick + 1e-9:
            event = events[i]
            step(scanner.feed(packer.pack(event.msg), end_of_datagram=True), event.deliver_s)
            i += 1
        if responder is not None:
            own = responder.fly(own_traj.state_at(t_tick))
            offsets.append((t_tick, responder.offset_m))
            if abs(t_tick / own_period - round(t_tick / own_period)) < 1e-6:
                for msg in ownship_messages(own, scenario.ground_elevation_m, int(t_tick * 1000)):
                    step(scanner.feed(packer.pack(msg), end_of_datagram=True), t_tick)
        step([], t_tick)
    result.misses = [_vertical_miss(scenario, own_traj, traj, spec.name, offsets,
                                    IntruderKey(spec.icao_address, spec.address_source))
                     for spec, traj in zip(scenario.intruders, intruder_trajs)]
    return result


@dataclass(frozen=True, slots=True)
class VerticalMiss:
    intruder: str
    t_cpa_s: float  # true time of horizontal closest approach
    hmd_m: float
    vmd_without_m: float  # |vertical separation| at CPA on the scenario's paths
    vmd_with_m: float  # ... with ownship flying the RAs (equal when the loop is open)
    key: IntruderKey | None = None  # as the node keys it (the advisory CSV's intruder column)


def _vertical_miss(scenario, own_traj, traj, name, offsets, key=None) -> VerticalMiss:
    """Truth at the time of least horizontal distance, sampled at 0.1 s."""
    times = [k * 0.1 for k in range(int(scenario.duration_s * 10) + 1)]
    dist = []
    for t in times:
        oe, on, _ = own_traj.enu_at(t)
        ie, in_, _ = traj.enu_at(t)
        dist.append(math.hypot(ie - oe, in_ - on))
    k = min(range(len(times)), key=dist.__getitem__)
    t = times[k]
    without = traj.enu_at(t)[2] - own_traj.enu_at(t)[2]
    offset = next((o for tt, o in reversed(offsets) if tt <= t + 1e-9), 0.0) if offsets else 0.0
    return VerticalMiss(name, t, dist[k], abs(without), abs(without - offset), key)
