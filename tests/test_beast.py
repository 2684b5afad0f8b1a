"""Beast binary input (avionics/io/feeds/beast.py) and the simulator's 1090ES encoder (sitl/avionics_sitl/beast.py).

Oracles: published messages from Junzi Sun, "The 1090 MHz Riddle" (2nd ed., mode-s.org/1090mhz), decoded by our
decoder; pyModeS 3.x (an independent implementation) decoding what our encoder writes, to the format's
quantisation, and agreeing with our decoder on the same messages."""

from __future__ import annotations

import math
import random
from collections import Counter

import pyModeS as pms
import pytest
from hypothesis import assume, given, settings, strategies as st
from pyModeS.position import airborne_position_pair, cprNL

from avionics.base.types import AltitudeDatum
from avionics.base.units import FPM, FT, KT
from avionics.io.feeds.beast import (
    BeastDecoder, BeastDeframer, BeastFrame, CLOCK_HZ, EMITTER_TYPE, nic_of_type_code,
)
from avionics_sitl.beast import (
    EMITTER_CATEGORY, NIC_TYPE_CODE, airborne_position_me, airborne_velocity_me, beast_frame, cpr_nl, crc24, df17,
    identification_me, operational_status_me,
)

RIDDLE_EVEN = "8D40621D58C382D690C8AC2863A7"  # the Riddle's airborne position pair, even received last
RIDDLE_ODD = "8D40621D58C386435CC412692AD6"
RIDDLE_VELOCITY = "8D485020994409940838175B284F"  # 159 kt, 182.88 deg, -832 fpm
RIDDLE_IDENTIFICATION = "8D4840D6202CC371C32CE0576098"  # KLM1023
CPR_QUANTUM_LAT_DEG = 360.0 / 60 / 2**17  # even latitude zone / 2^17: 4.6e-5 deg = 5.1 m


def frames_of(hexes, start_ticks=12_000_000, step_s=1.0):
    return b"".join(beast_frame(bytes.fromhex(h), start_ticks + int(i * step_s * CLOCK_HZ)) for i, h in enumerate(hexes))


def decode_stream(data: bytes, received=lambda i: float(i)):
    counters = Counter()
    deframer, decoder = BeastDeframer(counters), BeastDecoder(counters)
    out = [decoder.decode(f, received(i)) for i, f in enumerate(deframer.feed(data))]
    return out, counters, decoder


# --- the Riddle's messages --------------------------------------------------------------------------------------
def test_the_riddles_position_pair_velocity_and_identification():
    # the pair twice (5 s apart: its two positions are 1.6 km apart), a position once both formats confirmed it
    out, counters, _ = decode_stream(frames_of([RIDDLE_ODD, RIDDLE_EVEN, RIDDLE_ODD, RIDDLE_EVEN, RIDDLE_VELOCITY,
                                                RIDDLE_IDENTIFICATION], step_s=5.0), received=lambda i: 5.0 * i + 0.1)
    *held, even, velocity, ident = out
    assert held == [None] * 3  # one message, then the pair, then one format's confirmation: no position yet
    assert (even.lat_deg, even.lon_deg) == (pytest.approx(52.2572, abs=1e-4), pytest.approx(3.9194, abs=1e-4))
    assert even.altitude_m == pytest.approx(38000 * FT)
    assert even.altitude_datum is AltitudeDatum.PRESSURE and even.nic == 8  # TC 11, version unknown: NIC 8
    east, north = velocity.velocity_en_mps
    assert math.hypot(east, north) / KT == pytest.approx(159.2, abs=0.05)
    assert math.degrees(math.atan2(east, north)) % 360 == pytest.approx(182.88, abs=0.01)
    assert velocity.vertical_rate_mps == pytest.approx(-832 * FPM)
    assert ident.callsign == "KLM1023" and ident.emitter_type == 0  # category 0: no information
    assert counters["traffic.beast.cpr_global"] == 1 and counters["traffic.beast.cpr_no_pair"] == 1
    assert counters["traffic.beast.cpr_held"] == 2 and counters["traffic.beast.frames"] == 6


def test_our_encoder_writes_the_riddles_even_message_bit_for_bit():
    me = airborne_position_me(52.2572021484375, 3.91937255859375, 38000, odd=False, nic=8)
    assert df17(0x40621D, me, ca=5).hex().upper() == RIDDLE_EVEN
    assert crc24(bytes.fromhex(RIDDLE_VELOCITY[:22])) == int(RIDDLE_VELOCITY[22:], 16)


def test_a_pair_more_than_10_s_apart_is_not_decoded_then_local_decoding_follows_a_confirmed_global_one():
    lat, lon = 47.3, 8.55
    even = df17(0xABCDEF, airborne_position_me(lat, lon, 5000, odd=False)).hex()
    odd = df17(0xABCDEF, airborne_position_me(lat, lon, 5000, odd=True)).hex()
    # even at 0 s, odd at 10.5 s: no pair; the even at 11 s pairs with the odd at 10.5 s; the odd at 11.5 s and the
    # even at 12 s confirm it (both formats): the reference; then each message alone, locally
    times = [0.0, 10.5, 11.0, 11.5, 12.0, 12.5, 13.0]
    data = b"".join(beast_frame(bytes.fromhex(h), 1000 + int(t * CLOCK_HZ))
                    for h, t in zip([even, odd] * 3 + [even], times))
    out, counters, _ = decode_stream(data, received=lambda i: times[i] + 0.05)
    assert [o is not None for o in out] == [False, False, False, False, True, True, True]
    assert counters["traffic.beast.cpr_no_pair"] == 2 and counters["traffic.beast.cpr_held"] == 2
    assert counters["traffic.beast.cpr_global"] == 1 and counters["traffic.beast.cpr_local"] == 2
    for o in out[4:]:
        assert o.lat_deg == pytest.approx(lat, abs=CPR_QUANTUM_LAT_DEG) and o.lon_deg == pytest.approx(lon, abs=1e-4)


def test_a_position_farther_than_the_aircraft_can_fly_is_rejected_and_the_reference_kept():
    def pos(lat, odd):
        return df17(0x123456, airborne_position_me(lat, 8.5, 5000, odd=odd)).hex()

    # the reference at 47.3 N; a message 1.5 degrees north (local decoding puts it there: half a zone) is rejected,
    # and the next true message is decoded against the kept reference. When the aircraft is really at 48.8 N (say
    # heard again after a gap), its new messages replace the reference once both formats confirm their pair.
    hexes = [pos(47.3, False), pos(47.3, True)] * 2 + [pos(48.8, False), pos(47.3, True)] + [
        pos(48.8, False), pos(48.8, True)] * 2
    data = b"".join(beast_frame(bytes.fromhex(h), 1000 + int(i * 0.5 * CLOCK_HZ)) for i, h in enumerate(hexes))
    out, counters, _ = decode_stream(data, received=lambda i: 0.5 * i)
    assert [None if o is None else round(o.lat_deg, 3) for o in out] == [
        None, None, None, 47.3, None, 47.3, None, None, None, 48.8]
    assert counters["traffic.beast.cpr_implausible"] == 5  # the lone 48.8, then the four before the new reference
    assert counters["traffic.beast.cpr_local"] == 1 and counters["traffic.beast.cpr_global"] == 2
    assert counters["traffic.beast.cpr_zone_mismatch"] == 2  # 48.8 N even with a 47.3 N odd: not one aircraft


def test_the_12_mhz_counter_wrapping_at_2_48_keeps_time_running():
    start = 2**48 - int(1.5 * CLOCK_HZ)  # the counter wraps 1.5 s into the stream
    hexes = [RIDDLE_VELOCITY] * 6
    data = b"".join(beast_frame(bytes.fromhex(h), start + int(i * 0.5 * CLOCK_HZ)) for i, h in enumerate(hexes))
    out, counters, decoder = decode_stream(data, received=lambda i: 100.0 + 0.5 * i + 0.02)
    times = [o.time_s for o in out]
    # the constant 0.02 s delay is in the envelope (the receiver's clock cannot tell it): times step by 0.5 s
    assert times == pytest.approx([100.02 + 0.5 * i for i in range(6)], abs=1e-6)
    assert decoder.clock.steps == 0


def test_df18_other_than_cf0_non_es_and_mode_ac_are_counted_not_used():
    me = airborne_velocity_me(50.0, 0.0, 0.0)

    def df18(cf):
        data = (((18 << 3 | cf) << 24 | 0xA1B2C3) << 56 | me).to_bytes(11, "big")
        return data + crc24(data).to_bytes(3, "big")

    df11 = bytes.fromhex("5D4840D6") + crc24(bytes.fromhex("5D4840D6")).to_bytes(3, "big")
    df20 = bytes.fromhex("A0001838CA3E51F0A8000047A9D4")
    data = b"".join(beast_frame(m, 1000 * (i + 1)) for i, m in enumerate(
        [df18(0), df18(1), df18(2), df18(5), df18(6), df11, df20, bytes([0x12, 0x34])]))
    out, counters, _ = decode_stream(data)
    assert out[0] is not None and out[0].velocity_en_mps == pytest.approx((50.0, 0.0), abs=0.5 * KT)
    assert out[1:] == [None] * 7
    for cf in (0, 1, 2, 5, 6):
        assert counters[f"traffic.beast.df18.cf{cf}"] == 1
    assert counters["traffic.beast.mode_s_short"] == 1 and counters["traffic.beast.mode_ac"] == 1
    assert counters["traffic.beast.mode_s_long_other"] == 1


@pytest.mark.parametrize("tc, version, nic_a, nic_b, nic", [
    (9, None, 0, 0, 11), (11, 2, 1, 1, 9), (11, 2, 1, 0, 8), (11, 1, 1, 0, 9), (11, None, 1, 1, 8),
    (16, 2, 1, 1, 3), (16, 2, 0, 0, 2), (16, 0, 0, 0, 1), (18, 2, 0, 0, 0), (20, 2, 0, 0, 11),
])
def test_nic_from_the_type_code_and_supplements(tc, version, nic_a, nic_b, nic):
    assert nic_of_type_code(tc, version, nic_a, nic_b) == nic


def test_nic_and_nacp_reach_the_observation_from_the_operational_status():
    me_status = operational_status_me(nacp=10, version=2, nic_a=1)
    positions = [airborne_position_me(40.0, -3.0, 3000, odd=odd, nic=8) for odd in (False, True)]  # TC 11, NIC-B 0
    out, _, _ = decode_stream(b"".join(beast_frame(df17(0xA00001, me), 1000 * (i + 1))
                                       for i, me in enumerate([me_status] + positions * 2)))
    assert out[0].nacp == 10 and out[-1].nic == 8


# --- encoder vs pyModeS, decoder vs pyModeS (hypothesis) ----------------------------------------------------------
latitudes = st.floats(min_value=-85.0, max_value=85.0, allow_nan=False)
longitudes = st.floats(min_value=-180.0, max_value=179.9999, allow_nan=False)


def _near_nl_boundary(lat: float) -> bool:
    return cprNL(lat - 1e-3) != cprNL(lat + 1e-3)


@settings(max_examples=300)
@given(lat=latitudes, lon=longitudes, alt_ft=st.integers(-1000, 50175), even_newer=st.booleans())
def test_positions_we_encode_decode_with_pymodes_within_the_cpr_quantum(lat, lon, alt_ft, even_newer):
    assume(not _near_nl_boundary(lat))
    alt_ft = alt_ft // 25 * 25
    even = pms.decode(df17(0x3C6586, airborne_position_me(lat, lon, alt_ft, odd=False)).hex())
    odd = pms.decode(df17(0x3C6586, airborne_position_me(lat, lon, alt_ft, odd=True)).hex())
    assert even["crc_valid"] and odd["crc_valid"] and even["cpr_format"] == 0 and odd["cpr_format"] == 1
    assert even["altitude"] == alt_ft == odd["altitude"]
    decoded = airborne_position_pair(even["cpr_lat"], even["cpr_lon"], odd["cpr_lat"], odd["cpr_lon"],
                                     even_is_newer=even_newer)
    assert decoded is not None
    d_lat = 360.0 / (60 if even_newer else 59)
    lon_zones = max(cprNL(lat) - (0 if even_newer else 1), 1)
    assert abs(decoded[0] - lat) <= d_lat / 2**17  # one quantum: 5.1 m (even), 5.2 m (odd)
    assert abs((decoded[1] - lon + 180) % 360 - 180) <= 360.0 / lon_zones / 2**17
    # our decoder, through Beast frames and the receiver clock, gives pyModeS's position (the pair's, once the
    # next two messages confirmed it, is the last message's local decoding: the same zone, the same position)
    frames = [df17(0x3C6586, airborne_position_me(lat, lon, alt_ft, odd=o)) for o in ([True, False] if even_newer
                                                                                      else [False, True])]
    out, _, _ = decode_stream(b"".join(beast_frame(f, 5000 + i * 6_000_000) for i, f in enumerate(frames * 2)),
                              received=lambda i: 0.5 * i)
    assert out[3].lat_deg == pytest.approx(decoded[0], abs=1e-9)
    assert abs((out[3].lon_deg - decoded[1] + 180) % 360 - 180) <= 1e-9  # -180 is 180
    assert out[3].altitude_m == pytest.approx(alt_ft * FT)


def test_our_nl_is_the_standards_nl():
    for k in range(0, 900):
        lat = k * 0.1 + 0.05
        assert cpr_nl(lat) == cprNL(lat) == cpr_nl(-lat)


speeds = st.floats(min_value=-1000 * KT, max_value=1000 * KT, allow_nan=False)


@settings(max_examples=300)
@given(ve=speeds, vn=speeds, vu=st.floats(min_value=-160.0, max_value=160.0), nacv=st.integers(0, 4))
def test_velocities_we_encode_decode_with_pymodes_to_the_knot_and_64_fpm(ve, vn, vu, nacv):
    message = df17(0x4CA7B4, airborne_velocity_me(ve, vn, vu, nacv))
    decoded = pms.decode(message.hex())
    e_kt, n_kt = round(ve / KT), round(vn / KT)
    assert decoded["crc_valid"] and decoded["subtype"] == 1 and decoded["nac_v"] == nacv
    assert decoded["groundspeed"] == int(math.sqrt(e_kt**2 + n_kt**2))
    if e_kt or n_kt:
        assert decoded["track"] == pytest.approx(math.degrees(math.atan2(e_kt, n_kt)) % 360)
    assert decoded["vertical_rate"] == round(vu / FPM / 64) * 64
    out, _, _ = decode_stream(beast_frame(message, 77))
    (obs,) = out
    assert obs.velocity_en_mps == pytest.approx((e_kt * KT, n_kt * KT))
    assert abs(obs.velocity_en_mps[0] - ve) <= 0.5 * KT + 1e-9 and abs(obs.velocity_en_mps[1] - vn) <= 0.5 * KT + 1e-9
    assert obs.vertical_rate_mps == pytest.approx(decoded["vertical_rate"] * FPM)
    assert obs.nacv == (nacv or None)


@given(callsign=st.text(alphabet="ABCDEFGHIJKLMNOPQRSTUVWXYZ0123456789", min_size=1, max_size=8),
       emitter=st.sampled_from(sorted(EMITTER_CATEGORY)))
def test_callsigns_and_categories_we_encode_decode_with_pymodes(callsign, emitter):
    message = df17(0x89ABCD, identification_me(callsign, emitter))
    decoded = pms.decode(message.hex())
    assert decoded["crc_valid"] and decoded["callsign"] == callsign
    tc, category = EMITTER_CATEGORY[emitter]
    assert (decoded["typecode"], decoded["category"]) == (tc, category)
    out, _, _ = decode_stream(beast_frame(message, 5))
    assert out[0].callsign == callsign and out[0].emitter_type == EMITTER_TYPE.get((tc, category), 0) == emitter


@given(nacp=st.integers(0, 11), version=st.integers(0, 2), nic_a=st.integers(0, 1))
def test_operational_status_we_encode_decodes_with_pymodes(nacp, version, nic_a):
    decoded = pms.decode(df17(0x400000, operational_status_me(nacp, version, nic_a)).hex())
    assert decoded["crc_valid"] and (decoded["nac_p"], decoded["version"]) == (nacp, version)
    assert decoded["nic_supplement_a"] == nic_a


@given(payload=st.binary(min_size=11, max_size=11), bit=st.integers(0, 111))
def test_our_parity_is_pymodes_and_a_flipped_bit_fails_it(payload, bit):
    payload = bytes([0x8D]) + payload[1:]
    message = payload + crc24(payload).to_bytes(3, "big")
    assert pms.decode(message.hex())["crc_valid"] is True
    flipped = (int.from_bytes(message, "big") ^ (1 << bit)).to_bytes(14, "big")
    if flipped[0] >> 3 in (17, 18):
        assert pms.decode(flipped.hex())["crc_valid"] is False


def test_type_code_of_every_nic_round_trips():
    for nic, tc in NIC_TYPE_CODE.items():
        decoded = pms.decode(df17(0x1, airborne_position_me(10.0, 10.0, 1000, False, nic=nic)).hex())
        assert decoded["typecode"] == tc and nic_of_type_code(tc, 2, 0, 0) == nic


# --- the deframer -----------------------------------------------------------------------------------------------
def _squitter(i: int) -> bytes:
    """A valid DF17 whose bytes and timestamp contain 0x1a often (escapes exercised)."""
    return df17(0x1A1A00 | (i & 0xFF), airborne_velocity_me(26.0 * (i % 7), -13.0, 0.0))


garbage = st.one_of(
    st.binary(max_size=40),
    st.lists(st.sampled_from([b"\x1a", b"1", b"2", b"3", b"\x1a\x1a", b"\x00", b"\xff"]), max_size=12).map(b"".join),
    st.integers(0, 40).map(lambda i: beast_frame(_squitter(i), 0x1A1A1A1A1A1A)[:max(1, i % 25)]),  # truncated frame
    st.integers(0, 40).map(lambda i: beast_frame(_squitter(i)[:10] + b"\x1a\x1a\x1a\x00", 7)),  # bad parity
)


@settings(max_examples=300)
@given(items=st.lists(st.tuples(st.integers(0, 200), garbage), min_size=1, max_size=12),
       cuts=st.lists(st.integers(0, 400), max_size=8), mode_ac=st.booleans())
def test_garbage_between_frames_never_costs_a_valid_frame(items, cuts, mode_ac):
    stream, expected = b"", []
    for i, (n, junk) in enumerate(items):
        stream += junk
        if mode_ac and i % 3 == 0:
            stream += beast_frame(bytes([0x1A, 0x1A]), 0x1A0000 + i)  # a Mode A/C frame: not used, costs nothing
        message = _squitter(n)
        expected.append(message)
        stream += beast_frame(message, 0x1A1A00000000 + n, signal=0x1A)
    counters = Counter()
    deframer = BeastDeframer(counters)
    got = []
    points = sorted({c % (len(stream) + 1) for c in cuts} | {0, len(stream)})
    for a, b in zip(points, points[1:]):  # TCP reads split anywhere
        got += deframer.feed(stream[a:b])
    squitters = [f.message for f in got if f.kind == 0x33 and f.message[0] >> 3 == 17]
    assert squitters == expected
    assert all(f.signal == 0x1A for f in got if f.kind == 0x33 and f.message in expected)


def test_a_split_frame_waits_for_its_rest_and_a_lone_escape_before_a_frame_is_garbage():
    counters = Counter()
    deframer = BeastDeframer(counters)
    frame = beast_frame(_squitter(3), 0x1A1A1A1A1A1A)
    assert deframer.feed(frame[:9]) == [] and deframer.feed(frame[9:-1]) == []
    (got,) = deframer.feed(frame[-1:])
    assert got.message == _squitter(3) and got.ticks == 0x1A1A1A1A1A1A
    # "1a 33 .. 1a" garbage whose last 0x1a pairs with the next frame's start as an escape
    junk = b"\x1a\x33\x01\x02\x1a"
    got = deframer.feed(junk + frame)
    assert [f.message for f in got if f.message[0] >> 3 == 17] == [_squitter(3)]
    # the garbage candidate parses as a long reply (DF 3) whose parity cannot be checked: passed on, and the decoder
    # counts it as a reply it does not use; it did not cost the squitter after it
    assert counters["traffic.beast.frames"] == 3


def test_a_frame_with_a_bad_parity_is_counted():
    counters = Counter()
    bad = bytearray(_squitter(1))
    bad[6] ^= 0x10
    assert BeastDeframer(counters).feed(beast_frame(bytes(bad), 1) + beast_frame(_squitter(2), 2))[0].message == \
        _squitter(2)
    assert counters["traffic.beast.crc_failed"] == 1


def test_frame_fields():
    frame = BeastDeframer(Counter()).feed(beast_frame(_squitter(0), 0x0102030405, signal=0x99))[0]
    assert frame == BeastFrame(0x33, 0x0102030405, 0x99, _squitter(0))


# --- robustness ---------------------------------------------------------------------------------------------------
@settings(max_examples=500)
@given(messages=st.lists(st.tuples(st.sampled_from([17, 18]), st.integers(0, 7), st.integers(0, 2**24 - 1),
                                   st.integers(0, 2**56 - 1)), min_size=1, max_size=30),
       gaps=st.lists(st.floats(0.0, 20.0), min_size=30, max_size=30))
def test_any_squitter_with_a_valid_parity_decodes_without_raising_into_a_plausible_report(messages, gaps):
    """Random ME fields (every type code, subtype and value) of a few addresses, parity made valid: the parser never
    raises and every report it makes passes the merge's checks (positions on the globe, speeds in range)."""
    from avionics.config import load_config
    from avionics.io.feeds.beast import BeastParser

    config = load_config()
    counters = Counter()
    parser = BeastParser("beast:h:1", config, counters)
    t, reports = 0.0, []
    for (df, ca, address, me), gap in zip(messages, gaps):
        data = (((df << 3 | ca) << 24 | (address & 0x3)) << 56 | me).to_bytes(11, "big")
        t += gap
        reports += parser.feed(beast_frame(data + crc24(data).to_bytes(3, "big"), int(t * CLOCK_HZ) + 1), t + 0.1)
    assert not counters["traffic.beast.decode_errors"]
    for r in reports:
        assert abs(r.lat_deg) <= 90 and abs(r.lon_deg) <= 180
        assert r.velocity_en_mps is None or math.hypot(*r.velocity_en_mps) <= config.input.max_ground_speed_mps


def test_emitter_categories_map_as_readsbs_category_letters():
    """A (type code, category) of TC 1-4 is readsb's category letter and digit (TC 4 = set A ... TC 1 = set D): the
    Beast and readsb-json paths give an aircraft the same emitter type."""
    from avionics.io.feeds.aircraft import emitter_type_of_category

    for (tc, category), emitter in EMITTER_TYPE.items():
        letters = emitter_type_of_category(f"{'DCBA'[tc - 1]}{category}")
        assert letters in (emitter, None) and (letters is not None or (tc, category) in ((2, 4), (2, 5)))


@pytest.mark.parametrize("spec", ["beast:localhost", "beast:127.0.0.1:0", "beast:127.0.0.1:x", "beast::30005"])
def test_a_malformed_beast_spec_is_a_configuration_error_before_anything_connects(spec):
    from avionics.config import ConfigError, load_config
    from avionics.io.feeds.source import open_feed

    with pytest.raises(ConfigError, match="HOST:PORT"):
        open_feed(spec, load_config(), clock=lambda: 0.0)


def test_a_second_position_stream_under_a_heard_aircrafts_address_cannot_take_its_reference():
    """Forged messages at 48.8 N, consistent among themselves (a pair, then both formats), interleaved with the real
    aircraft's at 47.3 N: the forged candidate is confirmed but contested (the real messages keep confirming the
    reference), and no forged position is ever used."""
    def pos(lat, odd):
        return df17(0x123456, airborne_position_me(lat, 8.5, 5000, odd=odd)).hex()

    hexes = [pos(47.3, i % 2 == 1) for i in range(4)]
    for i in range(12):
        hexes += [pos(48.8, i % 2 == 1), pos(47.3, i % 2 == 1)]
    data = b"".join(beast_frame(bytes.fromhex(h), 1000 + int(i * 0.25 * CLOCK_HZ)) for i, h in enumerate(hexes))
    out, counters, _ = decode_stream(data, received=lambda i: 0.25 * i)
    assert {round(o.lat_deg, 3) for o in out if o is not None} == {47.3}
    assert sum(o is not None for o in out[4:]) == 12  # every real message after the lock
    assert counters["traffic.beast.cpr_global"] == 1 and counters["traffic.beast.cpr_contested"] >= 1


def test_random_crc_valid_positions_under_an_aircrafts_address_never_give_a_position():
    """600 junk positions (random ME of TC 9-18, valid parity) around a real aircraft flying north at 200 m/s: every
    position used is the aircraft's (within the CPR quantum and 1 m of its motion)."""
    rng = random.Random(7)
    frames, truth = [], []
    for k in range(80):  # the aircraft: 2 Hz, even and odd alternating
        t = 0.5 * k
        lat = 47.3 + 200.0 * t / 111_195.0
        frames.append((t, df17(0x123456, airborne_position_me(lat, 8.5, 5000, odd=k % 2 == 1))))
        truth.append(lat)
    frames += [(rng.uniform(0.0, 40.0), df17(0x123456, rng.randint(9, 18) << 51 | rng.getrandbits(51)))
               for _ in range(600)]
    frames.sort(key=lambda f: f[0])
    data = b"".join(beast_frame(m, 1000 + int(t * CLOCK_HZ)) for t, m in frames)
    out, counters, _ = decode_stream(data, received=lambda i: frames[i][0])
    used = [(frames[i][0], o) for i, o in enumerate(out) if o is not None]
    assert len(used) >= 75  # every real message from the fourth on
    for t, o in used:
        lat = 47.3 + 200.0 * t / 111_195.0
        assert o.lat_deg == pytest.approx(lat, abs=CPR_QUANTUM_LAT_DEG + 1e-5)
        assert o.lon_deg == pytest.approx(8.5, abs=1e-4)
    assert counters["traffic.beast.cpr_implausible"] > 500 and counters["traffic.beast.cpr_global"] == 1
