"""`avionics run --traffic beast:127.0.0.1:PORT` (a child process) against the simulator's Beast server on loopback,
the ownship over MAVLink UDP from this process: the head-on gives a TA and then an RA, through the feed framework's
reader thread (avionics/io/feeds/source.py) and the Beast session. Between the TA and the RA the receiver is killed
and restarted on the same port: the feed reconnects at its first or second retry (0.5 s, then 1 s later: within 2 s
with the position period), and the aircraft's CPR state outlives the connection (no new even/odd pair needed)."""

from __future__ import annotations

import csv
import json
import socket
import subprocess
import sys
import time

import avionics.io  # noqa: F401  (MAVLink 2 before pymavlink is imported)
import pytest

from avionics_sitl.autopilot import Packer, schedule
from avionics_sitl.beast import BeastServer, beast_schedule
from avionics_sitl.encounters import load_encounter
from avionics_sitl.impairments import PRESETS
from tests.conftest import DEADLINE_S, wait_for

pytestmark = pytest.mark.live  # a child process, UDP and TCP on loopback

SCENARIO = load_encounter("head-on")
START_S, KILL_S, END_S = 51.0, 59.0, 67.0  # TA ~55 s, RA ~65.3 s


def test_run_with_a_beast_receiver_gives_ta_then_ra_and_survives_the_receiver_restarting(tmp_path, udp_port,
                                                                                          tcp_port):
    frames = beast_schedule(SCENARIO, PRESETS["none"], duration_s=END_S)
    ownship = [e for e in schedule(SCENARIO, PRESETS["none"], duration_s=END_S)
               if e.msg.get_type() != "ADSB_VEHICLE" and e.deliver_s >= START_S]
    server = BeastServer(frames, port=tcp_port, start_s=START_S, start_on_connect=True).start()
    out_csv = tmp_path / "advisories.csv"
    onboard = subprocess.Popen(
        [sys.executable, "-m", "avionics.cli", "run", "--connection", f"udpin:127.0.0.1:{udp_port}", "--no-zenoh",
         "--traffic", f"beast:127.0.0.1:{tcp_port}", "--csv", str(out_csv), "--counters",
         "--duration", str(END_S - START_S + 2 * DEADLINE_S)],  # ended by the test; a backstop only
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    packer, i, restarted = Packer(), 0, False
    try:
        # the clock of the encounter starts when the onboard process's feed connects (its link is open by then)
        assert wait_for(lambda: server.started() or onboard.poll() is not None), "the feed never connected"
        assert onboard.poll() is None, onboard.communicate()[1]
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as udp:
            while (now := server.scenario_time()) < END_S:
                while i < len(ownship) and ownship[i].deliver_s <= now:
                    udp.sendto(packer.pack(ownship[i].msg), ("127.0.0.1", udp_port))
                    i += 1
                if not restarted and now >= KILL_S:  # the receiver goes away and comes back on the same port
                    server.stop()
                    server = BeastServer(frames, port=tcp_port, start_s=now).start()
                    restarted = True
                time.sleep(0.01)  # pacing the ownship at 5 Hz in real time, not a synchronisation
        assert restarted and onboard.poll() is None
    finally:
        onboard.terminate()
        stdout, stderr = onboard.communicate(timeout=DEADLINE_S)
        server.stop()
    assert onboard.returncode == 0, stderr
    counters = json.loads(stdout[stdout.index("{"):])
    with open(out_csv) as f:
        rows = [r for r in csv.DictReader(f) if r["reason"] != "shutdown"]
    intruder = SCENARIO.intruders[0]
    levels = [r["advisory"] for r in rows if r["intruder"].endswith(f"{intruder.icao_address:06X}")]
    print(json.dumps({"levels": levels, "beast": {k: v for k, v in counters.items() if "beast" in k}}))
    assert levels[:2] == ["TA", "RA"], rows
    assert counters["traffic.beast.reports"] > 2 * (END_S - START_S) * 0.7
    assert counters["traffic.beast.disconnects"] == 1 and counters["traffic.beast.reconnects"] >= 1
    assert counters.get("traffic.beast.connect_failures", 0) <= 1  # back at the first or second retry
    assert counters["traffic.beast.cpr_global"] == 1  # one pair at the start; afterwards, locally, also after the
    assert not counters.get("traffic.beast.bad_frame") and not counters.get("traffic.beast.crc_failed")  # restart
