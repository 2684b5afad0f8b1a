"""Bands benchmark: microseconds per BandsEngine.compute call (all four kinds: track, ground speed, vertical
speed, altitude) with 1, 10 and 100 intruders, and the share of each kind. Prints one JSON object.

    python -m avionics_eval.bands_bench [--calls 20] [--seed 0]

The traffic: intruders on random bearings 2-12 km away, converging on the ownship (so that conflict, peripheral
and recovery bands are exercised), random vertical offsets within 600 m; one call per simulated second with the
whole picture flown on straight lines, so the engine's hysteresis runs as it would on board.
"""

from __future__ import annotations

import argparse
import datetime as _dt
import json
import math
import platform
import sys
import time

import numpy as np

from avionics.advisory.bands import BandsEngine, BandsParams
from avionics.advisory.tables import load_profile
from avionics.base.units import KT


def _traffic(rng, n):
    bearing = rng.uniform(0, 2 * math.pi, n)
    dist = rng.uniform(2000.0, 12000.0, n)
    pos = np.stack([dist * np.sin(bearing), dist * np.cos(bearing), 3000.0 + rng.uniform(-600, 600, n)], -1)
    aim = rng.normal(0.0, 0.3, n)  # heading roughly at the ownship
    gs = rng.uniform(100 * KT, 300 * KT, n)
    trk = bearing + math.pi + aim
    vel = np.stack([gs * np.sin(trk), gs * np.cos(trk), rng.uniform(-5, 5, n)], -1)
    return pos, vel


def run(n: int, calls: int, seed: int) -> dict:
    rng = np.random.default_rng(seed + n)
    pos, vel = _traffic(rng, n)
    own_p, own_v = np.array([0.0, 0.0, 3000.0]), np.array([0.0, 150 * KT, 0.0])
    ids = [f"ac{i}" for i in range(n)]
    levels = np.full(n, 2)
    engine = BandsEngine(BandsParams(), load_profile("daidalus-do365b-no-sum").alerter.levels)  # DO_365B_no_SUM.conf
    per_kind: dict[str, float] = {}
    inner = engine._kind_bands

    def timed(kind, *a):
        t0 = time.perf_counter()
        out = inner(kind, *a)
        per_kind[kind.name] = per_kind.get(kind.name, 0.0) + time.perf_counter() - t0
        return out

    engine._kind_bands = timed
    engine.compute(0.0, own_p, own_v, pos, vel, ids, levels)  # warm-up
    per_kind.clear()
    recoveries = 0
    t0 = time.perf_counter()
    for k in range(1, calls + 1):
        b = engine.compute(float(k), own_p + own_v * k, own_v, pos + vel * k, vel, ids, levels)
        recoveries += sum(b.recovery.values())
    total = time.perf_counter() - t0
    return {
        "intruders": n,
        "calls": calls,
        "us_per_call": round(total / calls * 1e6, 1),
        "us_per_call_by_kind": {k: round(v / calls * 1e6, 1) for k, v in per_kind.items()},
        "kinds_with_recovery_bands_per_call": round(recoveries / calls, 2),
    }


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--calls", type=int, default=20)
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args(argv)
    results = [run(n, args.calls, args.seed) for n in (1, 10, 100)]
    print(json.dumps({
        "benchmark": "avionics.advisory.bands.BandsEngine.compute (track, ground speed, vertical speed, altitude)",
        "date": _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds"),
        "command": " ".join(["python -m avionics_eval.bands_bench", *(argv if argv is not None else sys.argv[1:])]),
        "python": platform.python_version(),
        "numpy": np.__version__,
        "machine": platform.machine(),
        "results": results,
    }, indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
