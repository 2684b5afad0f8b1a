"""Cost of `avionics evaluate --pilot guidance` against a pilot model: CPU seconds per encounter and profile, and
where the guidance path's time goes. Prints one JSON object.

    python -m avionics_eval.guidance_cost_bench [--encounters 20] [--profile small-uas] [--seed 28]
        [--model uncor_1200exclude_rotorcraft_v1p2.txt] [--ownship uav-survey] [--vehicle multirotor]

The same encounters (the Lincoln model and ownship given, the set's seed) are evaluated with the TCAS standard
pilot (evaluate.py's 1 Hz core and 0.1 s response) and through the guidance port (guided.py: sitl replay's
fast-time loop), after one warm-up encounter of each (numba's kernels, the configuration). Then the guidance path
is run once more under cProfile: its loop steps per encounter (the pilot path steps the core 96 times in 95 s)
and the profiled time's share of its parts (cumulative, as cProfile counts it; the profiler's own overhead
inflates the many small calls, so the shares are indicative).
"""

from __future__ import annotations

import argparse
import cProfile
import datetime as _dt
import json
import os
import platform
import pstats
import time

# (label, file suffix, function): the parts of sitl replay's loop whose cumulative time is reported
PARTS = (
    ("loop step (Daa.step, all of it)", "avionics/daa.py", "step"),
    ("  core pipeline (tracking, assessment, alerting, RAs)", "avionics/pipeline/daa_core.py", "_step"),
    ("  result and guidance (Daa._result)", "avionics/daa.py", "_result"),
    ("    guidance stage with ownship's velocity (Daa._guide)", "avionics/daa.py", "_guide"),
    ("scenario source: schedule, copter, framing and decoding (_ScheduleSource.__iter__)",
     "avionics_sitl/replay.py", "__iter__"),
    ("  MAVLink decoding into core inputs (MavlinkInput.decode)", "avionics/loop.py", "decode"),
    ("  simulated ArduCopter flight (SimCopter.fly)", "avionics_sitl/guided.py", "fly"),
    ("  mission and intruder trajectories (SampledTrajectory.state_at)", "avionics_sitl/trajectory.py", "state_at"),
    ("output ports: MAVLink out to the autopilot (MavlinkOut.publish)", "avionics/ports.py", "publish"),
    ("MAVLink schedule of the ADS-B reports (autopilot.schedule)", "avionics_sitl/autopilot.py", "schedule"),
    ("misses on the 0.1 s grid (replay._vertical_miss)", "avionics_sitl/replay.py", "_vertical_miss"),
    ("record (evaluate._record)", "avionics_eval/evaluation/evaluate.py", "_record"),
)


def _cpu(fn, items) -> float:
    t0 = time.process_time()
    for item in items:
        fn(item)
    return (time.process_time() - t0) / max(len(items), 1)


def guidance_cost(encounters: int, profile: str, seed: int, model: str, ownship: str, vehicle: str) -> dict:
    from avionics_eval.evaluation.evaluate import Conditions, evaluate
    from avionics_eval.evaluation.lincoln import LincolnSource

    source = LincolnSource.of(model, ownship)
    pilot = Conditions("do365-adsb", None, "standard")
    guided = Conditions("do365-adsb", None, "guidance", vehicle)
    items = [source.encounter(seed, i) for i in range(encounters + 1)]
    warm, items = items[0], items[1:]
    for conditions in (pilot, guided):  # numba's kernels and the configuration, once per process
        evaluate(warm, profile, (seed, warm.index), conditions=conditions)
    pilot_s = _cpu(lambda e: evaluate(e, profile, (seed, e.index), conditions=pilot), items)
    guided_s = _cpu(lambda e: evaluate(e, profile, (seed, e.index), conditions=guided), items)
    profiler = cProfile.Profile()
    profiler.enable()
    for e in items:
        evaluate(e, profile, (seed, e.index), conditions=guided)
    profiler.disable()
    stats = pstats.Stats(profiler).stats
    total = sum(tt for (_, _, tt, _, _) in stats.values())  # every function's own time: the profiled total
    parts, steps = {}, None
    for label, suffix, name in PARTS:
        found = [(cc, ct) for (path, _, func), (cc, _, _, ct, _) in stats.items()
                 if func == name and path.replace(os.sep, "/").endswith(suffix)]
        if found:
            parts[label] = round(sum(ct for _, ct in found) / total, 3)
            if name == "step" and suffix == "avionics/daa.py":
                steps = sum(cc for cc, _ in found) / len(items)
    return {
        "benchmark": "guidance_cost", "utc": _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds"),
        "python": platform.python_version(), "machine": platform.machine(), "load_average": os.getloadavg(),
        "encounters": len(items), "profile": profile, "source": source.name, "vehicle": vehicle,
        "surveillance": "do365-adsb",
        "cpu_s_per_encounter": {"pilot_standard": round(pilot_s, 4), "guidance": round(guided_s, 4)},
        "guidance_over_pilot": round(guided_s / pilot_s, 2) if pilot_s else None,
        "guidance_loop_steps_per_encounter": steps, "pilot_core_steps_per_encounter": 96,
        "guidance_profile_share": parts,
    }


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--encounters", type=int, default=20)
    p.add_argument("--profile", default="small-uas")
    p.add_argument("--seed", type=int, default=28)
    p.add_argument("--model", default="uncor_1200exclude_rotorcraft_v1p2.txt")
    p.add_argument("--ownship", default="uav-survey")
    p.add_argument("--vehicle", default="multirotor")
    args = p.parse_args(argv)
    if args.encounters < 1:
        p.error("--encounters must be at least 1")
    print(json.dumps(guidance_cost(args.encounters, args.profile, args.seed, args.model, args.ownship, args.vehicle),
                     indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
