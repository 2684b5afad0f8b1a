"""DO-365 alerting against NASA DAIDALUS v2.0.4 (DO_365B_no_SUM.conf) on NASA's own encounter files.

`../shared/conformance/daidalus/first_alerts.csv` holds DAIDALUS's first preventive (alert level 1), corrective
(2) and warning (3) times for every intruder of every published DAIDALUS and daa-displays scenario, evaluated
every 1 s with its hysteresis, persistence and 2-of-4 alerting (its README says how they were made). Each file
is flown through `sitl replay` exactly as a user would (`sitl replay FILE --noise none --set
advisory.profile=daidalus-do365b-no-sum`): MAVLink framing, the IMM tracker, the core. The replay CSV's
`alert_level` gives our first onset of each level; every one must fall within 1 s of DAIDALUS's, none missed,
none extra.

The data are public and stay in ../shared: the test skips where the folder is absent (a user's clone) and
fails under CI (CI set).
"""

from __future__ import annotations

import csv
import io
from pathlib import Path

import pytest

from tests.golden.first_alerts import golden, problems, require
from tests.golden.generate import CONFORMANCE, DO365_ARGS, replayed_csv

# one xdist worker runs these replays, the other the TCAS3D and golden ones (group "replays"): both long poles
pytestmark = pytest.mark.xdist_group("replays-do365")
LEVELS = {1: "PREVENTIVE", 2: "CORRECTIVE", 3: "WARNING"}
GOLDEN = golden("DO_365B_no_SUM")


def test_the_golden_data_is_there_under_ci():
    require(GOLDEN)
    assert len(GOLDEN) >= 20, f"expected the published scenarios, found {sorted(GOLDEN)}"


def _first_alerts(path: Path) -> dict[tuple[str, int], float]:
    """(intruder name, level) -> first time that intruder's alert level reached the level, from avionics_sitl replay."""
    first: dict[tuple[str, int], float] = {}
    for row in csv.DictReader(io.StringIO(replayed_csv(str(path), tuple(DO365_ARGS)))):
        level = int(row["alert_level"])
        assert row["alert_name"] == ({0: "NONE"} | LEVELS)[level]
        for n in range(1, level + 1):
            first.setdefault((row["name"], n), float(row["time_s"]))
    return first


@pytest.mark.parametrize("case_file", sorted(GOLDEN) or ["(no data)"])
def test_first_preventive_corrective_and_warning_within_1_s_of_daidalus(case_file):
    require(GOLDEN)
    found = problems(GOLDEN[case_file], _first_alerts(CONFORMANCE / case_file), LEVELS)
    assert not found, f"{case_file}: " + "; ".join(found)
