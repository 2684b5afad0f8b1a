"""`avionics bench` runs end to end and accounts for every report (its numbers are measurements, not asserted)."""

import json
import os

import pytest

from avionics_eval.cli import main

pytestmark = pytest.mark.live  # a real zenoh session on loopback, the live loop on the wall clock


def test_bench_command_prints_both_modes_with_every_report_accounted_for(capsys):
    cores = os.sched_getaffinity(0)
    assert main(["bench", "--intruders", "5", "--seconds", "2"]) == 0
    assert os.sched_getaffinity(0) == cores  # pinned to one core for the run only
    out = json.loads(capsys.readouterr().out)
    assert [r["intruders"] for r in out["per_report"]] == [5] and [r["intruders"] for r in out["real_time"]] == [5]
    for run in out["per_report"] + out["real_time"]:
        assert run["reports"] == 10 and run["tracks"] == 5 and run["rejected"] == 0
        assert 0 < run["latency_us_p50"] <= run["latency_us_p99"] <= run["latency_us_max"]  # ordered, any size
    live = out["real_time"][0]
    # cpu_load is the loop's busy share of the wall time (a fraction, whatever the load); steps and the largest
    # batch depend on how promptly the loop was woken: it ran in steps, each taking what had arrived.
    assert 0 < live["cpu_load"] <= 1 and 1 <= live["steps"] and 1 <= live["largest_batch"] <= live["reports"]
