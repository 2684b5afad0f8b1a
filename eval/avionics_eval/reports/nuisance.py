"""Nuisance-alert study: `python -m avionics_eval.reports.nuisance [--encounters 500] [--seed 1]` prints JSON.

Encounters of the evaluation machinery (avionics_eval.evaluation, docs/evaluation.md) drawn from a narrow model:
ownship level at 3000 ft (TCAS SL 4) at 150 kt; an intruder from a random direction at 100-250 kt whose true
closest approach misses by a horizontal distance uniform in [0, 2 x RA HMD] and a vertical one uniform in
[-900, 900] ft, half of them level and half climbing or descending through the CPA altitude; no manoeuvres.
Each is evaluated once per alert criterion (advisory.criterion tcas, tcas+pc, pc) with the same ADS-B reports
(avionics_sitl.impairments.DEFAULT, the encounter's seed), the core stepped at 1 Hz.

  issued    an RA was issued
  missed    the true (noise-free) relative motion entered the RA volume (the TCAS II RA tests held on truth)
            and no RA was issued
  nuisance  an RA was issued although the true miss was outside the RA's protection (HMD > RA HMD filter or
            |VMD| > ALIM)
  missed_within_protection  missed, and the true miss was inside the protection (the dangerous misses)
"""

from __future__ import annotations

import argparse
import json

import numpy as np

from avionics.advisory.tables import load_profile
from avionics.config import load_config
from avionics.base.units import FT
from avionics_eval.evaluation.evaluate import evaluate
from avionics_eval.evaluation.generator import Model, generate

CRITERIA = ("tcas", "tcas+pc", "pc")
ALTITUDE_FT = 3000.0


def model(level) -> Model:
    """The study's encounter model around the SL's RA protection."""
    return Model(layers_ft=((ALTITUDE_FT, ALTITUDE_FT),), own_speed_kt=(150.0, 150.0), int_speed_kt=(100.0, 250.0),
                 hmd_max_ft=2 * level.ra_hmd_m / FT, vmd_max_ft=900.0, min_closure_mps=20.0, own_p_level=1.0,
                 int_p_level=0.5, p_turn=0.0, p_accel=0.0, p_vchange=0.0)


def _truth_enters_ra_volume(encounter, level) -> bool:
    """The TCAS II RA tests (range or modified tau, altitude or vertical tau, HMD filter) on the true relative
    motion at any 0.1 s sample while closing."""
    _, own, intruder = encounter.truth()
    s, v = intruder[:, :2] - own[:, :2], intruder[:, 3:5] - own[:, 3:5]
    sz, vz = intruder[:, 2] - own[:, 2], intruder[:, 5] - own[:, 5]
    r2, sv, vv = (s * s).sum(axis=1), (s * v).sum(axis=1), (v * v).sum(axis=1)
    closing = sv < 0
    with np.errstate(divide="ignore", invalid="ignore"):
        horizontal = (r2 <= level.ra_dmod_m**2) | ((level.ra_dmod_m**2 - r2) / sv <= level.ra_tau_s)
        vertical = (np.abs(sz) <= level.ra_zthr_m) | ((sz * vz < 0) & (-sz / vz <= level.ra_tau_s))
    tc = np.maximum(0.0, -sv / np.where(vv > 0, vv, 1.0))
    hmd = np.hypot(s[:, 0] + v[:, 0] * tc, s[:, 1] + v[:, 1] * tc)
    return bool(np.any(closing & horizontal & vertical & (hmd <= level.ra_hmd_m)))


def study(n: int = 500, seed: int = 1, overrides=()) -> dict:
    level = next(lvl for lvl in load_profile("tcas2").levels if lvl.sl == 4)
    m = model(level)
    counts = {c: {"issued": 0, "missed": 0, "nuisance": 0, "missed_within_protection": 0, "ta_issued": 0}
              for c in CRITERIA}
    entered_total = protected_outside = 0
    for index in range(n):
        e = generate(seed, index, m)
        entered = _truth_enters_ra_volume(e, level)
        outside = e.hmd_m > level.ra_hmd_m or abs(e.vmd_m) > level.alim_m
        entered_total += entered
        protected_outside += outside
        for criterion in CRITERIA:
            settings = (f'advisory.criterion="{criterion}"', *overrides)
            record = evaluate(e, "tcas2", (seed, index), settings)
            ra = record["ra"]
            c = counts[criterion]
            c["issued"] += ra
            c["ta_issued"] += record["alerted"]
            c["missed"] += entered and not ra
            c["nuisance"] += ra and outside
            c["missed_within_protection"] += entered and not ra and not outside
    config = load_config(overrides=['advisory.criterion="pc"', *overrides])
    thresholds = {"pc_ta": config.advisory.pc_ta_threshold, "pc_ra": config.advisory.pc_ra_threshold}
    return {
        "report": "nuisance RAs under ADS-B noise", "encounters": n, "seed": seed,
        "sensitivity_level": 4, "ra_hmd_m": round(level.ra_hmd_m, 1), "alim_m": round(level.alim_m, 2),
        "truth_entered_ra_volume": entered_total, "truth_miss_outside_protection": protected_outside,
        "thresholds": thresholds, "criteria": counts,
    }


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="python -m avionics_eval.reports.nuisance")
    parser.add_argument("--encounters", type=int, default=500)
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--set", action="append", default=[], help="config override for every criterion")
    args = parser.parse_args(argv)
    print(json.dumps(study(args.encounters, args.seed, args.set), indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
