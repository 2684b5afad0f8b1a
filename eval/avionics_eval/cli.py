"""The lab's commands of the `avionics` console script: `demo` and `bench` (they compose the onboard process with
the simulator) and `evaluate`.

The flight install's `avionics` (avionics.cli) finds them through this distribution's entry point
(`avionics.commands`, eval/pyproject.toml: add_commands and ERRORS); `python -m avionics_eval.cli` is the same
script. Each command imports its code only when it runs.
"""

from __future__ import annotations

import argparse
import json
import sys

from avionics import cli as flight

ERRORS = flight.ERRORS + (  # the table of avionics.cli plus the errors of demo (exit codes in README)
    ("avionics_sitl.encounters", "ScenarioError", 2, ""),
    ("avionics_eval.demo", "OnboardError", 1, ""),
    ("avionics_eval.evaluation.runner", "EvaluationError", 2, ""),
)


def call(prog: str, func, args) -> int:
    """avionics.cli.call with this table of expected errors."""
    return flight.call(prog, func, args, ERRORS)


def cmd_demo(args) -> int:
    from avionics_eval.demo import demo

    if args.guidance:
        from avionics_eval.demo import demo_guidance

        return demo_guidance(args.scenario, port=args.port, zenoh_port=args.zenoh_port, noise=args.noise,
                             profile=args.profile, autopilot=args.autopilot)
    return demo(args.scenario, port=args.port, zenoh_port=args.zenoh_port, noise=args.noise, profile=args.profile)


def cmd_bench(args) -> int:
    if args.step:
        from avionics_eval.step_bench import step_bench

        print(json.dumps(step_bench(args.profiles.split(","), args.encounters, args.seed, args.guided), indent=1))
        return 0
    if args.soak is not None:
        from avionics_eval.soak_bench import soak

        log = None if args.quiet else (lambda line: print(f"avionics bench: {line}", file=sys.stderr, flush=True))
        if args.intruders is not None and len(args.intruders) != 1:
            raise flight.ConfigError("--soak takes one --intruders count")
        print(json.dumps(soak(args.soak, (args.intruders or [1000])[0], zenoh=args.zenoh,
                              sample_every_s=args.sample_seconds, log=log), indent=1))
        return 0
    if args.capacity:
        from avionics_eval.capacity_bench import capacity_bench

        counts = args.intruders or [100, 1000, 3000]
        log = None if args.quiet else (lambda line: print(f"avionics bench: {line}", file=sys.stderr, flush=True))
        print(json.dumps(capacity_bench(counts, args.trial_seconds, zenoh=args.zenoh,
                                        startup_repeats=args.startup_repeats, max_trials=args.max_trials,
                                        log=log), indent=1))
        return 0
    from avionics_eval.bench import bench

    print(json.dumps(bench(args.intruders or [10, 100, 1000], args.seconds), indent=1))
    return 0


def cmd_evaluate(args) -> int:
    from avionics_eval.evaluation.cli import evaluate_command

    return evaluate_command(args)


_positive = flight.positive_seconds


def counts(text: str) -> list[int]:
    """--intruders: comma-separated whole numbers >= 1 (a usage error otherwise, exit 2)."""
    try:
        values = [int(n) for n in text.split(",")]
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected comma-separated whole numbers, e.g. 10,100, got {text!r}") \
            from None
    if not all(1 <= n <= 1_000_000 for n in values):
        raise argparse.ArgumentTypeError(f"each count must be in 1..1000000, got {text!r}")
    return values


def _whole(low: int):
    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"not a whole number: {text!r}") from None
        if value < low:
            raise argparse.ArgumentTypeError(f"must be >= {low}, got {text!r}")
        return value
    return parse


def add_commands(sub) -> None:
    """`demo` and `bench`, on the subparsers of avionics.cli.build_parser."""
    p = sub.add_parser("demo", help="fly the SITL head-on encounter against the onboard process on loopback")
    p.add_argument("--scenario", default="head-on", help="built-in encounter (sitl list) or scenario file")
    p.add_argument("--port", type=flight.port_number, default=14650, help="loopback UDP port of the MAVLink link")
    p.add_argument("--zenoh-port", type=flight.port_number, default=17447,
                   help="loopback TCP port of the zenoh session")
    p.add_argument("--noise", choices=("default", "none"), default="default", help="ADS-B impairments")
    p.add_argument("--profile", help="onboard alerting profile (advisory.profile), e.g. do365: DO-365 levels and "
                                     "guidance bands")
    p.add_argument("--guidance", action="store_true",
                   help="a multirotor on its mission avoids the encounter: the onboard process commands the "
                        "simulated autopilot (guidance.mode=execute; profile small-uas unless --profile) and "
                        "gives the mission back; prints the truth miss without and with")
    p.add_argument("--autopilot", choices=("ardupilot", "px4"), default="ardupilot",
                   help="with --guidance: the simulated autopilot, ArduCopter (GUIDED) or PX4 (OFFBOARD)")
    p.set_defaults(func=cmd_demo)

    p = sub.add_parser("bench", help="end-to-end throughput and report-to-advisory latency (JSON)")
    p.add_argument("--intruders", type=counts, help="comma-separated intruder counts (default 10,100,1000; with "
                                                    "--capacity 100,1000,3000; with --soak one count, 1000)")
    p.add_argument("--seconds", type=_positive, default=20.0, help="simulated seconds of traffic per count")
    p.add_argument("--capacity", action="store_true",
                   help="the capacity bench: the most intruders a real avionics run keeps up with at 1 Hz, its "
                        "report-to-advisory latency there and for one report alone, start-up time, memory, and "
                        "filterpy's IMM step as a reference (eval/avionics_eval/capacity_bench.py, docs/performance.md)")
    p.add_argument("--trial-seconds", type=_positive, default=20.0, metavar="S",
                   help="--capacity: length of each trial of the capacity search and of the 1 Hz run")
    p.add_argument("--soak", type=_positive, metavar="S",
                   help="memory soak: a real avionics run fed --intruders (one count, default 1000) at "
                        "1 Hz for S seconds, its VmRSS sampled (eval/avionics_eval/soak_bench.py, docs/performance.md)")
    p.add_argument("--step", action="store_true",
                   help="the whole step for one intruder and the evaluation's CPU per encounter, per profile, with "
                        "filterpy's IMM step as a reference (eval/avionics_eval/step_bench.py, docs/performance.md)")
    p.add_argument("--profiles", default="tcas2,do365,daidalus-do365b-sum", help="--step: alerting profiles")
    p.add_argument("--encounters", type=_whole(1), default=40, help="--step: encounters per profile (a warm-up more)")
    p.add_argument("--seed", type=_whole(0), default=1, help="--step: the evaluation's encounter seed")
    p.add_argument("--guided", type=_whole(0), default=0, metavar="N",
                   help="--step: also the CPU per encounter flown through the guidance (multirotor, the guidance "
                        "bands), over N encounters")
    p.add_argument("--sample-seconds", type=_positive, default=5.0, metavar="S",
                   help="--soak: seconds between samples of the child's memory")
    p.add_argument("--zenoh", action=argparse.BooleanOptionalAction, default=True,
                   help="--capacity, --soak: publish on a loopback zenoh session (default) or MAVLink only")
    p.add_argument("--startup-repeats", type=_whole(1), default=5, metavar="K",
                   help="--capacity: warm launches of avionics run timed (median reported)")
    p.add_argument("--max-trials", type=_whole(1), default=16, metavar="K",
                   help="--capacity: trials per intruder count at most (then the capacity is a lower bound)")
    p.set_defaults(func=cmd_bench)

    p = sub.add_parser("evaluate", help="a seeded encounter set through the alerting profiles on Dask, to Parquet, "
                                        "and its safety metrics (docs/evaluation.md)")
    from avionics_eval.evaluation.cli import add_arguments

    add_arguments(p)
    p.set_defaults(func=cmd_evaluate)


def build_parser() -> argparse.ArgumentParser:
    return flight.build_parser(add_commands)


def main(argv=None) -> int:
    return flight.main(argv, add_commands=add_commands, errors=ERRORS)


if __name__ == "__main__":
    sys.exit(main())
