"""`avionics` command line: run, demo, bench, config, monitor, router."""

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


def _tls_args(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--tls-root-ca", metavar="PEM", default="", help="CA certificate for tls/ connect endpoints")
    parser.add_argument("--tls-cert", metavar="PEM", default="", help="our certificate (tls/ listen; mutual TLS)")
    parser.add_argument("--tls-key", metavar="PEM", default="", help="our private key (with --tls-cert)")


def _tls(args, listening: bool) -> dict:
    side = "listen" if listening else "connect"
    return {"tls_root_ca_certificate": args.tls_root_ca, f"tls_{side}_certificate": args.tls_cert,
            f"tls_{side}_private_key": args.tls_key}


def cmd_monitor(args) -> int:
    from avionics.config import validate, Config
    from avionics.monitor.app import run_monitor
    from avionics.monitor.feed import monitor_zenoh_config

    cfg = monitor_zenoh_config(args.connect or ["tcp/127.0.0.1:7447"], args.mode, args.listen, **_tls(args, False))
    validate(Config(zenoh=cfg))
    return run_monitor(cfg, prefix=args.prefix, http=args.http, tui=args.tui, vehicle=args.vehicle,
                       duration_s=args.duration)


def cmd_router(args) -> int:
    from avionics.config import validate, Config
    from avionics.monitor.router import router_config, run_router

    cfg = router_config(args.listen or ["tcp/127.0.0.1:7447"], args.connect, **_tls(args, True))
    validate(Config(zenoh=cfg))
    return run_router(cfg)


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

    p = sub.add_parser("monitor", help="ground monitor: live traffic display in the browser (or --tui) from zenoh")
    p.add_argument("--connect", action="append", metavar="ENDPOINT",
                   help="zenoh endpoint of a router or onboard process (repeatable; default tcp/127.0.0.1:7447)")
    p.add_argument("--mode", choices=("client", "peer"), default="client", help="zenoh session mode (default client)")
    p.add_argument("--listen", action="append", default=[], metavar="ENDPOINT", help="zenoh listen endpoint (peer)")
    p.add_argument("--prefix", default="daa", help="zenoh key prefix (zenoh.key_prefix of the vehicles)")
    p.add_argument("--http", default="127.0.0.1:8047", metavar="HOST:PORT", help="where the page is served")
    p.add_argument("--tui", action="store_true", help="terminal view instead of the web page")
    p.add_argument("--vehicle", help="vehicle shown first (default: the first online)")
    p.add_argument("--duration", type=float, metavar="S", help="stop after S seconds")
    _tls_args(p)
    p.set_defaults(func=cmd_monitor)

    p = sub.add_parser("router", help="a zenoh router in Python (stand-in for zenohd) for monitors and vehicles")
    p.add_argument("--listen", action="append", metavar="ENDPOINT",
                   help="endpoint to listen on (repeatable; default tcp/127.0.0.1:7447)")
    p.add_argument("--connect", action="append", default=[], metavar="ENDPOINT", help="another router to join")
    _tls_args(p)
    p.set_defaults(func=cmd_router)
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
