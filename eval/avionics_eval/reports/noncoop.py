"""Traffic that does not broadcast, against DAIDALUS (issue 30's acceptance): first alerts from the ownship's own
sensors on NASA's published scenarios, beside DAIDALUS v2.0.4's on the true states.

Four runs per file (`sitl replay FILE --sensor ...`, no ADSB_VEHICLE):
- `radar exact`: the radar measuring exactly, all round (`--noise none`), profile daidalus-do365b-no-sum (its
  per-intruder alerter judges a sensor-only track by DWC_Non_Coop), against `first_alerts_noncoop.csv` (every
  intruder on DO-365B's DWC_Non_Coop): levels 1-3 within 1 s;
- `radar`: the DO-365 Appendix Q radar with its errors, missed detections and false returns, its field of regard
  (110 deg either side of the nose, +-15 deg elevation) and range limits (sitl/avionics_sitl/sensors.py RADAR), the
  same references and profile: within 3 s, counted only for intruders the radar sees from 10 s before DAIDALUS's
  first level 1 until it (an intruder behind the radar's field of regard is not the radar's to find);
- `active`: active surveillance (TCAS-like Mode C interrogation, Appendix Q: 1 Hz, 9-15 deg bearing), profile
  daidalus-tcas3d, against the TCAS3D rows of `first_alerts.csv`: TA and RA within 3 s, counted, as the radar's,
  only for intruders inside its field of regard (-15 to +20 deg elevation) and range for those 10 s.
- `active exact`: active surveillance measuring exactly, all round (`--noise none`: range, bearing and altitude
  exact, every scan detected), the same references and tolerance: what the tracks and the logic do where the
  sensor's errors are not in the way.
A first alert with no reference is "extra"; a reference with none of ours is "missed".

    python -m avionics_eval.reports.noncoop [--jobs 2] [--seed 0] [--markdown]
"""

from __future__ import annotations

import argparse
import csv
import json
import math
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

CONFORMANCE = Path(__file__).resolve().parents[3].parent / "shared" / "conformance" / "daidalus"
RUNS = {  # name -> (sensor, exact, profile, reference table, reference config, levels compared, tolerance s)
    "radar exact": ("radar", True, "daidalus-do365b-no-sum", "first_alerts_noncoop.csv", "DO_365B_no_SUM_non_coop",
                    (1, 2, 3), 1.0),
    "radar": ("radar", False, "daidalus-do365b-no-sum", "first_alerts_noncoop.csv", "DO_365B_no_SUM_non_coop",
              (1, 2, 3), 3.0),
    "active exact": ("active", True, "daidalus-tcas3d", "first_alerts.csv", "TCAS3D", (1, 2), 3.0),
    "active": ("active", False, "daidalus-tcas3d", "first_alerts.csv", "TCAS3D", (1, 2), 3.0),
}
SEEN_BEFORE_S = 10.0  # `radar`: the intruder in the field of regard this long before DAIDALUS's first level 1


def references(folder: Path, table: str, config: str) -> dict[str, list[dict]]:
    out: dict[str, list[dict]] = {}
    with open(folder / table, newline="") as fh:
        for row in csv.DictReader(fh):
            if row["config"] == config:
                out.setdefault(row["case_file"], []).append(row)
    return out


def first_levels(path: Path, sensor: str, exact: bool, profile: str, seed: int) -> dict[tuple[str, int], float]:
    """(aircraft name, level) -> our first time at or above that level."""
    from avionics.config import load_config
    from avionics_sitl.encounters import load_scenario
    from avionics_sitl.impairments import PRESETS
    from avionics_sitl.replay import replay

    config = load_config(overrides=[f"advisory.profile={profile}", "zenoh.enabled=false"])
    result = replay(load_scenario(str(path)), config, PRESETS["none" if exact else "default"], seed=seed,
                    sensors=(sensor,), exact_sensors=exact)
    first: dict[tuple[str, int], float] = {}
    for row in result.rows():
        for n in range(1, int(row["alert_level"]) + 1):
            first.setdefault((row["name"], n), float(row["time_s"]))
    return first


def sensor_sees(path: Path, name: str, t_s: float, kind: str) -> bool:
    """Whether the Appendix Q sensor `kind` (radar, active) sees the aircraft at every second from SEEN_BEFORE_S
    before t_s until t_s (its field of regard and range limits, sitl/avionics_sitl/sensors.py)."""
    import numpy as np

    from avionics_sitl.encounters import load_scenario
    from avionics_sitl.sensor_feed import _enu
    from avionics_sitl.sensors import MODELS, SimulatedSensor

    scenario = load_scenario(str(path))
    own_traj, trajs = scenario.trajectories()
    traj = trajs[[a.name for a in scenario.intruders].index(name)]
    sensor = SimulatedSensor(MODELS[kind], "0")
    for t in np.arange(max(0.0, t_s - SEEN_BEFORE_S), t_s + 1e-9, 1.0):
        own = _enu(own_traj, float(t))
        heading = math.atan2(own[3], own[4]) if math.hypot(own[3], own[4]) > 0.0 else 0.0
        if not sensor.in_view(own, heading, _enu(traj, float(t))[None])[0]:
            return False
    return True


def compare(run: str, case_file: str, rows: list[dict], ours: dict, folder: Path) -> list[dict]:
    """One line per (intruder, level): DAIDALUS's first time, ours, and the verdict (ok, late/early, missed,
    extra, not seen: outside the sensor's field of regard or range)."""
    sensor, exact, _, _, _, levels, tolerance = RUNS[run]
    out = []
    for row in rows:
        t1 = row["first_level1_sim_s"]
        unseen = not exact and t1 and not sensor_sees(folder / case_file, row["intruder"], float(t1), sensor)
        for level in levels:
            text = row[f"first_level{level}_sim_s"]
            theirs = float(text) if text else None
            mine = ours.pop((row["intruder"], level), None)
            if unseen:
                verdict = "not seen"
            elif theirs is None:
                verdict = "ok" if mine is None else "extra"
            elif mine is None:
                verdict = "missed"
            else:
                verdict = "ok" if abs(mine - theirs) <= tolerance else ("early" if mine < theirs else "late")
            if theirs is not None or mine is not None:
                out.append({"file": case_file, "intruder": row["intruder"], "level": level, "daidalus_s": theirs,
                            "ours_s": mine, "verdict": verdict})
    out += [{"file": case_file, "intruder": name, "level": level, "daidalus_s": None, "ours_s": t,
             "verdict": "extra"} for (name, level), t in ours.items() if level in levels]
    return out


def _one(job):
    run, case_file, folder, seed = job
    sensor, exact, profile, *_ = RUNS[run]
    return run, case_file, first_levels(folder / case_file, sensor, exact, profile, seed)


def report(folder: Path = CONFORMANCE, seed: int = 0, jobs: int = 2, runs=tuple(RUNS)) -> dict:
    refs = {run: references(folder, RUNS[run][3], RUNS[run][4]) for run in runs}
    work = [(run, case, folder, seed) for run in runs for case in sorted(refs[run])]
    with ProcessPoolExecutor(max_workers=jobs) as pool:
        done = list(pool.map(_one, work))
    lines = {run: [] for run in runs}
    for run, case_file, ours in done:
        lines[run] += compare(run, case_file, refs[run][case_file], ours, folder)
    summary = {}
    for run, rows in lines.items():
        judged = [r for r in rows if r["verdict"] != "not seen" and r["daidalus_s"] is not None]
        summary[run] = {"first_levels": len(judged), "within": sum(r["verdict"] == "ok" for r in judged),
                        "missed": sum(r["verdict"] == "missed" for r in rows),
                        "extra": sum(r["verdict"] == "extra" for r in rows),
                        "not_seen": sum(r["verdict"] == "not seen" for r in rows),
                        "tolerance_s": RUNS[run][6]}
    return {"seed": seed, "summary": summary, "lines": lines}


def markdown(res: dict) -> str:
    out = ["| run | first levels judged | within tolerance | missed | extra | outside the field of regard |",
           "|---|---|---|---|---|---|"]
    for run, s in res["summary"].items():
        share = s["within"] / s["first_levels"] if s["first_levels"] else float("nan")
        out.append(f"| {run} (±{s['tolerance_s']:g} s) | {s['first_levels']} | {s['within']} ({share:.0%}) | "
                   f"{s['missed']} | {s['extra']} | {s['not_seen']} |")
    out += ["", "| run | file | intruder | level | DAIDALUS s | ours s |", "|---|---|---|---|---|---|"]
    for run, rows in res["lines"].items():
        for r in rows:
            if r["verdict"] not in ("ok", "not seen"):
                out.append(f"| {run} | {r['file']} | {r['intruder']} | {r['level']} | {r['daidalus_s']} | "
                           f"{r['ours_s']} ({r['verdict']}) |")
    return "\n".join(out)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="python -m avionics_eval.reports.noncoop", description=__doc__.split("\n")[0])
    parser.add_argument("--folder", type=Path, default=CONFORMANCE, help="the DAIDALUS conformance data")
    parser.add_argument("--seed", type=int, default=0, help="the sensors' error draws")
    parser.add_argument("--jobs", type=int, default=2, help="replays in parallel")
    parser.add_argument("--run", action="append", choices=tuple(RUNS), help="only these runs (default: all)")
    parser.add_argument("--markdown", action="store_true", help="print the docs tables instead of the JSON")
    args = parser.parse_args(argv)
    if not (args.folder / "first_alerts_noncoop.csv").is_file():
        parser.error(f"no DAIDALUS conformance data at {args.folder}")
    res = report(args.folder, args.seed, args.jobs, tuple(args.run or RUNS))
    print(markdown(res) if args.markdown else json.dumps(res, indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
