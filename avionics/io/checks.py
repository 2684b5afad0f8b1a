"""Plausibility checks shared by every traffic path: the MAVLink decoder (decode.py) and the receiver feeds
(feeds/aircraft.py) reject the same values for the same reasons. Each check takes SI values and returns the
reason a value is rejected (the counter suffix, e.g. "speed_out_of_range") or None when it is usable. The limits
are InputConfig's (avionics/tracking/params.py, [input]) and the vehicle's own address ([vehicle] own_icao)."""

from __future__ import annotations

import math

MAX_ICAO = 0xFFFFFF  # a 24-bit ICAO / UAT address (ICAO Annex 10 Vol III; DO-282B 2.2.4.5.1.2)


def position_problem(lat_deg: float, lon_deg: float) -> str | None:
    if not (math.isfinite(lat_deg) and math.isfinite(lon_deg)):
        return "position_not_finite"
    if abs(lat_deg) > 90.0:
        return "lat_out_of_range"
    if abs(lon_deg) > 180.0:
        return "lon_out_of_range"
    if lat_deg == 0.0 and lon_deg == 0.0:
        return "null_position"  # 0,0 is what an unset fix looks like, not a place we fly
    return None


def altitude_problem(cfg, altitude_m: float) -> str | None:
    if not (math.isfinite(altitude_m) and cfg.min_altitude_m <= altitude_m <= cfg.max_altitude_m):
        return "altitude_out_of_range"
    return None


def speed_problem(cfg, ground_speed_mps: float) -> str | None:
    if not (math.isfinite(ground_speed_mps) and ground_speed_mps <= cfg.max_ground_speed_mps):
        return "speed_out_of_range"
    return None


def vertical_rate_problem(cfg, vertical_rate_mps: float) -> str | None:
    if not (math.isfinite(vertical_rate_mps) and abs(vertical_rate_mps) <= cfg.max_vertical_rate_mps):
        return "vertical_rate_out_of_range"
    return None


def address_problem(own_icao: int, address: int, es1090: bool) -> str | None:
    """own_icao: [vehicle] own_icao (0: we transmit none); es1090: the address came over 1090ES."""
    if not 0 <= address <= MAX_ICAO:
        return "address_out_of_range"
    if es1090 and address == own_icao != 0:
        return "own_address"
    return None


def callsign_text(raw: bytes) -> str | None:
    """The callsign in raw bytes (NUL-terminated or padded), or None when it is not printable ASCII text."""
    text = raw.split(b"\0", 1)[0].decode("ascii", errors="replace").strip()
    if text and text.isprintable() and text.isascii() and "\ufffd" not in text:
        return text
    return None


def squawk_valid(squawk: int) -> bool:
    """A Mode A code written as four octal digits in decimal (7700 = emergency), as ADSB_VEHICLE carries it."""
    digits = f"{squawk:04d}"
    return 0 <= squawk and len(digits) == 4 and all(d <= "7" for d in digits)
