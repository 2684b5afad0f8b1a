"""The whole chain over real sockets: SITL autopilot (this process) <-UDP-> `avionics run` (a child
process) -> zenoh -> a subscriber in another session. Head-on: TA, then RA, then clear."""

import json
import socket
import subprocess
import sys
import threading
import time

import avionics.io  # noqa: F401
import pytest
from pymavlink.dialects.v20 import common as mavlink2

from avionics.config import ZenohConfig
from avionics.io.zenoh_bus import open_session
from avionics_sitl.impairments import PRESETS
from avionics_sitl.live import fly
from avionics_sitl.encounters import load_encounter
from tests.conftest import DEADLINE_S, wait_for

pytestmark = pytest.mark.live  # a child process, UDP and zenoh on loopback

START_S, END_S = 46.0, 100.0  # head-on: TA ~55 s, RA ~65 s, CPA 86.4 s, clear ~93.3 s (range > TA DMOD)


def _wait_for_tcp(port: int, process, timeout_s: float = DEADLINE_S) -> None:
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        assert process.poll() is None, process.communicate()[1]
        with socket.socket() as probe:
            if probe.connect_ex(("127.0.0.1", port)) == 0:
                return
        time.sleep(0.1)
    raise AssertionError(f"the onboard process did not listen on {port} within {timeout_s} s")


def test_head_on_over_udp_gives_ta_ra_clear_on_mavlink_and_zenoh(udp_port, tcp_port):
    endpoint = f"tcp/127.0.0.1:{tcp_port}"
    onboard = subprocess.Popen(
        [sys.executable, "-m", "avionics.cli", "run", "--connection", f"udpin:127.0.0.1:{udp_port}",
         "--set", f'zenoh.listen=["{endpoint}"]', "--set", "vehicle.id=testuav",
         "--duration", str(END_S - START_S + 10 + 2 * DEADLINE_S)],  # ended by the test; a backstop only
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    received = {"advisories": [], "status": []}
    lock = threading.Lock()

    def on_sample(sample):
        with lock:
            kind = "status" if str(sample.key_expr).endswith("/status") else "advisories"
            if kind == "advisories" or "/tracks/" not in str(sample.key_expr):
                received[kind].append((str(sample.key_expr), str(sample.encoding), json.loads(sample.payload.to_bytes())))

    session = None
    try:
        _wait_for_tcp(tcp_port, onboard)  # the onboard process is up once its zenoh endpoint listens
        session = open_session(ZenohConfig(listen=(), connect=(endpoint,)))
        subscribers = [session.declare_subscriber("daa/testuav/advisories/*", on_sample),
                       session.declare_subscriber("daa/testuav/status", on_sample)]
        # Bad input on the same link before the encounter: garbage with start markers, and an ADSB_VEHICLE
        # with latitude 91 degrees. Neither may cost a valid frame or raise an advisory.
        mav = mavlink2.MAVLink(None, srcSystem=1, srcComponent=156)
        bad = mav.adsb_vehicle_encode(0xBADBAD, 910000000, 80000000, 0, 914400, 0, 12000, 0, b"BAD", 1, 0,
                                      0x1FF, 0).pack(mav)
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as raw:
            for _ in range(3):
                raw.sendto(bytes([0xFD, 0x40, 0, 0, 0xFE, 0x20, 1, 2]) + bad, ("127.0.0.1", udp_port))
        recording = fly(load_encounter("head-on"), f"udpout:127.0.0.1:{udp_port}", PRESETS["default"], seed=3,
                        start_s=START_S, duration_s=END_S - START_S)
        with lock:  # the status as of the end of the flight: published while ownship was still flowing
            status_at_end = len(received["status"])
        # The clear (NONE) went out at ~93 s, before the flight ended: wait until it is here, however loaded.
        wait_for(lambda: [p["level"] for _, _, p in received["advisories"]][-1:] == ["NONE"])
        for sub in subscribers:
            sub.undeclare()
    finally:
        onboard.terminate()
        _, err = onboard.communicate(timeout=DEADLINE_S)
        if session is not None:
            session.close()

    collisions = [r.msg for r in recording.of_type("COLLISION")]
    levels = []
    for msg in collisions:
        if not levels or levels[-1] != msg.threat_level:
            levels.append(msg.threat_level)
    # TA, RA, then TA again while the opening range is inside the TA DMOD (closing or not), then clear
    assert levels == [mavlink2.MAV_COLLISION_THREAT_LEVEL_LOW, mavlink2.MAV_COLLISION_THREAT_LEVEL_HIGH,
                      mavlink2.MAV_COLLISION_THREAT_LEVEL_LOW, mavlink2.MAV_COLLISION_THREAT_LEVEL_NONE], err
    ta = next(m for m in collisions if m.threat_level == mavlink2.MAV_COLLISION_THREAT_LEVEL_LOW)
    ra = next(m for m in collisions if m.threat_level == mavlink2.MAV_COLLISION_THREAT_LEVEL_HIGH)
    # action: REPORT for a TA and an RA unless mavlink.collision_action_request (docs/mavlink.md, COLLISION)
    assert ta.action == mavlink2.MAV_COLLISION_ACTION_REPORT and ra.action == mavlink2.MAV_COLLISION_ACTION_REPORT
    assert ta.id == ra.id == 0xA10001 and ta.src == mavlink2.MAV_COLLISION_SRC_ADSB
    assert 25 < ta.time_to_minimum_delta < 38 and ta.horizontal_minimum_delta < 150
    assert {m.id for m in collisions} == {0xA10001}  # nothing from the invalid report
    assert recording.of_type("HEARTBEAT") and recording.of_type("STATUSTEXT")

    with lock:
        advisories = [p for _, _, p in received["advisories"]]
        encodings = {e for _, e, _ in received["advisories"]}
        assert status_at_end, "no status arrived during the flight"
        status = received["status"][status_at_end - 1][2]
    assert [a["level"] for a in advisories if a["level"] != "NONE"][:1] == ["TA"]
    assert "RA" in [a["level"] for a in advisories] and advisories[-1]["level"] == "NONE"
    assert all(a["intruder"] == "1090es-A10001" and a["vehicle"] == "testuav" for a in advisories)
    assert encodings == {"application/json"}
    assert status["counters"]["adsb.lat_out_of_range"] == 3
    assert status["counters"]["frame.skipped_bytes"] > 0
    assert status["ownship_valid"] and status["sensitivity_level"] == 4


def test_head_on_over_tcpin_reaches_the_autopilot_behind_an_idle_client(tcp_port):
    """An idle TCP client connects to `avionics run --connection tcpin:...` first, then the autopilot: the
    autopilot gets the link (ownship, TA and RA), and the idle client is closed after
    mavlink.tcpin_idle_timeout_s. pymavlink's tcpin gave the only slot to the idle client."""
    onboard = subprocess.Popen(
        [sys.executable, "-m", "avionics.cli", "run", "--connection", f"tcpin:127.0.0.1:{tcp_port}", "--no-zenoh",
         "--counters", "--duration", str(25 + 2 * DEADLINE_S)],  # ended by the test; a backstop only
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    idle = None
    try:
        _wait_for_tcp(tcp_port, onboard)  # (the probe's connection closes at once)
        idle = socket.create_connection(("127.0.0.1", tcp_port), timeout=DEADLINE_S)  # connects, says nothing
        recording = fly(load_encounter("head-on"), f"tcp:127.0.0.1:{tcp_port}", PRESETS["default"], seed=3,
                        start_s=START_S, duration_s=70.0 - START_S)  # TA ~55 s, RA ~65 s
        idle.settimeout(DEADLINE_S)
        closed_by_onboard = idle.recv(4096) == b""
    finally:
        if idle is not None:
            idle.close()
        onboard.terminate()
        out, err = onboard.communicate(timeout=DEADLINE_S)
    levels = {m.threat_level for m in (r.msg for r in recording.of_type("COLLISION")) if m.id == 0xA10001}
    assert {mavlink2.MAV_COLLISION_THREAT_LEVEL_LOW, mavlink2.MAV_COLLISION_THREAT_LEVEL_HIGH} <= levels, err
    assert recording.of_type("HEARTBEAT")
    assert closed_by_onboard
    counters = json.loads(out)
    assert counters["link.tcpin_idle_closed"] >= 1 and counters["link.tcpin_owner"] == 1, counters
