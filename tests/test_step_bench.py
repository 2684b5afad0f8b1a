"""`avionics bench --step` (eval/avionics_eval/step_bench.py, issue 32 item 4) prints its JSON: every step of every
timed encounter timed once (the evaluation steps the core once a second for 96 steps), positive times, the
targets beside them; an unknown profile is a usage error before anything runs. No timing is asserted: the numbers
are docs/performance.md's."""

from __future__ import annotations

import json

from avionics_eval import cli
from avionics_eval.evaluation.generator import DURATION_S
from avionics_eval.evaluation.evaluate import STEP_S


def test_the_step_bench_times_every_step_of_every_encounter(capsys):
    assert cli.main(["bench", "--step", "--profiles", "tcas2,do365", "--encounters", "2"]) == 0
    out = json.loads(capsys.readouterr().out)
    steps_per_encounter = round(DURATION_S / STEP_S) + 1
    assert out["encounters"] == 2 and out["filterpy_imm_step_us"] > 0 and out["command"].startswith("avionics")
    assert set(out["profiles"]) == {"tcas2", "do365"}
    for cost in out["profiles"].values():
        step = cost["one_intruder_step_us"]
        assert step["steps"] == 2 * steps_per_encounter and 0 < step["p50"] <= step["p90"]
        assert cost["evaluation_cpu_ms_per_encounter"] > 0
    assert out["targets"]["one_intruder_step_us"] == 33.0
    assert all("guided_cpu_ms_per_encounter" not in cost for cost in out["profiles"].values())


def test_the_guided_cost_is_asked_for(capsys):
    assert cli.main(["bench", "--step", "--profiles", "do365", "--encounters", "1", "--guided", "1"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["profiles"]["do365"]["guided_cpu_ms_per_encounter"] > 0


def test_an_unknown_profile_is_refused_before_anything_runs(capsys):
    assert cli.main(["bench", "--step", "--profiles", "tcas2,nonesuch"]) == 2
    err = capsys.readouterr()
    assert "nonesuch" in err.err and err.out == ""
