"""`avionics bench --soak SECONDS [--intruders N] [--zenoh | --no-zenoh]`: issue 13's "resident memory, 1000
intruders: report it; no growth in a 10-minute soak". Prints JSON; no test asserts its numbers.

A real `avionics run` child (capacity_bench.Onboard, as the capacity bench's memory run) is fed `avionics bench`'s
traffic (bench._traffic: ownship at 5 Hz, N intruders at 1 Hz, a third converging) over loopback UDP on the wall
clock for SECONDS, generated CHUNK_S seconds at a time so that a long soak does not hold it all in memory. Every
`sample_every_s` seconds (and once after the last datagram) its VmRSS and VmHWM (/proc/PID/status) and its CPU
time (/proc/PID/stat, user + system) are sampled. Parent and child are pinned to one core (bench.one_core), as in
the capacity bench.

Summary:
- `rss_first_quarter_mb` / `rss_last_quarter_mb`: the mean VmRSS of the samples taken in the first and in the
  last quarter of the soak;
- `rss_growth_mb_per_min`: the slope of a least-squares line through the VmRSS samples of the second half (after
  the tracks' start and the warm-up of caches and allocator pools), in MB per minute; null with fewer than two;
- `reports_sent` (by this process) and `reports_received` (the child's own `rx.adsb_vehicle` counter, read from
  its `--counters` output at a clean SIGTERM stop), `child_counters` all of them;
- `rss_peak_mb`: the largest VmHWM sampled (not the last one: the kernel reports max(the high-water mark it
  recorded, the current RSS) and records the mark only at some events, so a later VmHWM can be below an
  earlier VmRSS; the 600 s soak of docs/performance.md saw 277.91 then 277.85 MB);
- `kept_up`: every report sent was received and decoded by the child (a child that falls behind lets the
  socket's buffer overflow: the kernel drops datagrams and the count falls short);
- `child_cpu_load`: the child's CPU time over the soak's wall time; `send_lag_max_s`: how late this process sent
  its most delayed datagram (a sender that could not keep its own schedule would make the soak offer less).
"""

from __future__ import annotations

import math
import os
import platform
import time

import numpy as np

from avionics import __version__
from avionics_eval import bench as b
from avionics_eval.capacity_bench import Onboard, proc_memory_mb

CHUNK_S = 5  # traffic generated this many seconds at a time (whole seconds: bench._traffic's windows then tile)
CLOCK_TICKS = os.sysconf("SC_CLK_TCK")


def sample(pid: int, t_s: float) -> dict:
    """One sample of the child: seconds since the traffic started, VmRSS and VmHWM in MB, CPU seconds."""
    rss, hwm = proc_memory_mb(pid)
    with open(f"/proc/{pid}/stat") as f:
        stat = f.read()
    utime, stime = (int(x) for x in stat[stat.rindex(")") + 2:].split()[11:13])  # fields 14 and 15 of proc(5)
    return {"t_s": round(t_s, 3), "rss_mb": round(rss, 2), "hwm_mb": round(hwm, 2),
            "cpu_s": round((utime + stime) / CLOCK_TICKS, 2)}


def summarize(samples: list[dict], seconds: float) -> dict:
    """The quarters' mean RSS and the growth per minute fitted over the second half (module docstring)."""
    t = np.array([s["t_s"] for s in samples])
    rss = np.array([s["rss_mb"] for s in samples])
    first, last, half = t < seconds / 4, t >= seconds * 3 / 4, t >= seconds / 2
    slope = float(np.polyfit(t[half], rss[half], 1)[0]) * 60.0 if half.sum() >= 2 else None
    return {"rss_first_quarter_mb": round(float(rss[first].mean()), 2) if first.any() else None,
            "rss_last_quarter_mb": round(float(rss[last].mean()), 2) if last.any() else None,
            "rss_growth_mb_per_min": None if slope is None else round(slope, 4),
            "rss_growth_fit_samples": int(half.sum()),
            "rss_min_mb": round(float(rss.min()), 2), "rss_max_mb": round(float(rss.max()), 2)}


def soak(seconds: float, n: int = 1000, zenoh: bool = True, sample_every_s: float = 5.0, log=None) -> dict:
    """The soak of the module docstring."""
    with b.one_core() as pinned:
        load_start = [round(x, 2) for x in os.getloadavg()]
        onboard = Onboard(zenoh, duration_s=seconds + 600.0)  # stopped by SIGTERM, never by its own duration
        samples, sent, send_lag = [], 0, 0.0
        try:
            window = b._traffic(n, min(CHUNK_S, seconds))
            startup_s = onboard.first_reply_s(window[0][1])
            start = time.perf_counter()
            next_sample = 0.0

            def take(now: float) -> None:
                if onboard.proc.poll() is not None:
                    raise RuntimeError(f"avionics run exited with {onboard.proc.returncode} during the soak: "
                                       f"{onboard.proc.stderr.read()!r}")
                samples.append(sample(onboard.proc.pid, now))
                if log and len(samples) % 12 == 1:
                    log(f"soak: {samples[-1]} sent {sent}")

            for chunk_start in range(0, math.ceil(seconds), CHUNK_S):
                if chunk_start:
                    window = b._traffic(n, min(CHUNK_S, seconds - chunk_start), start=chunk_start)
                for t, data, is_report in window:
                    while True:
                        now = time.perf_counter() - start
                        if now >= next_sample:
                            take(now)
                            next_sample += sample_every_s
                            continue
                        if now >= t:
                            break
                        time.sleep(min(t, next_sample) - now)
                    onboard.sock.sendto(data, ("127.0.0.1", onboard.port))
                    send_lag = max(send_lag, now - t)
                    sent += is_report
            time.sleep(0.5)  # the last datagrams processed
            take(time.perf_counter() - start)
            wall_s = samples[-1]["t_s"]
        finally:
            counters = onboard.stop()
    received = counters.get("rx.adsb_vehicle", 0)
    return {
        "benchmark": "avionics bench --soak (issue 13: resident memory, no growth in a soak)",
        "version": __version__, "python": platform.python_version(), "machine": platform.machine(),
        "numpy": np.__version__, "pinned_to_one_core": pinned, "zenoh": zenoh, "intruders": n,
        "soak_s": seconds, "sample_every_s": sample_every_s,
        "load_average_at_start": load_start, "load_average_at_end": [round(x, 2) for x in os.getloadavg()],
        "startup_s": round(startup_s, 3),
        **summarize(samples, seconds),
        "rss_peak_mb": max(s["hwm_mb"] for s in samples),  # VmHWM as read can fall back: the kernel
        # reports max(its recorded high-water mark, the current RSS) and records the mark only at some events
        "reports_sent": sent, "reports_received": received, "kept_up": received == sent,
        "child_cpu_load": round((samples[-1]["cpu_s"] - samples[0]["cpu_s"]) / wall_s, 3) if wall_s > 0 else None,
        "send_lag_max_s": round(send_lag, 4),
        "child_counters": dict(sorted(counters.items())),
        "samples": samples,
    }
