"""FrameScanner: every valid MAVLink frame is recovered from a byte stream or datagram, whatever garbage
surrounds it, and nothing that is not a valid frame is ever decoded. Frames are real pymavlink encodings."""

from __future__ import annotations

from collections import Counter

import avionics.io  # noqa: F401  (MAVLINK20=1 before pymavlink is imported)
import pytest
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st
from pymavlink.dialects.v20 import common as m2

from avionics.io.framing import MAX_FRAME, SIGNATURE_LEN, FrameScanner

SETTINGS = settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])
SIGNING_KEY = bytes(range(32))

# -- real pymavlink encoders ---------------------------------------------------------------------------------
PLAIN = m2.MAVLink(None, srcSystem=1, srcComponent=1)
SIGNED = m2.MAVLink(None, srcSystem=1, srcComponent=1)
SIGNED.signing.secret_key = SIGNING_KEY
SIGNED.signing.sign_outgoing = True
SIGNED.signing.link_id = 3
SIGNED.signing.timestamp = 1


def pack(msg, how: str = "v2") -> bytes:
    if how == "v1":
        return bytes(msg.pack(PLAIN, force_mavlink1=True))
    return bytes(msg.pack(SIGNED if how == "signed" else PLAIN))


def heartbeat(custom_mode: int = 0):
    return m2.MAVLink_heartbeat_message(m2.MAV_TYPE_QUADROTOR, m2.MAV_AUTOPILOT_PX4, 0, custom_mode,
                                        m2.MAV_STATE_ACTIVE, 3)


def scanner() -> tuple[FrameScanner, Counter]:
    counters = Counter()
    return FrameScanner(counters), counters


def bufs(msgs) -> list[bytes]:
    return [bytes(m.get_msgbuf()) for m in msgs]


# -- strategies ----------------------------------------------------------------------------------------------
u8, u16, i16 = st.integers(0, 2**8 - 1), st.integers(0, 2**16 - 1), st.integers(-2**15, 2**15 - 1)
u32, i32 = st.integers(0, 2**32 - 1), st.integers(-2**31, 2**31 - 1)

messages = st.one_of(
    st.builds(m2.MAVLink_heartbeat_message, u8, u8, u8, u32, u8, st.just(3)),
    st.builds(m2.MAVLink_scaled_pressure_message, u32, st.floats(width=32), st.floats(width=32), i16),
    st.builds(m2.MAVLink_global_position_int_message, u32, i32, i32, i32, i32, i16, i16, i16, u16),
    st.builds(m2.MAVLink_adsb_vehicle_message, u32, i32, i32, u8, i32, u16, u16, i16,
              st.binary(max_size=9), u8, u8, u16, u16),
)
# Payload bytes holding 0xFD/0xFE are the interesting ones: bias towards them.
marker_heavy_messages = st.one_of(
    messages,
    st.builds(m2.MAVLink_heartbeat_message, st.sampled_from([0xFD, 0xFE]), st.sampled_from([0xFD, 0xFE]),
              u8, st.sampled_from([0xFDFDFDFD, 0xFEFEFEFE, 0x00FD00FE]), u8, st.just(3)),
)
frames = st.tuples(marker_heavy_messages, st.sampled_from(["v2", "v2", "signed", "v1"])).map(lambda mh: pack(*mh))


@st.composite
def fragments(draw) -> bytes:
    """A piece of a valid frame: a head cut short before its signature, or any tail."""
    frame = draw(frames)
    signed = frame[0] == 0xFD and frame[2] & 0x01
    if draw(st.booleans()):
        return frame[:draw(st.integers(1, len(frame) - 1 - (SIGNATURE_LEN if signed else 0)))]
    return frame[draw(st.integers(1, len(frame) - 1)):]


garbage = st.lists(
    st.one_of(
        st.binary(max_size=24),
        st.lists(st.one_of(st.sampled_from([0xFD, 0xFE]), u8), max_size=24).map(bytes),
        fragments(),
    ),
    max_size=3,
).map(b"".join)


def stray_frame_at(stream: bytes, starts: set[int]) -> int | None:
    """Oracle independent of the scanner: the first position, other than the given frame starts, where
    pymavlink decodes a frame of a known msgid. Random bytes can (rarely) make one, e.g. a frame head cut one
    byte short followed by a byte equal to the missing CRC byte: such a frame is valid, not garbage."""
    parser = m2.MAVLink(None)
    for p, b in enumerate(stream):
        if p in starts or b not in (0xFD, 0xFE) or p + 3 > len(stream):
            continue
        length = (8 if b == 0xFE else 12 + (SIGNATURE_LEN if stream[p + 2] & 1 else 0)) + stream[p + 1]
        try:
            msg = parser.decode(bytearray(stream[p:p + length]))
        except Exception:  # noqa: BLE001
            continue
        if not isinstance(msg, m2.MAVLink_unknown):
            return p
    return None


@st.composite
def streams(draw) -> tuple[list[bytes], bytes]:
    """Valid frames with garbage between and around them: (the frames in order, the whole byte stream)."""
    valid = draw(st.lists(frames, min_size=1, max_size=6))
    gaps = [draw(garbage) for _ in range(len(valid) + 1)]
    stream, starts = gaps[0], set()
    for f, g in zip(valid, gaps[1:]):
        starts.add(len(stream))
        stream += f + g
    assume(stray_frame_at(stream, starts) is None)
    return valid, stream


def split(data: bytes, cuts: list[int]) -> list[bytes]:
    points = sorted({c % (len(data) + 1) for c in cuts} | {0, len(data)})
    return [data[a:b] for a, b in zip(points, points[1:])]


# -- properties ----------------------------------------------------------------------------------------------
@SETTINGS
@given(streams())
def test_one_datagram_decodes_every_valid_frame_in_order_and_nothing_else(case):
    valid, stream = case
    s, counters = scanner()
    assert bufs(s.feed(stream, end_of_datagram=True)) == valid
    after = pack(heartbeat(1))
    assert bufs(s.feed(after, end_of_datagram=True)) == [after]  # nothing was carried over to the next datagram


@SETTINGS
@given(streams(), st.lists(st.integers(0, 10_000), max_size=12))
def test_stream_in_arbitrary_chunks_decodes_every_valid_frame_in_order_and_nothing_else(case, cuts):
    """A stream cannot tell a garbage 0xFD claiming 255 bytes from a long frame still arriving before those
    bytes are there, so the frames behind such garbage come out once the stream has gone on by at most one
    maximal frame: here the link's later traffic is stood in for by marker-free bytes."""
    valid, stream = case
    s, _ = scanner()
    out = []
    for chunk in split(stream, cuts):
        out += s.feed(chunk)
    out += s.feed(bytes(MAX_FRAME + SIGNATURE_LEN))
    assert bufs(out) == valid


@SETTINGS
@given(st.lists(frames, min_size=1, max_size=6), st.lists(st.integers(0, 10_000), max_size=12))
def test_clean_stream_frame_comes_out_of_the_feed_that_completes_it(valid, cuts):
    """Without garbage nothing waits: each frame is returned by the very feed() that delivers its last byte."""
    stream = b"".join(valid)
    ends, total = [], 0
    for f in valid:
        total += len(f)
        ends.append(total)
    s, counters = scanner()
    fed = 0
    for chunk in split(stream, cuts):
        fed += len(chunk)
        expect = [f for f, end in zip(valid, ends) if fed - len(chunk) < end <= fed]
        assert bufs(s.feed(chunk)) == expect
    assert counters["frame.skipped_bytes"] == 0 and counters["frame.bad_crc"] == 0


@SETTINGS
@given(st.binary(max_size=400), st.booleans())
def test_random_bytes_never_raise_and_decode_to_nothing(data, datagram):
    s, _ = scanner()
    assert s.feed(data, end_of_datagram=datagram) == []


# -- documented cases ----------------------------------------------------------------------------------------
def test_pymavlink_parse_buffer_loses_a_frame_that_the_scanner_recovers():
    """Why FrameScanner exists: a garbage 0xFD followed by a length makes pymavlink swallow that many bytes,
    and the valid HEARTBEAT inside them is gone."""
    hb, pressure = pack(heartbeat(7)), pack(m2.MAVLink_scaled_pressure_message(1000, 1013.25, 0.0, 2000))
    junk = bytes([0xFD, 9, 0, 0, 0, 1, 1, 0, 0, 0])  # a v2 HEARTBEAT header with its 9-byte payload length
    stream = junk + hb + pressure

    parser = m2.MAVLink(None)
    parser.robust_parsing = True
    theirs = [m for m in (parser.parse_buffer(stream) or []) if m.get_type() != "BAD_DATA"]
    assert "HEARTBEAT" not in [m.get_type() for m in theirs]

    s, counters = scanner()
    ours = s.feed(stream, end_of_datagram=True)
    assert bufs(ours) == [hb, pressure]
    assert counters["frame.bad_crc"] == 1
    assert counters["frame.skipped_bytes"] == len(junk)


def test_bad_crc_frame_is_counted_and_its_neighbours_survive():
    good1, good2 = pack(heartbeat(1)), pack(heartbeat(2))
    bad = bytearray(pack(heartbeat(3)))
    bad[-1] ^= 0x5A  # CRC high byte
    assert not any(b in (0xFD, 0xFE) for b in bad[1:])  # the only candidate inside is the bad frame itself
    for datagram in (True, False):
        s, counters = scanner()
        assert bufs(s.feed(good1 + bytes(bad) + good2, end_of_datagram=datagram)) == [good1, good2]
        assert counters["frame.bad_crc"] == 1
        assert counters["frame.skipped_bytes"] == len(bad)


def test_corrupted_payload_byte_is_a_bad_crc():
    frame = bytearray(pack(m2.MAVLink_scaled_pressure_message(1000, 1013.25, 0.0, 2000)))
    frame[12] ^= 0x01
    s, counters = scanner()
    assert s.feed(bytes(frame), end_of_datagram=True) == []
    assert counters["frame.bad_crc"] >= 1


@pytest.mark.parametrize("datagram", [True, False])
def test_signed_frame_length_includes_the_signature(datagram):
    signed = pack(heartbeat(5), "signed")
    assert signed[2] & m2.MAVLINK_IFLAG_SIGNED
    after = pack(heartbeat(6))
    s, counters = scanner()
    out = s.feed(signed + after, end_of_datagram=datagram)
    assert bufs(out) == [signed, after]
    msg = out[0]
    assert len(msg.get_msgbuf()) == 10 + msg._header.mlen + 2 + SIGNATURE_LEN
    assert msg.custom_mode == 5 and msg.get_srcSystem() == 1
    assert not counters


def test_signed_frame_split_inside_its_signature_waits_for_the_rest():
    signed = pack(heartbeat(5), "signed")
    s, _ = scanner()
    assert s.feed(signed[:-SIGNATURE_LEN + 4]) == []
    assert bufs(s.feed(signed[-SIGNATURE_LEN + 4:])) == [signed]


@pytest.mark.parametrize("lost", [1, 6, SIGNATURE_LEN])
@pytest.mark.parametrize("datagram", [True, False])
def test_signature_cut_short_does_not_cost_the_next_frame(lost, datagram):
    """The CRC does not cover the signature: a signed frame that lost signature bytes still decodes, and must
    not take the head of the next frame as the rest of its signature."""
    signed = pack(m2.MAVLink_scaled_pressure_message(1, 1000.0, 0.0, 1500), "signed")
    nxt, last = pack(heartbeat(8)), pack(heartbeat(9), "signed")
    s, counters = scanner()
    out = s.feed(signed[:-lost] + nxt + last, end_of_datagram=datagram)
    if not datagram:
        out += s.feed(bytes(MAX_FRAME + SIGNATURE_LEN))
    assert bufs(out)[-2:] == [nxt, last]
    assert counters["frame.signature_truncated"] == 1


def test_garbage_header_with_unknown_msgid_does_not_swallow_frames():
    """pymavlink returns an unknown msgid without a CRC check: such a header in garbage is not a frame."""
    hb = pack(heartbeat(4))
    junk = bytes([0xFD, len(hb), 0, 0, 0, 1, 1, 0xEE, 0xEE, 0xEE, 0x00, 0x00])  # msgid 0xEEEEEE: not in common
    s, counters = scanner()
    assert bufs(s.feed(junk + hb, end_of_datagram=True)) == [hb]
    assert counters["frame.unknown_msgid"] == 1


@pytest.mark.parametrize("junk", [
    bytes([0xFD, 0xFF, 0x00, 0x00, 0x00, 0x01, 0x01, 0xEE, 0xEE, 0xEE]),  # unknown msgid
    bytes([0xFD, 0xFF, 0x84, 0x00, 0x00, 0x01, 0x01, 0x00, 0x00, 0x00]),  # unknown incompat flag
    bytes([0xFE, 0xFF, 0x00, 0x01, 0x01, 0x00]),  # MAVLink 1 HEARTBEAT claiming 255 bytes
])
def test_garbage_header_no_frame_can_have_does_not_hold_back_the_stream(junk):
    """A stream waits for a candidate's claimed length only when its header could be a frame's."""
    hb = pack(heartbeat(4))
    s, counters = scanner()
    assert bufs(s.feed(junk + hb)) == [hb]
    assert counters["frame.skipped_bytes"] == len(junk)


def test_plausible_garbage_header_waits_for_its_length_then_lets_go():
    junk = bytes([0xFD, 0x20, 0x00, 0x00, 0x00, 0x01, 0x01, 0xF6, 0x00, 0x00])  # ADSB_VEHICLE (38 at most): 32 bytes
    hb, more = pack(heartbeat(4)), pack(heartbeat(5))
    s, counters = scanner()
    assert s.feed(junk + hb) == []  # it might be a frame still arriving
    assert bufs(s.feed(more)) == [hb, more]
    assert counters["frame.bad_crc"] == 1


def test_mavlink1_frames_decode_and_keep_their_version():
    v1, v2 = pack(heartbeat(1), "v1"), pack(heartbeat(2))
    s, _ = scanner()
    out = s.feed(b"\xfe\x00" + v1 + b"\xfd" + v2, end_of_datagram=True)
    assert bufs(out) == [v1, v2]
    assert out[0].get_msgbuf()[0] == 0xFE and out[1].get_msgbuf()[0] == 0xFD


def test_incomplete_candidate_at_datagram_end_is_dropped_not_carried_over():
    hb = pack(heartbeat(1))
    s, counters = scanner()
    assert s.feed(hb[:-3], end_of_datagram=True) == []
    assert counters["frame.skipped_bytes"] == len(hb) - 3
    assert bufs(s.feed(hb, end_of_datagram=True)) == [hb]  # the next datagram starts clean
