"""`avionics evaluate --model FILE --ownship ...` (avionics_eval.evaluation.lincoln and the weighted metrics):
encounters of the shipped Lincoln models paired with a UAV ownship are a function of (seed, index) alone, their
truth has the drawn misses, their records fit the schema; the weighted report by hand; bad options refused."""

from __future__ import annotations

import math

import numpy as np
import pyarrow as pa
import pytest

from avionics.base.units import FT
from avionics_eval import cli
from avionics_eval.evaluation import evaluate as ev
from avionics_eval.evaluation.generator import DT_S, T_CPA_S
from avionics_eval.evaluation.lincoln import OWNSHIPS, LincolnSource
from avionics_eval.evaluation.metrics import markdown, metrics

ROTORCRAFT = "uncor_1200exclude_rotorcraft_v1p2.txt"


@pytest.mark.parametrize("ownship", [*OWNSHIPS, "uncor_1200only_fwse_v1p2.txt"])
def test_an_encounter_is_reproducible_and_its_truth_has_the_drawn_misses(ownship):
    source = LincolnSource.of(ROTORCRAFT, ownship)
    e = source.encounter(5, 17)
    again = LincolnSource.of(ROTORCRAFT, ownship).encounter(5, 17)
    assert np.array_equal(e.own, again.own) and np.array_equal(e.intruder, again.intruder)
    assert e.weight == again.weight > 0 and not np.array_equal(source.encounter(5, 18).own, e.own)
    t, own, intruder = e.truth()
    c = round(T_CPA_S / DT_S)
    horizontal = np.hypot(intruder[:, 0] - own[:, 0], intruder[:, 1] - own[:, 1])
    assert horizontal[c] == pytest.approx(abs(e.hmd_drawn_ft) * FT, abs=1 * FT)  # the miss at TCA, to 1 ft
    assert horizontal.min() >= abs(e.hmd_drawn_ft) * FT - 1 * FT                 # and nowhere closer
    assert intruder[c, 2] - own[c, 2] == pytest.approx(e.vmd_drawn_ft * FT, abs=1 * FT)
    # positions advance by the segment velocities (the 1 Hz tracks are piecewise linear)
    assert np.allclose(np.diff(own[:, 0]), own[:-1, 3] * DT_S, atol=1e-6)


def test_a_record_of_a_lincoln_encounter_fits_the_schema():
    e = LincolnSource.of(ROTORCRAFT, "uav-survey").encounter(1, 3)
    record = ev.evaluate(e, "do365", (1, 3))
    table = pa.Table.from_pylist([record], schema=ev.RECORD_SCHEMA)
    assert table.column_names == list(record) and record["weight"] == e.weight
    assert record["source"] == f"lincoln:{ROTORCRAFT};ownship=uav-survey" and record["layer"] is None
    assert record["hmd_ft"] == pytest.approx(abs(e.hmd_drawn_ft), abs=1.0)


def _rows(profile, weights, nmac_u, nmac_e, source="lincoln:x;ownship=uav-hover"):
    n = len(weights)
    return [{"seed": 1, "index": i, "profile": profile, "source": source, "weight": weights[i],
             "nmac_unequipped": nmac_u[i], "nmac_equipped": nmac_e[i], "lowc_unequipped": nmac_u[i] or i % 2 == 0,
             "lowc_equipped": nmac_e[i], "alerted": i < 6, "ra": i < 4, "nuisance_ra": i == 3} for i in range(n)]


def test_the_weighted_report_by_hand():
    w = [4.0, 1.0, 1.0, 2.0, 2.0, 1.0, 1.0, 3.0, 1.0, 4.0]
    u = [True, True, True, False, False, False, False, False, False, False]
    e = [True, False, False, True, False, False, False, False, False, False]  # one left, one induced
    r = metrics(pa.Table.from_pylist(_rows("do365", w, u, e)))["do365"]
    total = sum(w)
    assert r["p_nmac_unequipped"][0] == pytest.approx(6 / total) and r["events"]["p_nmac_unequipped"] == 3
    assert r["p_nmac_equipped"][0] == pytest.approx(6 / total)
    assert r["risk_ratio"][0] == pytest.approx(1.0) and r["events"]["risk_ratio"] == (2, 3)
    assert r["unresolved_ratio"][0] == pytest.approx(4 / 6) and r["induced_ratio"][0] == pytest.approx(2 / 6)
    assert r["p_induced_nmac"][0] == pytest.approx(2 / total) and r["p_unresolved_nmac"][0] == pytest.approx(4 / total)
    lowc_u = 4 + 1 + 1 + 2 + 1 + 1  # indices 0, 1, 2, 4, 6, 8
    assert r["lowc_ratio"][0] == pytest.approx(6 / lowc_u)
    assert r["alert_rate"][0] == pytest.approx(11 / total) and r["nuisance_ra_rate"][0] == pytest.approx(2 / total)
    assert r["effective_n"] == pytest.approx(total ** 2 / sum(x * x for x in w))
    assert r["nmac_counts"] == {"both": 1, "induced": 1, "resolved": 2}
    for key in ("p_nmac_unequipped", "risk_ratio", "lowc_ratio", "alert_rate"):
        est, lo, hi = r[key]
        assert lo <= est <= hi and not math.isnan(lo)
    table = markdown({"do365": r})
    assert "| risk ratio | 1 [" in table and "(2/3) |" in table and "encounters (effective n) | 10 (" in table


def test_sources_are_not_mixed_and_ours_stays_unweighted():
    rows = _rows("p", [1.0] * 4, [True] * 4, [False] * 4) + _rows("p", [1.0] * 4, [True] * 4, [False] * 4, "y")
    for i, row in enumerate(rows):
        row["index"] = i
    with pytest.raises(ValueError, match="mix encounter sources"):
        metrics(pa.Table.from_pylist(rows))
    ours = _rows("p", [1.0] * 4, [True] * 4, [False] * 4, "ours")
    for row in ours:
        row.update(ra_reversals=0, ra_strengthenings=0, late_ra=False, ra_lead_s=None, alert_duration_s=1.0)
    assert "weighted" not in metrics(pa.Table.from_pylist(ours))["p"]


@pytest.mark.parametrize("argv, message", [
    (["--model", ROTORCRAFT, "--ownship", "uav-fly"], "--ownship 'uav-fly'"),
    (["--model", "no-such-model.txt", "--ownship", "uav-hover"], "no-such-model.txt"),
    (["--model", ROTORCRAFT], "needs --model FILE[,FILE] and --ownship"),
    (["--generator", "ours", "--model", ROTORCRAFT, "--ownship", "uav-hover"], "not with --generator ours"),
])
def test_bad_lincoln_options_exit_2_before_anything_is_written(tmp_path, capsys, argv, message):
    out = tmp_path / "out"
    assert cli.main(["evaluate", *argv, "--out", str(out), "--scheduler", "synchronous"]) == 2
    assert message in capsys.readouterr().err and not out.exists()


def test_the_command_runs_a_weighted_set_resumes_it_and_reports_it(tmp_path, capsys):
    """avionics evaluate --model ... end to end, in process: a set of 6 encounters in partitions of 3, the second
    partition by a second run; its manifest names source and conditions; another ownship is refused on the
    same --out; the report is weighted, in Markdown and in JSON."""
    import json

    out = tmp_path / "set"
    argv = ["evaluate", "--model", ROTORCRAFT, "--ownship", "uav-transit", "--surveillance", "do365-adsb",
            "--pilot", "standard", "--profiles", "daidalus-tcas3d", "--encounters", "6", "--partition-size", "3",
            "--seed", "2", "--scheduler", "synchronous", "--out", str(out)]
    assert cli.main([*argv, "--max-partitions", "1"]) == 0
    assert json.loads(capsys.readouterr().out)["partitions_left"] == 1
    assert cli.main(argv) == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["complete"] and summary["evaluated_now"] == 3
    assert summary["source"] == f"lincoln:{ROTORCRAFT};ownship=uav-transit"
    assert summary["conditions"] == "surveillance=do365-adsb,pilot=standard"
    manifest = json.loads((out / "_manifest.json").read_text())
    assert manifest["source"] == summary["source"] and manifest["conditions"] == summary["conditions"]
    other = [a if a != "uav-transit" else "uav-hover" for a in argv]
    assert cli.main(other) == 2 and "holds another set" in capsys.readouterr().err
    assert cli.main(["evaluate", "--report", str(out)]) == 0
    report = capsys.readouterr().out
    assert report.startswith(f"source: lincoln:{ROTORCRAFT}") and "| encounters (effective n) | 6 (" in report
    assert cli.main(["evaluate", "--report", str(out), "--json"]) == 0
    result = json.loads(capsys.readouterr().out)["daidalus-tcas3d"]
    assert result["weighted"] and result["encounters"] == 6 and len(result["p_nmac_unequipped"]) == 3
