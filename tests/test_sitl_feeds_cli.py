"""`sitl live --sbs PORT --no-adsb-vehicle` and `avionics run --traffic sbs:127.0.0.1:PORT`, both as child processes on
loopback, as a user runs them in two terminals: the ownship goes over MAVLink UDP, the head-on intruder only over the
simulator's SBS server, and the onboard process raises a TA for it (COLLISION back to sitl, and its --csv), with
`traffic.sbs` reports and no ADSB_VEHICLE in its counters. A port already in use is exit 1 in one line.

Waits poll with generous deadlines (conftest.wait_for); nothing is timed."""

from __future__ import annotations

import csv
import json
import socket
import subprocess
import sys
from pathlib import Path

import pytest

from avionics_sitl.encounters import load_encounter
from tests.conftest import DEADLINE_S, wait_for
from tests.test_cli_errors import assert_one_line_error, cli

pytestmark = pytest.mark.live  # child processes, UDP and TCP on loopback

ROOT = Path(__file__).resolve().parent.parent
INTRUDER = load_encounter("head-on").intruders[0]
START_S, DURATION_S = 48.0, 22.0  # TA ~55 s, RA ~65 s; the feed connects within its 2 s retry period


def test_sitl_live_sbs_feed_is_the_onboard_process_only_traffic_and_gives_a_ta(tmp_path, udp_port, tcp_port):
    out_csv = tmp_path / "advisories.csv"
    onboard = subprocess.Popen(
        [sys.executable, "-m", "avionics.cli", "run", "--connection", f"udpin:127.0.0.1:{udp_port}", "--no-zenoh",
         "--traffic", f"sbs:127.0.0.1:{tcp_port}", "--csv", str(out_csv), "--counters",
         "--duration", str(DURATION_S + 3 * DEADLINE_S)],  # ended by the test; a backstop only
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, cwd=ROOT)
    sitl = None
    try:
        # the CSV is opened after the MAVLink link: the onboard process listens once it exists
        assert wait_for(lambda: out_csv.exists() or onboard.poll() is not None), "onboard never started"
        assert onboard.poll() is None, onboard.communicate()[1]
        sitl = subprocess.Popen(
            [sys.executable, "-m", "avionics_sitl.cli", "live", "head-on", "--start", str(START_S),
             "--duration", str(DURATION_S), "--connection", f"udpout:127.0.0.1:{udp_port}",
             "--sbs", str(tcp_port), "--no-adsb-vehicle"],
            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, cwd=ROOT)
        sitl_out, sitl_err = sitl.communicate(timeout=DURATION_S + 3 * DEADLINE_S)
        assert onboard.poll() is None, onboard.communicate()[1]
    finally:
        if sitl is not None and sitl.poll() is None:
            sitl.kill()
            sitl.communicate()
        onboard.terminate()
        stdout, stderr = onboard.communicate(timeout=DEADLINE_S)
    assert sitl.returncode == 0, sitl_err
    assert onboard.returncode == 0, stderr
    summary = json.loads(sitl_err.splitlines()[-1])
    counters = json.loads(stdout[stdout.index("{"):])
    collisions = [json.loads(line) for line in sitl_out.splitlines() if '"COLLISION"' in line]
    with open(out_csv) as f:
        rows = [r for r in csv.DictReader(f) if r["reason"] != "shutdown"]
    address = f"{INTRUDER.icao_address:06X}"
    levels = [r["advisory"] for r in rows if r["intruder"].endswith(address)]
    print(json.dumps({"levels": levels, "sitl": summary, "collisions": len(collisions),
                      "onboard": {k: v for k, v in counters.items() if k.startswith(("traffic.", "rx."))}}))
    # the traffic came by SBS only: no ADSB_VEHICLE sent or received, SBS reports accepted and none rejected
    assert counters.get("rx.adsb_vehicle", 0) == 0 and counters["rx.global_position_int"] > 0
    assert counters["traffic.sbs.reports"] >= 0.5 * (DURATION_S - 3)  # 1 Hz, less the 5 % dropouts and connecting
    assert not any(k.startswith("traffic.sbs.rejected") for k in counters), counters
    assert summary["sbs_lines"] >= 2 * 0.8 * DURATION_S  # MSG,3 and MSG,4 per report
    assert summary["sent"] <= 2 * 5 * (DURATION_S + 1)  # GLOBAL_POSITION_INT and SCALED_PRESSURE at 5 Hz, nothing else
    # a TA for the head-on intruder, from the SBS path: in the CSV and as COLLISION back over MAVLink
    assert levels and levels[0] == "TA", rows
    assert any(c["id"] == address and c["threat_level"] >= 1 for c in collisions), collisions


def test_sitl_live_feed_port_in_use_is_one_line_exit_1():
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as busy:
        busy.bind(("127.0.0.1", 0))
        busy.listen()
        port = busy.getsockname()[1]
        for option in ("--sbs", "--beast"):
            proc = cli("live", "head-on", "--duration", "30", option, str(port), "--no-adsb-vehicle",
                       module="avionics_sitl.cli")
            assert_one_line_error(proc, 1, "sitl:", f"127.0.0.1:{port}", "in use", option)
            assert proc.stdout == ""  # refused before flying: nothing came back
