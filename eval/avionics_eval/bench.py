"""`avionics bench`: end-to-end throughput and report-to-advisory latency, in one process on one core.

Each report is a real MAVLink 2 ADSB_VEHICLE frame in its own datagram; the timed path is everything the
live process does with it: robust framing, validation, tracking, assessment, advisory state, COLLISION/
STATUSTEXT packing and zenoh publishing on a real (loopback, no scouting) session. Only the socket read is
left out. Two runs per intruder count:

- `per_report`: every datagram its own step, as fast as possible. Latency is the cost of one report from
  bytes to outputs sent; throughput is reports per second of wall time, ownship fixes and the 10 Hz full
  re-assessment included. The worst case for per-call overheads.
- `real_time`: the live loop (avionics/runner.py) at 1x: the traffic arrives on the wall clock and each
  step takes what has arrived since the last one, at most MAX_DATAGRAMS_PER_RECEIVE datagrams, as the link
  hands over its backlog. Latency is from a report's arrival to its outputs sent, queueing included;
  `cpu_load` is the busy fraction of the core: near 1 the process is saturated, and `lag_at_end_s` (how
  long after the last datagram arrived its step finished) says whether it kept up.
"""

from __future__ import annotations

import math
import os
import platform
import socket
import time
from collections import Counter
from contextlib import contextmanager
from dataclasses import dataclass

import numpy as np

import avionics.io  # noqa: F401
from pymavlink.dialects.v20 import common as mavlink2

from avionics import __version__
from avionics.config import load_config
from avionics.base.geodesy import LocalTangentPlane
from avionics.base.units import KT
from avionics.io.framing import FrameScanner
from avionics.io.link import MAX_DATAGRAMS_PER_RECEIVE
from avionics.io.zenoh_bus import ZenohBus
from avionics.daa import Daa
from avionics.loop import Batch, Loop, MavlinkInput
from avionics.ports import AdvisoryAnnouncements, MavlinkOut, ZenohOut

LAT0, LON0, ALT0 = 47.40, 8.55, 1500.0


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _traffic(n: int, seconds: float, seed: int = 1, rate_hz: float = 1.0, start: float = 0.0):
    """Pre-encoded datagrams (time, bytes, is_report): ownship at 5 Hz, n intruders at rate_hz each (1 Hz, as
    ADS-B; higher to offer more reports per second with the same tracks), staggered. `start`: the window
    [start, start + seconds) of the same traffic (same seed, same trajectories), so that a long run can be
    generated a window at a time; consecutive windows tile exactly when start * rate_hz and start * 5 are
    whole numbers."""
    rng = np.random.default_rng(seed)
    plane = LocalTangentPlane(LAT0, LON0)
    mav = mavlink2.MAVLink(None, srcSystem=1, srcComponent=1)
    own_v = 60 * KT
    bearing = rng.uniform(0, 2 * math.pi, n)
    distance = rng.uniform(2000.0, 15000.0, n)
    speed = rng.uniform(80, 250, n) * KT
    # A third converge on ownship (advisories happen), the rest fly random headings.
    heading = np.where(np.arange(n) % 3 == 0, bearing + math.pi, rng.uniform(0, 2 * math.pi, n))
    alt = ALT0 + rng.uniform(-300, 300, n)
    phase = rng.uniform(0, 1, n)
    events = []
    for k in range(int(start * 5), int((start + seconds) * 5)):
        t = k / 5.0
        lat, lon = plane.to_geodetic(0.0, own_v * t)
        msg = mav.global_position_int_encode(int(t * 1000), int(round(float(lat) * 1e7)),
                                             int(round(float(lon) * 1e7)), int(ALT0 * 1000), int(ALT0 * 1000),
                                             int(own_v * 100), 0, 0, 0)
        events.append((t, msg.pack(mav), False))
        events.append((t, mav.scaled_pressure_encode(int(t * 1000), 1013.25 * (1 - 2.25577e-5 * ALT0) ** 5.25588,
                                                     0.0, 1500).pack(mav), False))
    for i in range(n):
        t = (np.arange(int(start * rate_hz), int((start + seconds) * rate_hz)) + phase[i]) / rate_hz
        e = distance[i] * math.sin(bearing[i]) + speed[i] * math.sin(heading[i]) * t
        nn = distance[i] * math.cos(bearing[i]) + speed[i] * math.cos(heading[i]) * t
        lats, lons = plane.to_geodetic(e, nn)
        track_cdeg, speed_cms = int(math.degrees(heading[i]) % 360 * 100), int(speed[i] * 100)
        for tk, lat, lon in zip(t.tolist(), np.round(lats * 1e7).tolist(), np.round(lons * 1e7).tolist()):
            msg = mav.adsb_vehicle_encode(0x100000 + i, int(lat), int(lon), 0, int(alt[i] * 1000), track_cdeg,
                                          speed_cms, 0, b"BENCH", 1, 0, 0x1FF, 1200)
            events.append((tk, msg.pack(mav), True))
    events.sort(key=lambda e: e[0])
    return events


class _Sent:
    """Counts what the ports send: MAVLink packed for the wire, zenoh samples queued on the bus."""

    def __init__(self, bus: ZenohBus | None):
        self.count, self.bus = 0, bus
        self.mav = mavlink2.MAVLink(None, srcSystem=1, srcComponent=191)

    def mavlink(self, msg) -> None:
        msg.pack(self.mav)
        self.count += 1

    def zenoh(self, suffix: str, payload: dict) -> None:
        self.bus.publish(suffix, payload)
        self.count += 1


def _setup(n: int, seconds: float, port: int, zenoh: bool = True, rate_hz: float = 1.0):
    """The live loop's parts (avionics/runner.py) without the socket: MAVLink input, facade, MAVLink and zenoh
    ports (zenoh=False: MAVLink only, as `avionics run --no-zenoh`); the bench makes the batches."""
    overrides = [f'zenoh.listen=["tcp/127.0.0.1:{port}"]'] if zenoh else ["zenoh.enabled=false"]
    config = load_config(overrides=overrides)
    counters: Counter = Counter()
    bus = ZenohBus(config.zenoh, config.vehicle.id) if zenoh else None
    sent = _Sent(bus)
    mavlink = MavlinkInput(config, counters)
    advisories = AdvisoryAnnouncements.of(config)  # as avionics run wires the two ports
    ports = [MavlinkOut(sent.mavlink, config, advisories=advisories)] + (
        [ZenohOut(sent.zenoh, config, advisories=advisories)] if zenoh else [])
    loop = Loop(Daa(config, counters), mavlink, ports)
    return config, counters, loop, mavlink, FrameScanner(counters), bus, sent, _traffic(n, seconds, rate_hz=rate_hz)


def _close(bus: ZenohBus | None) -> None:
    if bus is not None:
        bus.close()


def _summary(loop: Loop, counters: Counter, lat_s: list[float], outputs: int) -> dict:
    lat_us = np.array(lat_s) * 1e6
    return {
        "latency_us_p50": round(float(np.percentile(lat_us, 50)), 1),
        "latency_us_p99": round(float(np.percentile(lat_us, 99)), 1),
        "latency_us_max": round(float(lat_us.max()), 1),
        "tracks": loop.daa.status(loop.now_s)["tracks"],
        "alerts_at_end": len(loop.last.active) if loop.last else 0,
        "outputs": outputs,
        "rejected": sum(v for k, v in counters.items() if not k.startswith(("rx.", "track.", "assessment."))),
    }


def _run_per_report(n: int, seconds: float, port: int, zenoh: bool = True) -> dict:
    config, counters, loop, mavlink, scanner, bus, sent, events = _setup(n, seconds, port, zenoh)
    latencies = []
    wall_start = time.perf_counter()
    for t, data, is_report in events:
        t0 = time.perf_counter()
        loop.last = loop.step(Batch(t, mavlink.decode(scanner.feed(data, end_of_datagram=True), t)))
        if is_report:
            latencies.append(time.perf_counter() - t0)
    wall = time.perf_counter() - wall_start
    _close(bus)
    return {"intruders": n, "simulated_s": seconds, "reports": len(latencies), "wall_s": round(wall, 3),
            "reports_per_s": round(len(latencies) / wall, 1), "realtime_factor": round(seconds / wall, 2),
            **_summary(loop, counters, latencies, sent.count)}


@dataclass
class LiveRun:
    """What drive_real_time measured: per report its arrival and when its step finished (s since start)."""

    arrived_s: np.ndarray
    done_s: np.ndarray
    busy_s: float
    steps: int
    largest_batch: int
    wall_s: float
    last_event_s: float
    aborted: bool = False  # stopped once a report's lag passed abort_lag_s (the rest never processed)

    @property
    def latencies_s(self) -> np.ndarray:
        return self.done_s - self.arrived_s


def drive_real_time(loop: Loop, mavlink: MavlinkInput, scanner: FrameScanner, events, tick: float,
                    abort_lag_s: float = math.inf) -> LiveRun:
    """The live loop (avionics/runner.py) on the wall clock: the events arrive at their times and each step takes
    what has arrived since the last one, at most MAX_DATAGRAMS_PER_RECEIVE datagrams, as the link hands over its
    backlog; a step at least every tick. Ends when the last event's step is done, or (aborted) after the step
    that answered a report more than abort_lag_s after its arrival."""
    arrived, done, busy, steps, biggest = [], [], 0.0, 0, 0
    i = 0
    start = time.perf_counter()
    last_step = 0.0
    while i < len(events):
        now = time.perf_counter() - start
        if events[i][0] > now:  # the link's select(): wake on the next datagram or after one tick
            wake = min(events[i][0], last_step + tick)
            if wake > now:
                time.sleep(wake - now)
            now = time.perf_counter() - start
        t0 = time.perf_counter()
        msgs, batch, first = [], [], i
        while i < len(events) and events[i][0] <= now and i - first < MAX_DATAGRAMS_PER_RECEIVE:
            t, data, is_report = events[i]
            msgs.extend(scanner.feed(data, end_of_datagram=True))
            if is_report:
                batch.append(t)
            i += 1
        loop.last = loop.step(Batch(now, mavlink.decode(msgs, now)))
        t1 = time.perf_counter()
        busy += t1 - t0
        steps += 1
        biggest = max(biggest, len(batch))
        arrived.extend(batch)
        done.extend([t1 - start] * len(batch))
        last_step = now
        if batch and t1 - start - batch[0] > abort_lag_s:
            break
    wall = time.perf_counter() - start
    return LiveRun(np.array(arrived), np.array(done), busy, steps, biggest, wall, events[-1][0] if events else 0.0,
                   aborted=i < len(events))


def _run_real_time(n: int, seconds: float, port: int, zenoh: bool = True, rate_hz: float = 1.0) -> dict:
    config, counters, loop, mavlink, scanner, bus, sent, events = _setup(n, seconds, port, zenoh, rate_hz)
    run = drive_real_time(loop, mavlink, scanner, events, 1.0 / config.advisory.assessment_hz)
    _close(bus)
    return {"intruders": n, "simulated_s": seconds, "reports": len(run.arrived_s), "wall_s": round(run.wall_s, 3),
            "cpu_load": round(run.busy_s / run.wall_s, 3),
            "lag_at_end_s": round(max(0.0, run.wall_s - run.last_event_s), 3),
            "steps": run.steps, "largest_batch": run.largest_batch,
            **_summary(loop, counters, run.latencies_s.tolist(), sent.count)}


@contextmanager
def one_core():
    """Pinned to one core, as on a companion computer; the caller's affinity is restored afterwards. Yields
    whether the pinning worked (not on every platform)."""
    try:
        cores = os.sched_getaffinity(0)
        os.sched_setaffinity(0, {min(cores)})
    except (AttributeError, OSError):
        cores = None
    try:
        yield cores is not None
    finally:
        if cores is not None:
            os.sched_setaffinity(0, cores)


WARMUP_INTRUDERS, WARMUP_SECONDS = 10, 5.0  # one short unmeasured run first (see bench)


def bench(intruder_counts: list[int], seconds: float) -> dict:
    """Pinned to one core (one_core). A short per-report run is made first and thrown away: the first run of a
    process pays the one-time costs (kernels loaded from the disk cache, imports, the zenoh session's first
    declarations, ~2 s), which would otherwise land in the first row's latencies."""
    with one_core() as pinned:
        _run_per_report(WARMUP_INTRUDERS, WARMUP_SECONDS, _free_port())
        return {
            "benchmark": "end-to-end ADSB_VEHICLE -> advisory, in-process",
            "version": __version__,
            "python": platform.python_version(),
            "machine": platform.machine(),
            "pinned_to_one_core": pinned,
            "per_report": [_run_per_report(n, seconds, _free_port()) for n in intruder_counts],
            "real_time": [_run_real_time(n, seconds, _free_port()) for n in intruder_counts],
        }
