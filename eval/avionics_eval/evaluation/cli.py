"""`avionics evaluate`: run a set (runner.py) or report on one (metrics.py). Kept apart from eval/avionics_eval/cli.py
so that its arguments live beside the code they drive."""

from __future__ import annotations

import json
import sys

DEFAULT_PROFILES = "tcas2,daidalus-tcas3d,do365"


def add_arguments(p) -> None:
    p.add_argument("--encounters", type=int, default=1000, metavar="N", help="encounters 0..N-1 of the set")
    p.add_argument("--seed", type=int, default=1, help="the set's seed: encounter i is drawn from (seed, i) alone")
    p.add_argument("--generator", choices=("ours", "lincoln"),
                   help="ours: the project's own encounter model (generator.py; the default without --model); "
                        "lincoln: the MIT LL models paired with importance weights (implied by --model)")
    p.add_argument("--model", metavar="FILE[,FILE]",
                   help="intruder model(s): MIT LL parameter files or names of shipped ones, e.g. "
                        "uncor_1200code_v2p1.txt (several: one drawn uniformly per encounter)")
    p.add_argument("--ownship", metavar="OWNSHIP",
                   help="with --model: uav-survey, uav-corridor, uav-hover, uav-transit (multirotor missions) "
                        "or a Lincoln model file")
    p.add_argument("--surveillance", choices=("sitl", "do365-adsb"), default="sitl",
                   help="intruder surveillance: sitl (the SITL's ADS-B noise, the default) or do365-adsb (DO-365 "
                        "Appendix Q as MIT LL DEGAS: 75.6 m / 1.22 m/s Gauss-Markov errors, 300 s)")
    p.add_argument("--altitude-quantum-ft", type=float, metavar="FT",
                   help="reported altitude step: 25 (ADS-B, the models' own) or 100 (Mode C)")
    p.add_argument("--pilot", choices=("spread", "standard", "trams", "guidance"), default="spread",
                   help="spread (the profile's response, delay x U[0.6, 1.4]; the default), standard (TCAS "
                        "standard pilot: 5 s, 0.25 g; 2.5 s, 0.35 g), trams (responds with p = 0.62) or guidance "
                        "(no pilot: the vehicle's autopilot flies the RAs through the guidance port, as sitl replay "
                        "--fly-guidance)")
    p.add_argument("--vehicle", metavar="NAME",
                   help="with --pilot guidance: the vehicle profile (vehicle.profile) the RA logic assumes and the "
                        "simulated ArduCopter flies (default multirotor)")
    p.add_argument("--guidance-bands", action="store_true",
                   help="with --pilot guidance: also fly a DO-365 alerter's horizontal resolutions from its guidance "
                        "bands, as the default configuration does (advisory.guidance_bands; about twice the CPU); "
                        "without it the guidance flies the RAs vertically only")
    p.add_argument("--profiles", default=DEFAULT_PROFILES,
                   help=f"comma-separated alerting profiles (advisory.profile), default {DEFAULT_PROFILES}")
    p.add_argument("--out", help="results: a directory of Parquet partitions (created in an existing directory; "
                                 "resumed when it exists)")
    p.add_argument("--scheduler", default="local",
                   help="local[:N] (a LocalCluster of N processes on 127.0.0.1; default N = cores), synchronous "
                        "(in-process) or tcp://HOST:PORT (an existing dask scheduler)")
    p.add_argument("--partition-size", type=int, default=100, metavar="K", help="encounters per Parquet partition")
    p.add_argument("--max-partitions", type=int, metavar="K",
                   help="stop after K more partitions (the rest on a later run of the same command)")
    p.add_argument("--progress", action="store_true", default=None,
                   help="a progress bar on stderr (default: when stderr is a terminal)")
    p.add_argument("--report", nargs="+", metavar="RESULTS",
                   help="instead of running: the metrics of these results directories as a Markdown table "
                        "(and JSON with --json)")
    p.add_argument("--plots", metavar="DIR", help="--report: also draw the plots into DIR")
    p.add_argument("--common", action="store_true",
                   help="--report: only the encounters that every profile has (results of unequal length)")
    p.add_argument("--json", action="store_true", help="--report: print the metrics as JSON")


def _new_directory(path: str, option: str) -> None:
    """A directory the command may create: its parent must exist (a typo in the path is refused, not created)."""
    from pathlib import Path

    from avionics_eval.evaluation.runner import EvaluationError

    target = Path(path)
    if target.exists() and not target.is_dir():
        raise EvaluationError(f"{option} {path!r}: exists and is not a directory")
    if not target.parent.is_dir():
        raise EvaluationError(f"{option} {path!r}: no such directory {str(target.parent)!r}")


def encounter_source(args):
    """None for the project's generator, else the Lincoln source of --model and --ownship (files read now)."""
    from avionics_eval.evaluation.runner import EvaluationError

    generator = args.generator or ("lincoln" if args.model else "ours")
    if generator == "ours":
        if args.model or args.ownship:
            raise EvaluationError("--model and --ownship choose the Lincoln models: not with --generator ours")
        return None
    if not args.model or not args.ownship:
        raise EvaluationError("--generator lincoln needs --model FILE[,FILE] and --ownship")
    from avionics_eval.evaluation.lincoln import LincolnSource, LincolnSourceError

    try:
        return LincolnSource.of(args.model, args.ownship)
    except LincolnSourceError as exc:
        raise EvaluationError(str(exc)) from None


def conditions(args):
    """evaluate.Conditions of --surveillance, --altitude-quantum-ft, --pilot, --vehicle and --guidance-bands."""
    from avionics_eval.evaluation.evaluate import Conditions
    from avionics_eval.evaluation.runner import EvaluationError

    vehicle = getattr(args, "vehicle", None)
    bands = bool(getattr(args, "guidance_bands", False))
    if vehicle is not None and args.pilot != "guidance":
        raise EvaluationError("--vehicle is the vehicle the guidance flies: only with --pilot guidance")
    if bands and args.pilot != "guidance":
        raise EvaluationError("--guidance-bands: the guidance flies the bands' resolutions: only with --pilot guidance")
    if args.pilot == "guidance" and vehicle is None:
        vehicle = "multirotor"
    try:
        return Conditions(args.surveillance, args.altitude_quantum_ft, args.pilot, vehicle, bands)
    except ValueError as exc:
        option = "--vehicle" if vehicle is not None and "vehicle" in str(exc) else "--altitude-quantum-ft"
        raise EvaluationError(f"{option}: {exc}") from None


def evaluate_command(args) -> int:
    from pathlib import Path

    from avionics_eval.evaluation.runner import EvaluationError

    if args.report:
        for path in args.report:
            if not Path(path).is_dir():
                raise EvaluationError(f"--report {path!r}: no such results directory")
        if args.plots:
            _new_directory(args.plots, "--plots")
        from avionics_eval.evaluation.metrics import (
            load,
            markdown,
            metrics,
            plot,
            profiles_of,
        )

        table = load(args.report, common=args.common)
        result = metrics(table, profiles_of(args.report))
        print(json.dumps(result, indent=1) if args.json else markdown(result))
        if args.plots:
            for path in plot(table, result, args.plots):
                print(f"avionics evaluate: wrote {path}", file=sys.stderr)
        return 0
    if not args.out:
        raise EvaluationError("--out is required to run a set (or --report RESULTS to report on one)")
    if args.encounters < 1 or args.partition_size < 1:
        raise EvaluationError("--encounters and --partition-size must be at least 1")
    _new_directory(args.out, "--out")
    from avionics_eval.evaluation.runner import run

    profiles = tuple(p.strip() for p in args.profiles.split(",") if p.strip())
    summary = run(args.encounters, args.seed, profiles, args.out, scheduler=args.scheduler,
                  partition_size=args.partition_size, max_partitions=args.max_partitions, progress=args.progress,
                  source=encounter_source(args), conditions=conditions(args))
    print(json.dumps(summary, indent=1))
    return 0
