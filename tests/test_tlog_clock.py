""".tlog replay through a clock step (issue 25, item 6): a log whose recording computer's clock was set back
an hour mid-flight replays whole, the step counted, and alerts as the clean log; a log whose stamps are all zero
or frozen is a file error (one line, exit 2), not a replay to nothing. The logs are written in pymavlink's tlog
format (an 8-byte big-endian UNIX time in microseconds before each frame) with pymavlink-packed frames, and
replayed by `avionics run --connection FILE.tlog` as a child process (docs/mavlink.md, "Limits")."""

import csv
import json
import struct
import subprocess
import sys
from collections import Counter

import pytest

from avionics.io.link import LogError
from avionics_sitl.autopilot import Packer, schedule
from avionics_sitl.encounters import load_encounter
from avionics_sitl.impairments import PRESETS
from tests.conftest import DEADLINE_S
from tests.test_signing import _replay, _write_tlog

pytestmark = pytest.mark.live  # child processes

BASE_S = 1_700_000_000.0  # a plausible UNIX time
STEP_AT_S = 40.0  # before the TA (~55 s) and the RA (~65 s) of the head-on


def _head_on_tlog(path, stamp_s) -> int:
    """The head-on's MAVLink schedule to 75 s as a .tlog, each frame stamped stamp_s(its delivery time); returns
    the number of frames."""
    packer = Packer()
    events = schedule(load_encounter("head-on"), PRESETS["none"], duration_s=75.0)
    with open(path, "wb") as fh:
        for event in events:
            fh.write(struct.pack(">Q", int(round(stamp_s(event.deliver_s) * 1e6))) + packer.pack(event.msg))
    return len(events)


def _avionics_run(path, tmp_path) -> tuple[subprocess.CompletedProcess, Counter, list[dict]]:
    out_csv = tmp_path / f"{path.stem}.csv"
    out = subprocess.run([sys.executable, "-m", "avionics.cli", "run", "--connection", str(path), "--no-zenoh",
                          "--counters", "--csv", str(out_csv)], capture_output=True, text=True,
                         timeout=3 * DEADLINE_S)
    counters = Counter(json.loads(out.stdout[out.stdout.index("{"):])) if "{" in out.stdout else Counter()
    rows = list(csv.DictReader(out_csv.open())) if out_csv.exists() else []
    return out, counters, rows


def test_a_tlog_whose_clock_steps_back_an_hour_replays_every_frame_and_alerts_as_the_clean_log(tmp_path):
    frames = _head_on_tlog(tmp_path / "clean.tlog", lambda t: BASE_S + t)
    _head_on_tlog(tmp_path / "stepped.tlog", lambda t: BASE_S + t - (3600.0 if t >= STEP_AT_S else 0.0))
    clean, clean_counters, clean_rows = _avionics_run(tmp_path / "clean.tlog", tmp_path)
    stepped, counters, rows = _avionics_run(tmp_path / "stepped.tlog", tmp_path)
    assert clean.returncode == 0 and stepped.returncode == 0, stepped.stderr
    # every frame delivered (today's code dropped every frame after the step: no TA, no RA)
    assert counters["tlog.clock_step_back"] == 1 and not counters["tlog.bad_timestamp"], counters
    delivered = ("rx.adsb_vehicle", "rx.global_position_int", "rx.scaled_pressure")
    assert [counters[k] for k in delivered] == [clean_counters[k] for k in delivered]
    assert sum(clean_counters[k] for k in delivered) >= frames - 80  # (HEARTBEATs are not counted there)
    # the same advisories at the same log times: the step is removed, the frames keep their spacing (the frame
    # after the step follows the one before it at once, one frame period early at most)
    assert [(r["intruder"], r["advisory"]) for r in rows] == [(r["intruder"], r["advisory"]) for r in clean_rows]
    assert [r["advisory"] for r in rows][:2] == ["TA", "RA"], rows
    assert {r["name"] for r in clean_rows} == {"HEADON"}  # run --csv names the intruder by its callsign
    for row, clean_row in zip(rows, clean_rows):
        assert float(row["time_s"]) == pytest.approx(float(clean_row["time_s"]), abs=0.5)


@pytest.mark.parametrize("stamp_s", [lambda t: 0.0, lambda t: BASE_S], ids=["all-zero", "frozen"])
def test_a_tlog_without_a_usable_stamp_is_a_file_error_not_a_silent_replay(tmp_path, stamp_s):
    _head_on_tlog(tmp_path / "frozen.tlog", stamp_s)
    out, _, _ = _avionics_run(tmp_path / "frozen.tlog", tmp_path)
    assert out.returncode == 2, out.stderr
    lines = [line for line in out.stderr.splitlines() if line.startswith("avionics:")]
    assert len(lines) == 1 and "no usable timestamp" in lines[0] and "zero or frozen" in lines[0], out.stderr
    assert "Traceback" not in out.stderr


def test_clock_steps_both_ways_are_counted_and_the_replay_time_never_goes_back(tmp_path):
    """Back 1 h (removed: the replay goes on from where it was), ahead 10 min (kept: a link that went quiet
    looks the same), and one stamp an hour back alone (corrupted, unconfirmed: that frame rejected)."""
    t = [BASE_S + 0.5 * k for k in range(10)]
    t += [BASE_S - 3600.0 + 5.0 + 0.5 * k for k in range(10)]
    t += [BASE_S - 3600.0 + 600.0 + 0.5 * k for k in range(10)]
    t[25] -= 3600.0
    frames = _write_tlog(tmp_path / "steps.tlog", t)
    got, counters = _replay(tmp_path / "steps.tlog")
    times = [m._timestamp for m in got]
    assert [bytes(m.get_msgbuf()) for m in got] == frames[:25] + frames[26:]
    assert counters == Counter({"tlog.clock_step_back": 1, "tlog.clock_step_ahead": 1, "tlog.bad_timestamp": 1})
    assert times == sorted(times) and times[10] == times[9]  # the step back: no time passed
    assert times[19] - times[10] == pytest.approx(4.5) and times[20] - times[19] == pytest.approx(590.5)


def test_a_log_of_every_stamp_rejected_is_a_log_error(tmp_path):
    _write_tlog(tmp_path / "bad.tlog", [(1 << 64) - 1] * 5)
    with pytest.raises(LogError, match="every stamp of 5 frame"):
        _replay(tmp_path / "bad.tlog")
