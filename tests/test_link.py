"""MavlinkLink over real sockets on 127.0.0.1 (UDP datagrams with garbage, TCP streams split across writes) and
.tlog recording and replay. Every wait polls for its condition up to a generous deadline (DEADLINE_S); nothing
asserts how long anything took; every socket is closed."""

from __future__ import annotations

import select
import socket
import threading
import time
from collections import Counter
from contextlib import closing

import avionics.io  # noqa: F401  (MAVLINK20=1 before pymavlink is imported)
import pytest
from pymavlink.dialects.v20 import common as m2

import avionics.io.tcpin as tcpin_module
from avionics.io.framing import FrameScanner
from avionics.io.link import LinkError, MavlinkLink
from tests.conftest import DEADLINE_S

pytestmark = pytest.mark.live  # real sockets on 127.0.0.1

HOST = "127.0.0.1"
OUR_SYSTEM, OUR_COMPONENT = 1, 191
GARBAGE = [b"", b"\x00\x01\x02", b"\xfd", b"\xfe\x09\xfd\xff\x00\x00", b"\xfd\x20\x00\x00\x00\x01\x01\x00\x00\x00",
           bytes(range(0xF0, 0x100)) * 3]


def free_port(kind: int) -> int:
    with socket.socket(socket.AF_INET, kind) as s:
        s.bind((HOST, 0))
        return s.getsockname()[1]


def frames() -> list[bytes]:
    """What an autopilot sends: real pymavlink encodings, one of them signed and one MAVLink 1."""
    mav = m2.MAVLink(None, srcSystem=1, srcComponent=1)
    signed = m2.MAVLink(None, srcSystem=1, srcComponent=1)
    signed.signing.secret_key, signed.signing.sign_outgoing, signed.signing.timestamp = bytes(32), True, 1
    msgs = [
        (m2.MAVLink_heartbeat_message(2, 12, 81, 0, 4, 3), mav),
        (m2.MAVLink_global_position_int_message(1000, 473977418, 85455939, 914400, 304800, 6430, 0, 0, 0), mav),
        (m2.MAVLink_scaled_pressure_message(1000, 908.1, 0.0, 1500), mav),
        (m2.MAVLink_adsb_vehicle_message(0xA1B2C3, 474000000, 85500000, 0, 914400, 18000, 6430, 0, b"DLH4AB",
                                         1, 0, 0x1FF, 7000), signed),
    ]
    out = [bytes(m.pack(p)) for m, p in msgs]
    out.append(bytes(m2.MAVLink_heartbeat_message(6, 8, 0, 0, 4, 3).pack(mav, force_mavlink1=True)))
    return out


def receive_until(link: MavlinkLink, count: int, timeout_s: float = DEADLINE_S) -> list:
    out, deadline = [], time.monotonic() + timeout_s
    while len(out) < count and time.monotonic() < deadline:
        out += link.receive(0.05)
    return out


def bufs(msgs) -> list[bytes]:
    return [bytes(m.get_msgbuf()) for m in msgs]


def our_reply():
    return m2.MAVLink_collision_message(m2.MAV_COLLISION_SRC_ADSB, 0xA1B2C3, m2.MAV_COLLISION_ACTION_REPORT,
                                        m2.MAV_COLLISION_THREAT_LEVEL_LOW, 21.5, 12.0, 150.0)


def assert_is_our_reply(data: bytes) -> None:
    out = FrameScanner(Counter()).feed(data, end_of_datagram=True)
    assert [m.get_type() for m in out] == ["COLLISION"]
    assert (out[0].get_srcSystem(), out[0].get_srcComponent()) == (OUR_SYSTEM, OUR_COMPONENT)
    assert out[0].id == 0xA1B2C3 and out[0].threat_level == m2.MAV_COLLISION_THREAT_LEVEL_LOW


def recv_exactly(sock: socket.socket, n: int, timeout_s: float = DEADLINE_S) -> bytes:
    sock.settimeout(timeout_s)
    data = b""
    while len(data) < n:
        chunk = sock.recv(n - len(data))
        assert chunk, "peer closed"
        data += chunk
    return data


def link(connection: str, counters: Counter | None = None, **kw) -> MavlinkLink:
    return MavlinkLink(connection, counters if counters is not None else Counter(), OUR_SYSTEM, OUR_COMPONENT, **kw)


# -- UDP ------------------------------------------------------------------------------------------------------
def test_udpin_receives_frames_behind_garbage_and_replies_to_the_sender():
    port = free_port(socket.SOCK_DGRAM)
    counters = Counter()
    with closing(link(f"udpin:{HOST}:{port}", counters)) as rx, \
            closing(socket.socket(socket.AF_INET, socket.SOCK_DGRAM)) as autopilot:
        assert rx.datagrams
        autopilot.bind((HOST, 0))
        sent = frames()
        for i, frame in enumerate(sent):
            autopilot.sendto(GARBAGE[i % len(GARBAGE)] + frame + GARBAGE[(i + 3) % len(GARBAGE)], (HOST, port))
        got = receive_until(rx, len(sent))
        assert bufs(got) == sent
        assert counters["frame.skipped_bytes"] > 0

        rx.send(our_reply())
        autopilot.settimeout(DEADLINE_S)
        data, addr = autopilot.recvfrom(4096)
        assert addr == (HOST, port)
        assert_is_our_reply(data)


def test_udp_frame_split_over_two_datagrams_is_not_glued_together():
    """A datagram holds whole frames: half a frame at its end is garbage, not the start of the next datagram."""
    port = free_port(socket.SOCK_DGRAM)
    frame, after = frames()[1], frames()[2]
    with closing(link(f"udpin:{HOST}:{port}")) as rx, \
            closing(socket.socket(socket.AF_INET, socket.SOCK_DGRAM)) as autopilot:
        autopilot.sendto(frame[:10], (HOST, port))
        autopilot.sendto(frame[10:] + after, (HOST, port))
        got = receive_until(rx, 1)
        got += rx.receive(0.1)
        assert bufs(got) == [after]


# -- TCP ------------------------------------------------------------------------------------------------------
def split_writes(sock: socket.socket, data: bytes, rx: MavlinkLink, sizes=(1, 7, 3, 29, 2, 64)) -> list:
    """Writes data in small pieces, letting the link read between them so frames arrive in parts."""
    out, i, n = [], 0, 0
    while i < len(data):
        piece = data[i:i + sizes[n % len(sizes)]]
        sock.sendall(piece)
        i, n = i + len(piece), n + 1
        time.sleep(0.001)  # pacing, not synchronisation: frames arrive in parts (coalesced pieces pass too)
        out += rx.receive(0.005)
    return out


def test_tcpin_receives_frames_split_across_writes_and_replies():
    port = free_port(socket.SOCK_STREAM)
    with closing(link(f"tcpin:{HOST}:{port}")) as rx:
        assert not rx.datagrams
        with closing(socket.create_connection((HOST, port), timeout=DEADLINE_S)) as autopilot:
            autopilot.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
            # A garbage header that could be a frame's (GARBAGE[4]) is only settled by the bytes after it:
            # the autopilot's next frame does that, as on any live link.
            sent = frames() + [bytes(m2.MAVLink_heartbeat_message(2, 12, 81, 1, 4, 3).pack(m2.MAVLink(None, 1, 1)))]
            stream = b"".join(GARBAGE[i % len(GARBAGE)] + f for i, f in enumerate(sent))
            got = split_writes(autopilot, stream, rx)
            got += receive_until(rx, len(sent) - len(got))
            assert bufs(got) == sent

            reply = our_reply()
            expected = bytes(reply.pack(m2.MAVLink(None, srcSystem=OUR_SYSTEM, srcComponent=OUR_COMPONENT)))
            rx.send(reply)
            assert_is_our_reply(recv_exactly(autopilot, len(expected)))


def test_tcp_client_receives_frames_split_across_writes_and_replies():
    port = free_port(socket.SOCK_STREAM)
    with closing(socket.socket(socket.AF_INET, socket.SOCK_STREAM)) as server:
        server.bind((HOST, port))
        server.listen(1)
        server.settimeout(DEADLINE_S)
        rx, conn = link(f"tcp:{HOST}:{port}"), None
        try:
            conn, _ = server.accept()
            conn.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
            sent = frames()
            got = split_writes(conn, b"".join(g + f for g, f in zip(reversed(GARBAGE), sent)), rx)
            got += receive_until(rx, len(sent) - len(got))
            assert bufs(got) == sent

            reply = our_reply()
            rx.send(reply)
            expected = bytes(reply.pack(m2.MAVLink(None, srcSystem=OUR_SYSTEM, srcComponent=OUR_COMPONENT)))
            assert_is_our_reply(recv_exactly(conn, len(expected)))
        finally:
            rx.close()  # first: on EOF pymavlink's tcp client blocks for seconds trying to reconnect
            if conn is not None:
                conn.close()


class SelectSpy:
    """Stands in for the select module inside avionics.io.link: records whether each wait found a readable fd."""

    def __init__(self):
        self.readable: list[bool] = []

    def select(self, rlist, wlist, xlist, timeout=None):
        out = select.select(rlist, wlist, xlist, timeout)
        self.readable.append(bool(out[0]))
        return out


def test_tcpin_hears_an_autopilot_that_reconnects_and_does_not_spin_meanwhile(monkeypatch):
    port = free_port(socket.SOCK_STREAM)
    counters = Counter()
    first, again = frames()[0], frames()[2]
    with closing(link(f"tcpin:{HOST}:{port}", counters)) as rx:
        with closing(socket.create_connection((HOST, port), timeout=DEADLINE_S)) as autopilot:
            autopilot.sendall(first)
            assert bufs(receive_until(rx, 1)) == [first]
        # The peer has gone. Spinning is select() finding the dead connection readable on every call (at once,
        # for ever); waiting out the timeout is select() finding nothing readable. Counted, not timed.
        spy = SelectSpy()
        with monkeypatch.context() as m:
            m.setattr(tcpin_module, "select", spy)
            for _ in range(6):
                assert rx.receive(0.05) == []
        assert len(spy.readable) >= 6  # it waited in select() on every call
        assert sum(spy.readable) <= 1  # at most the one wake-up that reads the EOF
        assert not spy.readable[-1] and counters["link.disconnected"] == 1
        with closing(socket.create_connection((HOST, port), timeout=DEADLINE_S)) as autopilot:
            autopilot.sendall(again)
            assert bufs(receive_until(rx, 1)) == [again]


def _listen(port: int) -> socket.socket:
    server = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
    server.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
    server.bind((HOST, port))
    server.listen(1)
    server.settimeout(0.05)
    return server


def test_tcp_client_survives_the_autopilot_going_away_and_reconnects(monkeypatch):
    """The peer closing used to leave a stale fd: the next receive() raised EBADF and stopped the node."""
    port = free_port(socket.SOCK_STREAM)
    counters = Counter()
    with closing(_listen(port)) as server:
        rx = link(f"tcp:{HOST}:{port}", counters)
        try:
            server.settimeout(DEADLINE_S)
            conn, _ = server.accept()
            conn.close()  # the autopilot goes away, listening socket and all
        finally:
            server.close()
        peer = None
        try:
            # No seconds of reconnect sleeps inside receive() (pymavlink sleeps reconnect_delay, 1 s, between
            # its retries): every sleep receive() asks for while nobody listens is at most its own timeout.
            # The sleeps requested on this thread are recorded, not timed.
            slept, real_sleep, me = [], time.sleep, threading.get_ident()

            def sleep(s):
                if threading.get_ident() == me:
                    slept.append(s)
                real_sleep(s)

            with monkeypatch.context() as m:
                m.setattr(time, "sleep", sleep)
                for _ in range(3):
                    assert rx.receive(0.05) == []
            assert all(s <= 0.05 for s in slept) and sum(slept) < 1.0, slept

            frame, got = frames()[1], []
            with closing(_listen(port)) as server:  # the autopilot is back
                deadline = time.monotonic() + DEADLINE_S
                while not got and time.monotonic() < deadline:
                    got += rx.receive(0.05)
                    if peer is None:
                        try:
                            peer, _ = server.accept()
                            peer.sendall(frame)
                        except socket.timeout:
                            pass
                assert bufs(got) == [frame] and counters["link.reconnected"] == 1
        finally:
            rx.close()
            if peer is not None:
                peer.close()


def heartbeat(n: int = 0) -> bytes:
    """The autopilot's (system OUR_SYSTEM, component 1) HEARTBEAT number n."""
    return bytes(m2.MAVLink_heartbeat_message(2, 12, 81, n, 4, 3).pack(m2.MAVLink(None, OUR_SYSTEM, 1)))


def test_tcpin_idle_and_garbage_clients_first_do_not_keep_the_autopilot_out():
    """pymavlink's tcpin gave the only slot to whoever connected first: the autopilot behind an idle client was
    never read. Now the autopilot's first valid frame owns the link, and the others are closed after the
    idle timeout (mavlink.tcpin_idle_timeout_s)."""
    port = free_port(socket.SOCK_STREAM)
    counters = Counter()
    with closing(link(f"tcpin:{HOST}:{port}", counters, tcpin_idle_timeout_s=1.0)) as rx, \
            closing(socket.create_connection((HOST, port), timeout=DEADLINE_S)) as idle:
        for _ in range(3):
            assert rx.receive(0.05) == []  # the idle client is accepted (and sends nothing)
        with closing(socket.create_connection((HOST, port), timeout=DEADLINE_S)) as junk, \
                closing(socket.create_connection((HOST, port), timeout=DEADLINE_S)) as autopilot:
            junk.sendall(bytes(range(256)) * 4 + heartbeat()[:-1])  # no valid frame
            autopilot.sendall(heartbeat(1))
            assert [m.custom_mode for m in receive_until(rx, 1)] == [1]
            rx.send(our_reply())  # to the autopilot, the link's owner
            assert_is_our_reply(recv_exactly(autopilot, len(bytes(our_reply().pack(
                m2.MAVLink(None, srcSystem=OUR_SYSTEM, srcComponent=OUR_COMPONENT))))))
            # The idle and the garbage client are closed after the timeout; the autopilot, talking, is not.
            deadline, n, got = time.monotonic() + DEADLINE_S, 2, []
            while counters["link.tcpin_idle_closed"] < 2 and time.monotonic() < deadline:
                autopilot.sendall(heartbeat(n))
                got += rx.receive(0.1)
                n += 1
            assert counters["link.tcpin_idle_closed"] == 2 and counters["link.tcpin_owner"] == 1
            assert [m.custom_mode for m in got] == list(range(2, 2 + len(got)))
            for client in (idle, junk):
                client.settimeout(DEADLINE_S)
                assert client.recv(4096) == b""  # closed by us, and nothing sent to it
            assert counters["frame.skipped_bytes"] > 0


def test_tcpin_autopilot_reconnecting_replaces_its_silent_connection():
    """The autopilot rebooted without closing its connection (half-open): the new connection's frames wait while
    the old one is within the idle timeout, then the new one owns the link."""
    port = free_port(socket.SOCK_STREAM)
    counters = Counter()
    with closing(link(f"tcpin:{HOST}:{port}", counters, tcpin_idle_timeout_s=1.0)) as rx, \
            closing(socket.create_connection((HOST, port), timeout=DEADLINE_S)) as old:
        old.sendall(heartbeat(1))
        assert [m.custom_mode for m in receive_until(rx, 1)] == [1]
        with closing(socket.create_connection((HOST, port), timeout=DEADLINE_S)) as new:
            deadline, n, got = time.monotonic() + DEADLINE_S, 100, []
            while not got and time.monotonic() < deadline:
                new.sendall(heartbeat(n))
                got += rx.receive(0.1)
                n += 1
            assert got and got[0].custom_mode > 100  # not the first: it waited for the old one's timeout
            assert counters["link.tcpin_idle_closed"] == 1 and counters["link.tcpin_owner"] == 2
            assert counters["link.tcpin_standby_frames"] >= 1
            rx.send(our_reply())
            assert_is_our_reply(recv_exactly(new, len(bytes(our_reply().pack(
                m2.MAVLink(None, srcSystem=OUR_SYSTEM, srcComponent=OUR_COMPONENT))))))


def test_tcpin_and_tcp_links_talk_to_each_other():
    port = free_port(socket.SOCK_STREAM)
    with closing(link(f"tcpin:{HOST}:{port}")) as server:
        client = MavlinkLink(f"tcp:{HOST}:{port}", Counter(), OUR_SYSTEM, 1)  # the vehicle's autopilot: owns tcpin
        try:
            beats = [m2.MAVLink_heartbeat_message(2, 12, 81, n, 4, 3) for n in range(3)]
            server.receive(0.2)  # accepts the connection
            for b in beats:
                client.send(b)
            got = receive_until(server, len(beats))
            assert [(m.get_type(), m.custom_mode, m.get_srcSystem()) for m in got] == \
                [("HEARTBEAT", n, OUR_SYSTEM) for n in range(3)]
            server.send(our_reply())
            back = receive_until(client, 1)
            assert [(m.get_type(), m.get_srcSystem(), m.get_srcComponent()) for m in back] == \
                [("COLLISION", OUR_SYSTEM, OUR_COMPONENT)]
        finally:
            client.close()


# -- .tlog ----------------------------------------------------------------------------------------------------
def test_tlog_recording_replays_the_same_messages(tmp_path):
    port = free_port(socket.SOCK_DGRAM)
    tlog = tmp_path / "flight.tlog"
    sent = frames()
    t0 = time.time()
    with closing(link(f"udpin:{HOST}:{port}", tlog_out=tlog)) as rx, \
            closing(socket.socket(socket.AF_INET, socket.SOCK_DGRAM)) as autopilot:
        for i, frame in enumerate(sent):
            autopilot.sendto(GARBAGE[i % len(GARBAGE)] + frame, (HOST, port))
        received = receive_until(rx, len(sent))
        assert bufs(received) == sent
        reply = our_reply()
        rx.send(reply)  # what we send is recorded too
    t1 = time.time()
    reply_buf = bytes(reply.pack(m2.MAVLink(None, srcSystem=OUR_SYSTEM, srcComponent=OUR_COMPONENT)))

    replay = link(str(tlog))
    try:
        assert replay.is_log
        replayed = []
        for _ in range(100):
            msgs = replay.receive(0.0)
            if not msgs:
                break
            replayed += msgs
    finally:
        replay.close()
    assert bufs(replayed) == sent + [reply_buf]
    assert [m.to_dict() for m in replayed[:len(sent)]] == [m.to_dict() for m in received]
    stamps = [m._timestamp for m in replayed]
    assert stamps == sorted(stamps) and t0 - 1 <= stamps[0] and stamps[-1] <= t1 + 1


def test_missing_log_file_is_a_file_error(tmp_path):
    """A file error (ConfigError: exit 2), not a link (pymavlink would open the name as a serial port and say
    "could not open port", or "No module named 'serial'" without pyserial)."""
    from avionics.config import ConfigError

    with pytest.raises(ConfigError, match="no such file"):
        link(str(tmp_path / "absent.tlog"))
