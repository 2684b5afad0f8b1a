"""What a whole step and an evaluated encounter cost, per profile (issue 32 item 4; `avionics bench --step`), beside
filterpy's IMM step as the reference that travels between machines. Prints one JSON object.

    avionics bench --step [--profiles tcas2,do365,daidalus-do365b-sum] [--encounters 40] [--seed 1]
    python -m avionics_eval.step_bench ...        # the same

- `one_intruder_step_us`: `Daa.step` for one intruder as `avionics evaluate` steps it: once a second, the ownship's
  fix and pressure and the intruder's ADS-B report in, tracking, assessment, alerting and the advisory state
  out (the evaluation's configuration: zenoh off, the guidance bands off). p50 and p90 of every step's wall time
  (time.perf_counter_ns) over the encounters, after a warm-up encounter (the compiled kernels are loaded then,
  never while timed). DAIDALUS's whole step (states in, alerting) is about 33 us for one intruder on this
  machine (issue 29, an outside harness).
- `evaluation_cpu_ms_per_encounter`: `avionics evaluate`'s CPU time (time.process_time) per encounter and profile,
  the record included, over the same encounters (our encounter model, evaluation/generator.py, seed --seed).
- `filterpy_imm_step_us`: filterpy's IMMEstimator predict and update (tracking_bench.bench_filterpy).

Targets (issue 32; the benchmark prints, no test asserts a time): one intruder's step <= 33 us; an evaluated
encounter <= 8 ms (tcas2), <= 15 ms (do365).
"""

from __future__ import annotations

import argparse
import datetime as _dt
import json
import os
import platform
import sys
import time

import numpy as np

from avionics.daa import Daa

TARGETS = {"one_intruder_step_us": 33.0, "evaluation_cpu_ms_per_encounter": {"tcas2": 8.0, "do365": 15.0}}


class _TimedDaa(Daa):
    """The evaluation's Daa, every step's wall time kept (the class evaluate.py builds, swapped for the run)."""

    steps_ns: list[int] = []

    def step(self, *args, **kwargs):
        t0 = time.perf_counter_ns()
        result = super().step(*args, **kwargs)
        _TimedDaa.steps_ns.append(time.perf_counter_ns() - t0)
        return result


def _cpu_ms_per_encounter(profile: str, encounters: list, conditions=None) -> float:
    """`avionics evaluate`'s CPU time per encounter over encounters[1:], after encounters[0] as a warm-up."""
    from avionics_eval.evaluation import evaluate as evaluation

    conditions = conditions or evaluation.DEFAULT_CONDITIONS
    warm, timed = encounters[0], encounters[1:]
    evaluation.evaluate(warm, profile, (warm.seed, warm.index), conditions=conditions)
    t0 = time.process_time()
    for e in timed:
        evaluation.evaluate(e, profile, (e.seed, e.index), conditions=conditions)
    return (time.process_time() - t0) / len(timed) * 1e3


def profile_cost(profile: str, encounters: list) -> dict:
    """One profile over the encounters (the first one a warm-up): its steps' wall times and CPU per encounter."""
    from avionics_eval.evaluation import evaluate as evaluation

    cpu_ms = _cpu_ms_per_encounter(profile, encounters)
    timed = encounters[1:]
    built, evaluation.Daa = evaluation.Daa, _TimedDaa
    _TimedDaa.steps_ns = []
    try:
        for e in timed:
            evaluation.evaluate(e, profile, (e.seed, e.index))
    finally:
        evaluation.Daa = built
    steps_us = np.array(_TimedDaa.steps_ns) / 1e3
    return {"one_intruder_step_us": {"p50": round(float(np.percentile(steps_us, 50)), 1),
                                     "p90": round(float(np.percentile(steps_us, 90)), 1),
                                     "steps": len(steps_us)},
            "evaluation_cpu_ms_per_encounter": round(cpu_ms, 1)}


def guided_cost(profile: str, encounters: list) -> float:
    """CPU ms per encounter flown through the guidance with the multirotor and the guidance bands (the first a
    warm-up)."""
    from avionics_eval.evaluation.evaluate import Conditions

    return round(_cpu_ms_per_encounter(profile, encounters, Conditions("sitl", None, "guidance", "multirotor", True)),
                 1)


def step_bench(profiles: list[str], encounters: int, seed: int, guided: int = 0) -> dict:
    from avionics_eval.evaluation.evaluate import check_profile
    from avionics_eval.evaluation.generator import generate
    from avionics_eval.tracking_bench import bench_filterpy

    for profile in profiles:  # an unknown name is the configuration's one-line error, before anything runs
        check_profile(profile)
    items = [generate(seed, i) for i in range(max(encounters, guided) + 1)]
    return {
        "benchmark": "whole step and evaluated encounter (issue 32)",
        "utc": _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds"),
        "command": " ".join(["avionics" if i == 0 else a for i, a in enumerate(sys.argv)]),
        "python": platform.python_version(), "machine": platform.machine(),
        "load_average": [round(x, 2) for x in os.getloadavg()],
        "encounters": encounters, "seed": seed,
        "filterpy_imm_step_us": round(bench_filterpy(200), 1),
        "profiles": {p: {**profile_cost(p, items[:encounters + 1]),
                         **({"guided_cpu_ms_per_encounter": guided_cost(p, items[:guided + 1])} if guided else {})}
                     for p in profiles},
        "targets": TARGETS,
    }


def main(argv=None) -> int:
    p = argparse.ArgumentParser(prog="python -m avionics_eval.step_bench", description=__doc__.split("\n\n")[0])
    p.add_argument("--profiles", default="tcas2,do365,daidalus-do365b-sum")
    p.add_argument("--encounters", type=int, default=40)
    p.add_argument("--seed", type=int, default=1)
    p.add_argument("--guided", type=int, default=0, metavar="N",
                   help="also the CPU per encounter flown through the guidance (multirotor, bands), over N encounters")
    args = p.parse_args(argv)
    print(json.dumps(step_bench(args.profiles.split(","), args.encounters, args.seed, args.guided), indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
