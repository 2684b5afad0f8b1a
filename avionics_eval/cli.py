"""The `avionics` console script: the flight commands of avionics.cli (run, config, monitor, router) plus the
two that compose the onboard process with the simulator, `demo` and `bench`.

It lives here, not in the flight package, so that flight code never imports the simulator; demo and bench are
imported only when their command runs.
"""

from __future__ import annotations

import argparse
import json
import sys

from avionics import cli as flight

ERRORS = flight.ERRORS + (  # the table of avionics.cli plus the errors of demo (exit codes in README)
    ("avionics_sitl.encounters", "ScenarioError", 2, ""),
    ("avionics_eval.demo", "OnboardError", 1, ""),
)


def call(prog: str, func, args) -> int:
    """avionics.cli.call with this table of expected errors."""
    return flight.call(prog, func, args, ERRORS)


def cmd_demo(args) -> int:
    from avionics_eval.demo import demo

    return demo(args.scenario, port=args.port, zenoh_port=args.zenoh_port, noise=args.noise, profile=args.profile)


def cmd_bench(args) -> int:
    from avionics_eval.bench import bench

    print(json.dumps(bench([int(n) for n in args.intruders.split(",")], args.seconds), indent=1))
    return 0


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
    p.set_defaults(func=cmd_demo)

    p = sub.add_parser("bench", help="end-to-end throughput and report-to-advisory latency (JSON)")
    p.add_argument("--intruders", default="10,100,1000", help="comma-separated intruder counts")
    p.add_argument("--seconds", type=float, default=20.0, help="simulated seconds of traffic per count")
    p.set_defaults(func=cmd_bench)


def build_parser() -> argparse.ArgumentParser:
    return flight.build_parser(add_commands)


def main(argv=None) -> int:
    return flight.main(argv, add_commands=add_commands, errors=ERRORS)


if __name__ == "__main__":
    sys.exit(main())
