"""Golden regression against NASA DAIDALUS v2.0.4 (TCAS3D.conf) on NASA's own encounter files.

`../shared/conformance/daidalus/first_alerts.csv` holds DAIDALUS's first TA (alert level 1) and first RA
(level 2) time for every intruder of every published DAIDALUS and daa-displays scenario (its README says how
they were made). Each file is flown through `sitl replay` exactly as a user would
(`sitl replay FILE --noise none --set advisory.profile=daidalus-tcas3d`): MAVLink framing, the IMM tracker,
the core. Every first TA and RA must fall within 1 s of DAIDALUS's, none missed, none extra.

The data are public and stay in ../shared: the test skips where the folder is absent (a user's clone) and
fails under CI (CI set).
"""

from __future__ import annotations

import csv
import io
from pathlib import Path

import pytest

from tests.golden.first_alerts import golden, problems, require
from tests.golden.generate import CONFORMANCE, DAIDALUS_ARGS, replayed_csv

# one xdist worker runs both files: they read the same cached replays (tests/golden/generate.py)
pytestmark = pytest.mark.xdist_group("replays")
GOLDEN = golden("TCAS3D")


def test_the_golden_data_is_there_under_ci():
    require(GOLDEN)
    assert len(GOLDEN) >= 20, f"expected the published scenarios, found {sorted(GOLDEN)}"


def _first_alerts(path: Path) -> dict[tuple[str, int], float]:
    """(intruder name, level) -> first time that intruder's advisory reached the level, from avionics_sitl replay."""
    first: dict[tuple[str, int], float] = {}
    for row in csv.DictReader(io.StringIO(replayed_csv(str(path), tuple(DAIDALUS_ARGS)))):
        rank = {"NONE": 0, "TA": 1, "RA": 2}[row["advisory"]]
        for level in range(1, rank + 1):
            first.setdefault((row["name"], level), float(row["time_s"]))
    return first


@pytest.mark.parametrize("case_file", sorted(GOLDEN) or ["(no data)"])
def test_first_ta_and_ra_within_1_s_of_daidalus(case_file):
    require(GOLDEN)
    found = problems(GOLDEN[case_file], _first_alerts(CONFORMANCE / case_file), {1: "TA", 2: "RA"})
    assert not found, f"{case_file}: " + "; ".join(found)
