"""Receiver feeds without sockets (avionics/io/feeds/): the per-aircraft merge and its checks, the NACp/NACv
tables, the receiver clock alignment, the SBS and readsb-json parsers, and garbage interleaved with valid input
(hypothesis): every bad line is counted and never costs the next valid one."""

from __future__ import annotations

import json
import math
from collections import Counter

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from avionics.config import ConfigError, load_config
from avionics.base.types import AddressSource, AltitudeDatum
from avionics.io.feeds.aircraft import (
    NACP_EPU_M, AircraftMerge, Observation, emitter_type_of_category, nacp_sigma_m, nacv_sigma_mps,
)
from avionics.io.feeds.clock import ReceiverClock
from avionics.io.feeds.readsb_json import ReadsbParser
from avionics.io.feeds.sbs import SbsParser, receiver_time_s
from avionics.io.feeds.source import parse_host_port, parse_spec
from avionics.io.feeds.transport import LineSplitter
from avionics.tracking.integrity import position_sigma_per_axis

CONFIG = load_config(None, ["vehicle.own_icao=0xABCDEF"])
SBS = "sbs:127.0.0.1:30003"


def merge(counters=None):
    counters = counters if counters is not None else Counter()
    return AircraftMerge(SBS, CONFIG, counters), counters


# --- the merge ---------------------------------------------------------------------------------------------------

def test_partial_messages_merge_into_one_report_with_recent_fields():
    m, c = merge()
    assert m.observe(Observation(0xA10001, 10.0, 10.1, velocity_en_mps=(3.0, 4.0), vertical_rate_mps=-2.0)) is None
    assert m.observe(Observation(0xA10001, 10.2, 10.3, callsign="HEADON", squawk=7700)) is None
    r = m.observe(Observation(0xA10001, 10.5, 10.6, lat_deg=47.5, lon_deg=8.5, altitude_m=900.0,
                              altitude_datum=AltitudeDatum.PRESSURE))
    assert r is not None and r.key.address == 0xA10001 and r.key.source is AddressSource.ES1090
    assert (r.time_s, r.received_s, r.velocity_en_mps, r.vertical_rate_mps) == (10.5, 10.6, (3.0, 4.0), -2.0)
    assert (r.callsign, r.squawk, r.altitude_m, r.altitude_datum) == ("HEADON", 7700, 900.0, AltitudeDatum.PRESSURE)
    assert r.path == SBS and (r.position_sigma_m, r.velocity_sigma_mps) == CONFIG.traffic.default_sigmas("sbs")
    # a velocity older than traffic.merge_max_age_s is not merged; the callsign stays
    r = m.observe(Observation(0xA10001, 10.0 + CONFIG.traffic.merge_max_age_s + 0.1, 14.0, lat_deg=47.5, lon_deg=8.6))
    assert r.velocity_en_mps is None and r.vertical_rate_mps is None and r.callsign == "HEADON"
    assert c["traffic.sbs.reports"] == 2


@pytest.mark.parametrize("obs, reason", [
    (dict(lat_deg=91.0, lon_deg=8.0), "lat_out_of_range"),
    (dict(lat_deg=47.0, lon_deg=181.0), "lon_out_of_range"),
    (dict(lat_deg=0.0, lon_deg=0.0), "null_position"),
    (dict(lat_deg=math.nan, lon_deg=8.0), "position_invalid"),
    (dict(lat_deg=47.0), "position_invalid"),
])
def test_a_bad_position_makes_no_report_and_is_counted(obs, reason):
    m, c = merge()
    assert m.observe(Observation(0xA10001, 1.0, 1.0, **obs)) is None
    assert c == Counter({f"traffic.sbs.rejected.{reason}": 1})


@pytest.mark.parametrize("field, value, reason", [
    ("velocity_en_mps", (400.0, 0.0), "speed_out_of_range"),  # input.max_ground_speed_mps 350
    ("velocity_en_mps", (math.inf, 0.0), "velocity_invalid"),
    ("vertical_rate_mps", 150.0, "vertical_rate_out_of_range"),  # input.max_vertical_rate_mps 100
    ("altitude_m", 25000.0, "altitude_out_of_range"),  # input.max_altitude_m 20000
    ("callsign", "NOT\x07OK", "callsign_invalid"),
    ("squawk", 7800, "squawk_invalid"),
    ("emitter_type", 99, "emitter_type_invalid"),
    ("nacp", 12, "nacp_invalid"),
])
def test_a_bad_field_is_dropped_and_counted_the_position_still_reported(field, value, reason):
    m, c = merge()
    extra = {"altitude_datum": AltitudeDatum.PRESSURE} if field == "altitude_m" else {}
    r = m.observe(Observation(0xA10001, 1.0, 1.0, lat_deg=47.0, lon_deg=8.0, **{field: value}, **extra))
    assert r is not None and c[f"traffic.sbs.rejected.{reason}"] == 1 and c["traffic.sbs.reports"] == 1


def test_own_address_stale_and_repeated_positions_are_rejected():
    m, c = merge()
    assert m.observe(Observation(0xABCDEF, 1.0, 1.0, lat_deg=47.0, lon_deg=8.0)) is None  # vehicle.own_icao
    assert m.observe(Observation(0x1000000, 1.0, 1.0, lat_deg=47.0, lon_deg=8.0)) is None
    assert m.observe(Observation(0xA10001, 1.0, 1.0 + CONFIG.input.max_report_age_s + 0.1, lat_deg=47.0,
                                 lon_deg=8.0)) is None
    assert m.observe(Observation(0xA10001, 5.0, 5.0, lat_deg=47.0, lon_deg=8.0)) is not None
    assert m.observe(Observation(0xA10001, 5.0, 5.5, lat_deg=47.0, lon_deg=8.0)) is None
    assert m.observe(Observation(0xA10001, 5.0, 6.0, address_source=AddressSource.UAT, lat_deg=47.0,
                                 lon_deg=8.0)) is not None  # another address source: another aircraft
    assert c == Counter({"traffic.sbs.rejected.own_address": 1, "traffic.sbs.rejected.address_out_of_range": 1,
                         "traffic.sbs.rejected.stale": 1, "traffic.sbs.rejected.not_newer": 1,
                         "traffic.sbs.reports": 2})


def test_nacp_and_nacv_tables_give_the_reports_accuracy():
    # DO-260B Table 2-70: NACp 11 < 3 m ... 5 < 926 m (0.5 NM); NACv Table 2-22: 1 < 10 m/s ... 4 < 0.3 m/s
    assert [NACP_EPU_M[n] for n in (11, 10, 9, 8, 7, 6, 5)] == [3.0, 10.0, 30.0, 92.6, 185.2, 555.6, 926.0]
    assert nacp_sigma_m(9) == pytest.approx(30.0 / 2.4477, rel=1e-4) == position_sigma_per_axis(30.0)
    assert nacp_sigma_m(0) is None and nacp_sigma_m(None) is None and nacv_sigma_mps(0) is None
    assert nacv_sigma_mps(2) == pytest.approx(3.0 / 2.4477, rel=1e-4)
    m, _ = merge()
    m.observe(Observation(0xA10001, 1.0, 1.0, nacp=10, nacv=3))
    r = m.observe(Observation(0xA10001, 1.5, 1.5, lat_deg=47.0, lon_deg=8.0))
    assert r.position_sigma_m == position_sigma_per_axis(10.0) and r.velocity_sigma_mps == position_sigma_per_axis(1.0)
    assert emitter_type_of_category("A7") == 7 and emitter_type_of_category("B6") == 14
    assert emitter_type_of_category("Z9") is None


def test_bounded_memory_under_address_churn(monkeypatch):
    import avionics.io.feeds.aircraft as aircraft

    monkeypatch.setattr(aircraft, "MAX_AIRCRAFT", 10)
    m, c = merge()
    for a in range(20):
        m.observe(Observation(a + 1, 1.0, 1.0, lat_deg=47.0, lon_deg=8.0))
    assert len(m) == 10 and c["traffic.sbs.rejected.too_many_aircraft"] == 10
    m.observe(Observation(100, 200.0, 200.0, lat_deg=47.0, lon_deg=8.0))  # the others are forgotten after 60 s
    assert len(m) == 1


# --- the clock -----------------------------------------------------------------------------------------------------

def test_clock_takes_the_lower_envelope_and_is_never_later_than_receipt():
    clock = ReceiverClock(window_s=60.0)
    offset = 1000.0  # receiver clock = ours - 1000 s
    delays = [0.30, 0.05, 0.20, 0.10, 0.40, 0.05]
    for i, d in enumerate(delays):
        t = clock.align(100.0 + i - offset, 100.0 + i + d)
        assert t <= 100.0 + i + d
    assert clock.offset_s == pytest.approx(offset + 0.05)
    assert clock.align(None, 123.0) == 123.0


@settings(max_examples=300, deadline=None)
@given(st.lists(st.floats(0.0, 0.9), min_size=2, max_size=60), st.floats(0.05, 1.0))
def test_clock_keeps_one_receivers_messages_in_order_when_its_envelope_drops(delays, spacing_s):
    """Messages sent every spacing_s, each read after its own delay (a busy reader: long delays, then short ones,
    the envelope dropping by more than the spacing): mapped times keep the order the receiver sent them in and
    never pass their receipt; once the delays stay at their least, the mapping is the envelope's (the slew done).
    Reads are in order of receipt, as from one socket."""
    clock = ReceiverClock(window_s=60.0)
    offset = 1000.0
    received = np.maximum.accumulate([i * spacing_s + d for i, d in enumerate(delays)])  # one socket: in order
    out = [clock.align(i * spacing_s - offset, r) for i, r in enumerate(received)]
    assert all(t <= r for t, r in zip(out, received))
    # the same receipt can hold several messages (one batch): those may share it, no others may tie or cross
    assert all(b > a or rb == ra and b == rb for a, b, ra, rb in zip(out, out[1:], received, received[1:]))
    n, least = len(delays), min(delays)
    settle = [clock.align((n + k) * spacing_s - offset, (n + k) * spacing_s + least)
              for k in range(int(2.0 / spacing_s) + 4)]
    assert settle[-1] == pytest.approx((n + len(settle) - 1) * spacing_s + least, abs=1e-9)


def test_clock_window_forgets_old_floors_and_a_step_restarts_it():
    clock = ReceiverClock(window_s=10.0)
    clock.align(0.0, 0.01)  # a fast one early ...
    for i in range(1, 20):
        clock.align(float(i), i + 0.2)
    assert clock.offset_s == pytest.approx(0.2)  # ... out of the window now
    t = clock.align(100.0, 25.0)  # the receiver's clock stepped 75 s ahead
    assert clock.steps == 1 and t == pytest.approx(25.0)


def test_clock_unwraps_a_wrapping_counter():
    wrap = 2**48 / 12e6  # Beast: a 12 MHz counter in 48 bits
    clock = ReceiverClock(wrap_s=wrap)
    t1 = clock.align(wrap - 0.5, 10.0)
    t2 = clock.align(0.5, 11.0)  # wrapped
    assert t2 - t1 == pytest.approx(1.0)


# --- SBS -----------------------------------------------------------------------------------------------------------

def msg(kind, t="12:00:00.000", hex_="A10001", **f):
    fields = ["MSG", str(kind), "1", "1", hex_, "1", "2024/06/01", t, "2024/06/01", t] + [""] * 12
    names = {"callsign": 10, "alt": 11, "gs": 12, "track": 13, "lat": 14, "lon": 15, "rate": 16, "squawk": 17,
             "ground": 21}
    for k, v in f.items():
        fields[names[k]] = str(v)
    return ",".join(fields).encode()


def test_sbs_lines_to_reports_in_si_units():
    c = Counter()
    p = SbsParser(SBS, CONFIG, c)
    assert p.line(msg(4, gs=100, track=90, rate=-1000), 5.0) is None
    assert p.line(msg(1, callsign="HEADON  "), 5.0) is None
    r = p.line(msg(3, "12:00:00.500", alt=3000, lat=47.5, lon=8.5), 5.5)
    assert r.velocity_en_mps == pytest.approx((100 * 1852 / 3600, 0.0), abs=1e-9)
    assert r.vertical_rate_mps == pytest.approx(-1000 * 0.3048 / 60)
    assert r.altitude_m == pytest.approx(914.4) and r.altitude_datum is AltitudeDatum.PRESSURE
    assert r.callsign == "HEADON" and r.time_s <= r.received_s == 5.5
    assert receiver_time_s("2024/06/01", "12:00:00.5") - receiver_time_s("2024/06/01", "11:59:59") == 1.5
    for line in (b"", b"STA,,,", b"AIR,,1", b"MSG,3", msg(3, hex_="~A10001", lat=1, lon=1), msg(9),
                 msg(3, hex_="XYZ123"), msg(3, lat="north", lon=8)):
        assert p.line(line, 6.0) is None
    assert c["traffic.sbs.rejected.malformed"] == 4 and c["traffic.sbs.ignored"] == 2
    assert c["traffic.sbs.rejected.non_icao_address"] == 1 and c["traffic.sbs.lines"] == 11


def test_line_splitter_keeps_partial_lines_and_drops_overlong_ones():
    s = LineSplitter(10)
    assert s.feed(b"abc\r\nde") == [b"abc"]
    assert s.feed(b"f\n" + b"x" * 30) == [b"def"]
    assert s.feed(b"yyy\nok\n") == [b"ok"] and s.too_long == 1


# --- readsb-json ---------------------------------------------------------------------------------------------------

def aircraft_json(now, **entry):
    base = {"hex": "a10001", "flight": "HEADON  ", "alt_baro": 3000, "gs": 100.0, "track": 180.0,
            "baro_rate": 0, "lat": 47.5, "lon": 8.5, "squawk": "1200", "category": "A1", "nac_p": 10, "nac_v": 2,
            "nic": 8, "seen_pos": 0.3, "seen": 0.1}
    base.update(entry)
    return json.dumps({"now": now, "messages": 1, "aircraft": [base]}).encode()


def test_readsb_document_to_reports_with_nac_and_no_repeat():
    c = Counter()
    p = ReadsbParser("readsb-json:/run/readsb/aircraft.json", CONFIG, c)
    (r,) = p.document(aircraft_json(1.7e9), 10.0)
    assert r.position_sigma_m == position_sigma_per_axis(10.0) and r.velocity_sigma_mps == position_sigma_per_axis(3.0)
    assert r.emitter_type == 1 and r.squawk == 1200 and r.callsign == "HEADON" and r.time_s <= 10.0
    assert p.document(aircraft_json(1.7e9 + 1.0, seen_pos=1.3, seen=0.2), 11.0) == []  # the same position
    assert c["traffic.readsb-json.unchanged"] == 1
    (r2,) = p.document(aircraft_json(1.7e9 + 5.0, lat=47.49, nac_p=0, alt_baro="ground"), 15.0)
    assert r2.position_sigma_m == CONFIG.traffic.readsb_position_sigma_m and r2.altitude_m is None
    assert p.document(b"{not json", 13.0) == [] and p.document(b'{"now": 1, "aircraft": 3}', 13.0) == []
    assert p.document(json.dumps({"now": 1.7e9 + 3, "aircraft": [7, {"hex": "~abc123", "lat": 1, "lon": 1},
                                                                  {"hex": "a10001", "lat": "x", "lon": 8}]}).encode(),
                      14.0) == []
    assert c["traffic.readsb-json.rejected.malformed_json"] == 2 and c["traffic.readsb-json.rejected.malformed"] == 1
    assert c["traffic.readsb-json.rejected.non_icao_address"] == 1
    assert c["traffic.readsb-json.rejected.position_invalid"] == 1


# --- specs and configuration ---------------------------------------------------------------------------------------

def test_specs_and_traffic_config_are_checked():
    assert parse_spec("sbs:127.0.0.1:30003") == ("sbs", "127.0.0.1:30003")
    assert parse_spec("readsb-json:http://127.0.0.1:8080/data/aircraft.json")[1].startswith("http://")
    assert parse_host_port("x", "127.0.0.1:30005") == ("127.0.0.1", 30005)
    for bad in ("sbs", "nmea:1.2.3.4:1", "sbs:"):
        with pytest.raises(ConfigError):
            parse_spec(bad)
    with pytest.raises(ConfigError):
        parse_host_port("sbs:host", "host")
    with pytest.raises(ConfigError, match="traffic.reconnect_max_s"):
        load_config(None, ["traffic.reconnect_max_s=0.1"])
    with pytest.raises(ConfigError, match="traffic.sbs_position_sigma_m"):
        load_config(None, ["traffic.sbs_position_sigma_m=0"])


# --- garbage never costs the next valid line (property) ------------------------------------------------------------

GARBAGE = st.one_of(
    st.binary(max_size=200).map(lambda b: b.replace(b"\n", b"")),
    st.lists(st.text(alphabet=st.characters(codec="ascii", exclude_characters="\n"), max_size=12),
             min_size=1, max_size=25).map(lambda xs: ",".join(xs).encode()),
    st.builds(lambda n, x: msg(3, lat=x, lon=x).replace(b",", b";", n % 3), st.integers(0, 5), st.floats()),
)


@settings(max_examples=150)
@given(st.lists(st.lists(GARBAGE, max_size=3), min_size=1, max_size=12))
def test_sbs_garbage_between_valid_lines_never_costs_a_valid_line(garbage):
    c = Counter()
    p = SbsParser(SBS, CONFIG, c)
    splitter = LineSplitter(512)
    stream = b""
    for i, junk in enumerate(garbage):
        stream += b"".join(j + b"\r\n" for j in junk)
        valid = msg(3, "", hex_="B00001", alt=3000, lat=47.0 + i * 1e-3, lon=8.0)  # no receiver time: receipt's
        stream += valid.replace(b"2024/06/01,,", b",,") + b"\r\n"
    reports = []
    for k in range(0, len(stream), 7):  # in small TCP-like chunks, each later than the last
        for line in splitter.feed(stream[k:k + 7]):
            r = p.line(line, 100.0 + k * 1e-3)
            if r is not None and r.key.address == 0xB00001:
                reports.append(r)
    assert [round(r.lat_deg, 6) for r in reports] == [round(47.0 + i * 1e-3, 6) for i in range(len(garbage))]


@settings(max_examples=100)
@given(st.lists(st.one_of(st.binary(max_size=100), st.recursive(
    st.none() | st.booleans() | st.floats() | st.integers() | st.text(max_size=8),
    lambda inner: st.lists(inner, max_size=4) | st.dictionaries(st.sampled_from(
        ["now", "aircraft", "hex", "lat", "lon", "seen_pos", "alt_baro", "gs", "track", "nac_p", "squawk"]), inner,
        max_size=6), max_leaves=20).map(lambda d: json.dumps(d).encode())), max_size=5))
def test_readsb_garbage_documents_never_cost_the_next_valid_one(garbage):
    c = Counter()
    p = ReadsbParser("readsb-json:aircraft.json", CONFIG, c)
    for i, junk in enumerate(garbage):
        p.document(junk, 10.0 + i)
    now = 10.0 + len(garbage)
    reports = p.document(aircraft_json(2e9, hex="c00001", lat=46.0), now)
    assert [r.key.address for r in reports] == [0xC00001]


# --- one bad readsb entry costs only itself (issue 25) -------------------------------------------------------------

HUGE = int("9" * 400)  # a JSON integer of 400 digits: beyond a float (float(), math.isfinite() raise OverflowError)


def test_a_400_digit_number_or_a_unicode_digit_squawk_costs_only_its_entry():
    """Before: document() raised out (OverflowError, ValueError from int("²")), every poll failed and no aircraft
    of the receiver was delivered while `reports` counted them."""
    c = Counter()
    p = ReadsbParser("readsb-json:aircraft.json", CONFIG, c)
    good = {"hex": "c00001", "lat": 47.0, "lon": 8.0, "alt_baro": 3000, "seen_pos": 0.2, "seen": 0.1}
    bad = [dict(good, hex="c00002", alt_baro=HUGE), dict(good, hex="c00003", squawk="²"),
           dict(good, hex="c00004", lat=HUGE), dict(good, hex="c00005", baro_rate=-HUGE, gs=HUGE, track=1),
           dict(good, hex="c00006", seen_pos=HUGE, seen=HUGE), dict(good, hex="c00007", squawk="7" * 5000)]
    reports = p.document(json.dumps({"now": 1.7e9, "aircraft": [*bad[:3], good, *bad[3:]]}).encode(), 10.0)
    by_address = {r.key.address: r for r in reports}
    assert by_address[0xC00001].altitude_m == pytest.approx(3000 * 0.3048)
    # each bad field dropped and counted, the rest of its entry used
    assert by_address[0xC00002].altitude_m is None and by_address[0xC00003].squawk is None
    assert 0xC00004 not in by_address and by_address[0xC00005].velocity_en_mps is None
    assert c["traffic.readsb-json.rejected.altitude_out_of_range"] == 1
    assert c["traffic.readsb-json.rejected.squawk_invalid"] == 2
    assert c["traffic.readsb-json.rejected.position_invalid"] == 1
    assert c["traffic.readsb-json.rejected.velocity_invalid"] == 1
    assert c["traffic.readsb-json.rejected.vertical_rate_out_of_range"] == 1
    assert c["traffic.readsb-json.reports"] == len(reports) == 6  # counted = delivered
    assert not c["traffic.readsb-json.decode_errors"]
    # a 400-digit `now` is a document without a time: positions at their receipt
    (r,) = p.document(json.dumps({"now": HUGE, "aircraft": [dict(good, lat=47.1)]}).encode(), 11.0)
    assert r.time_s == 11.0


JSON_VALUE = st.recursive(
    st.none() | st.booleans() | st.floats() | st.integers() | st.just(HUGE) | st.just(-HUGE)
    | st.text(max_size=6) | st.sampled_from(["²", "٣٤", "1e400", "ground", "7700", "~a1"]),
    lambda inner: st.lists(inner, max_size=3) | st.dictionaries(st.text(max_size=4), inner, max_size=3),
    max_leaves=8)
FIELDS = ["hex", "flight", "alt_baro", "gs", "track", "baro_rate", "geom_rate", "lat", "lon", "squawk", "category",
          "nac_p", "nac_v", "nic", "seen_pos", "seen"]


@settings(max_examples=200)
@given(st.lists(st.dictionaries(st.sampled_from(FIELDS), JSON_VALUE, max_size=6), max_size=6),
       st.integers(0, 6), st.one_of(st.none(), st.floats(0.0, 4e9), st.just(HUGE), st.text(max_size=4)))
def test_any_mutated_entry_beside_a_good_aircraft_never_costs_it(mutations, position, now):
    """Entries of a good aircraft with any fields replaced by any JSON value, in one document with a good one:
    document() never raises and the good aircraft is always delivered, counted once. (`now` is the document's, not
    an entry's: any POSIX time, or none usable; a `now` of 1e17 s makes every position stale, rightly.)"""
    c = Counter()
    p = ReadsbParser("readsb-json:aircraft.json", CONFIG, c)
    base = {"hex": "c00002", "lat": 46.0, "lon": 7.0, "alt_baro": 3000, "gs": 100, "track": 90, "squawk": "1200",
            "seen_pos": 0.2, "seen": 0.1}
    entries = [dict(base, **m) for m in mutations]
    entries.insert(min(position, len(entries)), {"hex": "c00001", "lat": 47.0, "lon": 8.0, "seen_pos": 0.2})
    reports = p.document(json.dumps({"now": 1.7e9 if now is None else now, "aircraft": entries}).encode(), 10.0)
    assert [r.key.address for r in reports].count(0xC00001) == 1
    assert c["traffic.readsb-json.reports"] == len(reports) and not c["traffic.readsb-json.decode_errors"]
