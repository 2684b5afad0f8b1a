"""Overload: strict MAVLink lengths (checksum-collision frames cannot swallow the next frame), the numpy scan
path equal to the Python one, the UDP link's bounded step (reports before garbage, the rest carried, our own
drops counted), the kernel's drop counter, and zenoh status/ownship samples that tracks cannot starve.

Nothing here asserts a duration or a rate (those are in `python -m avionics_eval.flood_bench`, docs/performance.md);
waits poll for their condition up to DEADLINE_S."""

from __future__ import annotations

import glob
import json
import os
import random
import socket
import threading
from collections import Counter
from contextlib import closing

import avionics.io  # noqa: F401  (MAVLINK20=1 before pymavlink is imported)
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from pymavlink.dialects.v20 import common as m2
from pymavlink.generator import mavcrc, mavparse

import avionics.io.link as link_module
from avionics.config import ZenohConfig
from avionics.io import framing
from avionics.io.framing import KNOWN_MESSAGES, MAX_FRAME, SIGNATURE_LEN, FrameScanner, base_length
from avionics.io.link import MavlinkLink, udp_kernel_drops
from avionics.io.zenoh_bus import VITAL_QUEUE, ZenohBus
from tests.conftest import DEADLINE_S, wait_for
from tests.test_framing import frames as frame_strategy, streams, split

HOST = "127.0.0.1"
MAV = m2.MAVLink(None, srcSystem=1, srcComponent=1)


def hb(custom_mode: int = 0, v1: bool = False) -> bytes:
    return bytes(m2.MAVLink_heartbeat_message(2, 12, 81, custom_mode, 4, 3).pack(MAV, force_mavlink1=v1))


def report(icao: int = 0xA1B2C3) -> bytes:
    return bytes(m2.MAVLink_adsb_vehicle_message(icao, 474000000, 85500000, 0, 914400, 18000, 6430, 0, b"OVL",
                                                 1, 0, 0x1FF, 7000).pack(MAV))


def with_crc(frame: bytearray) -> bytes:
    """Give a hand-made frame the CRC its bytes and message id call for: what a checksum collision in noise
    looks like (1 in 65536 candidates)."""
    v1 = frame[0] == 0xFE
    msgid = frame[5] if v1 else frame[7] | frame[8] << 8 | frame[9] << 16
    crc = mavcrc.x25crc(bytes(frame[1:-2]))
    crc.accumulate(bytes([KNOWN_MESSAGES[msgid].crc_extra]))
    frame[-2:] = crc.crc.to_bytes(2, "little")
    return bytes(frame)


def scanner() -> tuple[FrameScanner, Counter]:
    counters = Counter()
    return FrameScanner(counters), counters


def bufs(msgs) -> list[bytes]:
    return [bytes(m.get_msgbuf()) for m in msgs]


# -- strict lengths ----------------------------------------------------------------------------------------------
def test_length_tables_match_the_xml_definitions():
    """base_length() (from pymavlink's classes) against mavparse's wire_min_length / wire_length for every
    message we decode, ours and ArduPilot's."""
    xml = {}
    dialects = os.path.dirname(mavparse.__file__).replace("generator", "dialects/v20")
    ours = os.path.join(os.path.dirname(framing.__file__), "dialect", "daa.xml")
    for path in glob.glob(f"{dialects}/*.xml") + [ours]:
        try:
            parsed = mavparse.MAVXML(path, "2.0")
        except Exception:  # noqa: BLE001  (test-only dialects pymavlink ships that do not parse alone)
            continue
        for m in parsed.message:
            xml.setdefault((m.id, m.name), m)
    checked = 0
    for msgid, msgtype in KNOWN_MESSAGES.items():
        m = xml[(msgid, msgtype.msgname)]
        assert (base_length(msgtype), msgtype.unpacker.size) == (m.wire_min_length, m.wire_length), msgtype.msgname
        assert framing.V2_MAX_PAYLOAD[msgid] == m.wire_length
        if msgid < 256:
            assert framing.V1_PAYLOAD_LENGTHS[msgid] == {m.wire_min_length, m.wire_length}
        checked += 1
    assert checked == len(KNOWN_MESSAGES) > 250


@pytest.mark.parametrize("case", ["v2_too_long", "v2_empty", "v1_too_short", "v1_too_long"])
@pytest.mark.parametrize("datagram", [True, False])
def test_checksum_collision_frame_of_a_wrong_length_does_not_swallow_the_next_frame(case, datagram):
    """A 'frame' with a correct CRC but a length its message cannot have: pymavlink decodes it (padding or
    cutting the payload), and the valid frame it spans would be lost. Strict lengths refuse it."""
    nxt = hb(7)
    if case == "v2_too_long":  # HEARTBEAT (9 bytes at most) claiming 9 + len(nxt) bytes: nxt inside
        fake = bytearray([0xFD, 9 + len(nxt), 0, 0, 0, 1, 1, 0, 0, 0]) + bytes(9) + nxt + bytes(2)
    elif case == "v2_empty":  # a MAVLink 2 payload is never cut below one byte
        fake = bytearray([0xFD, 0, 0, 0, 0, 1, 1, 0, 0, 0, 0, 0])
    elif case == "v1_too_short":  # MAVLink 1 HEARTBEAT with 5 of its 9 payload bytes
        fake = bytearray([0xFE, 5, 0, 1, 1, 0]) + bytes(5) + bytes(2)
    else:  # MAVLink 1 SCALED_PRESSURE (14 or 16 bytes) claiming 14 + len(nxt)
        fake = bytearray([0xFE, 14 + len(nxt), 0, 1, 1, 29]) + bytes(14) + nxt + bytes(2)
    fake = with_crc(fake)
    assert m2.MAVLink(None).decode(bytearray(fake)) is not None  # pymavlink takes it: a real collision frame
    stream = fake + (b"" if "too_long" in case else nxt) + hb(8)
    s, counters = scanner()
    out = s.feed(stream, end_of_datagram=datagram)
    if not datagram:
        out += s.feed(bytes(MAX_FRAME + SIGNATURE_LEN))
    assert bufs(out) == [nxt, hb(8)]
    assert counters["frame.bad_length"] == 1


def test_every_length_a_real_sender_uses_is_accepted():
    """MAVLink 1 without extensions (C libraries) and with them (pymavlink); MAVLink 2 cut to one byte."""
    pressure = m2.MAVLink_scaled_pressure_message(1000, 1013.25, 0.0, 1500, 7)  # 14 bytes + 2 of extension
    full_v1 = bytes(pressure.pack(MAV, force_mavlink1=True))
    assert full_v1[1] == 16
    base_v1 = bytearray(full_v1[:6 + 14] + bytes(2))
    base_v1[1] = 14
    base_v1 = with_crc(base_v1)
    zeros_v2 = bytes(m2.MAVLink_heartbeat_message(0, 0, 0, 0, 0, 0).pack(MAV))
    assert zeros_v2[1] == 1
    s, counters = scanner()
    out = s.feed(full_v1 + base_v1 + zeros_v2, end_of_datagram=True)
    assert bufs(out) == [full_v1, base_v1, zeros_v2]
    assert out[1].temperature_press_diff == 0 and out[0].temperature_press_diff == 7
    assert not counters


# -- the numpy scan path is the Python scan path ---------------------------------------------------------------
def both() -> tuple[FrameScanner, Counter, FrameScanner, Counter]:
    (py, pyc), (vec, vecc) = scanner(), scanner()
    py.vector_min_markers, vec.vector_min_markers = 10**9, 0
    return py, pyc, vec, vecc


noise = st.lists(st.one_of(st.binary(max_size=64), st.lists(st.sampled_from([0xFD, 0xFE, 0, 1, 9, 0x1C]),
                                                            max_size=64).map(bytes)), max_size=8).map(b"".join)


@settings(max_examples=200, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.one_of(streams().map(lambda c: c[1]), st.lists(st.one_of(frame_strategy, noise), max_size=12).map(b"".join)),
       st.lists(st.integers(0, 10_000), max_size=8), st.booleans())
def test_vector_scan_decodes_and_counts_exactly_like_the_python_scan(stream, cuts, datagram):
    py, pyc, vec, vecc = both()
    if datagram:
        assert bufs(vec.feed(stream, end_of_datagram=True)) == bufs(py.feed(stream, end_of_datagram=True))
    else:
        a, b = [], []
        for chunk in split(stream, cuts):
            a += py.feed(chunk)
            b += vec.feed(chunk)
            assert vec._signature_left == py._signature_left and vec._buf == py._buf
        assert bufs(b) == bufs(a)
    assert vecc == pyc


def test_marker_dense_noise_with_frames_inside_decodes_every_frame_on_both_paths():
    rnd = random.Random(5)
    valid = [hb(k) for k in range(20)] + [report(k) for k in range(20)]
    rnd.shuffle(valid)
    stream = b""
    for f in valid:
        stream += bytes(rnd.choice([0xFD, 0xFE, rnd.randrange(256)]) for _ in range(rnd.randrange(300))) + f
    py, pyc, vec, vecc = both()
    # Oracle independent of both scanners is test_framing's: here the claim is frames in == frames out.
    out = vec.feed(stream, end_of_datagram=True)
    assert bufs(py.feed(stream, end_of_datagram=True)) == bufs(out)
    assert [f for f in bufs(out) if f in valid] == valid
    assert vecc == pyc and vecc["frame.skipped_bytes"] == len(stream) - sum(map(len, bufs(out)))


# -- the UDP link: a bounded step ------------------------------------------------------------------------------
def free_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.bind((HOST, 0))
        return s.getsockname()[1]


def marker_garbage(size: int, seed: int) -> bytes:
    rnd = random.Random(seed)
    return bytes(rnd.choice((0xFD, 0xFE, rnd.randrange(256))) for _ in range(size))


@pytest.fixture
def udp_link():
    port = free_port()
    counters = Counter()
    link = MavlinkLink(f"udpin:{HOST}:{port}", counters, 1, 191)
    sender = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    try:
        yield link, counters, lambda data: sender.sendto(data, (HOST, port))
    finally:
        sender.close()
        link.close()


def queued_bytes(sock: socket.socket) -> int:
    """What the kernel holds for the socket (rx_queue of /proc/net/udp: at least the payload bytes)."""
    inode = str(os.fstat(sock.fileno()).st_ino)
    with open("/proc/net/udp") as f:
        for line in f:
            fields = line.split()
            if len(fields) > 9 and fields[9] == inode:
                return int(fields[4].split(":")[1], 16)
    return 0


def send_all(link, send, datagrams: list[bytes]) -> None:
    """Send, then wait until the kernel holds every datagram: the next receive() reads them all at once."""
    for d in datagrams:
        send(d)
    assert wait_for(lambda: queued_bytes(link.conn.port) >= sum(map(len, datagrams)))


pytestmark_live = pytest.mark.live


@pytestmark_live
def test_report_behind_big_garbage_datagrams_comes_out_in_the_first_step(udp_link):
    link, counters, send = udp_link
    link.step_budget_s = 0.0  # a step frames one datagram: the report must be that one
    send_all(link, send, [marker_garbage(60_000, k) for k in range(4)] + [report()])
    first = link.receive(0.0)
    assert counters["link.datagrams"] == 5 and [m.get_type() for m in first] == ["ADSB_VEHICLE"]
    assert counters["link.deferred"] == 1 and link.backlog[0] == 4  # the garbage waits for the next steps ...
    assert wait_for(lambda: (link.receive(0.0), link.backlog == (0, 0))[1])  # ... and is framed there
    assert counters["frame.skipped_bytes"] == 4 * 60_000


@pytestmark_live
def test_a_step_with_a_backlog_does_not_wait_for_the_socket(udp_link, monkeypatch):
    link, counters, send = udp_link
    link.step_budget_s = 0.0
    frames = [hb(k) for k in range(6)]
    send_all(link, send, frames)
    timeouts = []
    real_select = link_module.select.select

    def recording_select(r, w, x, timeout):
        timeouts.append(timeout)
        return real_select(r, w, x, timeout)

    monkeypatch.setattr(link_module.select, "select", recording_select)
    out = [link.receive(DEADLINE_S) for _ in range(6)]  # a step that waited would return nothing new
    assert [bufs(m) for m in out] == [[f] for f in frames]  # one per step, in order
    assert timeouts[1:] == [0.0] * 5  # every step after the first had a backlog: no wait
    assert counters["link.deferred"] == 5 and counters["link.datagrams"] == 6


@pytestmark_live
def test_backlog_over_its_cap_drops_the_oldest_large_datagrams_and_counts_them(udp_link):
    link, counters, send = udp_link
    link.step_budget_s = 0.0
    link.max_backlog_bytes = 50_000
    sent = []
    for k in range(8):
        sent += [marker_garbage(20_000, k), report(0x100000 + k)]
    send_all(link, send, sent)
    out = link.receive(0.0)
    # 8 x 20 kB and 8 reports read at once; 50 kB allowed: the 6 oldest large ones go, the reports stay.
    assert counters["link.dropped_datagrams"] == 6 and counters["link.dropped_bytes"] == 6 * 20_000
    assert wait_for(lambda: (out.extend(link.receive(0.0)), link.backlog == (0, 0))[1])
    assert sorted(m.ICAO_address for m in out) == [0x100000 + k for k in range(8)]  # no report lost
    assert counters["frame.skipped_bytes"] == 2 * 20_000
    assert counters["link.datagrams"] == len(sent) and counters["link.kernel_drops"] == 0


@pytestmark_live
def test_kernel_drops_are_counted_and_every_datagram_is_accounted_for(udp_link):
    link, counters, send = udp_link
    sock = link.conn.port
    sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4096)  # the kernel holds a handful of datagrams
    n = 200
    for k in range(n):
        send(report(0x200000 + k))
    assert wait_for(lambda: (udp_kernel_drops(sock) or 0) > 0)
    dropped_now = udp_kernel_drops(sock)
    out = []
    assert wait_for(lambda: (out.extend(link.receive(0.0)), counters["link.datagrams"] + dropped_now >= n)[1])
    sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 1 << 20)
    send(report(0x2FFFFF))  # carries the kernel's count (SO_RXQ_OVFL) as of now
    assert wait_for(lambda: (out.extend(link.receive(0.0)), counters["link.datagrams"] == n + 1 - dropped_now)[1])
    assert counters["link.kernel_drops"] == dropped_now == udp_kernel_drops(sock) > 0
    assert counters["link.datagrams"] + counters["link.kernel_drops"] == n + 1
    assert len(out) == counters["link.datagrams"]  # every datagram received was a report that came out


@pytestmark_live
def test_kernel_drops_since_the_last_datagram_are_counted_at_close():
    port = free_port()
    counters = Counter()
    link = MavlinkLink(f"udpin:{HOST}:{port}", counters, 1, 191)
    link.conn.port.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4096)
    with closing(socket.socket(socket.AF_INET, socket.SOCK_DGRAM)) as sender:
        for k in range(100):
            sender.sendto(report(k + 1), (HOST, port))
    assert wait_for(lambda: (udp_kernel_drops(link.conn.port) or 0) > 0)
    expected = udp_kernel_drops(link.conn.port)
    link.close()  # nothing read: only /proc can tell
    assert counters["link.kernel_drops"] == expected > 0


# -- zenoh: status and ownship ahead of tracks -----------------------------------------------------------------
@pytestmark_live
def test_status_and_ownship_are_never_starved_by_tracks(monkeypatch):
    counters = Counter()
    bus = ZenohBus(ZenohConfig(queue_size=100, listen=(), connect=()), "v", counters=counters)
    put, gate = [], threading.Event()

    def stalled_put(suffix, payload, is_advisory):  # a link that stalls until the gate opens
        gate.wait()
        put.append(suffix)

    monkeypatch.setattr(bus, "_put", stalled_put)
    try:
        vital = VITAL_QUEUE // 2 - 1  # status + ownship ticks, each with 1000 tracks in between
        for tick in range(vital):
            for k in range(1000):
                bus.publish(f"tracks/t{k}", {"time_s": tick + k * 1e-4})
            bus.publish("ownship", {"time_s": tick + 0.5})
            bus.publish("status", {"time_s": tick + 0.5})
        depths = bus.queue_depths()
        gate.set()
        assert bus.flush(DEADLINE_S)
    finally:
        gate.set()
        bus.close()
    assert depths["updates"] == 100 and depths["status"] <= 2 * vital  # the tracks: bounded
    assert put.count("status") == put.count("ownship") == vital  # every one went out
    assert "zenoh.dropped_status" not in counters
    tracks_put = sum(1 for s in put if s.startswith("tracks/"))
    assert counters["zenoh.dropped_updates"] == vital * 1000 - tracks_put > 0
    # After the batch the stalled thread held (at most 64 tracks), status and ownship went out before any
    # other track.
    last_vital = max(i for i, s in enumerate(put) if s in ("status", "ownship"))
    assert sum(1 for s in put[:last_vital] if s.startswith("tracks/")) <= 64


@pytestmark_live
def test_status_queue_overflow_is_counted():
    counters = Counter()
    bus = ZenohBus(ZenohConfig(listen=(), connect=()), "v", counters=counters)
    gate = threading.Event()
    bus._put = lambda *a: gate.wait()
    try:
        for k in range(VITAL_QUEUE + 10 + 1):  # one may already be held by the stalled thread
            bus.publish("status", {"time_s": float(k)})
        assert wait_for(lambda: counters["zenoh.dropped_status"] in (10, 11))
        assert bus.snapshot()["queue"]["dropped_status"] == counters["zenoh.dropped_status"]
    finally:
        gate.set()
        bus.close()


# -- the benchmark runs and accounts for every byte (its numbers are measurements, not asserted) ------------------
def test_framing_benchmark_prints_json_with_every_byte_accounted_for(capsys, tmp_path):
    from avionics_eval import flood_bench

    reference = tmp_path / "framing_reference.py"
    reference.write_text(open(framing.__file__).read())  # a "before" that is this one: the same counts
    assert flood_bench.main(["framing", "--datagrams", "1", "--reference", str(reference)]) == 0
    out = json.loads(capsys.readouterr().out)["framing"]
    assert set(out["kinds"]) == set(flood_bench.KINDS)
    for kind, result in out["kinds"].items():
        before, after = result["before"], result["after"]
        assert before["counters"] == after["counters"] and before["frames_decoded"] == after["frames_decoded"]
        if kind == "valid_frames":
            assert after["frames_decoded"] == after["stream_frames_decoded"] > 1000 and not after["counters"]
        else:
            skipped = after["counters"]["frame.skipped_bytes"]
            assert skipped <= out["datagram_bytes"]
            assert (skipped == out["datagram_bytes"]) == (after["frames_decoded"] == 0)
