"""How long a loop thread is starved while the compiled kernels compile (issue 26 item 1, "no stall, ever"). Prints
one JSON object.

    python -m avionics_eval.kernel_stall_bench [--ways thread,child,warm] [--tick-ms 10]

Each way runs in a fresh interpreter with its own empty kernel cache (AVIONICS_CACHE_DIR in a temporary directory;
`warm` reuses the cache `child` filled, so list it after `child`). Its main thread ticks as the live loop waits on
its link: sleep --tick-ms, then a little numpy; the gaps between ticks are the loop's stalls. Meanwhile:

  thread  `jit.load()` on a thread of the same process: numba compiles there (the GIL is the loop's only rival)
  child   avionics/base/kernel_startup.py, as `avionics run` does it: a cache-only load on a thread, then
          `avionics warmup` in a child process at nice COMPILE_NICE, then the load from the now warm cache
  warm    the same on the warm cache: the load only

Reported per way: the ticks' largest and 99th-percentile gap (ms), the seconds until the kernels were loaded, and
the CPU seconds of the process (the child's are not in it). A cold compile costs tens of seconds of CPU: run it
once, not in a loop.
"""

from __future__ import annotations

import argparse
import datetime as _dt
import json
import os
import platform
import subprocess
import sys
import tempfile

WAYS = ("thread", "child", "warm")

_PROBE = r"""
import json, sys, threading, time
import numpy as np
from avionics.base import jit
from avionics.base.kernel_startup import KernelStartup

way, tick_s = sys.argv[1], float(sys.argv[2])
a = np.random.default_rng(0).standard_normal((6, 6))
cpu0, t0 = time.process_time(), time.monotonic()
gaps, last = [], time.monotonic()
with jit.deferred():  # as in `avionics run`
    if way == "thread":
        threading.Thread(target=jit.load, daemon=True).start()
        startup = None
    else:
        startup = KernelStartup()
        startup.after_step()  # starts the load (and, on a cold cache, the child)
    while not jit.loaded() and time.monotonic() - t0 < 600:
        time.sleep(tick_s)
        a = a @ a.T / np.abs(a).sum()  # a step's worth of small numpy
        now = time.monotonic()
        gaps.append(now - last)
        last = now
loaded_s = time.monotonic() - t0
if startup is not None:
    startup.close()
gaps.sort()
print(json.dumps({"loaded": jit.loaded(), "loaded_after_s": round(loaded_s, 2),
                  "max_gap_ms": round(1e3 * gaps[-1], 1) if gaps else None,
                  "p99_gap_ms": round(1e3 * gaps[int(0.99 * (len(gaps) - 1))], 1) if gaps else None,
                  "ticks": len(gaps), "cpu_s": round(time.process_time() - cpu0, 2)}))
"""


def measure(way: str, cache_dir: str, tick_ms: float) -> dict:
    env = {**os.environ, "AVIONICS_CACHE_DIR": cache_dir}
    env.pop("NUMBA_CACHE_DIR", None)
    env.pop("AVIONICS_COMPILED", None)
    out = subprocess.run([sys.executable, "-c", _PROBE, way, str(tick_ms / 1e3)], env=env, capture_output=True,
                         text=True, timeout=900)
    if out.returncode != 0:
        return {"error": out.stderr.strip().splitlines()[-1:] or ["exit %d" % out.returncode]}
    return json.loads(out.stdout.strip().splitlines()[-1])


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--ways", default=",".join(WAYS), help="comma-separated: " + ", ".join(WAYS))
    parser.add_argument("--tick-ms", type=float, default=10.0, help="the loop's sleep per tick (ms)")
    args = parser.parse_args(argv)
    ways = [w for w in args.ways.split(",") if w]
    bad = [w for w in ways if w not in WAYS]
    if bad:
        parser.error(f"--ways: unknown {bad}; choose from {', '.join(WAYS)}")
    res = {"bench": "kernel_stall", "utc": _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds"),
           "machine": platform.machine(), "cpus": os.cpu_count(), "python": platform.python_version(),
           "load_1min_before": round(os.getloadavg()[0], 2), "tick_ms": args.tick_ms, "ways": {}}
    with tempfile.TemporaryDirectory(prefix="avionics-stall-") as tmp:
        for way in ways:
            cache = os.path.join(tmp, "thread" if way == "thread" else "child")  # warm: the child's, filled
            res["ways"][way] = measure(way, cache, args.tick_ms)
    res["load_1min_after"] = round(os.getloadavg()[0], 2)
    print(json.dumps(res, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
