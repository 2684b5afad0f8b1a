"""One aircraft of an encounter: its initial state and leg program (Leg, AircraftSpec), and plausibility bounds.

SI (m, s, m/s) and true-north headings. avionics_sitl.trajectory integrates these; avionics_sitl.scenario groups them into an
encounter and reads them from TOML files.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass

from avionics.base.types import AddressSource, AltitudeDatum

# Plausibility bounds. They catch unit mix-ups (knots given as m/s, feet as metres) rather than describe any
# airframe: a 311 m/s jet (Radosavljević et al.) and a hovering multirotor must both pass.
MAX_ABS_LAT_DEG = 85.0  # the tangent-plane model degrades near the poles
ALT_RANGE_M = (-1000.0, 20000.0)
MAX_SPEED_MPS = 400.0
MAX_VERTICAL_RATE_MPS = 100.0
MAX_TURN_RATE_DPS = 90.0
MAX_ACCELERATION_MPS2 = 20.0
MAX_DURATION_S = 86400.0
GROUND_RANGE_M = (-500.0, 9000.0)
MAX_PLANE_OFFSET_M = 500e3  # east/north offsets from [reference]: keep the tangent plane honest
CALLSIGN_RE = re.compile(r"[A-Z0-9 ]{0,8}")  # what an ADS-B identification message can carry
MAX_EMITTER_TYPE = 19  # MAVLink ADSB_EMITTER_TYPE values 0..19


def check_finite(name: str, value: float) -> None:
    if not isinstance(value, (int, float)) or isinstance(value, bool) or not math.isfinite(value):
        raise ValueError(f"{name} must be a finite number, got {value!r}")


def check_range(name: str, value: float, lo: float, hi: float, unit: str = "") -> None:
    check_finite(name, value)
    if not lo <= value <= hi:
        raise ValueError(f"{name} = {value:g}{unit} is outside [{lo:g}, {hi:g}]{unit}")


@dataclass(frozen=True, slots=True)
class Leg:
    """A segment flown for duration_s with constant rates. turn_rate_dps > 0 turns right (heading increases)."""

    duration_s: float
    turn_rate_dps: float = 0.0
    vertical_rate_mps: float = 0.0
    acceleration_mps2: float = 0.0  # along-track: speed changes, heading does not

    def __post_init__(self) -> None:
        check_finite("duration_s", self.duration_s)
        if not 0.0 < self.duration_s <= MAX_DURATION_S:
            raise ValueError(f"duration_s = {self.duration_s:g} s must be in (0, {MAX_DURATION_S:g}] s")
        check_range("turn_rate_dps", self.turn_rate_dps, -MAX_TURN_RATE_DPS, MAX_TURN_RATE_DPS, " deg/s")
        check_range(
            "vertical_rate_mps", self.vertical_rate_mps, -MAX_VERTICAL_RATE_MPS, MAX_VERTICAL_RATE_MPS, " m/s"
        )
        check_range(
            "acceleration_mps2", self.acceleration_mps2, -MAX_ACCELERATION_MPS2, MAX_ACCELERATION_MPS2, " m/s^2"
        )


@dataclass(frozen=True, slots=True)
class AircraftSpec:
    """Initial state and leg program of one aircraft.

    With no legs the aircraft flies straight at constant velocity (including `vertical_rate_mps`) forever.
    With legs, each leg sets its own vertical rate, and after the last leg the aircraft flies straight and
    level at the speed reached; `vertical_rate_mps` must then be 0 (it would be ambiguous)."""

    name: str
    icao_address: int
    lat_deg: float
    lon_deg: float
    alt_msl_m: float  # in `altitude_datum`
    heading_deg: float  # true track, 0 = north, 90 = east
    speed_mps: float  # ground speed
    vertical_rate_mps: float = 0.0
    legs: tuple[Leg, ...] = ()
    altitude_datum: AltitudeDatum = AltitudeDatum.PRESSURE
    address_source: AddressSource = AddressSource.ES1090
    callsign: str = ""
    emitter_type: int = 1  # MAVLink ADSB_EMITTER_TYPE_LIGHT

    def __post_init__(self) -> None:
        if not isinstance(self.icao_address, int) or not 0 <= self.icao_address <= 0xFFFFFF:
            raise ValueError(f"icao_address must be a 24-bit integer, got {self.icao_address!r}")
        check_range("lat_deg", self.lat_deg, -MAX_ABS_LAT_DEG, MAX_ABS_LAT_DEG, " deg")
        check_range("lon_deg", self.lon_deg, -180.0, 180.0, " deg")
        check_range("alt_msl_m", self.alt_msl_m, *ALT_RANGE_M, " m")
        check_finite("heading_deg", self.heading_deg)
        if not 0.0 <= self.heading_deg < 360.0:
            raise ValueError(f"heading_deg = {self.heading_deg:g} must be in [0, 360)")
        check_range("speed_mps", self.speed_mps, 0.0, MAX_SPEED_MPS, " m/s")
        check_range(
            "vertical_rate_mps", self.vertical_rate_mps, -MAX_VERTICAL_RATE_MPS, MAX_VERTICAL_RATE_MPS, " m/s"
        )
        if not isinstance(self.legs, tuple) or not all(isinstance(leg, Leg) for leg in self.legs):
            raise ValueError("legs must be a tuple of Leg")
        if self.legs and self.vertical_rate_mps != 0.0:
            raise ValueError("vertical_rate_mps applies only without legs; give each leg its vertical rate")
        if not isinstance(self.altitude_datum, AltitudeDatum):
            raise ValueError(f"altitude_datum must be an AltitudeDatum, got {self.altitude_datum!r}")
        if not isinstance(self.address_source, AddressSource):
            raise ValueError(f"address_source must be an AddressSource, got {self.address_source!r}")
        if not isinstance(self.callsign, str) or not CALLSIGN_RE.fullmatch(self.callsign):
            raise ValueError(f"callsign {self.callsign!r}: up to 8 characters of A-Z, 0-9, space")
        if not isinstance(self.emitter_type, int) or not 0 <= self.emitter_type <= MAX_EMITTER_TYPE:
            raise ValueError(f"emitter_type must be an integer in [0, {MAX_EMITTER_TYPE}], got {self.emitter_type!r}")
