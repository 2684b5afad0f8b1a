"""Overload benchmarks (JSON on stdout): framing throughput on garbage, and a garbage flood over real UDP.

    python -m avionics_eval.flood_bench framing [--reference OLD_framing.py] [--datagrams 40]
    python -m avionics_eval.flood_bench flood [--rate 1e6] [--size 8192] [--kind markers] [--repeat 1]
    python -m avionics_eval.flood_bench all

`framing`: FrameScanner.feed() on 64 KiB datagrams (UDP) and on the same bytes as a stream in 4 KiB chunks
(TCP/serial), per kind of input: uniform random bytes, bytes a quarter / half of which are 0xFD/0xFE, crafted
garbage made of plausible MAVLink 1/2 headers whose CRC fails (every candidate costs a CRC check), the same
packed 10 bytes apart each claiming a 200+ byte payload (the worst case: `crafted_dense`), and valid frames
back to back. Throughput in bytes/s and microseconds per datagram (median and max).
With --reference, a second FrameScanner implementation (e.g. the previous framing.py, from
`git show REV:avionics/io/framing.py > /tmp/framing_before.py`) is measured on the same bytes ("before").

`flood`: `avionics run` as a child process on udpin:127.0.0.1 (zenoh on a loopback port), the SITL head-on
encounter flown at 1x over UDP by this process (avionics_sitl.live.fly, no ADS-B impairments), once without and then
with a second process sending garbage datagrams to the same port at --rate bytes/s. Reported: the TA and RA
onsets in scenario time as received on the SITL side (COLLISION), their shift under the flood, the zenoh
status samples received during the run, and every datagram accounted for: sent = received by the process +
dropped by the kernel (SO_RXQ_OVFL); of those received, the ones the link dropped itself under overload.
Nothing here is asserted: these are measurements.
"""

from __future__ import annotations

import argparse
import importlib.util
import json
import os
import platform
import socket
import subprocess
import sys
import threading
import time
from collections import Counter

import numpy as np

import avionics.io  # noqa: F401  (MAVLink 2)
from pymavlink.dialects.v20 import common as mavlink2

from avionics import __version__

DATAGRAM = 65536
STREAM_CHUNK = 4096
KINDS = ("random", "markers_25", "markers_50", "crafted_headers", "crafted_dense", "valid_frames")


# -- inputs ------------------------------------------------------------------------------------------------
def _crafted(rng: np.random.Generator, size: int) -> bytes:
    """Plausible headers (known message id, a length the message can have, no unknown flag) with random
    payload and CRC: nothing is refused from its header, every candidate needs a CRC check."""
    from avionics.io.framing import KNOWN_MESSAGES  # the current table, whichever scanner is measured

    ids = [m for m in sorted(KNOWN_MESSAGES) if m < 256]
    out = bytearray()
    while len(out) < size:
        msgid = int(rng.choice(ids))
        full = KNOWN_MESSAGES[msgid].unpacker.size
        if rng.random() < 0.5:
            out += bytes([0xFD, int(rng.integers(1, full + 1)), 0, 0, int(rng.integers(256)), 1, 1, msgid, 0, 0])
            n = out[-9]
        else:
            out += bytes([0xFE, full, int(rng.integers(256)), 1, 1, msgid])
            n = full
        out += rng.integers(0, 256, n + 2, dtype=np.uint8).tobytes()
    return bytes(out[:size])


def _crafted_dense(rng: np.random.Generator, size: int) -> bytes:
    """The worst case found: MAVLink 2 headers back to back, 10 bytes apart, each of a message whose payload
    can be 200+ bytes and claiming all of it. Every candidate passes its header and costs a CRC over ~260 bytes
    (with pymavlink's decode before this change: a copy and a decode each)."""
    from avionics.io.framing import V2_MAX_PAYLOAD

    ids = [m for m, full in sorted(V2_MAX_PAYLOAD.items()) if full >= 200]
    out = bytearray()
    while len(out) < size:
        msgid = int(rng.choice(ids))
        out += bytes([0xFD, V2_MAX_PAYLOAD[msgid], 0, 0, int(rng.integers(256)), 1, 1]) + msgid.to_bytes(3, "little")
    return bytes(out[:size])


def _valid(rng: np.random.Generator, size: int) -> bytes:
    mav = mavlink2.MAVLink(None, srcSystem=1, srcComponent=1)
    out = bytearray()
    k = 0
    while len(out) < size:
        k += 1
        if k % 3:
            msg = mav.adsb_vehicle_encode(0x100000 + k % 997, 473000000 + k, 85000000 - k, 0, 1500000, 18000,
                                          6400, 0, b"FLOOD", 1, 0, 0x1FF, 1200)
        else:
            msg = mav.global_position_int_encode(k, 474000000, 85500000, 1500000, 1500000, 3000, 0, 0, 0)
        frame = msg.pack(mav)
        if len(out) + len(frame) > size:
            break
        out += frame
    return bytes(out)


def garbage(kind: str, size: int, seed: int) -> bytes:
    rng = np.random.default_rng(seed)
    if kind == "random":
        return rng.integers(0, 256, size, dtype=np.uint8).tobytes()
    if kind in ("markers_25", "markers_50"):
        share = 0.25 if kind == "markers_25" else 0.5
        data = rng.integers(0, 256, size, dtype=np.uint8)
        marked = rng.random(size) < share
        data[marked] = rng.choice(np.array([0xFD, 0xFE], dtype=np.uint8), int(marked.sum()))
        return data.tobytes()
    if kind == "crafted_headers":
        return _crafted(rng, size)
    if kind == "crafted_dense":
        return _crafted_dense(rng, size)
    if kind == "valid_frames":
        return _valid(rng, size)
    raise ValueError(f"unknown kind {kind!r}")


# -- framing ----------------------------------------------------------------------------------------------
def _load_scanner(path: str | None):
    if path is None:
        from avionics.io.framing import FrameScanner

        return FrameScanner
    spec = importlib.util.spec_from_file_location("framing_reference", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module.FrameScanner


def _measure(scanner_cls, datagrams: list[bytes]) -> dict:
    counters: Counter = Counter()
    scanner = scanner_cls(counters)
    times, cpu, frames = [], [], 0
    for data in datagrams:
        t0, c0 = time.perf_counter(), time.process_time()
        frames += len(scanner.feed(data, end_of_datagram=True))
        times.append(time.perf_counter() - t0)
        cpu.append(time.process_time() - c0)
    stream_counters: Counter = Counter()
    stream = scanner_cls(stream_counters)
    stream_frames = 0
    t0 = time.perf_counter()
    for data in datagrams:
        for k in range(0, len(data), STREAM_CHUNK):
            stream_frames += len(stream.feed(data[k:k + STREAM_CHUNK]))
    stream_s = time.perf_counter() - t0
    total = sum(len(d) for d in datagrams)
    us, cpu_us = np.array(times) * 1e6, np.array(cpu) * 1e6
    return {
        "datagram_bytes_per_s": round(total / sum(times)),
        "us_per_datagram_p50": round(float(np.percentile(us, 50)), 1),
        "us_per_datagram_max": round(float(us.max()), 1),
        # CPU time of this process: what the framing costs, without the time other processes took the core
        "cpu_bytes_per_s": round(total / max(sum(cpu), 1e-9)),
        "cpu_us_per_datagram_p50": round(float(np.percentile(cpu_us, 50)), 1),
        "stream_bytes_per_s": round(total / stream_s),
        "frames_decoded": frames,
        "stream_frames_decoded": stream_frames,
        "counters": dict(sorted(counters.items())),
    }


def framing_bench(reference: str | None = None, n_datagrams: int = 40, seed: int = 1) -> dict:
    implementations = {"after": _load_scanner(None)}
    if reference:
        implementations = {"before": _load_scanner(reference), **implementations}
    out = {}
    for i, kind in enumerate(KINDS):
        datagrams = [garbage(kind, DATAGRAM, seed * 1000 + 17 * i + k) for k in range(n_datagrams)]
        out[kind] = {name: _measure(cls, datagrams) for name, cls in implementations.items()}
        if "before" in out[kind]:
            out[kind]["speedup"] = round(out[kind]["after"]["datagram_bytes_per_s"]
                                         / out[kind]["before"]["datagram_bytes_per_s"], 1)
            out[kind]["cpu_speedup"] = round(out[kind]["after"]["cpu_bytes_per_s"]
                                             / out[kind]["before"]["cpu_bytes_per_s"], 1)
    return {"datagram_bytes": DATAGRAM, "datagrams_per_kind": n_datagrams, "stream_chunk_bytes": STREAM_CHUNK,
            "reference": reference, "kinds": out}


# -- flood over UDP -----------------------------------------------------------------------------------------
def _free_port(kind=socket.SOCK_STREAM) -> int:
    with socket.socket(socket.AF_INET, kind) as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _listening(port: int) -> bool:
    with socket.socket() as probe:
        return probe.connect_ex(("127.0.0.1", port)) == 0


def flooder(port: int, rate: float, size: int, seconds: float, kind: str, seed: int) -> dict:
    """Send garbage datagrams of `size` bytes to 127.0.0.1:port at `rate` bytes/s for `seconds` (paced on the
    wall clock, no burst catch-up beyond one datagram). 64 distinct datagrams are cycled."""
    pool = [garbage(kind, size, seed + k) for k in range(64)]
    sent = sent_bytes = errors = 0
    print("ready", flush=True)  # the encounter starts once the garbage flows
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as sock:
        start = time.monotonic()
        while True:
            now = time.monotonic() - start
            if now >= seconds:
                break
            due = rate * now
            if sent_bytes + size <= due + size:
                try:
                    sock.sendto(pool[sent % len(pool)], ("127.0.0.1", port))
                    sent += 1
                    sent_bytes += size
                except OSError:
                    errors += 1  # ENOBUFS etc.: not sent, so not a datagram the receiver could lose
                continue
            time.sleep(min(0.002, (sent_bytes + size - due) / rate))
        wall = time.monotonic() - start
    return {"datagrams": sent, "bytes": sent_bytes, "send_errors": errors, "seconds": round(wall, 3),
            "bytes_per_s": round(sent_bytes / wall)}


def _run_encounter(scenario_name: str, start_s: float, duration_s: float, flood: dict | None, seed: int,
                   node_root: str | None = None) -> dict:
    from avionics.io.zenoh_bus import open_session
    from avionics.config import ZenohConfig
    from avionics_sitl.impairments import PRESETS
    from avionics_sitl.live import fly
    from avionics_sitl.encounters import load_encounter

    scenario = load_encounter(scenario_name)
    port, zport = _free_port(socket.SOCK_DGRAM), _free_port()
    endpoint = f"tcp/127.0.0.1:{zport}"
    node = subprocess.Popen([
        sys.executable, "-m", "avionics.cli", "--quiet", "run", "--connection", f"udpin:127.0.0.1:{port}",
        "--set", f'zenoh.listen=["{endpoint}"]', "--duration", f"{duration_s + 30:.0f}", "--counters",
    ], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, cwd=node_root,
        env={**os.environ, "PYTHONPATH": node_root} if node_root else None)
    deadline = time.monotonic() + 60.0
    while not _listening(zport):
        if node.poll() is not None or time.monotonic() > deadline:
            node.kill()
            raise RuntimeError(f"avionics run did not start: {node.communicate()[1]}")
        time.sleep(0.05)
    session = open_session(ZenohConfig(listen=(), connect=(endpoint,)))
    lock = threading.Lock()
    status_times: list[float] = []  # monotonic receipt times of the zenoh status samples

    def on_status(sample) -> None:
        with lock:
            status_times.append(time.monotonic())

    subscriber = session.declare_subscriber("daa/*/status", on_status)
    flood_proc = None
    try:
        if flood is not None:
            flood_proc = subprocess.Popen([
                sys.executable, "-m", "avionics_eval.flood_bench", "_flood", "--port", str(port),
                "--rate", str(flood["rate"]), "--size", str(flood["size"]), "--seconds", f"{duration_s:.3f}",
                "--kind", flood["kind"], "--seed", str(seed)], stdout=subprocess.PIPE, text=True)
            if flood_proc.stdout.readline().strip() != "ready":
                raise RuntimeError("the garbage sender did not start")
        flight_start = time.monotonic()
        recording = fly(scenario, f"udpout:127.0.0.1:{port}", PRESETS["none"], start_s=start_s,
                        duration_s=duration_s)
        flight_end = time.monotonic()
        flood_sent = json.loads(flood_proc.communicate(timeout=60)[0].strip().splitlines()[-1]) \
            if flood_proc is not None else None
        time.sleep(1.0)  # the process drains its socket and backlog (the counters are read at its exit)
    finally:
        if flood_proc is not None and flood_proc.poll() is None:
            flood_proc.kill()
        node.terminate()
        out, err = node.communicate(timeout=30)
        subscriber.undeclare()
        session.close()
    counters = json.loads(out) if out.strip() else {}
    collisions = recording.of_type("COLLISION")

    def onset(level: int):
        times = [r.time_s for r in collisions if r.msg.threat_level == level]
        return round(times[0], 3) if times else None

    sent = recording.sent + (flood_sent["datagrams"] if flood_sent else 0)
    received = counters.get("link.datagrams")  # None: a node that does not count them (an older tree)
    kernel = counters.get("link.kernel_drops", 0) if received is not None else None
    with lock:  # status samples during the flight, and the longest time without one
        during = [t for t in sorted(status_times) if flight_start <= t <= flight_end]
    gaps = np.diff([flight_start, *during, flight_end])
    return {
        "ta_onset_s": onset(1), "ra_onset_s": onset(2),
        "encounter_datagrams_sent": recording.sent,
        "flood": flood_sent,
        "node_exit_code": node.returncode,
        "datagrams": {
            "sent": sent, "received": received, "kernel_drops": kernel,
            "unaccounted": sent - received - kernel if received is not None else None,
            "link_dropped_datagrams": counters.get("link.dropped_datagrams", 0),
            "link_dropped_bytes": counters.get("link.dropped_bytes", 0),
            "link_deferred_steps": counters.get("link.deferred", 0),
        },
        "rx": {k: v for k, v in counters.items() if k.startswith("rx.")},
        "frame": {k: v for k, v in counters.items() if k.startswith("frame.")},
        "zenoh_status_samples": len(during),
        "zenoh_status_max_gap_s": round(float(gaps.max()), 3),
        "zenoh_dropped": {k: v for k, v in counters.items() if k.startswith("zenoh.")},
        "stderr_tail": err.strip().splitlines()[-3:] if node.returncode not in (0, -15) else [],
    }


def flood_bench(rate: float = 1e6, size: int = 8192, kind: str = "markers_25", scenario: str = "head-on",
                start_s: float = 50.0, duration_s: float = 22.0, repeat: int = 1, seed: int = 7,
                node_root: str | None = None) -> dict:
    """node_root: run `avionics run` from another source tree (e.g. the previous commit, for a before/after)."""
    flood = {"rate": rate, "size": size, "kind": kind}
    runs = []
    for r in range(repeat):
        baseline = _run_encounter(scenario, start_s, duration_s, None, seed + r, node_root)
        flooded = _run_encounter(scenario, start_s, duration_s, flood, seed + r, node_root)
        shift = None
        if baseline["ra_onset_s"] is not None and flooded["ra_onset_s"] is not None:
            shift = round(flooded["ra_onset_s"] - baseline["ra_onset_s"], 3)
        runs.append({"baseline": baseline, "flooded": flooded, "ra_onset_shift_s": shift})
    shifts = [r["ra_onset_shift_s"] for r in runs]
    return {"scenario": scenario, "start_s": start_s, "duration_s": duration_s, "garbage": flood,
            "node_root": node_root,
            "ra_onset_shift_s": shifts, "ra_onset_shift_max_s": max(
                (abs(s) for s in shifts if s is not None), default=None),
            "every_datagram_accounted": all(r[k]["datagrams"]["unaccounted"] == 0 for r in runs
                                            for k in ("baseline", "flooded")),
            "runs": runs}


def _header() -> dict:
    return {"version": __version__, "python": platform.python_version(), "machine": platform.machine(),
            "cpus": os.cpu_count()}


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="python -m avionics_eval.flood_bench", description=__doc__.split("\n")[0])
    sub = parser.add_subparsers(dest="mode", required=True)
    for name in ("framing", "all"):
        p = sub.add_parser(name)
        p.add_argument("--reference", help="another framing.py to measure on the same bytes (before)")
        p.add_argument("--datagrams", type=int, default=40)
    for name in ("flood", "all"):
        p = sub.choices.get(name) if name == "all" else sub.add_parser(name)
        p.add_argument("--rate", type=float, default=1e6, help="garbage bytes per second")
        p.add_argument("--size", type=int, default=8192, help="bytes per garbage datagram (<= 65507)")
        p.add_argument("--kind", default="markers_25", choices=KINDS[:5])
        p.add_argument("--scenario", default="head-on")
        p.add_argument("--start", type=float, default=50.0, help="scenario time the flight starts at")
        p.add_argument("--duration", type=float, default=22.0)
        p.add_argument("--repeat", type=int, default=1)
        p.add_argument("--node-root", help="source tree to run `avionics run` from (default: this one)")
    p = sub.add_parser("_flood")  # the garbage sender (a child process of `flood`)
    p.add_argument("--port", type=int, required=True)
    p.add_argument("--rate", type=float, required=True)
    p.add_argument("--size", type=int, required=True)
    p.add_argument("--seconds", type=float, required=True)
    p.add_argument("--kind", required=True)
    p.add_argument("--seed", type=int, default=0)
    args = parser.parse_args(argv)
    if args.mode == "_flood":
        print(json.dumps(flooder(args.port, args.rate, args.size, args.seconds, args.kind, args.seed)))
        return 0
    result = {"benchmark": "overload: framing throughput and a garbage flood", **_header()}
    if args.mode in ("framing", "all"):
        result["framing"] = framing_bench(args.reference, args.datagrams)
    if args.mode in ("flood", "all"):
        result["flood"] = flood_bench(args.rate, args.size, args.kind, args.scenario, args.start, args.duration,
                                      args.repeat, node_root=args.node_root)
    print(json.dumps(result, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
