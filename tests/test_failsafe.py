"""Fail-safe signalling (issue 11, deliverable 4): a stop never looks like "clear", a loss never looks healthy.

- SIGTERM or SIGINT during an RA: every active advisory goes out as NONE on MAVLink (COLLISION threat NONE,
  DAA_ADVISORY level 0) and zenoh (reason `shutdown`), the liveliness token is withdrawn, exit code 0.
- Loss of ownship: HEARTBEAT `system_status` MAV_STATE_CRITICAL (ACTIVE while healthy), STATUSTEXT "DAA
  UNAVAILABLE ..." at MAV_SEVERITY_WARNING (never "CLEAR OF CONFLICT"), zenoh status `daa_available: false`
  with `unavailable_reason`; and back to ACTIVE / "DAA AVAILABLE" when ownship returns.

The live tests run `avionics run` as a child process on loopback (real UDP, pymavlink framing, zenoh peer
sessions with scouting off); every wait polls for its condition with a generous deadline."""

import copy
import json
import signal
import socket
import subprocess
import sys
import threading
from collections import Counter
import time

import pytest
import zenoh

import avionics.io  # noqa: F401
from avionics.config import ZenohConfig, load_config
from avionics.base.types import AdvisoryLevel
from avionics.io.dialect import daa as m2
from avionics.io.link import MavlinkLink
from avionics.io.zenoh_bus import open_session
from harness import Harness
from avionics_sitl.autopilot import AutopilotConfig, Packer, schedule
from avionics_sitl.impairments import PRESETS
from avionics_sitl.encounters import load_encounter
from tests.conftest import DEADLINE_S, free_port, wait_for

HEAD_ON = 0xA10001  # the head-on intruder (callsign HEADON): TA ~55 s, RA ~65.3 s, CPA 86.4 s
OWNSHIP_TYPES = ("GLOBAL_POSITION_INT", "SCALED_PRESSURE")


def head_on_events(start_s: float, end_s: float = 100.0, extra_icao: int | None = None):
    """The head-on's exact MAVLink schedule from start_s; extra_icao: a second intruder on the same track."""
    events = [e for e in schedule(load_encounter("head-on"), PRESETS["none"], duration_s=end_s) if e.deliver_s >= start_s]
    if extra_icao is not None:
        for e in [e for e in events if e.msg.get_type() == "ADSB_VEHICLE"]:
            twin = copy.deepcopy(e.msg)
            twin.ICAO_address = extra_icao
            events.append(type(e)(e.deliver_s + 0.001, twin, e.truth_s))
        events.sort(key=lambda e: e.deliver_s)
    return events


class Autopilot:
    """The autopilot side of a link, in a thread: sends the events in real time (from the first event's time),
    minus those `drop(msg)` refuses (settable while it runs), and keeps every message the DAA process sends."""

    def __init__(self, connection: str, events, drop=None):
        self.events = events
        self.drop = drop
        self._stop = threading.Event()
        self._lock = threading.Lock()
        self._received: list = []
        self._counters: Counter = Counter()
        self._link = MavlinkLink(connection, self._counters, AutopilotConfig.system_id, AutopilotConfig.component_id)
        self._thread = threading.Thread(target=self._run, daemon=True)

    def start(self) -> None:
        self._thread.start()

    def stop(self) -> None:
        self._stop.set()
        self._thread.join(DEADLINE_S)
        self._link.close()

    def messages(self, kind: str | None = None) -> list:
        with self._lock:
            return [m for m in self._received if kind is None or m.get_type() == kind]

    def _run(self) -> None:
        packer = Packer()
        wall0 = time.monotonic() - self.events[0].deliver_s
        i = 0
        while not self._stop.is_set():
            now = time.monotonic() - wall0
            while i < len(self.events) and self.events[i].deliver_s <= now:
                msg = self.events[i].msg
                i += 1
                drop = self.drop
                if drop is None or not drop(msg):
                    self._link.conn.write(packer.pack(msg))
            wait = 0.05 if i >= len(self.events) else min(0.05, max(0.0, self.events[i].deliver_s - now))
            for msg in self._link.receive(wait):
                with self._lock:
                    self._received.append(msg)


class Onboard:
    """`avionics run` as a child process on udpin:PORT with its zenoh session listening on loopback, and a zenoh
    peer session subscribed to its advisories, status and liveliness token. args: more `avionics run` arguments."""

    def __init__(self, vehicle: str, args: tuple = ()):
        """args: more `avionics run` options (e.g. output files)."""
        self.vehicle = vehicle
        self.udp = free_port(socket.SOCK_DGRAM)
        tcp = free_port()
        self.endpoint = f"tcp/127.0.0.1:{tcp}"
        self.process = subprocess.Popen(
            [sys.executable, "-m", "avionics.cli", "run", "--connection", f"udpin:127.0.0.1:{self.udp}",
             "--set", f'zenoh.listen=["{self.endpoint}"]', "--set", f"vehicle.id={vehicle}",
             "--duration", str(4 * DEADLINE_S), *args],  # ended by the test; a backstop only
            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        self.samples: list = []
        self.alive: list = []
        self._lock = threading.Lock()
        self.session = None
        self._subs = []
        try:
            self._wait_listening(tcp)
            self.session = open_session(ZenohConfig(listen=(), connect=(self.endpoint,)))
            prefix = f"daa/{vehicle}"
            self._subs = [self.session.declare_subscriber(f"{prefix}/advisories/*", self._on_sample),
                          self.session.declare_subscriber(f"{prefix}/status", self._on_sample),
                          self.session.liveliness().declare_subscriber(f"{prefix}/alive", self._on_alive, history=True)]
        except BaseException:
            self.close()
            raise

    def _wait_listening(self, port: int) -> None:
        def up():
            assert self.process.poll() is None, self.process.communicate()[1]
            with socket.socket() as probe:
                return probe.connect_ex(("127.0.0.1", port)) == 0
        assert wait_for(up, period_s=0.1), f"the onboard process did not listen on {port}"

    def _on_sample(self, sample) -> None:
        kind = "status" if str(sample.key_expr).endswith("/status") else "advisory"
        with self._lock:
            self.samples.append((kind, json.loads(sample.payload.to_bytes())))

    def _on_alive(self, sample) -> None:
        with self._lock:
            self.alive.append(sample.kind)

    def of(self, kind: str) -> list:
        with self._lock:
            return [p for k, p in self.samples if k == kind]

    def liveliness(self) -> list:
        with self._lock:
            return list(self.alive)

    def close(self) -> tuple[int | None, str]:
        if self.process.poll() is None:
            self.process.terminate()
        try:
            _, err = self.process.communicate(timeout=DEADLINE_S)
        except subprocess.TimeoutExpired:
            self.process.kill()
            _, err = self.process.communicate()
        for sub in self._subs:
            sub.undeclare()
        self._subs = []
        if self.session is not None:
            self.session.close()
            self.session = None
        return self.process.returncode, err


def _collisions(autopilot, icao=HEAD_ON):
    return [m for m in autopilot.messages("COLLISION") if m.id == icao]


def _texts(autopilot):
    return [(m.severity, m.text) for m in autopilot.messages("STATUSTEXT")]


@pytest.mark.live
@pytest.mark.parametrize("signum", [signal.SIGTERM, signal.SIGINT], ids=["SIGTERM", "SIGINT"])
def test_a_signal_during_an_ra_sends_none_on_mavlink_and_zenoh_drops_liveliness_and_exits_0(signum):
    onboard = Onboard("stopuav")
    autopilot = None
    try:
        assert wait_for(lambda: zenoh.SampleKind.PUT in onboard.liveliness())
        autopilot = Autopilot(f"udpout:127.0.0.1:{onboard.udp}", head_on_events(start_s=58.0))
        autopilot.start()
        assert wait_for(lambda: any(m.threat_level == m2.MAV_COLLISION_THREAT_LEVEL_HIGH for m in _collisions(autopilot)))
        assert wait_for(lambda: any(p["level"] == "RA" for p in onboard.of("advisory")))
        onboard.process.send_signal(signum)
        assert onboard.process.wait(DEADLINE_S) == 0
        # what it sent before exiting is on its way to the autopilot and the subscriber: wait for it
        assert wait_for(lambda: _collisions(autopilot)[-1].threat_level == m2.MAV_COLLISION_THREAT_LEVEL_NONE)
        assert wait_for(lambda: onboard.of("advisory")[-1]["reason"] == "shutdown")
        assert wait_for(lambda: zenoh.SampleKind.DELETE in onboard.liveliness())
        assert wait_for(lambda: any(m.system_status == m2.MAV_STATE_POWEROFF for m in autopilot.messages("HEARTBEAT")))
    finally:
        if autopilot is not None:
            autopilot.stop()
        code, err = onboard.close()
    assert code == 0 and "Traceback" not in err, err

    last = _collisions(autopilot)[-1]
    assert (last.threat_level, last.action) == (m2.MAV_COLLISION_THREAT_LEVEL_NONE, m2.MAV_COLLISION_ACTION_NONE)
    assert m2.MAV_COLLISION_THREAT_LEVEL_HIGH in [m.threat_level for m in _collisions(autopilot)]
    daa = [m for m in autopilot.messages("DAA_ADVISORY") if m.id == HEAD_ON]
    assert daa[-1].level == 0 and 2 in [m.level for m in daa]
    texts = _texts(autopilot)
    assert (m2.MAV_SEVERITY_WARNING, "DAA UNAVAILABLE HEADON (shutdown)") in texts, texts
    assert (m2.MAV_SEVERITY_WARNING, "DAA UNAVAILABLE shutdown") in texts, texts
    assert not any("CLEAR OF CONFLICT" in t for _, t in texts), texts
    assert autopilot.messages("HEARTBEAT")[-1].system_status == m2.MAV_STATE_POWEROFF

    advisories = onboard.of("advisory")
    assert [(p["intruder"], p["level"], p["reason"]) for p in advisories][-1] == ("1090es-A10001", "NONE", "shutdown")
    last_status = onboard.of("status")[-1]
    assert last_status["daa_available"] is False and last_status["unavailable_reason"] == "shutdown"
    assert last_status["advisories"] == {"TA": 0, "RA": 0}
    assert onboard.liveliness()[-1] == zenoh.SampleKind.DELETE


@pytest.mark.live
def test_loss_of_ownship_is_announced_as_daa_unavailable_never_as_clear_of_conflict():
    onboard = Onboard("lossuav")
    autopilot = None
    try:
        autopilot = Autopilot(f"udpout:127.0.0.1:{onboard.udp}", head_on_events(start_s=52.0))
        autopilot.start()
        assert wait_for(lambda: any(m.threat_level == m2.MAV_COLLISION_THREAT_LEVEL_LOW for m in _collisions(autopilot)))
        assert wait_for(lambda: any(s["daa_available"] for s in onboard.of("status")))
        healthy = autopilot.messages("HEARTBEAT")
        lost_at = len(autopilot.messages())
        autopilot.drop = lambda msg: msg.get_type() in OWNSHIP_TYPES  # the autopilot's position stops

        assert wait_for(lambda: (m2.MAV_SEVERITY_WARNING, "DAA UNAVAILABLE no ownship position") in _texts(autopilot))
        assert wait_for(lambda: autopilot.messages("HEARTBEAT")[-1].system_status == m2.MAV_STATE_CRITICAL)
        assert wait_for(lambda: onboard.of("status")[-1]["unavailable_reason"] == "no_ownship")
        lost = autopilot.messages()[lost_at:]
        texts_lost = _texts(autopilot)
        status_lost = onboard.of("status")[-1]

        autopilot.drop = None  # the position is back
        assert wait_for(lambda: (m2.MAV_SEVERITY_NOTICE, "DAA AVAILABLE") in _texts(autopilot))
        assert wait_for(lambda: autopilot.messages("HEARTBEAT")[-1].system_status == m2.MAV_STATE_ACTIVE)
        assert wait_for(lambda: onboard.of("status")[-1]["daa_available"] is True)
    finally:
        if autopilot is not None:
            autopilot.stop()
        code, err = onboard.close()
    assert code == 0 and "Traceback" not in err, err

    assert healthy and all(m.system_status == m2.MAV_STATE_ACTIVE for m in healthy[1:])  # the first: before the fix
    # the TA ended because ownship was lost: said as DAA UNAVAILABLE at warning, never as clear of conflict
    assert (m2.MAV_SEVERITY_WARNING, "DAA UNAVAILABLE HEADON (no_ownship)") in texts_lost, texts_lost
    assert not any("CLEAR OF CONFLICT" in t for _, t in texts_lost), texts_lost
    ended = [m for m in lost if m.get_type() == "COLLISION" and m.id == HEAD_ON]
    assert ended and ended[-1].threat_level == m2.MAV_COLLISION_THREAT_LEVEL_NONE
    assert status_lost["daa_available"] is False and status_lost["ownship_valid"] is False
    assert "no ownship position: no advisories" in status_lost["warnings"]
    assert ("NONE", "no_ownship") in [(p["level"], p["reason"]) for p in onboard.of("advisory")]


# -- the same policy in fast time (Harness, no sockets) ----------------------------------------------------------

def _fly(node, events, until_s, drop=lambda t, msg: False):
    mav = m2.MAVLink(None, 1, 1)
    out, i = [], 0
    for k in range(int(until_s * 10) + 1):
        t = k / 10
        batch = []
        while i < len(events) and events[i].deliver_s <= t + 1e-9:
            if not drop(t, events[i].msg):
                events[i].msg.pack(mav)
                batch.append(events[i].msg)
            i += 1
        node.handle(batch, t)
        out += [(t, m) for m in node.mavlink_out]
        node.mavlink_out.clear()
        node.zenoh_out.clear()
    return out


def test_node_heartbeat_follows_availability_and_no_pressure_when_needed_is_unavailable():
    node = Harness(load_config())
    events = head_on_events(start_s=0.0, end_s=70.0)
    # pressure altitude missing from 30 s to 40 s (the intruder reports pressure altitude), ownship from 50 to 55 s
    out = _fly(node, events, 70.0, drop=lambda t, m: 30 <= t < 40 and m.get_type() == "SCALED_PRESSURE"
               or 50 <= t < 55 and m.get_type() in OWNSHIP_TYPES)
    texts = [(t, m.severity, m.text) for t, m in out if m.get_type() == "STATUSTEXT"]
    beats = [(t, m.system_status) for t, m in out if m.get_type() == "HEARTBEAT"]
    assert [x[1:] for x in texts if "AVAILABLE" in x[2]] == [
        (m2.MAV_SEVERITY_WARNING, "DAA UNAVAILABLE no pressure altitude"), (m2.MAV_SEVERITY_NOTICE, "DAA AVAILABLE"),
        (m2.MAV_SEVERITY_WARNING, "DAA UNAVAILABLE no ownship position"), (m2.MAV_SEVERITY_NOTICE, "DAA AVAILABLE")]
    t_np, t_back1, t_no, t_back2 = [t for t, _, x in texts if "AVAILABLE" in x]
    # pressure_timeout_s 3 s after the last SCALED_PRESSURE (29.8 s), ownship_timeout_s 2 s after 49.8 s
    assert 32.5 <= t_np <= 34.0 and 40.0 <= t_back1 <= 40.5 and 51.5 <= t_no <= 53.0 and 55.0 <= t_back2 <= 55.5
    for t, status in beats:
        unavailable = t_np < t < t_back1 or t_no < t < t_back2
        assert status == (m2.MAV_STATE_CRITICAL if unavailable else m2.MAV_STATE_ACTIVE), (t, status)
    status = node.status(70.0)
    assert status["daa_available"] and status["unavailable_reason"] is None and status["failed_intruders"] == {}


def test_node_shutdown_ends_active_advisories_with_reason_shutdown():
    config = load_config()
    node = Harness(config)
    _fly(node, head_on_events(start_s=0.0, end_s=67.0), 67.0)
    assert [a.level for a in node.core.active.values()] == [AdvisoryLevel.RA]
    ended = node.shutdown(67.0).changes
    assert [(str(a.intruder), a.level, a.reason) for a in ended] == [("1090es-A10001", AdvisoryLevel.NONE, "shutdown")]
    kinds = [(m.get_type(), getattr(m, "threat_level", getattr(m, "level", None))) for m in node.mavlink_out]
    assert ("COLLISION", 0) in kinds and ("DAA_ADVISORY", 0) in kinds
    assert node.mavlink_out[-1].get_type() == "HEARTBEAT" and node.mavlink_out[-1].system_status == m2.MAV_STATE_POWEROFF
    zenoh = dict(node.zenoh_out)
    assert zenoh["advisories/1090es-A10001"]["reason"] == "shutdown"
    assert zenoh["status"]["daa_available"] is False and zenoh["status"]["unavailable_reason"] == "shutdown"
