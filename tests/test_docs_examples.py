"""docs/mavlink.md's worked example ("A real sequence") is what the onboard process sends, field by field, so that
the block an integrator copies cannot drift from the code again (it once showed COLLISION `action: 2` on the RA
where the default sends 1, REPORT, and a CLIMB the head-on no longer gives).

The example is the head-on's MAVLink schedule as `sitl live head-on` sends it (default impairments, seed 0),
framed by pymavlink, through the parts `avionics run` is built from (tests/harness.py: the validating MAVLink
input, the DAA facade, the MAVLink output port, the loop) in fast time at the loop's 0.1 s tick, each message
sent packed and decoded again with the project's dialect. The example's lines are parsed out of the markdown and
compared with the run's: every advisory change (COLLISION, DAA_ADVISORY, STATUSTEXT) in order with the same
enumerations and the same STATUSTEXT, at the same time (±0.5 s); each refresh shown matches one sent; the
numbers within a tolerance. `python -m tests.test_docs_examples` prints the sequence in the example's format.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
TICK_S = 0.1  # 1 / advisory.assessment_hz: the loop's tick
TYPES = ("COLLISION", "DAA_ADVISORY", "STATUSTEXT")
EXACT = {  # enumerations and words: compared exactly
    "COLLISION": ("id", "action", "threat_level"),
    "DAA_ADVISORY": ("id", "level", "sense", "strength", "flags", "sensitivity_level", "callsign"),
    "STATUSTEXT": ("severity", "text"),
}
TOLERANCE = {"time_s": 0.5, "time_to_minimum_delta": 1.0, "time_to_cpa": 1.0, "tau": 1.0, "mod_tau": 1.0,
             "altitude_minimum_delta": 5.0, "horizontal_minimum_delta": 20.0, "horizontal_miss": 20.0,
             "vertical_miss": 5.0, "range": 50.0, "pc": 0.1, "target_vertical_rate": 0.01}
SHOWN = {  # the fields the example shows
    "COLLISION": ("id", "action", "threat_level", "time_to_minimum_delta", "altitude_minimum_delta",
                  "horizontal_minimum_delta"),
    "DAA_ADVISORY": ("id", "level", "sense", "strength", "flags", "sensitivity_level", "target_vertical_rate",
                     "range", "time_to_cpa", "horizontal_miss", "vertical_miss", "tau", "mod_tau", "pc", "callsign"),
    "STATUSTEXT": ("severity", "text", "id", "chunk_seq"),
}


def head_on_sequence() -> list[dict]:
    """Every COLLISION, DAA_ADVISORY and STATUSTEXT the onboard process sends for the head-on, as the example
    shows them (floats rounded, NaN as None, time_s the scenario time of the step that sent them)."""
    from avionics.config import load_config
    from avionics.io.dialect import daa as dialect
    from avionics_sitl.autopilot import Packer, schedule
    from avionics_sitl.encounters import load_encounter
    from avionics_sitl.impairments import PRESETS
    from tests.harness import Harness

    node = Harness(load_config(None, ["zenoh.enabled=false"]))
    events = schedule(load_encounter("head-on"), PRESETS["default"], 0)  # sitl live's defaults
    packer, inbound, outbound = Packer(), dialect.MAVLink(None), dialect.MAVLink(None)
    ours = dialect.MAVLink(None, srcSystem=1, srcComponent=191)
    out, k, step = [], 0, 0
    while step * TICK_S <= events[-1].deliver_s:  # the scenario's end (after it, ownship times out)
        now = step * TICK_S
        batch = []
        while k < len(events) and events[k].deliver_s <= now:
            batch.extend(inbound.parse_buffer(packer.pack(events[k].msg)) or [])
            k += 1
        sent = len(node.mavlink_out)
        node.handle(batch, now)
        for msg in node.mavlink_out[sent:]:
            if msg.get_type() in TYPES:
                (decoded,) = outbound.parse_buffer(bytes(msg.pack(ours)))
                out.append(_shown(decoded, now))
        step += 1
    return out


def _shown(msg, now_s: float) -> dict:
    def value(v):
        if isinstance(v, float):
            return None if math.isnan(v) else round(v, 2)
        return v

    fields = msg.to_dict()
    return {"mavpackettype": msg.get_type(), **{f: value(fields[f]) for f in SHOWN[msg.get_type()]},
            "time_s": round(now_s, 2)}


def example_block(doc: str, heading: str) -> list[dict]:
    """The JSON lines of the first ```text block under `heading`."""
    section = doc.split(heading, 1)[1]
    block = section.split("```text\n", 1)[1].split("```", 1)[0]
    return [json.loads(line) for line in block.splitlines() if line.strip()]


def _matches(shown: dict, sent: dict) -> bool:
    if shown["mavpackettype"] != sent["mavpackettype"]:
        return False
    if any(shown[f] != sent[f] for f in EXACT[shown["mavpackettype"]]):
        return False
    for field, tolerance in TOLERANCE.items():
        if field in shown and (shown[field] is None) != (sent[field] is None):
            return False
        if field in shown and shown[field] is not None and abs(shown[field] - sent[field]) > tolerance:
            return False
    return True


def _groups(messages: list[dict]) -> list[list[dict]]:
    """COLLISION, DAA_ADVISORY and, for a change (not a refresh), STATUSTEXT."""
    groups, i = [], 0
    while i < len(messages):
        n = 3 if i + 2 < len(messages) and messages[i + 2]["mavpackettype"] == "STATUSTEXT" else 2
        groups.append(messages[i:i + n])
        i += n
    return groups


@pytest.fixture(scope="module")
def sent() -> list[dict]:
    return head_on_sequence()


def test_mavlink_md_real_sequence_is_what_the_onboard_process_sends(sent):
    example = _groups(example_block((ROOT / "docs" / "mavlink.md").read_text(), "### A real sequence"))
    run = _groups(sent)
    changes = [g for g in run if len(g) == 3]
    shown_changes = [g for g in example if len(g) == 3]
    assert len(shown_changes) == len(changes), ([g[2]["text"] for g in shown_changes], [g[2]["text"] for g in changes])
    for shown, got in zip(shown_changes, changes):
        for a, b in zip(shown, got):
            assert _matches(a, b), (a, b)
    for shown in (g for g in example if len(g) == 2):
        assert any(len(g) == 2 and all(_matches(a, b) for a, b in zip(shown, g)) for g in run), shown


def test_the_ra_collision_says_report_by_default(sent):
    """mavlink.collision_action_request is false by default: an RA's COLLISION is REPORT (1), never
    ASCEND_OR_DESCEND (2) (docs/mavlink.md, COLLISION)."""
    ra = [m for m in sent if m["mavpackettype"] == "COLLISION" and m["threat_level"] == 2]
    assert ra and {m["action"] for m in ra} == {1}


@pytest.mark.live  # a child process
def test_algorithms_md_head_on_replay_is_what_sitl_replay_gives():
    """docs/algorithms.md's "`sitl replay tests/data/head_on_3000ft.daa --noise none` gives TA 54.90 s, ..."
    against the real command's CSV: the same advisory changes at the same times (the CSV's 0.01 s)."""
    import csv
    import io
    import re
    import subprocess
    import sys

    doc = (ROOT / "docs" / "algorithms.md").read_text()
    command = "sitl replay tests/data/head_on_3000ft.daa --noise none"
    sentence = doc.split(f"`{command}` gives ", 1)[1].split(":", 1)[0]
    shown = [(level, float(t)) for level, t in re.findall(r"\b(TA|RA|NONE) (\d+\.\d\d) s", sentence)]
    proc = subprocess.run([sys.executable, "-m", "avionics_sitl.cli", *command.split()[1:]], capture_output=True,
                          text=True, timeout=300, cwd=ROOT)
    assert proc.returncode == 0, proc.stderr
    rows = list(csv.DictReader(io.StringIO(proc.stdout)))
    assert shown == [(r["advisory"], float(r["time_s"])) for r in rows], (sentence, rows)


if __name__ == "__main__":
    for line in head_on_sequence():
        print(json.dumps(line))
