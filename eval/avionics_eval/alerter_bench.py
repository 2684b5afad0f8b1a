"""Micro-benchmark of the DO-365 alerter by itself (issue 29 item 4): one call of `Alerter.alert` (every level's
detector and its alerting time, advisory/alerting.py) for N intruders, without and with SUM, on the compiled path
(advisory/kernels.py wcv_alert_pairs) and on the numpy reference (jit.reference()). Prints one JSON object.

    python -m avionics_eval.alerter_bench [--sizes 1,10,100] [--repeats 7] [--seed 0]

  do365       the `do365` profile's alerter (three WCV_TAUMOD levels, DO_365B_no_SUM.conf's volumes)
  do365b_sum  `daidalus-do365b-sum`'s (WCV_TAUMOD_SUM) with every pair's errors non-zero (ADS-B-like: 15 m,
              4 m, 1.5 m/s, 0.5 m/s before z-scores), so each call takes the SUM path

Pairs: converging traffic 2-12 km away within 600 ft (the conflict stage's test traffic, kernel_bench._traffic).
Timings per path and size: p50 and p90 of single calls' wall time (time.perf_counter_ns, --calls of them after
one untimed call; the compiled kernels are loaded first, never compiled while timed), and us_per_call, the CPU
time (time.process_time) of the best of --repeats batches, per call and per pair. `one_intruder_p50_us` sums it
up beside DAIDALUS's whole step (alerting and bands) for one intruder, about 33 us on the same machine (issue 29,
measured by an outside harness): docs/performance.md sets the two side by side.
"""

from __future__ import annotations

import argparse
import datetime as _dt
import json
import platform
import sys
import time

import numpy as np

from avionics.advisory.alerting import Encounter, wcv_alerter
from avionics.advisory.tables import load_profile
from avionics.conflict.cpa import pair_geometry
from avionics.base import jit
from avionics_eval.kernel_bench import _best_us, _traffic

DAIDALUS_STEP_US = 33.0  # issue 29: DAIDALUS v2.0.4's whole step for one intruder, outside harness, this machine
ERRORS = (15.0, 4.0, 1.5, 0.5)  # SumData.errors sums (m, m, m/s, m/s): an ADS-B track's and a GNSS ownship's


def _encounter(rng, n: int, errors: bool) -> Encounter:
    rel, _ = _traffic(rng, n)
    g = pair_geometry(rel[:, 0:2], rel[:, 3:5], rel[:, 2], rel[:, 5])
    return Encounter(g, np.ones(n, bool), 0.0, True, np.tile(ERRORS, (n, 1)) if errors else None)


def _p50_p90_us(fn, calls: int) -> tuple[float, float]:
    """Median and 90th percentile of `calls` single fn() calls' wall time, in microseconds."""
    fn()
    samples = np.empty(calls)
    clock = time.perf_counter_ns
    for i in range(calls):
        t0 = clock()
        fn()
        samples[i] = clock() - t0
    p50, p90 = np.percentile(samples, [50, 90]) / 1e3
    return float(p50), float(p90)


def _timed(fn, n: int, repeats: int, calls: int) -> dict:
    p50, p90 = _p50_p90_us(fn, calls)
    us = _best_us(fn, repeats)
    return {"p50_us": round(p50, 2), "p90_us": round(p90, 2), "us_per_call": round(us, 2),
            "us_per_pair": round(us / n, 3)}


def run(sizes, repeats: int, seed: int, calls: int = 2000) -> dict:
    out: dict = {"host": platform.node(), "python": platform.python_version(),
                 "utc": _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds"), "repeats": repeats,
                 "calls": calls, "compiled_kernels": jit.ready(), "daidalus_step_us": DAIDALUS_STEP_US}
    p50 = {}
    for name, profile, errors in (("do365", "do365", False), ("do365b_sum", "daidalus-do365b-sum", True)):
        prof = load_profile(profile)
        alerter, level = wcv_alerter(prof.alerter), prof.levels[0]
        out[name] = {}
        for n in sizes:
            enc = _encounter(np.random.default_rng(seed), n, errors)
            previous = np.zeros(n, int)

            def call():
                return alerter.alert(enc, level, previous=previous)

            row = {}
            if jit.ready():
                row["compiled"] = _timed(call, n, repeats, calls)
            with jit.reference():
                row["reference"] = _timed(call, n, repeats, max(calls // 20, 50))
            out[name][f"N{n}"] = row
            if n == 1:
                p50[name] = row.get("compiled", row["reference"])["p50_us"]
    out["one_intruder_p50_us"] = p50
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="python -m avionics_eval.alerter_bench", description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", default="1,10,100", help="pairs per call (default 1,10,100)")
    ap.add_argument("--repeats", type=int, default=7)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--calls", type=int, default=2000, help="single calls timed for p50/p90 (default 2000)")
    args = ap.parse_args(argv)
    try:
        sizes = [int(x) for x in args.sizes.split(",")]
    except ValueError:
        ap.error(f"--sizes: comma-separated integers, got {args.sizes!r}")
    if not sizes or min(sizes) < 1 or args.repeats < 1 or args.calls < 1:
        ap.error("--sizes, --repeats and --calls must be >= 1")
    print(json.dumps(run(sizes, args.repeats, args.seed, args.calls), indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
