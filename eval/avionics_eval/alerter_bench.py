"""Micro-benchmark of the DO-365 alerter by itself (issue 29 item 4): one call of `Alerter.alert` (every level's
detector and its alerting time, advisory/alerting.py) for N intruders, without and with SUM. Prints one JSON object.

    python -m avionics_eval.alerter_bench [--sizes 1,10,100] [--repeats 7] [--seed 0]

  do365       the `do365` profile's alerter (three WCV_TAUMOD levels, DO_365B_no_SUM.conf's volumes)
  do365b_sum  `daidalus-do365b-sum`'s (WCV_TAUMOD_SUM) with every pair's errors non-zero (ADS-B-like: 15 m,
              4 m, 1.5 m/s, 0.5 m/s before z-scores), so each call takes the SUM path

Pairs: converging traffic 2-12 km away within 600 ft (the conflict stage's test traffic, kernel_bench._traffic).
Timings: CPU time of this process (time.process_time), the best of --repeats, per call and per pair. DAIDALUS's
whole step (alerting and bands) for one intruder costs about 33 us on the same machine (issue 29, measured by an
outside harness): docs/performance.md sets the two side by side.
"""

from __future__ import annotations

import argparse
import datetime as _dt
import json
import platform
import sys

import numpy as np

from avionics.advisory.alerting import Encounter, wcv_alerter
from avionics.advisory.tables import load_profile
from avionics.conflict.cpa import pair_geometry
from avionics_eval.kernel_bench import _best_us, _traffic

ERRORS = (15.0, 4.0, 1.5, 0.5)  # SumData.errors sums (m, m, m/s, m/s): an ADS-B track's and a GNSS ownship's


def _encounter(rng, n: int, errors: bool) -> Encounter:
    rel, _ = _traffic(rng, n)
    g = pair_geometry(rel[:, 0:2], rel[:, 3:5], rel[:, 2], rel[:, 5])
    return Encounter(g, np.ones(n, bool), 0.0, True, np.tile(ERRORS, (n, 1)) if errors else None)


def run(sizes, repeats: int, seed: int) -> dict:
    out: dict = {"host": platform.node(), "python": platform.python_version(),
                 "utc": _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds"), "repeats": repeats}
    for name, profile, errors in (("do365", "do365", False), ("do365b_sum", "daidalus-do365b-sum", True)):
        prof = load_profile(profile)
        alerter, level = wcv_alerter(prof.alerter), prof.levels[0]
        out[name] = {}
        for n in sizes:
            enc = _encounter(np.random.default_rng(seed), n, errors)
            previous = np.zeros(n, int)
            us = _best_us(lambda: alerter.alert(enc, level, previous=previous), repeats)
            out[name][f"N{n}"] = {"us_per_call": round(us, 1), "us_per_pair": round(us / n, 2)}
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="python -m avionics_eval.alerter_bench", description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", default="1,10,100", help="pairs per call (default 1,10,100)")
    ap.add_argument("--repeats", type=int, default=7)
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args(argv)
    try:
        sizes = [int(x) for x in args.sizes.split(",")]
    except ValueError:
        ap.error(f"--sizes: comma-separated integers, got {args.sizes!r}")
    if not sizes or min(sizes) < 1 or args.repeats < 1:
        ap.error("--sizes and --repeats must be >= 1")
    print(json.dumps(run(sizes, args.repeats, args.seed), indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
