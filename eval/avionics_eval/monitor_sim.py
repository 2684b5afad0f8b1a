"""A simulated vehicle for monitor tests, demos and fleets: the SITL autopilot's MAVLink schedule drives a real
DAA loop on a real clock (optionally sped up), and a real ZenohBus publishes what its zenoh port sends, exactly
as `avionics run` does, minus the UDP link. It measures its own loop: how long each tick's handle()+publish()
takes and how late each tick starts, so the cost of zenoh on the onboard loop can be read off.

    python -m avionics_eval.monitor_sim --vehicle uav2 --scenario crossing-90 --connect tcp/127.0.0.1:7447 --report r.json
"""

from __future__ import annotations

import argparse
import json
import math
import signal
import sys
import threading
import time
from collections import Counter

import avionics.io  # noqa: F401  (MAVLink 2)
from avionics.config import Config, load_config
from avionics.io.framing import FrameScanner
from avionics.io.zenoh_bus import ZenohBus
from avionics.daa import Daa
from avionics.loop import Batch, Loop, MavlinkInput
from avionics.ports import ZenohOut
from avionics_sitl.autopilot import Packer, schedule
from avionics_sitl.impairments import PRESETS
from avionics_sitl.encounters import load_encounter


def _percentiles(values: list[float]) -> dict:
    if not values:
        return {"n": 0}
    s = sorted(values)

    def q(p):
        return s[min(len(s) - 1, int(round(p / 100 * (len(s) - 1))))]

    return {"n": len(s), "p50_ms": round(q(50) * 1e3, 3), "p99_ms": round(q(99) * 1e3, 3),
            "max_ms": round(s[-1] * 1e3, 3), "mean_ms": round(sum(s) / len(s) * 1e3, 3)}


class SimVehicle:
    """Flies `scenario` from start_s to end_s (scenario seconds) at `speed` x real time on its own thread."""

    def __init__(self, config: Config, scenario: str = "head-on", start_s: float = 0.0, end_s: float | None = None,
                 speed: float = 1.0, noise: str = "none", seed: int = 0, session=None):
        self.config = config
        self.scenario = load_encounter(scenario)
        self.start_s = start_s
        self.end_s = self.scenario.duration_s if end_s is None else min(end_s, self.scenario.duration_s)
        self.speed = speed
        self.counters: Counter = Counter()
        self.bus = ZenohBus(config.zenoh, config.vehicle.id, session=session, counters=self.counters)
        self.mavlink = MavlinkInput(config, self.counters)
        self.loop = Loop(Daa(config, self.counters), self.mavlink, [ZenohOut(self._publish, config)])
        self._events = [e for e in schedule(self.scenario, PRESETS[noise], seed, duration_s=self.end_s)
                        if e.deliver_s >= start_s - 10.0]  # 10 s of history before the start: tracks exist
        self.changes: list = []  # (wall time, Advisory) of every change the DAA made
        self.ticks: list[tuple[float, float, float]] = []  # (wall_s since start, work_s, lateness_s)
        self.publish_calls: list[float] = []  # seconds per bus.publish() call
        self.stop = threading.Event()
        self.done = threading.Event()
        self.sim_time_s = start_s
        self._thread = threading.Thread(target=self._run, name=f"sim-{config.vehicle.id}", daemon=True)

    def start(self) -> "SimVehicle":
        self._thread.start()
        return self

    def _run(self) -> None:
        try:
            self._loop()
        finally:
            self.done.set()

    def _loop(self) -> None:
        scanner = FrameScanner(self.counters)
        packer = Packer()
        tick = 1.0 / self.config.advisory.assessment_hz
        i = 0
        # catch up on the 10 s before start_s in fast time: tracks, filters and the bus's picture warmed up
        while i < len(self._events) and self._events[i].deliver_s < self.start_s:
            e = self._events[i]
            self._step(scanner.feed(packer.pack(e.msg), end_of_datagram=True), e.deliver_s)
            i += 1
        wall0 = time.monotonic()
        k = 0
        while not self.stop.is_set():
            t = self.start_s + k * tick
            if t > self.end_s:
                break
            due_wall = wall0 + (t - self.start_s) / self.speed
            delay = due_wall - time.monotonic()
            if delay > 0:
                self.stop.wait(delay)
            started = time.monotonic()
            msgs = []
            while i < len(self._events) and self._events[i].deliver_s <= t + 1e-9:
                msgs.extend(scanner.feed(packer.pack(self._events[i].msg), end_of_datagram=True))
                i += 1
            self._step(msgs, t)
            work = time.monotonic() - started
            self.ticks.append((started - wall0, work, max(0.0, started - due_wall)))
            self.sim_time_s = t
            k += 1

    def _step(self, msgs, t: float) -> None:
        result = self.loop.step(Batch(t, self.mavlink.decode(msgs, t)))
        for a in result.changes:
            self.changes.append((time.time(), a))

    def _publish(self, suffix: str, payload: dict) -> None:
        c0 = time.perf_counter()
        self.bus.publish(suffix, payload)
        self.publish_calls.append(time.perf_counter() - c0)

    def wait_until(self, sim_time_s: float, timeout_s: float = 60.0) -> bool:
        deadline = time.monotonic() + timeout_s
        while self.sim_time_s < sim_time_s and not self.done.is_set() and time.monotonic() < deadline:
            time.sleep(0.01)
        return self.sim_time_s >= sim_time_s

    def timing(self, wall_from: float = 0.0, wall_to: float = math.inf) -> dict:
        """Tick work time and start lateness within [wall_from, wall_to) seconds since the loop started."""
        sel = [(w, lat) for ws, w, lat in self.ticks if wall_from <= ws < wall_to]
        return {"work": _percentiles([w for w, _ in sel]), "lateness": _percentiles([lat for _, lat in sel])}

    def close(self) -> None:
        self.stop.set()
        if self._thread.is_alive():
            self._thread.join(timeout=5.0)
        self.bus.close()


def main(argv=None) -> int:
    p = argparse.ArgumentParser(prog="python -m avionics_eval.monitor_sim", description=__doc__.split("\n\n")[0])
    p.add_argument("--vehicle", default="sim1")
    p.add_argument("--scenario", default="head-on")
    p.add_argument("--start", type=float, default=0.0, help="scenario time to start at (s)")
    p.add_argument("--end", type=float, default=None, help="scenario time to stop at (s)")
    p.add_argument("--speed", type=float, default=1.0, help="scenario seconds per real second")
    p.add_argument("--mode", default="peer")
    p.add_argument("--connect", action="append", default=[])
    p.add_argument("--listen", action="append", default=[])
    p.add_argument("--set", action="append", default=[], metavar="SECTION.KEY=VALUE")
    p.add_argument("--report", help="write the loop timing and advisory changes as JSON here at the end")
    p.add_argument("--mark", action="append", default=[], metavar="NAME=FILE",
                   help="timing split: when FILE appears, a phase NAME starts (for fault tests)")
    args = p.parse_args(argv)
    overrides = [f"vehicle.id={args.vehicle}", f'zenoh.mode="{args.mode}"',
                 f"zenoh.connect={json.dumps(args.connect)}", f"zenoh.listen={json.dumps(args.listen)}", *args.set]
    sim = SimVehicle(load_config(overrides=overrides), args.scenario, args.start, args.end, args.speed)
    signal.signal(signal.SIGTERM, lambda *_: sim.stop.set())
    marks: dict[str, float] = {}
    pending = dict(m.split("=", 1) for m in args.mark)
    print(json.dumps({"ready": True, "vehicle": args.vehicle}), flush=True)
    sim.start()
    t0 = time.monotonic()
    import os

    while not sim.done.wait(0.02):
        for name, path in list(pending.items()):
            if os.path.exists(path):
                marks[name] = time.monotonic() - t0
                del pending[name]
    sim.close()
    report = {
        "vehicle": args.vehicle,
        "marks_s": marks,
        "ticks": len(sim.ticks),
        "timing_all": sim.timing(),
        "publish_call": _percentiles(sim.publish_calls),
        "bus": dict(sim.bus.stats),
        "changes": [{"intruder": str(a.intruder), "level": a.level.name, "time_s": a.time_s,
                     "ra_sense": a.ra_sense, "wall_s": w} for w, a in sim.changes],
        "ticks_raw": [[round(ws, 4), round(w, 6), round(lat, 6)] for ws, w, lat in sim.ticks],
    }
    if args.report:
        with open(args.report, "w") as fh:
            json.dump(report, fh)
    return 0


if __name__ == "__main__":
    sys.exit(main())
