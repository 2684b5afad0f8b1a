"""avionics_eval.alerter_bench (issue 29 item 4) prints its JSON: both alerters, every size, the compiled path (when
the kernels are on) and the numpy reference, positive times per call and per pair, and the one-intruder p50 beside
DAIDALUS's 33 us (no timing is asserted: the numbers are docs/performance.md's)."""

from __future__ import annotations

import json

from avionics.base import jit
from avionics_eval.alerter_bench import main


def test_alerter_bench_prints_both_alerters_both_paths(capsys):
    assert main(["--sizes", "1,3", "--repeats", "1", "--calls", "20"]) == 0
    out = json.loads(capsys.readouterr().out)
    paths = {"compiled", "reference"} if jit.ENABLED else {"reference"}
    assert out["compiled_kernels"] is jit.ENABLED and out["daidalus_step_us"] == 33.0
    for name in ("do365", "do365b_sum"):
        assert set(out[name]) == {"N1", "N3"}
        assert out["one_intruder_p50_us"][name] == out[name]["N1"]["compiled" if jit.ENABLED else "reference"]["p50_us"]
        for n, size in ((1, out[name]["N1"]), (3, out[name]["N3"])):
            assert set(size) == paths
            for row in size.values():
                assert 0 < row["p50_us"] <= row["p90_us"] and row["us_per_call"] > 0
                assert abs(row["us_per_pair"] - row["us_per_call"] / n) < 0.01 * row["us_per_call"]
