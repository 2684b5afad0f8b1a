"""`sitl replay --misses`: one row per intruder with the true miss at the true horizontal CPA, without and
with the RAs flown (`--fly-ras` closes the loop; without it flown == unflown)."""

import csv

import pytest

from avionics.advisory.tables import load_profile
from avionics_sitl.cli import main

MISS_HEADER = ["intruder", "name", "t_cpa_s", "hmd_m", "vmd_unflown_m", "vmd_flown_m", "min_agl_m"]
# The built-in head-on is co-altitude at 3000 ft MSL over 0 ft ground: TCAS II SL4 (ceiling 5000 ft), ALIM 300 ft.
HEAD_ON_SL = 4
TOLERANCE_M = 0.5


def _read(path):
    with open(path, newline="") as fh:
        reader = csv.DictReader(fh)
        return reader.fieldnames, list(reader)


def _replay(tmp_path, *flags):
    misses, adv = tmp_path / "misses.csv", tmp_path / "adv.csv"
    assert main(["replay", "head-on", "--noise", "none", *flags, "--misses", str(misses), "--out", str(adv)]) == 0
    header, rows = _read(misses)
    assert header == MISS_HEADER
    _, advisories = _read(adv)
    return rows, advisories


def test_fly_ras_meets_alim(tmp_path):
    rows, advisories = _replay(tmp_path, "--fly-ras")
    (row,) = rows
    # the intruder column is the key exactly as the advisory CSV prints it for that aircraft
    assert row["name"] == "intruder"
    assert {a["intruder"] for a in advisories} == {row["intruder"]} == {"1090es-A10001"}
    assert float(row["t_cpa_s"]) == pytest.approx(86.4, abs=0.2)
    assert float(row["hmd_m"]) == pytest.approx(0.0, abs=1.0)
    assert float(row["vmd_unflown_m"]) == pytest.approx(0.0, abs=1e-3)
    ras = [a for a in advisories if a["advisory"] == "RA"]
    assert ras and all(int(a["sensitivity_level"]) == HEAD_ON_SL for a in ras)
    level = next(lvl for lvl in load_profile("tcas2").levels if lvl.sl == HEAD_ON_SL)
    assert float(row["vmd_flown_m"]) >= level.alim_m - TOLERANCE_M


def test_open_loop_misses_flown_equals_unflown(tmp_path):
    rows, _ = _replay(tmp_path)
    (row,) = rows
    assert row["intruder"] == "1090es-A10001" and row["name"] == "intruder"
    assert row["vmd_flown_m"] == row["vmd_unflown_m"]
    assert float(row["vmd_unflown_m"]) == pytest.approx(0.0, abs=1e-3)
