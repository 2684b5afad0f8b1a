"""Advisory CSVs of every built-in encounter and every DAIDALUS conformance file, as `sitl replay` writes them.

They were generated before the core was reshaped into components (issue 12) and are compared byte for byte by
tests/test_golden_advisories.py: a refactor that changes an advisory, a reason or a number shows up as a diff.
Regenerate (only for a behaviour change named in its commit):

    python -m tests.golden.generate
"""

from __future__ import annotations

import functools
import sys
import tempfile
from pathlib import Path

HERE = Path(__file__).resolve().parent
CONFORMANCE = HERE.parents[2] / "shared" / "conformance" / "daidalus"
# (name, replay arguments after the encounter): built-ins with the default configuration and ADS-B noise, the
# conformance files as the DAIDALUS regression flies them (no noise, the DAIDALUS TCAS3D profile)
BUILTIN_ARGS = ["--noise", "default", "--seed", "0"]
DAIDALUS_ARGS = ["--noise", "none", "--set", "advisory.profile=daidalus-tcas3d"]
DO365_ARGS = ["--noise", "none", "--set", "advisory.profile=daidalus-do365b-no-sum"]  # DO_365B_no_SUM.conf


def cases() -> list[tuple[str, str, list[str]]]:
    """(golden file name, encounter, replay arguments) for every case there is data for."""
    from avionics_sitl.builtin import BUILTIN

    out = [(f"builtin-{name}.csv", name, BUILTIN_ARGS) for name in sorted(BUILTIN)]
    if CONFORMANCE.is_dir():
        out += [(f"daidalus-{p.stem}.csv", str(p), DAIDALUS_ARGS) for p in sorted(CONFORMANCE.glob("*.daa"))]
    return out


@functools.cache
def replayed_csv(encounter: str, args: tuple[str, ...]) -> str:
    """The advisory CSV `sitl replay ENCOUNTER ARGS --out FILE` writes (once per process: the DAIDALUS regression
    and the golden comparison read the same replay)."""
    from avionics_sitl.cli import main

    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "advisories.csv"
        if main(["replay", encounter, *args, "--out", str(out)]) != 0:
            raise RuntimeError(f"sitl replay {encounter} failed")
        return out.read_text()


def main() -> int:
    for name, encounter, args in cases():
        (HERE / name).write_text(replayed_csv(encounter, tuple(args)))
        print(name, file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
