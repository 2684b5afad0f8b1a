"""Nuisance-alert study: `python -m avionics_eval.reports.nuisance [--encounters 500] [--seed 1]` prints JSON.

Random encounters at 3000 ft (TCAS SL 4) with ADS-B noise (avionics_sitl.impairments.DEFAULT): ownship northbound at
150 kt; an intruder from a random direction at 100-250 kt whose true closest approach at t = 60 s misses by a
horizontal distance uniform in [0, 2 x RA HMD] and a vertical one uniform in [-900, 900] ft, half of them level
and half climbing or descending through the CPA altitude. The same noisy reports feed the onboard core once
per alert criterion (advisory.criterion tcas, tcas+pc, pc), open loop.

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
import math

import numpy as np

from avionics.advisory.tables import load_profile
from avionics.config import load_config
from avionics.core.geodesy import LocalTangentPlane
from avionics.core.types import AddressSource, AdvisoryLevel, AltitudeDatum, IntruderKey, IntruderReport, OwnshipFix, OwnshipPressure
from avionics.core.units import FPM, FT, KT
from avionics.daa import Daa

CRITERIA = ("tcas", "tcas+pc", "pc")
T_CPA_S = 60.0
DURATION_S = 80.0
OWN_ALT_M = 3000 * FT
OWN_SPEED = 150 * KT
PLANE = LocalTangentPlane(47.4, 8.5)
KEY = IntruderKey(0xC0FFEE, AddressSource.ES1090)


def _encounter(rng, hmd_max_m):
    heading = rng.uniform(0, 2 * math.pi)
    speed = rng.uniform(100, 250) * KT
    v_own = np.array([0.0, OWN_SPEED])
    v_int = speed * np.array([math.sin(heading), math.cos(heading)])
    v_rel = v_int - v_own
    if np.hypot(*v_rel) < 20.0:  # nearly parallel and co-speed: no encounter in 60 s
        v_int = -v_int
        v_rel = v_int - v_own
    perp = np.array([-v_rel[1], v_rel[0]]) / np.hypot(*v_rel)
    hmd = rng.uniform(0, hmd_max_m)
    vmd = rng.uniform(-900, 900) * FT
    vrate = 0.0 if rng.random() < 0.5 else rng.choice([-1, 1]) * rng.uniform(500, 2000) * FPM
    own_cpa = v_own * T_CPA_S
    p_int0 = own_cpa + hmd * perp - v_int * T_CPA_S  # intruder position at t = 0
    z_int0 = OWN_ALT_M + vmd - vrate * T_CPA_S
    return dict(v_int=v_int, p0=p_int0, z0=z_int0, vrate=vrate, hmd=hmd, vmd=vmd)


def _truth_enters_ra_volume(e, level) -> bool:
    for k in range(int(DURATION_S * 10)):
        t = k / 10
        s = e["p0"] + e["v_int"] * t - np.array([0.0, OWN_SPEED * t])
        v = e["v_int"] - np.array([0.0, OWN_SPEED])
        sz, vz = e["z0"] + e["vrate"] * t - OWN_ALT_M, e["vrate"]
        r, sv = float(np.hypot(*s)), float(s @ v)
        if sv > 0:
            continue
        horizontal = r <= level.ra_dmod_m or (level.ra_dmod_m**2 - r * r) / sv <= level.ra_tau_s
        vertical = abs(sz) <= level.ra_zthr_m or (sz * vz < 0 and -sz / vz <= level.ra_tau_s)
        tc = max(0.0, -sv / float(v @ v))
        if horizontal and vertical and float(np.hypot(*(s + v * tc))) <= level.ra_hmd_m:
            return True
    return False


def _reports(e, rng):
    """Noisy inputs per 0.1 s step: ownship exact at 5 Hz, intruder through DEFAULT ADS-B impairments."""
    from avionics_sitl.impairments import DEFAULT
    from avionics_sitl.trajectory import KinematicState

    impair = DEFAULT.with_seed(int(rng.integers(2**31)))
    n_steps = int(DURATION_S * 10) + 1
    deliveries: dict[int, list] = {}
    phase = rng.uniform(0, 1)
    for k in range(int(DURATION_S)):
        t_rep = phase + k  # 1 Hz, time of applicability
        p = e["p0"] + e["v_int"] * t_rep
        lat, lon = PLANE.to_geodetic(p[0], p[1])
        rep = impair.impair(KinematicState(t_rep, float(lat), float(lon), e["z0"] + e["vrate"] * t_rep,
                                           float(e["v_int"][0]), float(e["v_int"][1]), e["vrate"]))
        if rep is not None:  # delivered after its latency, stamped on receipt as tslc is 0
            deliveries.setdefault(math.ceil((t_rep + rep.latency_s) * 10 - 1e-9), []).append(rep.state)
    steps = []
    for k in range(n_steps):
        t = round(k * 0.1, 6)
        inputs = []
        if k % 2 == 0:
            lat, lon = PLANE.to_geodetic(0.0, OWN_SPEED * t)
            inputs += [OwnshipFix(t, float(lat), float(lon), OWN_ALT_M, OWN_ALT_M, (OWN_SPEED, 0.0, 0.0)),
                       OwnshipPressure(t, OWN_ALT_M)]
        for s in deliveries.get(k, ()):
            inputs.append(IntruderReport(KEY, t, t, s.lat_deg, s.lon_deg, s.alt_msl_m, AltitudeDatum.PRESSURE,
                                         (s.vel_east_mps, s.vel_north_mps), s.vel_up_mps))
        steps.append((t, inputs))
    return steps


def study(n: int = 500, seed: int = 1, overrides=()) -> dict:
    rng = np.random.default_rng(seed)
    level = next(lvl for lvl in load_profile("tcas2").levels if lvl.sl == 4)
    configs = {c: load_config(overrides=[f'advisory.criterion="{c}"', *overrides]) for c in CRITERIA}
    counts = {c: {"issued": 0, "missed": 0, "nuisance": 0, "missed_within_protection": 0, "ta_issued": 0}
              for c in CRITERIA}
    entered_total = protected_outside = 0
    for _ in range(n):
        e = _encounter(rng, 2 * level.ra_hmd_m)
        entered = _truth_enters_ra_volume(e, level)
        outside = e["hmd"] > level.ra_hmd_m or abs(e["vmd"]) > level.alim_m
        entered_total += entered
        protected_outside += outside
        steps = _reports(e, rng)
        for criterion, config in configs.items():
            daa = Daa(config)
            levels = set()
            for t, inputs in steps:
                for change in daa.step(t, inputs).changes:
                    levels.add(change.level)
            ra = AdvisoryLevel.RA in levels
            c = counts[criterion]
            c["issued"] += ra
            c["ta_issued"] += AdvisoryLevel.TA in levels or ra
            c["missed"] += entered and not ra
            c["nuisance"] += ra and outside
            c["missed_within_protection"] += entered and not ra and not outside
    return {
        "report": "nuisance RAs under ADS-B noise", "encounters": n, "seed": seed,
        "sensitivity_level": 4, "ra_hmd_m": round(level.ra_hmd_m, 1), "alim_m": round(level.alim_m, 2),
        "truth_entered_ra_volume": entered_total, "truth_miss_outside_protection": protected_outside,
        "thresholds": {"pc_ta": configs["pc"].advisory.pc_ta_threshold, "pc_ra": configs["pc"].advisory.pc_ra_threshold},
        "criteria": counts,
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
