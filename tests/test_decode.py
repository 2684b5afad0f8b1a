"""MessageDecoder on real pymavlink frames: every invalid flag, sentinel and out-of-range value of ADSB_VEHICLE,
GLOBAL_POSITION_INT and SCALED_PRESSURE is rejected under its own counter, exactly once, and valid fields come
out in SI units. End to end: the onboard process fed only invalid reports of a threatening intruder never alerts."""

from __future__ import annotations

import dataclasses
import math
from collections import Counter

import avionics.io  # noqa: F401  (MAVLINK20=1 before pymavlink is imported)
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from pymavlink.dialects.v20 import common as m2

from avionics.config import Config, InputConfig, VehicleConfig
from avionics.base.atmosphere import pressure_hpa_at
from avionics.base.geodesy import LocalTangentPlane
from avionics.base.types import (
    AddressSource, AdvisoryLevel, AltitudeDatum, IntruderKey, IntruderReport, OwnshipFix, OwnshipPressure,
)
from avionics.base.units import FT, INT16_MAX, INT32_MAX, KT, UINT16_MAX
from avionics.io.decode import MessageDecoder
from avionics.io.framing import FrameScanner
from harness import Harness

NOW = 1000.0
OWN_ICAO = 0xC0FFEE
F = m2  # flag names as MAVLink spells them
ALL_VALID = (F.ADSB_FLAGS_VALID_COORDS | F.ADSB_FLAGS_VALID_ALTITUDE | F.ADSB_FLAGS_VALID_HEADING
             | F.ADSB_FLAGS_VALID_VELOCITY | F.ADSB_FLAGS_VALID_CALLSIGN | F.ADSB_FLAGS_VALID_SQUAWK
             | F.ADSB_FLAGS_VERTICAL_VELOCITY_VALID)

ADSB_DEFAULTS = dict(ICAO_address=0xA1B2C3, lat=473977418, lon=85455939, altitude_type=0, altitude=914400,
                     heading=9000, hor_velocity=10000, ver_velocity=-500, callsign=b"DLH4AB  ", emitter_type=1,
                     tslc=2, flags=ALL_VALID, squawk=7000)
GPI_DEFAULTS = dict(time_boot_ms=123456, lat=473977418, lon=85455939, alt=914400, relative_alt=304800,
                    vx=6430, vy=-1200, vz=150, hdg=0)


def over_the_wire(msg, src_system: int = 1):
    """Encode as a sender would, decode as pymavlink does on receipt."""
    buf = msg.pack(m2.MAVLink(None, srcSystem=src_system, srcComponent=1))
    return m2.MAVLink(None).decode(bytearray(buf))


def adsb(**fields):
    return over_the_wire(m2.MAVLink_adsb_vehicle_message(**{**ADSB_DEFAULTS, **fields}))


def gpi(src_system: int = 1, **fields):
    return over_the_wire(m2.MAVLink_global_position_int_message(**{**GPI_DEFAULTS, **fields}), src_system)


def pressure(press_abs: float, src_system: int = 1):
    return over_the_wire(m2.MAVLink_scaled_pressure_message(1000, press_abs, 0.0, 1500), src_system)


def decode(msg, config: Config | None = None):
    """(decoded input or None, the counters it moved)."""
    counters = Counter()
    out = MessageDecoder(config or Config(), counters).decode(msg, NOW)
    return out, +counters


def config(own_icao: int = 0, **inputs) -> Config:
    return Config(vehicle=VehicleConfig(own_icao=own_icao), input=InputConfig(**inputs))


RX = "rx.adsb_vehicle"
BASELINE, _ = decode(adsb())


# -- ADSB_VEHICLE: valid conversions --------------------------------------------------------------------------
def test_valid_report_converts_every_field_to_si():
    report, moved = decode(adsb())
    assert moved == {RX: 1}
    assert report.key == IntruderKey(0xA1B2C3, AddressSource.ES1090)
    assert report.lat_deg == pytest.approx(47.3977418, abs=1e-9)
    assert report.lon_deg == pytest.approx(8.5455939, abs=1e-9)
    assert report.altitude_m == pytest.approx(914.4)  # 914400 mm = 3000 ft
    assert report.altitude_datum is AltitudeDatum.PRESSURE
    east, north = report.velocity_en_mps  # heading 90.00 deg, 100.00 m/s: due east
    assert east == pytest.approx(100.0) and north == pytest.approx(0.0, abs=1e-9)
    assert report.vertical_rate_mps == pytest.approx(-5.0)  # positive up: -500 cm/s is descending
    assert report.time_s == NOW - 2 and report.received_s == NOW  # tslc 2 back-dates by 2 s
    assert report.callsign == "DLH4AB"
    assert report.squawk == 7000
    assert report.emitter_type == 1 and report.simulated is False


@pytest.mark.parametrize("heading_cdeg, speed_cms, east, north", [
    (0, 10000, 0.0, 100.0), (9000, 10000, 100.0, 0.0), (18000, 10000, 0.0, -100.0), (27000, 5000, -50.0, 0.0),
    (4500, 14142, 100.0, 100.0), (35999, 0, 0.0, 0.0),
])
def test_heading_and_speed_become_east_north_velocity(heading_cdeg, speed_cms, east, north):
    report, _ = decode(adsb(heading=heading_cdeg, hor_velocity=speed_cms))
    assert report.velocity_en_mps == pytest.approx((east, north), abs=1e-2)


def test_geometric_altitude_type_and_simulated_flag():
    report, moved = decode(adsb(altitude_type=1, flags=ALL_VALID | F.ADSB_FLAGS_SIMULATED))
    assert moved == {RX: 1}
    assert report.altitude_datum is AltitudeDatum.GEOMETRIC and report.simulated is True


def test_negative_coordinates_and_extremes_are_valid():
    report, moved = decode(adsb(lat=-90 * 10**7, lon=180 * 10**7))
    assert moved == {RX: 1} and (report.lat_deg, report.lon_deg) == (-90.0, 180.0)
    report, _ = decode(adsb(lat=0, lon=-1))  # one axis at zero is a real place
    assert (report.lat_deg, report.lon_deg) == (0.0, pytest.approx(-1e-7))


# -- ADSB_VEHICLE: report rejected ------------------------------------------------------------------------------
REJECTED = [
    ("address_above_24_bits", {"ICAO_address": 0x1000000}, "adsb.address_out_of_range"),
    ("address_uint32_max", {"ICAO_address": 0xFFFFFFFF}, "adsb.address_out_of_range"),
    ("own_icao_1090es", {"ICAO_address": OWN_ICAO}, "adsb.own_address"),
    ("coords_flag_cleared", {"flags": ALL_VALID & ~F.ADSB_FLAGS_VALID_COORDS}, "adsb.no_position"),
    ("lat_int32_max", {"lat": INT32_MAX}, "adsb.position_sentinel"),
    ("lon_int32_max", {"lon": INT32_MAX}, "adsb.position_sentinel"),
    ("lat_91", {"lat": 91 * 10**7}, "adsb.lat_out_of_range"),
    ("lat_minus_91", {"lat": -91 * 10**7}, "adsb.lat_out_of_range"),
    ("lat_just_above_90", {"lat": 90 * 10**7 + 1}, "adsb.lat_out_of_range"),
    ("lat_int32_min", {"lat": -2**31}, "adsb.lat_out_of_range"),
    ("lon_181", {"lon": 181 * 10**7}, "adsb.lon_out_of_range"),
    ("lon_minus_181", {"lon": -181 * 10**7}, "adsb.lon_out_of_range"),
    ("zero_lat_lon", {"lat": 0, "lon": 0}, "adsb.null_position"),
    ("tslc_255", {"tslc": 255}, "adsb.stale"),
    ("tslc_4_above_3s", {"tslc": 4}, "adsb.stale"),
]


@pytest.mark.parametrize("fields, reason", [c[1:] for c in REJECTED], ids=[c[0] for c in REJECTED])
def test_invalid_report_is_rejected_under_its_own_counter_exactly_once(fields, reason):
    report, moved = decode(adsb(**fields), config(own_icao=OWN_ICAO))
    assert report is None
    assert moved == {RX: 1, reason: 1}


@pytest.mark.parametrize("max_age_s", [3.0, 2.5, 1.0, 10.0])
def test_report_age_just_below_and_just_above_max_report_age(max_age_s):
    cfg = config(max_report_age_s=max_age_s)
    oldest_ok = math.floor(max_age_s)
    report, moved = decode(adsb(tslc=oldest_ok), cfg)
    assert moved == {RX: 1} and report.time_s == NOW - oldest_ok
    report, moved = decode(adsb(tslc=oldest_ok + 1), cfg)
    assert report is None and moved == {RX: 1, "adsb.stale": 1}


def test_uat_report_with_our_1090es_address_is_another_aircraft():
    """Our own ICAO is dropped only when it comes from 1090ES: a UAT address is a different address space."""
    report, moved = decode(adsb(ICAO_address=OWN_ICAO, flags=ALL_VALID | F.ADSB_FLAGS_SOURCE_UAT),
                           config(own_icao=OWN_ICAO))
    assert moved == {RX: 1}
    assert report.key == IntruderKey(OWN_ICAO, AddressSource.UAT)
    assert dataclasses.replace(report, key=BASELINE.key) == BASELINE


def test_without_own_icao_configured_address_zero_is_not_ours():
    report, moved = decode(adsb(ICAO_address=0), config(own_icao=0))
    assert moved == {RX: 1} and report.key.address == 0


# -- ADSB_VEHICLE: one field rejected, report kept --------------------------------------------------------------
ALT, VEL, VRATE = ("altitude_m", "altitude_datum"), ("velocity_en_mps",), ("vertical_rate_mps",)
FIELD_REJECTED = [
    ("altitude_int32_max", {"altitude": INT32_MAX}, "adsb.altitude_sentinel", ALT),
    ("altitude_type_7", {"altitude_type": 7}, "adsb.altitude_type_unknown", ALT),
    ("altitude_type_2", {"altitude_type": 2}, "adsb.altitude_type_unknown", ALT),
    ("altitude_above_max", {"altitude": 20_000_001}, "adsb.altitude_out_of_range", ALT),
    ("altitude_below_min", {"altitude": -500_001}, "adsb.altitude_out_of_range", ALT),
    ("heading_uint16_max", {"heading": UINT16_MAX}, "adsb.velocity_sentinel", VEL),
    ("speed_uint16_max", {"hor_velocity": UINT16_MAX}, "adsb.velocity_sentinel", VEL),
    ("heading_360", {"heading": 36000}, "adsb.heading_out_of_range", VEL),
    ("speed_above_max", {"hor_velocity": 35001}, "adsb.speed_out_of_range", VEL),
    ("vertical_rate_int16_max", {"ver_velocity": INT16_MAX}, "adsb.vertical_rate_sentinel", VRATE),
    ("vertical_rate_above_max", {"ver_velocity": 10001}, "adsb.vertical_rate_out_of_range", VRATE),
    ("vertical_rate_int16_min", {"ver_velocity": -2**15}, "adsb.vertical_rate_out_of_range", VRATE),
    ("callsign_non_ascii", {"callsign": "MÜLLER".encode("latin-1")}, "adsb.callsign_invalid", ("callsign",)),
    ("callsign_utf8", {"callsign": "ÆØÅ1".encode()}, "adsb.callsign_invalid", ("callsign",)),
    ("callsign_control_char", {"callsign": b"AB\x07CD"}, "adsb.callsign_invalid", ("callsign",)),
    ("callsign_empty", {"callsign": b""}, "adsb.callsign_invalid", ("callsign",)),
    ("callsign_blank", {"callsign": b"        "}, "adsb.callsign_invalid", ("callsign",)),
    ("squawk_digit_8", {"squawk": 7780}, "adsb.squawk_invalid", ("squawk",)),
    ("squawk_digit_9", {"squawk": 1290}, "adsb.squawk_invalid", ("squawk",)),
    ("squawk_five_digits", {"squawk": 10000}, "adsb.squawk_invalid", ("squawk",)),
    ("squawk_uint16_max", {"squawk": UINT16_MAX}, "adsb.squawk_invalid", ("squawk",)),
]


@pytest.mark.parametrize("fields, reason, nulled", [c[1:] for c in FIELD_REJECTED], ids=[c[0] for c in FIELD_REJECTED])
def test_invalid_field_is_dropped_alone_and_counted_once(fields, reason, nulled):
    report, moved = decode(adsb(**fields))
    assert moved == {RX: 1, reason: 1}
    assert report == dataclasses.replace(BASELINE, **{name: None for name in nulled})


FLAG_CLEARED = [
    ("altitude", F.ADSB_FLAGS_VALID_ALTITUDE, {"altitude": INT32_MAX, "altitude_type": 9}, ALT),
    ("heading", F.ADSB_FLAGS_VALID_HEADING, {"heading": UINT16_MAX}, VEL),
    ("velocity", F.ADSB_FLAGS_VALID_VELOCITY, {"hor_velocity": UINT16_MAX}, VEL),
    ("vertical_velocity", F.ADSB_FLAGS_VERTICAL_VELOCITY_VALID, {"ver_velocity": INT16_MAX}, VRATE),
    ("callsign", F.ADSB_FLAGS_VALID_CALLSIGN, {"callsign": b"\xff\xfe"}, ("callsign",)),
    ("squawk", F.ADSB_FLAGS_VALID_SQUAWK, {"squawk": UINT16_MAX}, ("squawk",)),
]


@pytest.mark.parametrize("bit, sentinels, nulled", [c[1:] for c in FLAG_CLEARED], ids=[c[0] for c in FLAG_CLEARED])
@pytest.mark.parametrize("with_sentinel", [False, True], ids=["plain", "sentinel"])
def test_flag_cleared_field_is_absent_and_report_still_used(bit, sentinels, nulled, with_sentinel):
    """A field the sender flags unavailable is not an error: nothing counted, even when it holds a sentinel."""
    report, moved = decode(adsb(flags=ALL_VALID & ~bit, **(sentinels if with_sentinel else {})))
    assert moved == {RX: 1}
    assert report == dataclasses.replace(BASELINE, **{name: None for name in nulled})


def test_only_coords_flag_gives_a_position_only_report():
    report, moved = decode(adsb(flags=F.ADSB_FLAGS_VALID_COORDS, altitude=INT32_MAX, heading=UINT16_MAX,
                                hor_velocity=UINT16_MAX, ver_velocity=INT16_MAX, squawk=UINT16_MAX))
    assert moved == {RX: 1}
    assert (report.lat_deg, report.lon_deg) == (BASELINE.lat_deg, BASELINE.lon_deg)
    assert report.altitude_m is report.altitude_datum is report.velocity_en_mps is None
    assert report.vertical_rate_mps is report.callsign is report.squawk is None


# -- ADSB_VEHICLE: properties ---------------------------------------------------------------------------------
def _ints(lo, hi, *special):
    return st.one_of(st.sampled_from([v for v in special if lo <= v <= hi] + [lo, hi]), st.integers(lo, hi))


adsb_fields = st.fixed_dictionaries(dict(
    ICAO_address=_ints(0, 2**32 - 1, 0xFFFFFF, 0x1000000, OWN_ICAO),
    lat=_ints(-2**31, INT32_MAX, 0, 90 * 10**7, -90 * 10**7, 90 * 10**7 + 1),
    lon=_ints(-2**31, INT32_MAX, 0, 180 * 10**7, -180 * 10**7, 180 * 10**7 + 1),
    altitude_type=_ints(0, 255, 1, 2),
    altitude=_ints(-2**31, INT32_MAX, 914400, -500_000, 20_000_000),
    heading=_ints(0, UINT16_MAX, 35999, 36000),
    hor_velocity=_ints(0, UINT16_MAX, 35000, 35001),
    ver_velocity=_ints(-2**15, INT16_MAX, 10000, -10000),
    callsign=st.binary(max_size=9),
    emitter_type=_ints(0, 255),
    tslc=_ints(0, 255, 3, 4),
    flags=st.one_of(st.integers(0, UINT16_MAX), st.sampled_from([ALL_VALID, ALL_VALID | F.ADSB_FLAGS_SOURCE_UAT])),
    squawk=_ints(0, UINT16_MAX, 7777, 7778, 10000),
))


@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(adsb_fields)
def test_any_adsb_vehicle_decodes_without_raising_to_clean_si_values(fields):
    cfg = config(own_icao=OWN_ICAO).input
    report, moved = decode(adsb(**fields), config(own_icao=OWN_ICAO))
    rejections = {k: v for k, v in moved.items() if k != RX}
    assert moved[RX] == 1 and all(k.startswith("adsb.") and v == 1 for k, v in rejections.items())
    if report is None:
        assert len(rejections) == 1  # a dropped report is counted once, under one reason
        return
    assert len(rejections) <= 5  # altitude, velocity, vertical rate, callsign, squawk: at most one each
    assert isinstance(report, IntruderReport)
    numbers = [report.time_s, report.received_s, report.lat_deg, report.lon_deg]
    numbers += [v for v in (report.altitude_m, report.vertical_rate_mps) if v is not None]
    numbers += list(report.velocity_en_mps or ())
    assert all(math.isfinite(v) for v in numbers)
    assert -90 <= report.lat_deg <= 90 and -180 <= report.lon_deg <= 180
    assert (report.lat_deg, report.lon_deg) != (0.0, 0.0)
    assert 0 <= report.key.address <= 0xFFFFFF
    assert not (report.key.address == OWN_ICAO and report.key.source is AddressSource.ES1090)
    assert NOW - cfg.max_report_age_s <= report.time_s <= NOW
    assert (report.altitude_m is None) == (report.altitude_datum is None)
    if report.altitude_m is not None:
        assert cfg.min_altitude_m <= report.altitude_m <= cfg.max_altitude_m
        assert report.altitude_m != INT32_MAX * 1e-3
    if report.velocity_en_mps is not None:
        assert math.hypot(*report.velocity_en_mps) <= cfg.max_ground_speed_mps + 1e-9
    if report.vertical_rate_mps is not None:
        assert abs(report.vertical_rate_mps) <= cfg.max_vertical_rate_mps
    if report.squawk is not None:
        assert report.squawk <= 7777 and set(f"{report.squawk:04d}") <= set("01234567")
    if report.callsign is not None:
        assert report.callsign and report.callsign.isascii() and report.callsign.isprintable()


# -- GLOBAL_POSITION_INT --------------------------------------------------------------------------------------
def test_global_position_int_converts_to_si():
    fix, moved = decode(gpi())
    assert moved == {"rx.global_position_int": 1}
    assert isinstance(fix, OwnshipFix) and fix.time_s == NOW
    assert (fix.lat_deg, fix.lon_deg) == (pytest.approx(47.3977418), pytest.approx(8.5455939))
    assert fix.alt_msl_m == pytest.approx(914.4) and fix.height_above_home_m == pytest.approx(304.8)
    assert fix.velocity_ned_mps == pytest.approx((64.3, -12.0, 1.5))  # cm/s north, east, down


GPI_REJECTED = [
    ("other_system", 2, {}, "gpi.other_system"),
    ("lat_91", 1, {"lat": 91 * 10**7}, "gpi.lat_out_of_range"),
    ("lon_181", 1, {"lon": 181 * 10**7}, "gpi.lon_out_of_range"),
    ("zero_lat_lon", 1, {"lat": 0, "lon": 0}, "gpi.null_position"),
    ("lat_int32_max", 1, {"lat": INT32_MAX}, "gpi.position_sentinel"),
    ("lon_int32_max", 1, {"lon": INT32_MAX}, "gpi.position_sentinel"),
    ("alt_int32_max", 1, {"alt": INT32_MAX}, "gpi.altitude_invalid"),
    ("alt_above_max", 1, {"alt": 20_000_001}, "gpi.altitude_invalid"),
    ("alt_below_min", 1, {"alt": -500_001}, "gpi.altitude_invalid"),
    ("relative_alt_int32_max", 1, {"relative_alt": INT32_MAX}, "gpi.relative_alt_invalid"),
    ("relative_alt_below_min", 1, {"relative_alt": -9_000_001}, "gpi.relative_alt_invalid"),
    ("vx_int16_max", 1, {"vx": INT16_MAX}, "gpi.velocity_invalid"),
    ("vy_int16_max", 1, {"vy": INT16_MAX}, "gpi.velocity_invalid"),
    ("vz_int16_max", 1, {"vz": INT16_MAX}, "gpi.velocity_invalid"),
    ("ground_speed_above_max", 1, {"vx": 30000, "vy": 30000}, "gpi.velocity_invalid"),
    ("vertical_speed_above_max", 1, {"vz": -10001}, "gpi.velocity_invalid"),
]


@pytest.mark.parametrize("src, fields, reason", [c[1:] for c in GPI_REJECTED], ids=[c[0] for c in GPI_REJECTED])
def test_invalid_global_position_int_is_rejected_once(src, fields, reason):
    fix, moved = decode(gpi(src, **fields))
    assert fix is None
    assert moved == {"rx.global_position_int": 1, reason: 1}


@settings(max_examples=200, deadline=None)
@given(st.fixed_dictionaries(dict(
    time_boot_ms=st.integers(0, 2**32 - 1), lat=_ints(-2**31, INT32_MAX, 0, 90 * 10**7),
    lon=_ints(-2**31, INT32_MAX, 0, 180 * 10**7), alt=_ints(-2**31, INT32_MAX, 0),
    relative_alt=st.integers(-2**31, INT32_MAX), vx=_ints(-2**15, INT16_MAX, 0), vy=_ints(-2**15, INT16_MAX, 0),
    vz=_ints(-2**15, INT16_MAX, 0), hdg=st.integers(0, UINT16_MAX),
)), st.sampled_from([1, 1, 2]))
def test_any_global_position_int_decodes_without_raising_to_clean_values(fields, src):
    fix, moved = decode(gpi(src, **fields))
    assert moved["rx.global_position_int"] == 1 and sum(moved.values()) == (1 if fix else 2)
    if fix is not None:
        assert -90 <= fix.lat_deg <= 90 and -180 <= fix.lon_deg <= 180
        assert -500 <= fix.alt_msl_m <= 20000
        assert all(math.isfinite(v) and abs(v) <= 350 for v in fix.velocity_ned_mps)


# -- SCALED_PRESSURE ------------------------------------------------------------------------------------------
def test_scaled_pressure_becomes_pressure_altitude():
    p, moved = decode(pressure(1013.25))
    assert moved == {"rx.scaled_pressure": 1}
    assert isinstance(p, OwnshipPressure) and p.time_s == NOW
    assert p.pressure_altitude_m == pytest.approx(0.0, abs=0.05)
    p, _ = decode(pressure(pressure_hpa_at(3000 * FT)))
    assert p.pressure_altitude_m == pytest.approx(914.4, abs=0.5)  # float32 on the wire


@pytest.mark.parametrize("press_abs, reason", [
    (math.nan, "invalid"), (math.inf, "invalid"), (-math.inf, "invalid"), (-1.0, "out_of_range"),
    (0.0, "out_of_range"), (1.0, "out_of_range"), (54.7, "out_of_range"), (5000.0, "out_of_range")],
    ids=["nan", "inf", "-inf", "negative", "zero", "48_km", "above_20_km", "above_sensor_range"])
def test_invalid_scaled_pressure_is_rejected_once(press_abs, reason):
    p, moved = decode(pressure(press_abs))
    assert p is None
    assert moved == {"rx.scaled_pressure": 1, f"pressure.{reason}": 1}


def test_scaled_pressure_from_another_system_is_ignored():
    p, moved = decode(pressure(1013.25, src_system=42))
    assert p is None
    assert moved == {"rx.scaled_pressure": 1, "pressure.other_system": 1}


def test_other_messages_are_neither_used_nor_counted_as_rejections():
    out, moved = decode(over_the_wire(m2.MAVLink_heartbeat_message(2, 3, 0, 0, 4, 3)))
    assert out is None and moved == {}


# -- end to end: invalid data never alerts --------------------------------------------------------------------
PLANE = LocalTangentPlane(47.0, 8.0)
SPEED = 125 * KT  # each way: 250 kt closing
CPA_S = 85.0  # co-altitude head-on; at 60 s range is 3.2 km, mod tau 23 s: inside the SL 4 TA thresholds
ALT_M = 3000 * FT
INTRUDER = 0xA1B2C3
INVALID_KINDS = [  # (what is wrong, fields replaced in the true report, counter expected)
    ("address > 24 bits", {"ICAO_address": 0x1A1B2C3}, "adsb.address_out_of_range"),
    ("our own address", {"ICAO_address": OWN_ICAO}, "adsb.own_address"),
    ("no position flag", {"flags": ALL_VALID & ~F.ADSB_FLAGS_VALID_COORDS}, "adsb.no_position"),
    ("lat sentinel", {"lat": INT32_MAX}, "adsb.position_sentinel"),
    ("lon sentinel", {"lon": INT32_MAX}, "adsb.position_sentinel"),
    ("lat 91", {"lat": 91 * 10**7}, "adsb.lat_out_of_range"),
    ("lon 181", {"lon": 181 * 10**7}, "adsb.lon_out_of_range"),
    ("null position", {"lat": 0, "lon": 0}, "adsb.null_position"),
    ("tslc 255", {"tslc": 255}, "adsb.stale"),
    ("tslc just over max", {"tslc": 4}, "adsb.stale"),
]


def _latlon_e7(east: float, north: float) -> tuple[int, int]:
    lat, lon = PLANE.to_geodetic(east, north)
    return round(float(lat) * 1e7), round(float(lon) * 1e7)


def _ownship_frames(t: float, mav) -> bytes:
    lat, lon = _latlon_e7(0.0, SPEED * t)
    fix = m2.MAVLink_global_position_int_message(int(t * 1000), lat, lon, round(ALT_M * 1000),
                                                 round(ALT_M * 1000), round(SPEED * 100), 0, 0, 0)
    baro = m2.MAVLink_scaled_pressure_message(int(t * 1000), pressure_hpa_at(ALT_M), 0.0, 1500)
    return bytes(fix.pack(mav)) + bytes(baro.pack(mav))


def _intruder_frame(t: float, mav, **wrong) -> bytes:
    lat, lon = _latlon_e7(0.0, 2 * SPEED * CPA_S - SPEED * t)
    fields = {**ADSB_DEFAULTS, "ICAO_address": INTRUDER, "lat": lat, "lon": lon, "altitude": round(ALT_M * 1000),
              "heading": 18000, "hor_velocity": round(SPEED * 100), "ver_velocity": 0, "tslc": 0, **wrong}
    return bytes(m2.MAVLink_adsb_vehicle_message(**fields).pack(mav))


def test_invalid_reports_of_a_threat_never_alert_then_valid_ones_give_a_ta():
    node = Harness(config(own_icao=OWN_ICAO))
    autopilot = m2.MAVLink(None, srcSystem=1, srcComponent=1)
    adsb_in = m2.MAVLink(None, srcSystem=1, srcComponent=156)  # the ADS-B receiver behind the autopilot
    scanner = FrameScanner(node.counters)
    changes, expected = [], Counter()

    def tick(k: int, valid: bool) -> None:
        t = k / 10
        datagram = _ownship_frames(t, autopilot) if k % 2 == 0 else b""  # ownship at 5 Hz
        if k % 5 == 0:  # ADS-B at 2 Hz
            if valid:
                datagram += _intruder_frame(t, adsb_in)
            else:
                _, wrong, reason = INVALID_KINDS[(k // 5) % len(INVALID_KINDS)]
                datagram += _intruder_frame(t, adsb_in, **wrong)
                expected[reason] += 1
        result = node.handle(scanner.feed(datagram, end_of_datagram=True), t)
        changes.extend((t, c) for c in result.changes)

    # 60 s of invalid reports, the intruder closing from 11 km to 3.2 km: the same reports valid would have
    # given a TA at about 53.5 s, so the last seconds of this phase are a real threat reported invalidly.
    for k in range(600):
        tick(k, valid=False)
    assert changes == []
    assert node.core.tracker.tracks == {} and node.counters["track.initiated"] == 0
    assert not [m for m in node.mavlink_out if m.get_type() == "COLLISION"]
    assert {reason: node.counters[reason] for reason in expected} == dict(expected)
    assert node.counters["rx.adsb_vehicle"] == sum(expected.values()) == 120
    assert node.counters["rx.global_position_int"] == 300
    assert not [k for k in node.counters if k.startswith(("gpi.", "pressure.", "frame.", "ownship"))]
    assert node.status(59.9)["ownship_valid"] and node.status(59.9)["pressure_altitude_available"]

    for k in range(600, 630):  # the same intruder, now valid
        tick(k, valid=True)
    assert changes, "no advisory from valid reports of a head-on intruder inside the TA thresholds"
    t_first, first = changes[0]
    assert first.level is AdvisoryLevel.TA and first.intruder == IntruderKey(INTRUDER, AddressSource.ES1090)
    assert t_first <= 61.0
    assert first.sensitivity_level == 4 and node.core.level.sl == 4
    assert first.altitude_datum is AltitudeDatum.PRESSURE and not first.datum_mismatch
    assert [m for m in node.mavlink_out if m.get_type() == "COLLISION" and m.id == INTRUDER]
