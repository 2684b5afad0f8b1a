"""A forged component of our own vehicle, over real sockets: `avionics run` as a child process on UDP, a forger
posing as system 1 component 200 on its own socket from before the encounter starts, then the SITL head-on
(autopilot component 1, ADS-B receiver component 156). Neither forged traffic nor a forged ownship 50 km away
costs the TA or the RA, and the forgery is announced on MAVLink (docs/mavlink.md, "Trusted sources")."""

from __future__ import annotations

import json
import socket
import subprocess
import sys
import threading
import time

import avionics.io  # noqa: F401
import pytest
from pymavlink.dialects.v20 import common as mavlink2

from avionics_sitl.impairments import PRESETS
from avionics_sitl.live import fly
from forgery import INTRUDER, SCENARIO, forged_ownship, forged_traffic
from tests.conftest import DEADLINE_S, wait_for

pytestmark = pytest.mark.live  # a child process and UDP on loopback

START_S, END_S = 46.0, 75.0  # head-on: TA ~55 s, RA ~65 s (21 s before the CPA at 86.4 s)
FORGER = (1, 200)


def fly_with_forger(udp_port: int, forge) -> tuple[list, dict, list]:
    """The onboard process, the forger sending forge(scenario time) at 5 Hz from before the flight to its end, and
    the SITL head-on from START_S to END_S. (what the autopilot received, the exit counters, what the forger got)"""
    onboard = subprocess.Popen(
        [sys.executable, "-m", "avionics.cli", "run", "--connection", f"udpin:127.0.0.1:{udp_port}", "--no-zenoh",
         "--counters", "--duration", str(END_S - START_S + 2 * DEADLINE_S)],  # ended by the test; a backstop
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    mav, parser = mavlink2.MAVLink(None, *FORGER), mavlink2.MAVLink(None)
    parser.robust_parsing = True
    forger_got: list = []
    stop = threading.Event()
    clock = {"t0": None}  # the scenario clock once the flight starts; START_S before

    def forger():
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as sock:
            sock.settimeout(0.2)
            while not stop.is_set():
                t0 = clock["t0"]
                t = START_S if t0 is None else START_S + time.monotonic() - t0
                try:
                    sock.sendto(bytes(forge(t).pack(mav)), ("127.0.0.1", udp_port))
                    forger_got.extend(m for m in parser.parse_buffer(sock.recv(65536)) or () if m is not None)
                except (socket.timeout, ConnectionRefusedError):
                    pass

    thread = threading.Thread(target=forger, daemon=True)
    thread.start()
    try:
        # the onboard process is up and has heard the forger once its HEARTBEAT comes back to the forger's socket
        assert wait_for(lambda: onboard.poll() is not None or any(m.get_type() == "HEARTBEAT" for m in forger_got))
        assert onboard.poll() is None, onboard.communicate()[1]
        clock["t0"] = time.monotonic()
        recording = fly(SCENARIO, f"udpout:127.0.0.1:{udp_port}", PRESETS["default"], seed=3, start_s=START_S,
                        duration_s=END_S - START_S)
    finally:
        stop.set()
        thread.join(DEADLINE_S)
        onboard.terminate()
        out, err = onboard.communicate(timeout=DEADLINE_S)
    assert onboard.returncode == 0, err
    return recording.received, json.loads(out[out.index("{"):]), forger_got


def _collisions(received):
    return [r.msg for r in received if r.msg.get_type() == "COLLISION"]


def _assert_ta_and_ra_on_time(received):
    """TA then RA for the real intruder, each as early in the encounter as without the forger (TA 31 s and RA 21 s
    before the CPA: `sitl replay head-on --noise default --seed 3`), with the real geometry (a head-on: HMD small)."""
    collisions = _collisions(received)
    levels = [m.threat_level for m in collisions]
    assert mavlink2.MAV_COLLISION_THREAT_LEVEL_LOW in levels and mavlink2.MAV_COLLISION_THREAT_LEVEL_HIGH in levels
    ta = next(m for m in collisions if m.threat_level == mavlink2.MAV_COLLISION_THREAT_LEVEL_LOW)
    ra = next(m for m in collisions if m.threat_level == mavlink2.MAV_COLLISION_THREAT_LEVEL_HIGH)
    assert ta.id == ra.id == INTRUDER.icao_address and {m.id for m in collisions} == {INTRUDER.icao_address}
    assert 25 < ta.time_to_minimum_delta < 38 and ta.horizontal_minimum_delta < 150
    assert 18 < ra.time_to_minimum_delta < 24 and ra.horizontal_minimum_delta < 150
    assert levels.index(mavlink2.MAV_COLLISION_THREAT_LEVEL_HIGH) > \
        levels.index(mavlink2.MAV_COLLISION_THREAT_LEVEL_LOW)
    assert max(m.horizontal_minimum_delta for m in collisions if m.threat_level) < 500  # never a garbled geometry


def _statustexts(received) -> list[tuple[int, str]]:
    return [(r.msg.severity, r.msg.text) for r in received if r.msg.get_type() == "STATUSTEXT"]


def _assert_announced(received, text: str) -> None:
    """At warning severity, again every 10 s while the forger goes on: the autopilot, which joined the link after
    the forger's first frame, hears it too."""
    times = [r.time_s for r in received if r.msg.get_type() == "STATUSTEXT" and r.msg.text == text
             and r.msg.severity == mavlink2.MAV_SEVERITY_WARNING]
    assert 1 <= len(times) <= (END_S - START_S) / 10 + 1, _statustexts(received)
    assert all(b - a > 9 for a, b in zip(times, times[1:]))


def _heartbeat_states(received) -> set[int]:
    """The HEARTBEAT system_status values the autopilot saw (STANDBY until the first ownship fix, then ACTIVE while
    DAA is available, CRITICAL while it is not)."""
    return {r.msg.system_status for r in received if r.msg.get_type() == "HEARTBEAT"}


def test_forged_traffic_from_component_200_first_neither_owns_the_track_nor_costs_the_ra(udp_port):
    received, counters, forger_got = fly_with_forger(udp_port, forged_traffic)
    _assert_ta_and_ra_on_time(received)
    _assert_announced(received, "SPOOF? 1:200 SENDS TRAFFIC, IGNORED")
    spoof = (mavlink2.MAV_SEVERITY_WARNING, "SPOOF? 1:200 SENDS TRAFFIC, IGNORED")
    assert spoof in [(m.severity, m.text) for m in forger_got if m.get_type() == "STATUSTEXT"]  # at once
    assert counters["adsb.untrusted_source"] > 5 * (END_S - START_S) and not counters.get("adsb.second_sender")
    assert mavlink2.MAV_STATE_ACTIVE in _heartbeat_states(received)  # it cost nothing: DAA stayed available
    assert mavlink2.MAV_STATE_CRITICAL not in _heartbeat_states(received)


def test_a_forged_ownship_50_km_away_from_component_200_is_rejected_and_announced(udp_port):
    received, counters, _ = fly_with_forger(udp_port, forged_ownship)
    _assert_ta_and_ra_on_time(received)
    _assert_announced(received, "SPOOF? 1:200 SENDS OWNSHIP, IGNORED")
    assert not [t for _, t in _statustexts(received) if t.startswith("DAA UNAVAILABLE")]
    assert counters["gpi.other_component"] > 5 * (END_S - START_S) and not counters.get("gpi.jump")
    assert mavlink2.MAV_STATE_ACTIVE in _heartbeat_states(received)
    assert mavlink2.MAV_STATE_CRITICAL not in _heartbeat_states(received)
