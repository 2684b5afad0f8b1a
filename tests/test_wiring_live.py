"""Wiring mistakes named while they happen (issue 26 item 2; avionics/io/diagnostics.py): `avionics run` as a child
process on UDP with a receiver feed whose port refuses connections, and a real MAVLink sender (pymavlink framing)
on its own socket that makes the mistakes one after the other. Each is named on stderr (a WARNING line with the
ids and the configuration key), once as STATUSTEXT back to the sender (the autopilot's side of the link) and in
the zenoh status (`wiring`, and the warnings the monitor shows); an autopilot heard after a silence gets every
active condition again:

1. nothing on the link: "no MAVLink message for ..." (mavlink.silence_warn_s);
   the --traffic feed is down, named with its error;
2. the ownship from system 2 while mavlink.source_system = 1: both ids and the key named;
3. the ownship from system 1 at 1 Hz (below mavlink.min_ownship_hz), without SCALED_PRESSURE (profile tcas2 selects
   its sensitivity levels by pressure altitude), and ADSB_VEHICLE from system 2's receiver (not trusted).
A second process with a signing key gets unsigned frames: the signing rejection is named, never a silent link.
Waits poll for each condition up to DEADLINE_S; no timing is asserted."""

from __future__ import annotations

import json
import socket
import subprocess
import sys
import threading
import time

import avionics.io  # noqa: F401  (MAVLink 2)
import pytest
from pymavlink.dialects.v20 import common as mavlink2

from avionics.io.zenoh_bus import open_session
from avionics.monitor.feed import monitor_zenoh_config
from tests.conftest import DEADLINE_S, free_port, wait_for

pytestmark = pytest.mark.live  # a child process, UDP, TCP and zenoh on loopback


class Sender:
    """A MAVLink sender on its own UDP socket: every period it sends what `frames(t)` gives, framed as (system,
    component) each; it keeps what the onboard process sends back (its replies go to the last sender's address)."""

    def __init__(self, port: int):
        self.port = port
        self.got: list = []
        self.frames = lambda t: []
        self.period_s = 0.2
        self._stop = threading.Event()
        self._mav: dict = {}
        self._parser = mavlink2.MAVLink(None)
        self._parser.robust_parsing = True
        self._thread = threading.Thread(target=self._run, daemon=True)
        self._thread.start()

    def _run(self):
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as sock:
            sock.settimeout(0.02)
            next_s = time.monotonic()
            while not self._stop.is_set():
                now = time.monotonic()
                if now >= next_s:
                    next_s = now + self.period_s
                    for (system, component), msg in self.frames(now):
                        mav = self._mav.setdefault((system, component), mavlink2.MAVLink(None, system, component))
                        sock.sendto(bytes(msg.pack(mav)), ("127.0.0.1", self.port))
                try:
                    got = self._parser.parse_buffer(sock.recv(65536)) or ()
                    self.got.extend((time.monotonic(), m) for m in got if m is not None)
                except (socket.timeout, ConnectionRefusedError):
                    pass

    def statustexts(self) -> list[str]:
        return [m.text for _, m in list(self.got) if m.get_type() == "STATUSTEXT"]

    def close(self):
        self._stop.set()
        self._thread.join(DEADLINE_S)


def listening(port: int) -> bool:
    with socket.socket() as s:
        return s.connect_ex(("127.0.0.1", port)) == 0


def heartbeat():
    return mavlink2.MAVLink_heartbeat_message(mavlink2.MAV_TYPE_QUADROTOR, mavlink2.MAV_AUTOPILOT_ARDUPILOTMEGA,
                                              0, 0, mavlink2.MAV_STATE_ACTIVE, 3)


def position(t: float):
    return mavlink2.MAVLink_global_position_int_message(int(t * 1000) & 0xFFFFFFFF, 473977000, 85455000, 500000,
                                                        100000, 0, 0, 0, 0)


def pressure_traffic():
    """An ADS-B report with a pressure altitude, as a receiver component (156) sends it."""
    flags = 1 | 2 | 4 | 8  # coords, altitude, heading, velocity valid
    return mavlink2.MAVLink_adsb_vehicle_message(0xA10001, 474000000, 85500000, 0, 900000, 9000, 5000, 0,
                                                 b"TEST1", 1, 0, flags, 0)


def test_each_wiring_mistake_is_named_on_stderr_statustext_and_zenoh_status(udp_port, tcp_port):
    refused = free_port()  # nothing listens there: the feed's connection is refused
    endpoint = f"tcp/127.0.0.1:{tcp_port}"
    onboard = subprocess.Popen(
        [sys.executable, "-m", "avionics.cli", "run", "--connection", f"udpin:127.0.0.1:{udp_port}",
         "--traffic", f"sbs:127.0.0.1:{refused}", "--set", f'zenoh.listen=["{endpoint}"]',
         "--duration", str(10 * DEADLINE_S)],  # ended by the test; a backstop
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    lines: list[str] = []
    threading.Thread(target=lambda: lines.extend(onboard.stderr), daemon=True).start()
    statuses: list[dict] = []
    sender = session = None

    def logged(*words) -> bool:
        return any(all(w in line for w in words) and "WARNING" in line for line in list(lines))

    def wiring_keys() -> set:
        return {d["key"] for d in (statuses[-1].get("wiring") or [])} if statuses else set()

    try:
        assert wait_for(lambda: listening(tcp_port) or onboard.poll() is not None), lines
        session = open_session(monitor_zenoh_config([endpoint]))
        session.declare_subscriber("daa/uav1/status", lambda s: statuses.append(json.loads(s.payload.to_bytes())))
        # 1. nothing on the link; the feed down
        # the start-up banner: what the default profile means at a drone's height
        assert wait_for(lambda: any("profile tcas2: RAs inhibited below 1000 ft AGL" in line
                                    and "use --set advisory.profile=small-uas" in line for line in list(lines))), lines
        # and the response the RA logic assumes, with the way to give it the vehicle's own (1500 fpm: 7.62 m/s)
        assert wait_for(lambda: any("vehicle: profile tcas2's RA response (climb 7.6 m/s" in line
                                    and "--set vehicle.profile=fixed-wing|multirotor" in line for line in list(lines))), lines
        assert wait_for(lambda: logged("no MAVLink message for", f"udpin:127.0.0.1:{udp_port}",
                                       "mavlink.connection")), lines
        assert wait_for(lambda: logged(f"traffic source sbs:127.0.0.1:{refused} down", "Connection refused")), lines
        assert wait_for(lambda: {"no_mavlink", f"feed:sbs:127.0.0.1:{refused}"} <= wiring_keys()), statuses[-1:]
        assert any("no MAVLink message for" in w for w in statuses[-1]["warnings"])

        # 2. the ownship from system 2
        sender = Sender(udp_port)
        sender.frames = lambda t: [((2, 1), heartbeat()), ((2, 1), position(t))]
        assert wait_for(lambda: logged("no GLOBAL_POSITION_INT from system 1 (mavlink.source_system = 1)",
                                       "while system 2 sends it", "set mavlink.source_system = 2")), lines
        assert wait_for(lambda: "OWNSHIP? GPI FROM SYS 2, NOT 1" in sender.statustexts()), sender.statustexts()
        # the feed went down before the sender was there: announced again when MAVLink arrived
        assert f"TRAFFIC FEED DOWN sbs:127.0.0.1:{refused}" in sender.statustexts()
        assert wait_for(lambda: "ownship_other_system" in wiring_keys() and "no_mavlink" not in wiring_keys())
        assert any("wiring ok again: no_mavlink" in line for line in lines)

        # 3. the ownship from system 1 at 1 Hz without pressure; traffic from system 2's receiver
        sender.period_s = 1.0
        sender.frames = lambda t: [((1, 1), heartbeat()), ((1, 1), position(t)), ((2, 156), pressure_traffic())]
        assert wait_for(lambda: logged("GLOBAL_POSITION_INT from 1:1 at", "below the 2 Hz",
                                       "mavlink.min_ownship_hz")), lines
        assert wait_for(lambda: logged("no SCALED_PRESSURE from 1:1", "profile tcas2")), lines
        assert wait_for(lambda: logged("ADSB_VEHICLE from 2:156 ignored", "mavlink.traffic_sources")), lines
        assert wait_for(lambda: {"ownship_rate", "no_pressure", "untrusted_traffic"} <= wiring_keys()), statuses[-1:]
        assert wait_for(lambda: {"TRAFFIC FROM 2:156 NOT TRUSTED, IGNORED", "NO SCALED_PRESSURE FROM 1:1"}
                        <= set(sender.statustexts())), sender.statustexts()
        assert any(t.startswith("OWNSHIP GPI ") and t.endswith("NEED 2 HZ") for t in sender.statustexts())
        # one STATUSTEXT per onset, not repeated while the condition lasts (stderr repeats it each REPEAT_S)
        texts = [t for t in sender.statustexts() if not t.startswith(("DAA ", "SPOOF?"))]  # the wiring's
        assert len(texts) == len(set(texts)), texts
    finally:
        if sender is not None:
            sender.close()
        if session is not None:
            session.close()
        onboard.terminate()
        onboard.wait(DEADLINE_S)
    assert onboard.returncode == 0, "".join(lines)


def test_frames_that_fail_signing_are_named_not_taken_for_a_silent_link(udp_port, tmp_path):
    key = tmp_path / "signing.key"
    key.write_text("ab" * 32 + "\n")
    onboard = subprocess.Popen(
        [sys.executable, "-m", "avionics.cli", "run", "--connection", f"udpin:127.0.0.1:{udp_port}", "--no-zenoh",
         "--set", f'mavlink.signing_key_file="{key}"', "--duration", str(10 * DEADLINE_S)],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    lines: list[str] = []
    threading.Thread(target=lambda: lines.extend(onboard.stderr), daemon=True).start()
    sender = Sender(udp_port)  # unsigned frames, which signing_required (the default) rejects
    sender.frames = lambda t: [((1, 1), heartbeat()), ((1, 1), position(t))]
    try:
        assert wait_for(lambda: any("MAVLink frames rejected by signing (" in line and " unsigned" in line
                                    and "mavlink.signing_key_file" in line for line in list(lines))), lines
        # past mavlink.silence_warn_s (4 s): six of the onboard HEARTBEATs (1 Hz) came back, and no silence was named
        assert wait_for(lambda: sum(m.get_type() == "HEARTBEAT" for _, m in list(sender.got)) >= 6)
        assert not any("no MAVLink message" in line for line in lines), lines
    finally:
        sender.close()
        onboard.terminate()
        onboard.wait(DEADLINE_S)
    assert onboard.returncode == 0, "".join(lines)
