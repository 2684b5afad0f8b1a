"""`python -m avionics_eval.reports.fusion` (Dai Table 2 reproduced) runs and says what docs/tracking.md says of it."""

from __future__ import annotations

import json
import math

from avionics_eval.reports import fusion as report


def test_the_fusion_report_runs_and_fusion_falls_back_to_the_radar_under_an_adsb_step(capsys):
    assert report.main(["--runs", "2"]) == 0
    res = json.loads(capsys.readouterr().out)
    assert set(res["rows"]) == {"active", "radar"}
    for kind in res["rows"]:
        for sampling in report.SAMPLING:
            for fault in report.FAULTS:
                assert set(res["rows"][kind][sampling][fault]) == set(report.SYSTEMS)

    def horizontal(cell):
        return math.hypot(cell["rmse_east_m"], cell["rmse_north_m"])

    step = res["rows"]["radar"]["fixed"]["step"]
    assert horizontal(step["fused"]) < horizontal(step["adsb"]) / 2  # ADS-B alone jumps, fused falls back
    clean = res["rows"]["radar"]["fixed"]["clean"]
    assert horizontal(clean["fused"]) < horizontal(clean["sensor"]) / 10  # clean: ADS-B's accuracy
    table = report.markdown(res)
    assert table.splitlines()[0].startswith("| sensor | sampling | ADS-B | system |")
