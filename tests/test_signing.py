"""MAVLink 2 signing over real UDP sockets on 127.0.0.1: with a key, signed frames are used; unsigned, wrong-key,
replayed and stale frames are rejected, each counted by its reason; what we send verifies with the key (checked
by pymavlink itself). A bad key file is a one-line configuration error. And the .tlog replay: corrupted
timestamps are rejected like any bad input instead of becoming the replay's clock."""

from __future__ import annotations

import socket
import struct
import time
from collections import Counter
from contextlib import closing

import avionics.io  # noqa: F401  (MAVLINK20=1 before pymavlink is imported)
import pytest
from pymavlink.dialects.v20 import common as m2

from avionics.cli import main
from avionics.config import ConfigError, load_config
from avionics.io.link import MavlinkLink
from avionics.io.signing import Signing, load_key, timestamp_at
from tests.conftest import DEADLINE_S, free_port

HOST = "127.0.0.1"
KEY = bytes(range(1, 33))
OTHER_KEY = bytes(range(101, 133))
OUR_SYSTEM, OUR_COMPONENT = 1, 191


def key_file(tmp_path, key: bytes = KEY, text: str | None = None):
    path = tmp_path / "signing.key"
    path.write_text(key.hex() + "\n" if text is None else text)
    return path


def signer(key: bytes | None, system: int = 1, component: int = 1, timestamp: int | None = None,
           link_id: int = 0) -> m2.MAVLink:
    """The autopilot's side: pymavlink's own signing (None: unsigned)."""
    mav = m2.MAVLink(None, srcSystem=system, srcComponent=component)
    if key is not None:
        mav.signing.secret_key, mav.signing.sign_outgoing, mav.signing.link_id = key, True, link_id
        mav.signing.timestamp = timestamp_at(time.time()) if timestamp is None else timestamp
    return mav


def heartbeat(mav) -> bytes:
    return bytes(m2.MAVLink_heartbeat_message(2, 12, 81, 0, 4, 3).pack(mav))


def adsb(mav, address: int = 0xA1B2C3) -> bytes:
    return bytes(m2.MAVLink_adsb_vehicle_message(address, 474000000, 85500000, 0, 914400, 18000, 6430, 0,
                                                 b"DLH4AB", 1, 0, 0x1FF, 7000).pack(mav))


def receive_counted(rx: MavlinkLink, counters: Counter, datagrams: int) -> list:
    """Everything rx uses until all `datagrams` sent have been through the scanner (each holds one frame or more
    ending in a HEARTBEAT-sized frame, counted by the signing counters): no fixed sleep, a generous deadline."""
    out, deadline = [], time.monotonic() + DEADLINE_S

    def seen() -> int:
        return sum(v for k, v in counters.items() if k.startswith("signing."))

    while seen() < datagrams and time.monotonic() < deadline:
        out += rx.receive(0.05)
    return out


def open_link(tmp_path, port: int, counters: Counter, **kw) -> MavlinkLink:
    return MavlinkLink(f"udpin:{HOST}:{port}", counters, OUR_SYSTEM, OUR_COMPONENT,
                       signing_key_file=str(key_file(tmp_path)), **kw)


# -- incoming -------------------------------------------------------------------------------------------------
@pytest.mark.live
def test_signed_frames_are_used_and_unsigned_wrong_key_and_replayed_ones_rejected_by_reason(tmp_path):
    port = free_port(socket.SOCK_DGRAM)
    counters = Counter()
    autopilot = signer(KEY)
    with closing(open_link(tmp_path, port, counters)) as rx, \
            closing(socket.socket(socket.AF_INET, socket.SOCK_DGRAM)) as tx:
        # Made in the order they are sent: pymavlink adds 1 to the timestamp per frame it signs.
        good = [heartbeat(autopilot) for _ in range(2)]
        four = [adsb(autopilot, 0xA00000 + i) for i in range(4)]  # several signed frames in one datagram
        good.append(heartbeat(autopilot))
        unsigned_v2 = heartbeat(signer(None))
        unsigned_v1 = bytes(m2.MAVLink_heartbeat_message(6, 8, 0, 0, 4, 3).pack(signer(None), force_mavlink1=True))
        wrong_key = adsb(signer(OTHER_KEY, timestamp=timestamp_at(time.time()) + 10**9))  # far future, too
        replayed = good[0]
        flipped = bytearray(good[2])
        flipped[-1] ^= 0x01  # the signature of a frame whose CRC is intact
        datagrams = [good[0], good[1], b"".join(four), unsigned_v2, unsigned_v1, wrong_key, replayed, bytes(flipped),
                     good[2]]
        for d in datagrams:
            tx.sendto(d, (HOST, port))
        got = receive_counted(rx, counters, len(datagrams) + 3)
    assert [bytes(m.get_msgbuf()) for m in got] == [good[0], good[1], *four, good[2]]
    assert counters["signing.accepted"] == 7
    assert counters["signing.unsigned"] == 2
    assert counters["signing.bad_signature"] == 2
    assert counters["signing.replayed"] == 1


@pytest.mark.live
def test_a_forged_far_future_frame_does_not_lock_the_real_sender_out(tmp_path):
    """pymavlink's check_signature stores a stream's timestamp before it checks the signature: one forged frame
    with the same ids and a far-future timestamp would make every real frame after it 'old'. Ours does not."""
    port = free_port(socket.SOCK_DGRAM)
    counters = Counter()
    autopilot = signer(KEY)
    forger = signer(OTHER_KEY, timestamp=(1 << 48) - 10)  # same system, component and link id
    with closing(open_link(tmp_path, port, counters)) as rx, \
            closing(socket.socket(socket.AF_INET, socket.SOCK_DGRAM)) as tx:
        for d in (heartbeat(autopilot), heartbeat(forger), heartbeat(autopilot), heartbeat(autopilot)):
            tx.sendto(d, (HOST, port))
        got = receive_counted(rx, counters, 4)
    assert len(got) == 3 and counters["signing.accepted"] == 3 and counters["signing.bad_signature"] == 1


@pytest.mark.live
def test_streams_are_per_link_system_and_component_and_a_stale_new_stream_is_rejected(tmp_path):
    port = free_port(socket.SOCK_DGRAM)
    counters = Counter()
    now = timestamp_at(time.time())
    with closing(open_link(tmp_path, port, counters)) as rx, \
            closing(socket.socket(socket.AF_INET, socket.SOCK_DGRAM)) as tx:
        a = signer(KEY, 1, 1, timestamp=now + 1000)
        b = signer(KEY, 1, 156, timestamp=now)  # an older timestamp, but its own stream
        c = signer(KEY, 1, 1, timestamp=now, link_id=2)  # same ids on another link: its own stream
        old = signer(KEY, 1, 190, timestamp=now - 2 * 6_000_000)  # a new stream two minutes behind our time
        for d in (heartbeat(a), heartbeat(b), heartbeat(c), heartbeat(old)):
            tx.sendto(d, (HOST, port))
        got = receive_counted(rx, counters, 4)
    assert [(m.get_srcComponent()) for m in got] == [1, 156, 1]
    assert counters["signing.accepted"] == 3 and counters["signing.old_stream"] == 1


@pytest.mark.live
def test_signing_not_required_accepts_unsigned_frames_counted_but_still_rejects_bad_signatures(tmp_path):
    port = free_port(socket.SOCK_DGRAM)
    counters = Counter()
    with closing(open_link(tmp_path, port, counters, signing_required=False)) as rx, \
            closing(socket.socket(socket.AF_INET, socket.SOCK_DGRAM)) as tx:
        for d in (heartbeat(signer(None)), heartbeat(signer(OTHER_KEY)), heartbeat(signer(KEY))):
            tx.sendto(d, (HOST, port))
        got = receive_counted(rx, counters, 3)
    assert len(got) == 2
    assert counters["signing.unsigned_allowed"] == 1 and counters["signing.bad_signature"] == 1
    assert counters["signing.accepted"] == 1


@pytest.mark.live
def test_without_a_key_every_frame_is_used_as_before(tmp_path):
    port = free_port(socket.SOCK_DGRAM)
    counters = Counter()
    with closing(MavlinkLink(f"udpin:{HOST}:{port}", counters, OUR_SYSTEM, OUR_COMPONENT)) as rx, \
            closing(socket.socket(socket.AF_INET, socket.SOCK_DGRAM)) as tx:
        for d in (heartbeat(signer(None)), heartbeat(signer(OTHER_KEY))):
            tx.sendto(d, (HOST, port))
        got, deadline = [], time.monotonic() + DEADLINE_S
        while len(got) < 2 and time.monotonic() < deadline:
            got += rx.receive(0.05)
    assert len(got) == 2 and not [k for k in counters if k.startswith("signing.")]


# -- outgoing -------------------------------------------------------------------------------------------------
@pytest.mark.live
def test_our_frames_are_signed_and_verify_with_the_key_in_pymavlink(tmp_path):
    port = free_port(socket.SOCK_DGRAM)
    counters = Counter()
    verifier = m2.MAVLink(None)
    verifier.signing.secret_key = KEY  # pymavlink's own check; no allow_unsigned_callback: unsigned raises
    outsider = m2.MAVLink(None)
    outsider.signing.secret_key = OTHER_KEY
    before = timestamp_at(time.time())
    with closing(open_link(tmp_path, port, counters)) as rx, \
            closing(socket.socket(socket.AF_INET, socket.SOCK_DGRAM)) as tx:
        tx.bind((HOST, 0))
        tx.sendto(heartbeat(signer(KEY)), (HOST, port))  # udpin answers whoever sent last
        receive_counted(rx, counters, 1)
        for level in (1, 2):
            rx.send(m2.MAVLink_collision_message(m2.MAV_COLLISION_SRC_ADSB, 0xA1B2C3, m2.MAV_COLLISION_ACTION_REPORT,
                                                 level, 21.5, 12.0, 150.0))
        tx.settimeout(DEADLINE_S)
        frames = [tx.recvfrom(4096)[0] for _ in range(2)]
    stamps = []
    for frame in frames:
        msg = verifier.decode(bytearray(frame))
        assert msg.get_type() == "COLLISION" and msg._signed and msg._link_id == 0
        assert (msg.get_srcSystem(), msg.get_srcComponent()) == (OUR_SYSTEM, OUR_COMPONENT)
        stamps.append(int.from_bytes(frame[-12:-6], "little"))
        with pytest.raises(m2.MAVError, match="signature"):
            outsider.decode(bytearray(frame))
    assert before <= stamps[0] < stamps[1]  # 10 us units since 2015, strictly increasing


def test_our_timestamp_follows_the_clock_and_never_falls_behind_what_we_received():
    clock = [1_700_000_000.0]
    signing = Signing(KEY, Counter(), clock=lambda: clock[0])
    mav = m2.MAVLink(None, 1, 191)
    signing.attach(mav)
    assert mav.signing.timestamp == timestamp_at(clock[0]) == (1_700_000_000 - 1420070400) * 100_000
    ahead = signer(KEY, 1, 1, timestamp=timestamp_at(clock[0]) + 5_000_000)
    assert signing.accept(m2.MAVLink(None).decode(bytearray(heartbeat(ahead))))
    signing.before_send(mav)
    assert mav.signing.timestamp == timestamp_at(clock[0]) + 5_000_000  # never behind what we received
    clock[0] += 100.0
    signing.before_send(mav)
    assert mav.signing.timestamp == timestamp_at(clock[0])


# -- the key file ---------------------------------------------------------------------------------------------
@pytest.mark.parametrize("text, message", [
    ("00" * 31, "64 hexadecimal characters"),
    ("zz" * 32, "not hexadecimal"),
    ("00" * 32, "all-zero"),
])
def test_a_bad_key_file_is_a_configuration_error_naming_the_file(tmp_path, text, message):
    path = key_file(tmp_path, text=text)
    with pytest.raises(ConfigError, match=message) as info:
        load_config(overrides=[f'mavlink.signing_key_file="{path}"'])
    assert str(path) in str(info.value) and "\n" not in str(info.value)


def test_a_missing_key_file_exits_2_with_one_line(tmp_path, capsys):
    path = tmp_path / "absent.key"
    assert main(["run", "--no-zenoh", "--set", f'mavlink.signing_key_file="{path}"', "--duration", "0"]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and str(path) in err and "mavlink.signing_key_file" in err


def test_a_good_key_file_loads_with_surrounding_whitespace(tmp_path):
    path = key_file(tmp_path, text="\n  " + KEY.hex().upper() + "  \n")
    assert load_key(path) == KEY
    assert load_config(overrides=[f'mavlink.signing_key_file="{path}"']).mavlink.signing_required


# -- .tlog: recorded with signing, replayed with the same check -----------------------------------------------
@pytest.mark.live
def test_a_signed_session_recorded_as_tlog_replays_with_the_same_verdicts(tmp_path):
    port = free_port(socket.SOCK_DGRAM)
    tlog = tmp_path / "signed.tlog"
    counters = Counter()
    autopilot = signer(KEY)
    with closing(open_link(tmp_path, port, counters, tlog_out=tlog)) as rx, \
            closing(socket.socket(socket.AF_INET, socket.SOCK_DGRAM)) as tx:
        sent = [heartbeat(autopilot), heartbeat(signer(None)), heartbeat(signer(OTHER_KEY)), adsb(autopilot)]
        for d in sent:
            tx.sendto(d, (HOST, port))
        live = receive_counted(rx, counters, len(sent))
    replay_counters = Counter()
    replay = MavlinkLink(str(tlog), replay_counters, OUR_SYSTEM, OUR_COMPONENT,
                         signing_key_file=str(key_file(tmp_path)))
    try:
        replayed = []
        while msgs := replay.receive(0.0):
            replayed += msgs
    finally:
        replay.close()
    assert [bytes(m.get_msgbuf()) for m in replayed] == [bytes(m.get_msgbuf()) for m in live] == [sent[0], sent[3]]
    assert {k: v for k, v in replay_counters.items() if k.startswith("signing.")} == \
        {k: v for k, v in counters.items() if k.startswith("signing.")}


# -- .tlog timestamps -------------------------------------------------------------------------------------------
def _write_tlog(path, stamps_s: list[float | int]) -> list[bytes]:
    mav = signer(None)
    frames = []
    with open(path, "wb") as fh:
        for i, stamp in enumerate(stamps_s):
            frame = bytes(m2.MAVLink_global_position_int_message(i, 473977418, 85455939, 914400, 304800, 0, 0, 0,
                                                                 0).pack(mav))
            raw = stamp if isinstance(stamp, int) else int(stamp * 1e6)
            fh.write(struct.pack(">Q", raw) + frame)
            frames.append(frame)
    return frames


def _replay(path) -> tuple[list, Counter]:
    counters = Counter()
    link = MavlinkLink(str(path), counters, OUR_SYSTEM, OUR_COMPONENT)
    out = []
    try:
        while msgs := link.receive(0.0):
            out += msgs
        assert link.at_end
    finally:
        link.close()
    return out, counters


def test_corrupted_tlog_timestamps_are_rejected_and_the_replay_clock_never_jumps_or_goes_back(tmp_path):
    t0 = 1_700_000_000.0
    stamps = [t0 + 0.2 * k for k in range(40)]
    bad = {0: (1 << 64) - 1, 7: 0, 12: t0 + 86400 * 365, 20: t0 - 3600, 27: 2 ** 63, 33: t0 + 0.2 * 33 + 4.0}
    for k, v in bad.items():
        stamps[k] = v
    frames = _write_tlog(tmp_path / "bad.tlog", stamps)
    got, counters = _replay(tmp_path / "bad.tlog")
    times = [m._timestamp for m in got]
    assert [bytes(m.get_msgbuf()) for m in got] == [f for k, f in enumerate(frames) if k not in bad or k == 33]
    assert counters["tlog.bad_timestamp"] == len(bad) - 1
    assert times == sorted(times) and times[0] == pytest.approx(t0 + 0.2)
    assert max(b - a for a, b in zip(times, times[1:])) < 4.5
    # a step ahead within LOG_STAMP_STEP_S (33) is taken; the replay's time then waits there for the log
    assert times[-7:] == pytest.approx([stamps[33]] * 7)


def test_a_real_gap_in_a_tlog_is_kept_once_the_next_frame_confirms_it(tmp_path):
    t0 = 1_700_000_000.0
    stamps = [t0, t0 + 0.5, t0 + 1.0, t0 + 600.0, t0 + 600.5, t0 + 601.0]
    frames = _write_tlog(tmp_path / "gap.tlog", stamps)
    got, counters = _replay(tmp_path / "gap.tlog")
    assert [bytes(m.get_msgbuf()) for m in got] == frames and not counters["tlog.bad_timestamp"]
    assert [m._timestamp for m in got] == pytest.approx(stamps)


def _head_on_tlog(path, corrupt: dict[int, int]) -> None:
    from avionics_sitl.autopilot import Packer, schedule
    from avionics_sitl.impairments import PRESETS
    from avionics_sitl.encounters import load_encounter

    packer = Packer()
    with open(path, "wb") as fh:
        for i, event in enumerate(schedule(load_encounter("head-on"), PRESETS["none"], duration_s=75.0)):
            stamp = corrupt.get(i, int((1_700_000_000.0 + event.deliver_s) * 1e6))
            fh.write(struct.pack(">Q", stamp) + packer.pack(event.msg))


def _run_log(path) -> tuple[list, Counter]:
    from avionics.runner import Runner

    from avionics.ports import NOTHING

    runner = Runner(load_config(overrides=[f'mavlink.connection="{path}"', "zenoh.enabled=false"]))
    changes = []

    class Changes:  # one more output port: the advisory changes, as (time, intruder, level)
        def wants(self, now_s):
            return NOTHING

        def publish(self, result):
            changes.extend((round(result.time_s, 2), str(a.intruder), a.level.name) for a in result.changes)

        def close(self):
            pass

    runner.loop.ports.append(Changes())
    try:
        runner.run()
    finally:
        runner.close()
    return changes, runner.counters


def test_a_head_on_tlog_with_corrupted_timestamps_alerts_as_the_clean_one(tmp_path):
    """The first stamp all ones (the replay's time origin) and one a year ahead mid-encounter: both frames are
    rejected, counted, and the TA and RA come at the times of the clean log."""
    _head_on_tlog(tmp_path / "clean.tlog", {})
    _head_on_tlog(tmp_path / "bad.tlog", {0: (1 << 64) - 1, 300: int((1_700_000_000.0 + 86400 * 365) * 1e6)})
    clean, _ = _run_log(tmp_path / "clean.tlog")
    bad, counters = _run_log(tmp_path / "bad.tlog")
    assert [level for _, _, level in clean][:2] == ["TA", "RA"]
    assert bad == clean and counters["tlog.bad_timestamp"] == 2
