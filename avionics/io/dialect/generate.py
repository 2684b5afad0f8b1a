"""Regenerate daa.py from daa.xml with pymavlink's mavgen: `python -m avionics.io.dialect.generate`.

The generated module is committed (as pymavlink ships its dialects); tests/test_dialect.py regenerates it
into a temporary directory and fails if the committed file is out of date.
"""

from __future__ import annotations

import sys
from pathlib import Path

HERE = Path(__file__).parent


def generate(output: Path = HERE / "daa.py") -> Path:
    from pymavlink.generator import mavgen

    opts = mavgen.Opts(str(output.with_suffix("")), wire_protocol="2.0", language="Python3", validate=True,
                       strict_units=False)
    if not mavgen.mavgen(opts, [str(HERE / "daa.xml")]):
        raise RuntimeError("mavgen failed on daa.xml")
    return output


if __name__ == "__main__":
    print(generate(Path(sys.argv[1]) if len(sys.argv) > 1 else HERE / "daa.py"))
