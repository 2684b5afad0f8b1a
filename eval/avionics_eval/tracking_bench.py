"""Tracking benchmark: microseconds per track update of the vectorised IMM against filterpy's IMMEstimator.

    python -m avionics_eval.tracking_bench [--sizes 1,10,100,1000] [--cycles 30]

Prints JSON. Timings, all in this process, on the same machine, in one run, each for the numpy reference and
the compiled kernels (tracking/kernels.py; `compiled` needs AVIONICS_COMPILED unset or 1, and a warm cache):

- `bank`: ImmBank.update + commit for N tracks per cycle, on Hwang's CV/CT models (eqs 16-19, 6 states,
  position + velocity measured), the standard likelihood; us per track update = cycle time / N.
- `update`: ImmTracker._update of one report per track: the measurement arrays, both banks' IMM cycles, the
  plausibility test and the chi-square gate, the commit (compiled: one fused kernel call); us per report.
- `predict`: ImmTracker.predict of the N tracks to a time 0.5 s on (what every assessment calls); us per track.
- `ingest`: ImmTracker.ingest_many of one ADS-B report per track (default IMM modes: horizontal CV/CT and
  vertical CH/CAD banks, chi-square gating, the integrity monitor, lifecycle bookkeeping); us per report.
- `filterpy`: IMMEstimator.predict() + update(z) with KalmanFilters holding the very same F, Q, H, R and
  transition matrix; one track at a time (it has no batch form), so its cost per update does not depend on N.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import time
from collections import Counter

import numpy as np

from avionics.compose import build_tracker
from avionics.config import load_config
from avionics.base import jit
from avionics.base.types import AddressSource, AltitudeDatum, IntruderKey, IntruderReport
from avionics.tracking import models
from avionics.tracking.imm import ImmBank

SIGMA = np.array([50.0, 50.0, 3.0, 3.0])  # Hwang's example: 50 m, 3 m/s
MODES = [models.ConstantVelocity(0.05), models.CoordinatedTurn(3.0)]


CLOCK = time.process_time  # CPU time of this process: robust to other processes sharing the cores


def _best(fn, repeats: int = 5) -> float:
    """Best of `repeats` CPU-time measurements of fn()."""
    best = float("inf")
    for _ in range(repeats):
        t0 = CLOCK()
        fn()
        best = min(best, CLOCK() - t0)
    return best


def bench_bank(n: int, cycles: int, compiled: bool | None = None) -> float:
    rng = np.random.default_rng(n)
    bank = ImmBank(MODES, 4, models.switching_matrix(2, 0.05), capacity=n, compiled=compiled)
    slots = np.arange(n)
    x0 = np.zeros((n, 6))
    x0[:, 2] = 200.0
    bank.init(slots, x0, np.diag(np.r_[SIGMA**2, 9.0, 9.0]))
    r = np.broadcast_to(SIGMA**2, (n, 4))
    mask = np.ones((n, 4), bool)
    zs = [np.c_[200.0 * k + rng.normal(0, 50, n), rng.normal(0, 50, n), 200 + rng.normal(0, 3, n),
                rng.normal(0, 3, n)] for k in range(1, cycles + 1)]
    dts = [rng.uniform(0.8, 1.2, n) for _ in zs]  # irregular ADS-B intervals: every track its own F, Q

    def run():
        for z, dt in zip(zs, dts):
            bank.commit(bank.update(slots, dt, z, mask, r))

    return _best(run) / (cycles * n) * 1e6


def _reports(n: int, t: float, rng) -> tuple[list, np.ndarray, np.ndarray]:
    times = t + rng.uniform(-0.2, 0.2, n)  # irregular report times
    reps = [IntruderReport(IntruderKey(0x100000 + i, AddressSource.ES1090), times[i], times[i], 0.0, 0.0,
                           1000.0 + rng.normal(0, 5), AltitudeDatum.PRESSURE,
                           (100.0 + rng.normal(0, 1), rng.normal(0, 1)), rng.normal(0, 0.5)) for i in range(n)]
    easts = 100.0 * t + 1000.0 * np.arange(n) + rng.normal(0, 20, n)
    norths = rng.normal(0, 20, n)
    return reps, easts, norths


def _tracker(config, n: int, compiled: bool | None):
    tracker = build_tracker(config, Counter(), capacity=n)
    if compiled is not None:
        tracker.compiled = compiled
    return tracker


def bench_tracker(n: int, cycles: int, filter_name: str = "imm", compiled: bool | None = None) -> float:
    """us per report of ImmTracker.ingest_many (compiled None: the configuration's default path)."""
    rng = np.random.default_rng(n)
    config = load_config(overrides=[f"tracking.filter={filter_name}"]).tracking
    batches = [_reports(n, float(k), rng) for k in range(cycles + 3)]

    def run():
        tracker = _tracker(config, n, compiled)
        tracker.ingest_many(*batches[0])  # initiation is not timed below
        t0 = CLOCK()
        for reps, e, no in batches[1:]:
            tracker.ingest_many(reps, e, no)
        return CLOCK() - t0

    return min(run() for _ in range(5)) / ((len(batches) - 1) * n) * 1e6


def bench_update_predict(n: int, cycles: int, compiled: bool | None = None) -> tuple[float, float]:
    """us per report of ImmTracker._update (both banks, the gate, the commit) and us per track of
    ImmTracker.predict, default configuration."""
    rng = np.random.default_rng(n)
    config = load_config().tracking
    batches = [_reports(n, float(k), rng) for k in range(cycles + 1)]
    best_update = best_predict = float("inf")
    for _ in range(5):
        tracker = _tracker(config, n, compiled)
        tracker.ingest_many(*batches[0])
        keys = [r.key for r in batches[0][0]]
        tracks = [tracker.tracks[k] for k in keys]
        spent = 0.0
        for reps, e, no in batches[1:]:
            t0 = CLOCK()
            tracker._update(tracks, reps, e, no)
            spent += CLOCK() - t0
        best_update = min(best_update, spent / (cycles * n))
        t0 = CLOCK()
        for k in range(cycles):
            tracker.predict(keys, cycles + 0.5 + 0.1 * k)
        best_predict = min(best_predict, (CLOCK() - t0) / (cycles * n))
    return best_update * 1e6, best_predict * 1e6


def bench_filterpy(updates: int) -> float:
    from filterpy.kalman import IMMEstimator, KalmanFilter

    rng = np.random.default_rng(0)
    h = np.eye(4, 6)
    filters = []
    for mode in MODES:
        f, _, q = mode.matrices(np.array([1.0]), np.zeros((1, 6)), None)
        kf = KalmanFilter(6, 4)
        kf.F, kf.Q, kf.H, kf.R = f[0], q[0], h, np.diag(SIGMA**2)
        kf.x = np.array([0.0, 0.0, 200.0, 0.0, 0.0, 0.0])
        kf.P = np.diag(np.r_[SIGMA**2, 9.0, 9.0])
        filters.append(kf)
    imm = IMMEstimator(filters, np.array([0.5, 0.5]), models.switching_matrix(2, 0.05))
    zs = [np.array([200.0 * k, 0, 200, 0]) + rng.normal(0, SIGMA) for k in range(1, updates + 1)]

    def run():
        for z in zs:
            imm.predict()
            imm.update(z)

    return _best(run) / updates * 1e6


def bench(sizes=(1, 10, 100, 1000), cycles: int = 30) -> dict:
    fp = bench_filterpy(max(200, cycles))
    out = {
        "unit": "microseconds of CPU time per track update or prediction (best of 5)",
        "machine": {"python": platform.python_version(), "numpy": np.__version__, "cpus": os.cpu_count(),
                    "load_1min": round(os.getloadavg()[0], 2), "compiled_kernels": jit.ENABLED},
        "models": "bank: Hwang CV (sigma 0.05 m/s^2) + CT Wiener-sequence (sigma 3 m/s^2), x/y/vx/vy measured; "
                  "update, predict, ingest: the default configuration (imm, cv + ct, ch + cad)",
        "filterpy_imm_estimator_us": round(fp, 2),
        "sizes": [],
    }
    paths = {"reference": False, "compiled": True} if jit.ENABLED else {"reference": False}
    for n in sizes:
        row: dict = {"tracks": n}
        for label, compiled in paths.items():
            b = bench_bank(n, cycles, compiled)
            u, p = bench_update_predict(n, max(5, cycles // 3), compiled)
            t = bench_tracker(n, max(5, cycles // 3), compiled=compiled)
            row[label] = {"bank_us": round(b, 2), "update_us": round(u, 2), "predict_us": round(p, 2),
                          "ingest_us": round(t, 2), "bank_vs_filterpy": round(fp / b, 1),
                          "update_vs_filterpy": round(fp / u, 1), "ingest_vs_filterpy": round(fp / t, 1)}
        if "compiled" in row:
            row["compiled_speedup"] = {k: round(row["reference"][k + "_us"] / row["compiled"][k + "_us"], 1)
                                       for k in ("bank", "update", "predict", "ingest")}
        out["sizes"].append(row)
    return out


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="python -m avionics_eval.tracking_bench", description=__doc__.split("\n")[0])
    parser.add_argument("--sizes", default="1,10,100,1000")
    parser.add_argument("--cycles", type=int, default=30)
    args = parser.parse_args(argv)
    print(json.dumps(bench([int(s) for s in args.sizes.split(",")], args.cycles), indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
