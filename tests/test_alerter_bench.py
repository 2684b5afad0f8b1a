"""avionics_eval.alerter_bench (issue 29 item 4) prints its JSON: both alerters, every size, a positive time per
call and per pair (no timing is asserted: the numbers are docs/performance.md's)."""

from __future__ import annotations

import json

from avionics_eval.alerter_bench import main


def test_alerter_bench_prints_both_alerters(capsys):
    assert main(["--sizes", "1,3", "--repeats", "1"]) == 0
    out = json.loads(capsys.readouterr().out)
    for name in ("do365", "do365b_sum"):
        assert set(out[name]) == {"N1", "N3"}
        for n, row in ((1, out[name]["N1"]), (3, out[name]["N3"])):
            assert row["us_per_call"] > 0
            assert abs(row["us_per_pair"] - row["us_per_call"] / n) < 0.01 * row["us_per_call"]
