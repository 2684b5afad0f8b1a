"""`avionics` command line: run, demo, bench, config."""

from __future__ import annotations

import argparse
import json
import logging
import sys

from avionics import __version__
from avionics.config import ConfigError, as_dict, load_config


def _config_args(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--config", metavar="FILE", help="TOML configuration (default: built-in defaults)")
    parser.add_argument("--set", metavar="SECTION.KEY=VALUE", action="append", default=[],
                        help="override one configuration value, e.g. --set vehicle.id=uav7 (repeatable)")


def _load(args) -> "Config":  # noqa: F821
    overrides = list(args.set)
    if getattr(args, "connection", None):
        overrides.append(f'mavlink.connection="{args.connection}"')
    if getattr(args, "no_zenoh", False):
        overrides.append("zenoh.enabled=false")
    return load_config(args.config, overrides)


def cmd_run(args) -> int:
    from avionics.runner import run

    config = _load(args)
    logging.getLogger("avionics").info("avionics %s: MAVLink %s, zenoh %s, vehicle %s", __version__,
                                       config.mavlink.connection,
                                       list(config.zenoh.listen) if config.zenoh.enabled else "off",
                                       config.vehicle.id)
    counters = run(config, duration_s=args.duration, tlog_out=args.tlog_out)
    if args.counters:
        print(json.dumps(dict(sorted(counters.items())), indent=1))
    return 0


def cmd_demo(args) -> int:
    from avionics.demo import demo

    return demo(args.scenario, port=args.port, zenoh_port=args.zenoh_port, noise=args.noise)


def cmd_bench(args) -> int:
    from avionics.bench import bench

    print(json.dumps(bench([int(n) for n in args.intruders.split(",")], args.seconds), indent=1))
    return 0


def cmd_config(args) -> int:
    print(json.dumps(as_dict(_load(args)), indent=1))
    return 0


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="avionics", description="Onboard detect-and-avoid for UAVs.")
    parser.add_argument("--version", action="version", version=f"%(prog)s {__version__}")
    parser.add_argument("-q", "--quiet", action="store_true", help="only warnings and errors")
    sub = parser.add_subparsers(dest="command", required=True)

    p = sub.add_parser("run", help="run the onboard DAA process on a MAVLink link")
    _config_args(p)
    p.add_argument("--connection", help="pymavlink connection string, e.g. udpin:127.0.0.1:14550, "
                                        "tcp:127.0.0.1:5760, /dev/ttyUSB0, flight.tlog")
    p.add_argument("--no-zenoh", action="store_true", help="do not publish on zenoh")
    p.add_argument("--duration", type=float, metavar="S", help="stop after S seconds (default: run until killed)")
    p.add_argument("--tlog-out", metavar="FILE", help="record every frame received and sent as a .tlog")
    p.add_argument("--counters", action="store_true", help="print the input/rejection counters at exit")
    p.set_defaults(func=cmd_run)

    p = sub.add_parser("demo", help="fly the SITL head-on encounter against the onboard process on loopback")
    p.add_argument("--scenario", default="head-on", help="built-in encounter (sitl list) or scenario file")
    p.add_argument("--port", type=int, default=14650, help="loopback UDP port of the MAVLink link")
    p.add_argument("--zenoh-port", type=int, default=17447, help="loopback TCP port of the zenoh session")
    p.add_argument("--noise", choices=("default", "none"), default="default", help="ADS-B impairments")
    p.set_defaults(func=cmd_demo)

    p = sub.add_parser("bench", help="end-to-end throughput and report-to-advisory latency (JSON)")
    p.add_argument("--intruders", default="10,100,1000", help="comma-separated intruder counts")
    p.add_argument("--seconds", type=float, default=20.0, help="simulated seconds of traffic per count")
    p.set_defaults(func=cmd_bench)

    p = sub.add_parser("config", help="print the effective configuration as JSON")
    _config_args(p)
    p.set_defaults(func=cmd_config)
    return parser


def main(argv=None) -> int:
    args = build_parser().parse_args(argv)
    logging.basicConfig(level=logging.WARNING if args.quiet else logging.INFO,
                        format="%(asctime)s %(name)s %(levelname)s %(message)s", stream=sys.stderr)
    try:
        return args.func(args)
    except ConfigError as exc:
        print(f"avionics: configuration error: {exc}", file=sys.stderr)
        return 2
    except Exception as exc:  # noqa: BLE001  (one clear line for link/zenoh errors, not a traceback)
        from avionics.io.link import LinkError
        from avionics.io.zenoh_bus import ZenohBusError

        if isinstance(exc, (LinkError, ZenohBusError)):
            print(f"avionics: {exc}", file=sys.stderr)
            return 1
        raise


if __name__ == "__main__":
    sys.exit(main())
