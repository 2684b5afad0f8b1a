"""`sitl replay` in fast time: the acceptance encounter from a DAIDALUS .daa file, timed by hand."""

import csv
import math
import subprocess
import sys
from pathlib import Path

import pytest

from avionics.config import load_config
from avionics.base.units import KT, NM
from avionics_sitl.impairments import PRESETS
from avionics_sitl.replay import replay
from avionics_sitl.encounters import load_encounter

DATA = Path(__file__).parent / "data"
CLOSING = 250 * KT
RANGE0 = 6 * NM


def modified_tau_crossing(tau_s: float, dmod_m: float) -> float:
    """Time at which (r^2 - DMOD^2) / (r * closing) = tau for r = RANGE0 - closing * t (head-on)."""
    r = (tau_s * CLOSING + math.sqrt((tau_s * CLOSING) ** 2 + 4 * dmod_m**2)) / 2
    return (RANGE0 - r) / CLOSING


@pytest.mark.live  # the `sitl replay` command in a process of its own
def test_daa_head_on_at_3000_ft_alerts_at_the_hand_computed_times(tmp_path):
    out = tmp_path / "advisories.csv"
    subprocess.run([sys.executable, "-m", "avionics_sitl.cli", "replay", str(DATA / "head_on_3000ft.daa"),
                    "--noise", "none", "--out", str(out)], check=True)
    with open(out, newline="") as fh:
        reader = csv.DictReader(fh)
        assert reader.fieldnames[:3] == ["time_s", "intruder", "advisory"]
        rows = list(reader)
    firsts = [r for i, r in enumerate(rows) if i == 0 or rows[i - 1]["advisory"] != r["advisory"]]
    assert [r["advisory"] for r in firsts] == ["TA", "RA", "TA", "NONE"]
    assert {r["sensitivity_level"] for r in rows} == {"4"}
    assert all(r["ra"] and r["ra_sense"] in ("climb", "descend") for r in rows if r["advisory"] == "RA")
    ta, ra, ra_end, clear = (float(r["time_s"]) for r in firsts)
    assert ta == pytest.approx(modified_tau_crossing(30.0, 0.48 * NM), abs=1.0)  # SL4 TA: tau 30 s, DMOD 0.48 nm
    assert ra == pytest.approx(modified_tau_crossing(20.0, 0.35 * NM), abs=1.0)  # SL4 RA: tau 20 s, DMOD 0.35 nm
    # After CPA the range opens, but inside DMOD the pair is still a threat (DAIDALUS TCAS2D.horizontal_RA):
    # RA until the range passes the RA DMOD, TA until it passes the TA DMOD.
    assert ra_end == pytest.approx((RANGE0 + 0.35 * NM) / CLOSING, abs=1.0)
    assert clear == pytest.approx((RANGE0 + 0.48 * NM) / CLOSING, abs=1.0)


@pytest.mark.parametrize("name", ["head-on", "crossing-90", "overtaking", "climbing-intruder"])
def test_builtin_encounters_alert_with_and_without_adsb_noise(name):
    scenario = load_encounter(name)
    config = load_config(overrides=["zenoh.enabled=false"])
    exact = replay(scenario, config, PRESETS["none"])
    noisy = replay(scenario, config, PRESETS["default"], seed=7)
    for result in (exact, noisy):
        levels = [c.level.name for c in result.changes]
        levels = [lvl for i, lvl in enumerate(levels) if i == 0 or levels[i - 1] != lvl]
        assert levels[:2] == ["TA", "RA"] and levels[-1] == "NONE", levels
        # the autopilot side got every change as a COLLISION, decoded from real frames
        assert {m.threat_level for _, m in result.collisions} == {0, 1, 2}
    onsets = lambda r, lvl: next(c.time_s for c in r.changes if c.level.name == lvl)  # noqa: E731
    for level in ("TA", "RA"):
        assert abs(onsets(noisy, level) - onsets(exact, level)) <= 3.0


def test_replay_is_deterministic_for_a_seed():
    scenario = load_encounter("crossing-90")
    config = load_config(overrides=["zenoh.enabled=false"])
    a = replay(scenario, config, PRESETS["default"], seed=11).rows()
    b = replay(scenario, config, PRESETS["default"], seed=11).rows()
    assert a == b
