"""Micro-benchmark of the conflict stage's compiled kernels against their numpy references (issue 13 item 1).
Prints one JSON object.

    python -m avionics_eval.kernel_bench [--sizes 1,100,1000] [--repeats 5] [--dblquad-pairs 5] [--seed 0]

Timings are CPU time of this process (time.process_time, which other jobs on a loaded machine inflate less than
wall time), the best of --repeats calls, divided by the pairs (or pair-timesteps) of a call:

  exact_pc        pc_exact over the pair-timesteps of the conflict stage's 61-step curves of N intruders (the
                  pipeline's inputs: the CV prediction of converging traffic), and over the acceptance grid of
                  tests/test_probability.py (axis ratios to 1000:1, R from 0.01 to 100 sigma); scipy dblquad at
                  1e-9 (avionics_eval.reports.conflict.dblquad_pc, epsabs 1e-13) on --dblquad-pairs of them
  pc_at_cpa       the TA and RA volumes at the CPA of N pairs, one call
  geometry        pair_geometry of N pairs
  curve           assess.conflict_probabilities without the Monte Carlo (the 61-step curve, its maximum and Hwang's
                  eq 24), N pairs
  alerter         the tcas2 alerter's TA and RA levels (advisory/alerting.py: TCAS3D tests, one kernel call each) of
                  N pairs
  pc_within       the conflict stage's Monte Carlo (prediction.pc_within_cv_mc, config.within_samples trajectories
                  over the 60 s lookahead) of min(N, 100) converging pairs

Every `compiled` number needs compiled kernels (AVIONICS_COMPILED unset or 1) and a warm cache (`avionics warmup`).
"""

from __future__ import annotations

import argparse
import datetime as _dt
import json
import math
import os
import platform
import sys
import time

import numpy as np

from avionics.advisory.alerting import Encounter, tcas2_alerter
from avionics.advisory.tables import TCAS_II_V71, select_level
from avionics.conflict import assess
from avionics.conflict import probability as prob
from avionics.conflict.cpa import pair_geometry, pair_geometry_reference
from avionics.conflict.params import ConflictConfig
from avionics.conflict.pc_at_cpa import pc_at_cpa, pc_at_cpa_reference
from avionics.conflict.prediction import (cv_relative_prediction, lookahead_times, pc_within_cv_mc,
                                         pc_within_cv_mc_reference)
from avionics.base import jit


def _best_us(fn, repeats: int, min_s: float = 0.02) -> float:
    """CPU microseconds of one fn() call: the best of `repeats` timings, each of enough calls to last min_s."""
    t0 = time.process_time()
    fn()  # once untimed (first-call dispatch), and to size the loops
    loops = max(1, int(min_s / max(time.process_time() - t0, 1e-6)))
    best = math.inf
    for _ in range(repeats):
        t0 = time.process_time()
        for _ in range(loops):
            fn()
        best = min(best, (time.process_time() - t0) / loops)
    return best * 1e6


def _traffic(rng, n):
    """Relative states (intruder - ownship) of N intruders 2-12 km away converging on the ownship within 600 m
    vertically, with covariances of an ADS-B track (tens of metres, a few m/s)."""
    bearing = rng.uniform(0, 2 * math.pi, n)
    dist = rng.uniform(2000.0, 12000.0, n)
    trk = bearing + math.pi + rng.normal(0.0, 0.2, n)
    gs = rng.uniform(30.0, 150.0, n)
    x = np.column_stack([dist * np.sin(bearing), dist * np.cos(bearing), rng.uniform(-600, 600, n),
                         gs * np.sin(trk), gs * np.cos(trk), rng.uniform(-5, 5, n)])
    a = rng.normal(size=(n, 6, 6)) * np.array([20, 20, 10, 1.5, 1.5, 0.7])[None, :, None]
    p = a @ np.swapaxes(a, 1, 2) / 6 + np.diag([50.0, 50.0, 20.0, 0.5, 0.5, 0.2])[None]
    return x, p


def _grid(rng, n):
    sig = 10 ** rng.uniform(-1, 1, n)
    ratio, ang = 10 ** rng.uniform(0, 3, n), rng.uniform(0, np.pi, n)
    c, s = np.cos(ang), np.sin(ang)
    rot = np.stack([np.stack([c, -s], -1), np.stack([s, c], -1)], -2)
    d = np.zeros((n, 2, 2))
    d[:, 0, 0], d[:, 1, 1] = sig**2, (sig / ratio) ** 2
    cov = rot @ d @ np.swapaxes(rot, 1, 2)
    r = sig * 10 ** rng.uniform(-2, 2, n)
    phi = rng.uniform(0, 2 * np.pi, n)
    mean = (r * rng.uniform(0, 3, n))[:, None] * np.column_stack([np.cos(phi), np.sin(phi)])
    return mean, cov, r


def _pair(reference_us, compiled_us, per) -> dict:
    out = {"reference_us": reference_us / per}
    if compiled_us is not None:
        out["compiled_us"] = compiled_us / per
        out["speedup"] = reference_us / compiled_us if compiled_us > 0 else None
    return out


def run(sizes, repeats: int, dblquad_pairs: int, seed: int) -> dict:
    compiled = jit.ENABLED
    cfg = ConflictConfig(within_samples=0)
    t = lookahead_times(cfg.lookahead_s, cfg.step_s)
    out = {"sizes": sizes, "compiled_kernels": compiled, "unit": "CPU microseconds per pair (per pair-timestep for "
                                                                  "exact_pc), best of repeats"}
    rng = np.random.default_rng(seed)

    # exact Pc: the curve's pair-timesteps and the acceptance grid
    exact = {}
    for n in sizes:
        x, p = _traffic(rng, n)
        mean, cov, _, _ = cv_relative_prediction(x, p, t, cfg.step_s, cfg.accel_sigma_h_mps2, cfg.accel_sigma_v_mps2)
        m, c = mean.reshape(-1, 2), cov.reshape(-1, 2, 2)
        r = np.full(m.shape[0], cfg.zone_radius_m)
        ref = _best_us(lambda: prob.pc_exact_reference(m, c, r), repeats)
        comp = _best_us(lambda: prob.pc_exact(m, c, r), repeats) if compiled else None
        exact[f"curve_N{n}"] = {"pair_timesteps": m.shape[0], **_pair(ref, comp, m.shape[0])}
    m, c, r = _grid(rng, 20_000)
    ref = _best_us(lambda: prob.pc_exact_reference(m, c, r), repeats)
    comp = _best_us(lambda: prob.pc_exact(m, c, r), repeats) if compiled else None
    exact["acceptance_grid"] = {"pairs": m.shape[0], **_pair(ref, comp, m.shape[0])}
    if dblquad_pairs:
        from avionics_eval.reports.conflict import dblquad_pc

        k = min(dblquad_pairs, m.shape[0])
        t0 = time.process_time()
        err = max(abs(dblquad_pc(m[i], c[i], r[i]) - prob.pc_exact(m[i:i + 1], c[i:i + 1], r[i])[0]) for i in range(k))
        dbl = (time.process_time() - t0) * 1e6 / k  # (the exact calls are noise beside dblquad)
        exact["dblquad_1e-9"] = {"pairs": k, "us_per_pair": dbl, "max_abs_difference": err,
                                 "speedup_reference": dbl / exact["acceptance_grid"]["reference_us"]}
        if compiled:
            exact["dblquad_1e-9"]["speedup_compiled"] = dbl / exact["acceptance_grid"]["compiled_us"]
    out["exact_pc"] = exact

    level = select_level(None, 3000.0, TCAS_II_V71)  # SL 5 (a TA and an RA volume)
    volumes = [(level.ta_dmod_m, level.ta_zthr_m), (level.ra_hmd_m or level.ra_dmod_m, level.alim_m)]
    alerter = tcas2_alerter()
    for name in ("pc_at_cpa", "geometry", "curve", "alerter", "pc_within"):
        out[name] = {}
    for n in sizes:
        x, p = _traffic(rng, n)
        has_alt = np.ones(n, bool)
        g = pair_geometry_reference(x[:, 0:2], x[:, 3:5], x[:, 2], x[:, 5])
        tc = g.t_cpa_s
        args = (x, p, tc, volumes, cfg.accel_sigma_h_mps2, cfg.accel_sigma_v_mps2, has_alt)
        ref = _best_us(lambda: pc_at_cpa_reference(*args), repeats)
        comp = _best_us(lambda: pc_at_cpa(*args), repeats) if compiled else None
        out["pc_at_cpa"][f"N{n}"] = _pair(ref, comp, n)
        gargs = (x[:, 0:2], x[:, 3:5], x[:, 2], x[:, 5])
        ref = _best_us(lambda: pair_geometry_reference(*gargs), repeats)
        comp = _best_us(lambda: pair_geometry(*gargs), repeats) if compiled else None
        out["geometry"][f"N{n}"] = _pair(ref, comp, n)

        def curve():
            return assess.conflict_probabilities(x, p, cfg, has_alt=has_alt)

        comp = _best_us(curve, repeats) if compiled else None
        with jit.reference():
            ref = _best_us(curve, repeats)
        out["curve"][f"N{n}"] = _pair(ref, comp, n)
        enc = Encounter(g, has_alt, np.zeros(n), np.ones(n, bool))
        comp = _best_us(lambda: alerter.alert(enc, level), repeats) if compiled else None
        with jit.reference():
            ref = _best_us(lambda: alerter.alert(enc, level), repeats)
        out["alerter"][f"N{n}"] = _pair(ref, comp, n)
        m = min(n, 100)
        xw = x[:m].copy()
        xw[:, 0:3] *= 0.1  # within reach of the zone during the lookahead: the samples are not all dropped at once
        wargs = (xw, p[:m], cfg.zone_radius_m, cfg.lookahead_s, cfg.step_s, cfg.accel_sigma_h_mps2,
                 cfg.accel_sigma_v_mps2, np.full(m, cfg.zone_half_height_m), ConflictConfig().within_samples)
        comp = _best_us(lambda: pc_within_cv_mc(*wargs, np.random.default_rng(1)), repeats, 0.0) if compiled else None
        ref = _best_us(lambda: pc_within_cv_mc_reference(*wargs, np.random.default_rng(1)), repeats, 0.0)
        out["pc_within"][f"N{m}"] = {"samples": wargs[-1], **_pair(ref, comp, m)}
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="python -m avionics_eval.kernel_bench", description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", default="1,100,1000", help="pairs per call (default 1,100,1000)")
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--dblquad-pairs", type=int, default=5, help="pairs integrated by scipy dblquad (0: none)")
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args(argv)
    res = run([int(s) for s in args.sizes.split(",")], args.repeats, args.dblquad_pairs, args.seed)
    res["meta"] = {"date_utc": _dt.datetime.now(_dt.timezone.utc).strftime("%Y-%m-%d %H:%M"),
                   "python": platform.python_version(), "numpy": np.__version__, "machine": platform.machine(),
                   "cpus": os.cpu_count(), "load_average": [round(v, 2) for v in os.getloadavg()],
                   "command": "python -m avionics_eval.kernel_bench "
                              + " ".join(sys.argv[1:] if argv is None else argv)}
    print(json.dumps(res, indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
