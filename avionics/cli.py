"""`avionics`, the console script of the flight install: run, warmup, config, monitor, router.

Flight code only: nothing here imports the simulator (sitl) or avionics_eval by name. Other distributions add
commands through entry points (COMMANDS_GROUP): eval/ (avionics-eval) adds demo, bench and evaluate; without it
those say how to install them. `python -m avionics_eval.cli` is the same script with the lab's commands.
"""

from __future__ import annotations

import os

# One BLAS/OpenMP thread for the onboard process, set before numpy is first imported (its BLAS reads these once, at
# load; nothing above this imports numpy). The process is pinned to one core on a companion computer and its
# matrices are 6x6: a BLAS worker thread buys nothing there, and an idle OpenBLAS worker spinning on the pinned
# core nearly doubled report-to-advisory latency at 3000 intruders (issue 13). setdefault: an operator's choice
# stands. OPENBLAS_CORETYPE and OPENBLAS_L2_SIZE are left alone (a machine may set them for correctness).
for _threads in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_threads, "1")

import argparse  # after the thread settings above (E402 on purpose)
import json
import logging
import math
import sys
import traceback
from pathlib import Path

from avionics import __version__
from avionics.config import ConfigError, as_dict, load_config

# Exit codes (README): 0 success, 1 a link, zenoh session or listening socket could not be opened, 2 configuration,
# scenario, file or usage error, 70 a bug (with its traceback), 130 Ctrl-C. Every error these cover is one line on stderr, `PROG: message`. Named by module so that
# a command that never imported pymavlink or zenoh does not import them to classify its error (an exception of a
# class can only exist once its module is loaded). The shells above (avionics_sitl.cli, avionics_eval.cli) extend the
# table with their own errors (a bad scenario, a demo's onboard process) and pass it to `call`.
ERRORS = (  # (module, class, exit code, prefix of the line)
    ("avionics.base.params", "ConfigError", 2, "configuration error: "),
    ("avionics.advisory.tables", "ProfileError", 2, "configuration error: "),  # e.g. demo --profile nope
    ("avionics.io.link", "LinkError", 1, ""),
    ("avionics.io.link", "LogError", 2, ""),  # a .tlog given as the connection without usable timestamps
    ("avionics.io.zenoh_bus", "ZenohBusError", 1, ""),
    ("avionics.monitor.app", "HttpServerError", 1, ""),
)
EXIT_INTERNAL = 70  # EX_SOFTWARE: anything else is a bug, shown with its traceback and one summary line
EXIT_INTERRUPTED = 130  # Ctrl-C
EXIT_BROKEN_PIPE = 141  # 128 + SIGPIPE, as a shell reports a command whose reader went away


def _one_line(exc: BaseException) -> str:
    return " | ".join(line.strip() for line in str(exc).splitlines() if line.strip()) or type(exc).__name__


def classify(exc: BaseException, errors=ERRORS) -> tuple[int, str] | None:
    """(exit code, prefix) of an expected error, None for an unexpected one."""
    for module, name, code, prefix in errors:
        cls = getattr(sys.modules.get(module), name, None)
        if cls is not None and isinstance(exc, cls):
            return code, prefix
    return None


def call(prog: str, func, args, errors=ERRORS) -> int:
    """Run one command and return its exit code: an expected error (one of `errors`) is one line on stderr; an
    unexpected one keeps its traceback, followed by one line that says it is a bug."""
    try:
        return func(args)
    except KeyboardInterrupt:
        print(f"{prog}: interrupted", file=sys.stderr)
        return EXIT_INTERRUPTED
    except BrokenPipeError:  # `sitl list | head`: the reader left; nothing to report (Python docs, signal: SIGPIPE)
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())  # so that the exit's flush does not raise
        return EXIT_BROKEN_PIPE
    except Exception as exc:  # noqa: BLE001  (expected errors by type, in ERRORS; the rest is reported as a bug)
        known = classify(exc, errors)
        if known is None:
            traceback.print_exc()
            print(f"{prog}: internal error (a bug; traceback above): {type(exc).__name__}: {_one_line(exc)}",
                  file=sys.stderr)
            return EXIT_INTERNAL
        code, prefix = known
        print(f"{prog}: {prefix}{_one_line(exc)}", file=sys.stderr)
        return code


def check_output_file(path: str, option: str) -> None:
    """ConfigError (exit 2) when a file cannot be written at path, before any work is done for it."""
    target = Path(path)
    parent = target.parent
    if target.is_dir():
        raise ConfigError(f"{option} {path!r}: is a directory")
    if not parent.is_dir():
        raise ConfigError(f"{option} {path!r}: no such directory {str(parent)!r}")
    if not os.access(target if target.exists() else parent, os.W_OK):
        raise ConfigError(f"{option} {path!r}: permission denied")


class OneLineParser(argparse.ArgumentParser):
    """Usage errors in one line too (argparse prints the whole usage first); exit 2."""

    def error(self, message: str):
        # the program's name first (`avionics: error: ...`, also for a subcommand's option), as every error line
        self.exit(2, f"{self.prog.split()[0]}: error: {message} (see {self.prog} --help)\n")


def seconds(text: str) -> float:
    """A duration option: a finite number of seconds >= 0 (argparse: a usage error otherwise, exit 2)."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a number of seconds: {text!r}") from None
    if not (math.isfinite(value) and value >= 0):
        raise argparse.ArgumentTypeError(f"must be a finite number of seconds >= 0, got {text!r}")
    return value


def positive_seconds(text: str) -> float:
    value = seconds(text)
    if not value > 0:
        raise argparse.ArgumentTypeError(f"must be > 0, got {text!r}")
    return value


def port_number(text: str) -> int:
    try:
        port = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a port number: {text!r}") from None
    if not 1 <= port <= 65535:
        raise argparse.ArgumentTypeError(f"port {port} is outside 1..65535")
    return port


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
    from avionics.io.feeds.source import parse_spec
    from avionics.runner import run

    config = _load(args)
    for path, option in ((args.tlog_out, "--tlog-out"), (args.csv, "--csv")):
        if path:
            check_output_file(path, option)
    for spec in args.traffic:
        parse_spec(spec)  # a malformed --traffic is a usage error before anything opens
    counters = run(config, duration_s=args.duration, tlog_out=args.tlog_out, csv_out=args.csv,
                   traffic=tuple(args.traffic))
    if args.counters:
        print(json.dumps(dict(sorted(counters.items())), indent=1))
    return 0


def cmd_config(args) -> int:
    print(json.dumps(as_dict(_load(args)), indent=1))
    return 0


def _security_args(parser: argparse.ArgumentParser) -> None:
    """zenoh security of `monitor` and `router`: the [zenoh] keys of the same meaning (docs/zenoh.md,
    "Security recipes")."""
    parser.add_argument("--tls-root-ca", metavar="PEM", default="", help="CA certificate for tls/ connect endpoints")
    parser.add_argument("--tls-cert", metavar="PEM", default="", help="our certificate (tls/ listen; mutual TLS)")
    parser.add_argument("--tls-key", metavar="PEM", default="", help="our private key (with --tls-cert)")
    parser.add_argument("--mtls", action="store_true",
                        help="mutual TLS: certificates on both sides (zenoh.tls_enable_mtls)")
    parser.add_argument("--user", default="", help="zenoh user name to log in with (with --password-file)")
    parser.add_argument("--password-file", metavar="FILE", default="", help="file whose first line is the password")
    parser.add_argument("--auth-dictionary", metavar="FILE", default="",
                        help="user:password lines: who may open a link to us (zenoh.auth_dictionary_file)")
    parser.add_argument("--zenoh-config", metavar="FILE.json5", default="",
                        help="a zenoh configuration read first, e.g. access_control (zenoh.config_file)")


def _security(args, listening: bool) -> dict:
    side = "listen" if listening else "connect"
    return {"tls_root_ca_certificate": args.tls_root_ca, f"tls_{side}_certificate": args.tls_cert,
            f"tls_{side}_private_key": args.tls_key, "tls_enable_mtls": args.mtls, "auth_user": args.user,
            "auth_password_file": args.password_file, "auth_dictionary_file": args.auth_dictionary,
            "config_file": args.zenoh_config}


def cmd_warmup(args) -> int:
    """Compile every kernel (avionics.base.jit.KERNEL_MODULES) into the disk cache, or find it there."""
    from avionics.base import jit

    if not jit.ENABLED:
        print("avionics warmup: compiled kernels are off (AVIONICS_COMPILED=0, or numba missing): nothing to compile")
        return 0
    try:
        records = jit.warmup()
    except RuntimeError as exc:  # numba: "cannot cache function ...: no locator available": nowhere to write
        if "cannot cache" not in str(exc):
            raise
        print(f"avionics warmup: no writable kernel cache (numba: {exc}); set AVIONICS_CACHE_DIR to a writable "
              "directory", file=sys.stderr)
        return 1
    for r in records:
        count = len(r["signatures"])
        print(f"{r['state']:8} {r['kernel']} ({count} signature{'s' if count != 1 else ''})")
    dirs = sorted({r["cache_dir"] for r in records if r["cache_dir"]})
    compiled = sum(r["state"] == "compiled" for r in records)
    print(f"avionics warmup: {len(records)} kernels from {len(jit.KERNEL_MODULES)} modules, {compiled} compiled now, "
          f"{len(records) - compiled} loaded from the cache; cache: {', '.join(dirs) or 'none'}")
    return 0


def cmd_monitor(args) -> int:
    from avionics.config import validate, Config
    from avionics.monitor.app import run_monitor  # checks the endpoints and --http before opening anything
    from avionics.monitor.feed import monitor_zenoh_config

    cfg = monitor_zenoh_config(args.connect or ["tcp/127.0.0.1:7447"], args.mode, args.listen,
                               **_security(args, False))
    validate(Config(zenoh=cfg))
    return run_monitor(cfg, prefix=args.prefix, http=args.http, tui=args.tui, vehicle=args.vehicle,
                       duration_s=args.duration)


def cmd_router(args) -> int:
    from avionics.config import validate, Config
    from avionics.monitor.app import check_endpoints
    from avionics.monitor.router import router_config, run_router

    cfg = router_config(args.listen or ["tcp/127.0.0.1:7447"], args.connect, **_security(args, True))
    check_endpoints(cfg)
    validate(Config(zenoh=cfg))
    return run_router(cfg)


def build_parser(add_commands=None) -> argparse.ArgumentParser:
    """The flight commands; `add_commands(sub)`, when given, adds more subcommands after `run` (avionics_eval.cli:
    demo and bench)."""
    parser = OneLineParser(prog="avionics", description="Onboard detect-and-avoid for UAVs.")
    parser.add_argument("--version", action="version", version=f"%(prog)s {__version__}")
    parser.add_argument("-q", "--quiet", action="store_true", help="only warnings and errors")
    sub = parser.add_subparsers(dest="command", required=True)

    p = sub.add_parser("run", help="run the onboard DAA process on a MAVLink link")
    _config_args(p)
    p.add_argument("--connection", help="connection string (default udpin:0.0.0.0:14540), e.g. udp://:14540, "
                                        "udpin:127.0.0.1:14540, tcp://127.0.0.1:5760, serial:///dev/ttyUSB0:921600, "
                                        "tcp:127.0.0.1:5760, /dev/ttyUSB0, flight.tlog")
    p.add_argument("--no-zenoh", action="store_true", help="do not publish on zenoh")
    p.add_argument("--duration", type=seconds, metavar="S", help="stop after S seconds (default: run until killed)")
    p.add_argument("--tlog-out", metavar="FILE", help="record every frame received and sent as a .tlog")
    p.add_argument("--csv", metavar="FILE.csv", help="write every advisory change as a CSV row (as sitl replay --out)")
    p.add_argument("--counters", action="store_true", help="print the input/rejection counters at exit")
    p.add_argument("--traffic", action="append", default=[], metavar="SPEC",
                   help="an ADS-B receiver feed beside MAVLink (repeatable): sbs:HOST:PORT (BaseStation, e.g. port "
                        "30003), readsb-json:PATH_OR_HTTP_URL (aircraft.json), beast:HOST:PORT "
                        "(docs/traffic-inputs.md)")
    p.set_defaults(func=cmd_run)
    if add_commands is not None:
        add_commands(sub)

    p = sub.add_parser("warmup", help="compile the numeric kernels into the disk cache (once after install)")
    p.set_defaults(func=cmd_warmup)

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
    p.add_argument("--duration", type=seconds, metavar="S", help="stop after S seconds")
    _security_args(p)
    p.set_defaults(func=cmd_monitor)

    p = sub.add_parser("router", help="a zenoh router in Python (stand-in for zenohd) for monitors and vehicles")
    p.add_argument("--listen", action="append", metavar="ENDPOINT",
                   help="endpoint to listen on (repeatable; default tcp/127.0.0.1:7447)")
    p.add_argument("--connect", action="append", default=[], metavar="ENDPOINT", help="another router to join")
    _security_args(p)
    p.set_defaults(func=cmd_router)
    return parser


# Commands other distributions add to `avionics` (entry points of this group: a module with add_commands(sub) and
# ERRORS). eval/ (avionics-eval) adds demo, bench and evaluate; the flight install has none of them and says where
# they are instead of argparse's "invalid choice".
COMMANDS_GROUP = "avionics.commands"
LAB_COMMANDS = ("demo", "bench", "evaluate")
LAB_INSTALL = "pip install ./sitl ./eval (the simulator and the lab, from the repository; README)"


def extensions() -> list:
    """The installed modules that add commands (entry points COMMANDS_GROUP), in name order."""
    from importlib.metadata import entry_points

    return [ep.load() for ep in sorted(entry_points(group=COMMANDS_GROUP), key=lambda ep: ep.name)]


def _not_installed(args) -> int:
    raise ConfigError(f"avionics {args.command}: not in the flight install: {LAB_INSTALL}")


def _add_missing_lab_commands(sub) -> None:
    for name in LAB_COMMANDS:
        if name not in sub.choices:
            p = sub.add_parser(name, help=f"(not installed: {LAB_INSTALL})", add_help=False)
            p.add_argument("rest", nargs=argparse.REMAINDER)
            p.set_defaults(func=_not_installed)


def main(argv=None, add_commands=None, errors=ERRORS) -> int:
    """The `avionics` console script. add_commands and errors: given by a shell that extends it (avionics_eval.cli);
    otherwise those of the installed extensions."""
    if add_commands is None:
        found = extensions()
        errors = errors + tuple(e for module in found for e in module.ERRORS if e not in errors)

        def add_commands(sub):
            for module in found:
                module.add_commands(sub)
            _add_missing_lab_commands(sub)
    args = build_parser(add_commands).parse_args(argv)
    logging.basicConfig(level=logging.WARNING if args.quiet else logging.INFO,
                        format="%(asctime)s %(name)s %(levelname)s %(message)s", stream=sys.stderr)
    return call("avionics", args.func, args, errors)


if __name__ == "__main__":
    sys.exit(main())
