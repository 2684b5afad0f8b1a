"""python -m avionics_eval.reports.refly: the NMAC encounters of a results set flown again with the code as it is.

Oracle: evaluate() on the same encounter (what a new run would record); the set's conditions and source read
back from its manifest as they were written."""

from __future__ import annotations

import json

import pyarrow.parquet as pq
import pytest

from avionics_eval import cli
from avionics_eval.evaluation.evaluate import Conditions, evaluate
from avionics_eval.evaluation.generator import generate
from avionics_eval.evaluation.lincoln import LincolnSource
from avionics_eval.reports import refly

ROTORCRAFT = "uncor_1200exclude_rotorcraft_v1p2.txt"


@pytest.mark.parametrize("conditions", [Conditions(), Conditions("do365-adsb", 100.0, "standard"),
                                        Conditions("do365-adsb", None, "guidance", "multirotor"),
                                        Conditions("do365-adsb", None, "guidance", "multirotor", True)])
def test_the_manifests_conditions_read_back(conditions):
    assert refly.conditions_of(conditions.name) == conditions


def test_a_set_s_nmac_records_are_flown_again_and_their_outcome_now_reported(tmp_path, capsys):
    out = tmp_path / "set"
    assert cli.main(["evaluate", "--profiles", "tcas2", "--seed", "3", "--encounters", "2", "--scheduler",
                     "synchronous", "--out", str(out)]) == 0
    capsys.readouterr()
    (part,) = out.glob("part-*.parquet")
    table = pq.read_table(part)
    rows = table.to_pylist()
    rows[1].update(nmac_equipped=True, induced_nmac=True)  # as if an earlier code had flown encounter 1 into one
    pq.write_table(table.from_pylist(rows, schema=table.schema), part)
    assert refly.main([str(out)]) == 0
    report = json.loads(capsys.readouterr().out)
    now = evaluate(generate(3, 1), "tcas2", (3, 1))
    assert report["nmac_before"] == report["induced_before"] == 1 and report["profile"] == "tcas2"
    (one,) = report["encounters"]
    assert one["index"] == 1 and one["nmac_now"] == now["nmac_equipped"]
    assert report["nmac_now"] == int(now["nmac_equipped"]) and one["weight"] == rows[1]["weight"]
    assert refly.main([str(tmp_path / "none")]) == 2
    assert refly.main([str(out), "--guidance-bands"]) == 2  # a pilot set: no guidance to give the bands to
    assert "was not flown through the guidance" in capsys.readouterr().err


def test_a_guided_set_s_nmacs_are_flown_again_with_the_guidance_bands(tmp_path, capsys):
    out = tmp_path / "guided"
    assert cli.main(["evaluate", "--model", ROTORCRAFT, "--ownship", "uav-survey", "--surveillance", "do365-adsb",
                     "--pilot", "guidance", "--profiles", "do365", "--seed", "28", "--encounters", "1",
                     "--scheduler", "synchronous", "--out", str(out)]) == 0
    capsys.readouterr()
    (part,) = out.glob("part-*.parquet")
    table = pq.read_table(part)
    rows = table.to_pylist()
    rows[0].update(nmac_equipped=True)  # as if it had ended in an NMAC
    pq.write_table(table.from_pylist(rows, schema=table.schema), part)
    assert refly.main([str(out), "--guidance-bands"]) == 0
    report = json.loads(capsys.readouterr().out)
    assert report["conditions"] == "surveillance=do365-adsb,pilot=guidance,vehicle=multirotor,guidance_bands=on"
    bands = Conditions("do365-adsb", None, "guidance", "multirotor", True)
    now = evaluate(LincolnSource.of(ROTORCRAFT, "uav-survey").encounter(28, 0), "do365", (28, 0), conditions=bands)
    (one,) = report["encounters"]
    assert one["nmac_now"] == now["nmac_equipped"] and one["hmd_flown_ft"][1] == now["hmd_flown_ft"]
