"""`python -m avionics_eval.encounter_models sample MODEL_FILE --n N --seed S --out DIR`: one CSV per sampled
trajectory (columns of tracks.CSV_COLUMNS). Bad files or values: one line on stderr, exit 2 (avionics.cli.call)."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

from avionics import cli as flight
from avionics_eval.encounter_models.model import PACKAGED, read_model
from avionics_eval.encounter_models.sampler import TRANSITIONS
from avionics_eval.encounter_models.tracks import sample_tracks, write_csv

ERRORS = flight.ERRORS + (("avionics_eval.encounter_models.model", "ModelFileError", 2, ""),)
PROG = "python -m avionics_eval.encounter_models"


def _count(text: str) -> int:
    value = int(text)
    if value < 1:
        raise argparse.ArgumentTypeError(f"must be >= 1, got {text!r}")
    return value


def _prior(text: str) -> float | str:
    if text == "dbe":
        return text
    value = float(text)
    if not value >= 0:
        raise argparse.ArgumentTypeError(f"must be >= 0 or 'dbe', got {text!r}")
    return value


def model_path(name: str) -> Path:
    """A file path, or the name of a shipped model (e.g. uncor_1200code_v2p1.txt)."""
    path = Path(name)
    if not path.exists() and (PACKAGED / name).is_file():
        return PACKAGED / name
    return path


def cmd_sample(args) -> int:
    model = read_model(model_path(args.model))
    out = Path(args.out)
    if out.exists() and not out.is_dir():
        raise flight.ConfigError(f"--out {args.out!r}: not a directory")
    tracks = sample_tracks(model, args.n, args.duration, np.random.default_rng(args.seed), args.prior,
                           args.transition)
    paths = write_csv(tracks, out, args.ground_msl)
    print(f"{PROG}: wrote {len(paths)} trajectories of {args.duration} s to {out}", file=sys.stderr)
    return 0


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog=PROG, description=__doc__.splitlines()[0])
    sub = parser.add_subparsers(dest="command", required=True)
    p = sub.add_parser("sample", help="sample trajectories of a Lincoln encounter model into CSV files")
    p.add_argument("model", metavar="MODEL_FILE",
                   help=f"parameter file, or the name of a shipped one ({', '.join(sorted(x.name for x in PACKAGED.glob('*.txt')))})")
    p.add_argument("--n", type=_count, required=True, help="number of trajectories")
    p.add_argument("--seed", type=int, required=True, help="random seed (numpy default_rng)")
    p.add_argument("--out", required=True, help="output directory (created)")
    p.add_argument("--duration", type=_count, default=120, help="seconds per trajectory (default 120)")
    p.add_argument("--prior", type=_prior, default=0.0,
                   help="Dirichlet prior: a constant pseudo-count or 'dbe' (default 0, as the reference model)")
    p.add_argument("--transition", choices=TRANSITIONS, default="reference",
                   help="reference: as dbn_sample.m (transition column fixed by the initial state); markov: "
                        "re-read each second")
    p.add_argument("--ground-msl", type=float, default=0.0, help="ground elevation, ft MSL (alt_MSL_ft = AGL + it)")
    p.set_defaults(func=cmd_sample)
    return parser


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    return flight.call(PROG, args.func, args, ERRORS)


if __name__ == "__main__":
    sys.exit(main())
