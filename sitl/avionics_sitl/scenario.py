"""What an encounter is: aircraft (avionics_sitl.aircraft: initial states and leg programs) and how long to fly them.

Everything here is SI (m, s, m/s) and true-north headings; feet, knots and fpm exist only in the TOML file
reader below (docs/scenarios.md describes the file format). `Scenario.trajectories()` turns the description
into truth trajectories (avionics_sitl.trajectory).
"""

from __future__ import annotations

import bisect
import math
import re
import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from contextlib import contextmanager
from typing import Any, Iterator

from avionics.base.geodesy import LocalTangentPlane
from avionics.base.types import AddressSource, AltitudeDatum
from avionics.base.units import FPM, FT, KT, NM
from avionics_sitl.aircraft import (
    GROUND_RANGE_M, MAX_ABS_LAT_DEG, MAX_DURATION_S, MAX_PLANE_OFFSET_M, AircraftSpec, Leg, check_finite, check_range,
)
from avionics_sitl.trajectory import LegTrajectory, Trajectory


@dataclass(frozen=True)
class Scenario:
    """An encounter: ownship, intruders and how long to fly it (simulation time starts at 0).

    `origin` is the (lat, lon) of the tangent plane the leg programs are integrated in (default: ownship's
    initial position); encounters authored in east/north metres set it to their reference point so that
    their geometry is exact. `precomputed_trajectories` (ownship, intruders), when given, replaces the leg
    programs (the .daa reader uses it for sampled trajectories); the specs then hold the initial states."""

    name: str
    description: str
    ownship: AircraftSpec
    intruders: tuple[AircraftSpec, ...]
    duration_s: float
    ground_elevation_m: float = 0.0
    precomputed_trajectories: tuple[Trajectory, tuple[Trajectory, ...]] | None = field(default=None, compare=False)
    origin: tuple[float, float] | None = None
    # The surveillance's stated uncertainties per aircraft name (a .daa file's *_std columns): (simulation times,
    # SumData at each), ascending; the replay attaches the latest at or before a report's time to it.
    stated_uncertainty: dict[str, tuple[tuple[float, ...], tuple]] | None = field(default=None, compare=False)

    def uncertainty_at(self, name: str, t_s: float):
        """The SumData `name` stated at its latest sample at or before t_s (its first before that); None: none."""
        if not self.stated_uncertainty or name not in self.stated_uncertainty:
            return None
        times, values = self.stated_uncertainty[name]
        i = bisect.bisect_right(times, t_s + 1e-9) - 1
        return values[max(i, 0)]

    def __post_init__(self) -> None:
        if not isinstance(self.ownship, AircraftSpec):
            raise ValueError("ownship must be an AircraftSpec")
        if not isinstance(self.intruders, tuple) or not all(isinstance(a, AircraftSpec) for a in self.intruders):
            raise ValueError("intruders must be a tuple of AircraftSpec")
        check_finite("duration_s", self.duration_s)
        if not 0.0 < self.duration_s <= MAX_DURATION_S:
            raise ValueError(f"duration_s = {self.duration_s:g} s must be in (0, {MAX_DURATION_S:g}] s")
        check_range("ground_elevation_m", self.ground_elevation_m, *GROUND_RANGE_M, " m")
        keys = [(a.icao_address, a.address_source) for a in self.aircraft]
        if len(set(keys)) != len(keys):
            raise ValueError("two aircraft share an ICAO address and address source")
        if self.precomputed_trajectories is not None:
            own, intr = self.precomputed_trajectories
            if len(tuple(intr)) != len(self.intruders):
                raise ValueError("precomputed_trajectories must hold one trajectory per intruder")
        if self.origin is not None:
            check_range("origin latitude", self.origin[0], -MAX_ABS_LAT_DEG, MAX_ABS_LAT_DEG, " deg")
            check_range("origin longitude", self.origin[1], -180.0, 180.0, " deg")

    @property
    def aircraft(self) -> tuple[AircraftSpec, ...]:
        """Ownship first, then the intruders."""
        return (self.ownship, *self.intruders)

    def plane(self) -> LocalTangentPlane:
        lat, lon = self.origin if self.origin is not None else (self.ownship.lat_deg, self.ownship.lon_deg)
        return LocalTangentPlane(lat, lon)

    def trajectories(self) -> tuple[Trajectory, list[Trajectory]]:
        """(ownship trajectory, [intruder trajectories]) in intruder order."""
        if self.precomputed_trajectories is not None:
            own, intr = self.precomputed_trajectories
            return own, list(intr)
        plane = self.plane()
        return LegTrajectory(self.ownship, plane), [LegTrajectory(a, plane) for a in self.intruders]


# --- TOML scenario files (docs/scenarios.md, "Scenario files") ---------------------------------------------

DEFAULT_ADDRESS_BASE = 0xA00001  # aircraft without `icao` get BASE + index (ownship index 0), as in .daa files

_TOP_KEYS = {"name", "description", "duration_s", "ground_elevation_ft", "ground_elevation_m",
             "reference", "ownship", "intruder"}
_REFERENCE_KEYS = {"lat_deg", "lon_deg"}
_AIRCRAFT_KEYS = {"name", "icao", "lat_deg", "lon_deg", "east_m", "north_m", "east_nm", "north_nm",
                  "alt_ft", "alt_m", "heading_deg", "speed_kt", "speed_mps", "vs_fpm", "vs_mps",
                  "altitude_datum", "address_source", "callsign", "emitter_type", "legs"}
_LEG_KEYS = {"duration_s", "turn_rate_dps", "vs_fpm", "vs_mps", "accel_mps2", "accel_kt_per_s"}


class _Table:
    """A TOML table with its path for error messages; keys outside `allowed` are rejected up front."""

    def __init__(self, data: Any, where: str, allowed: set[str]):
        if not isinstance(data, dict):
            raise ValueError(f"{where}: expected a table, got {type(data).__name__}")
        unknown = sorted(set(data) - allowed)
        if unknown:
            raise ValueError(f"{where}: unknown key(s) {', '.join(unknown)} (allowed: {', '.join(sorted(allowed))})")
        self.data, self.where = data, where

    def has(self, key: str) -> bool:
        return key in self.data

    def number(self, key: str, default: float | None = None) -> float:
        if key not in self.data:
            if default is None:
                raise ValueError(f"{self.where}: missing key {key}")
            return default
        value = self.data[key]
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
            raise ValueError(f"{self.where}.{key}: expected a finite number, got {value!r}")
        return float(value)

    def integer(self, key: str, default: int) -> int:
        value = self.data.get(key, default)
        if isinstance(value, bool) or not isinstance(value, int):
            raise ValueError(f"{self.where}.{key}: expected an integer, got {value!r}")
        return value

    def string(self, key: str, default: str) -> str:
        value = self.data.get(key, default)
        if not isinstance(value, str):
            raise ValueError(f"{self.where}.{key}: expected a string, got {value!r}")
        return value

    def one_of(self, scaled_keys: dict[str, float], default: float | None = None) -> float:
        """The value of whichever single key of a unit family is present, converted to SI."""
        present = [k for k in scaled_keys if k in self.data]
        if len(present) > 1:
            raise ValueError(f"{self.where}: give only one of {', '.join(present)}")
        if not present:
            if default is None:
                raise ValueError(f"{self.where}: missing key, one of {', '.join(scaled_keys)}")
            return default
        return self.number(present[0]) * scaled_keys[present[0]]


@contextmanager
def _context(where: str) -> Iterator[None]:
    """Prefix a dataclass validation message with the table it came from."""
    try:
        yield
    except ValueError as e:
        if str(e).startswith(where):
            raise
        raise ValueError(f"{where}: {e}") from None


def _enum(table: _Table, key: str, enum_type, default):
    text = table.string(key, default.value)
    try:
        return enum_type(text.lower())
    except ValueError:
        choices = ", ".join(e.value for e in enum_type)
        raise ValueError(f"{table.where}.{key}: {text!r} is not one of {choices}") from None


def _icao(table: _Table, default: int) -> int:
    if not table.has("icao"):
        return default
    value = table.data["icao"]
    if isinstance(value, str) and re.fullmatch(r"(0x)?[0-9A-Fa-f]{1,6}", value):
        return int(value, 16)
    if isinstance(value, int) and not isinstance(value, bool):
        return value
    raise ValueError(f"{table.where}.icao: expected an integer (e.g. 0xA1B2C3) or a hex string, got {value!r}")


def _leg(data: Any, where: str) -> Leg:
    t = _Table(data, where, _LEG_KEYS)
    with _context(where):
        return Leg(
            duration_s=t.number("duration_s"),
            turn_rate_dps=t.number("turn_rate_dps", 0.0),
            vertical_rate_mps=t.one_of({"vs_fpm": FPM, "vs_mps": 1.0}, 0.0),
            acceleration_mps2=t.one_of({"accel_mps2": 1.0, "accel_kt_per_s": KT}, 0.0),
        )


def _aircraft(data: Any, where: str, default_name: str, default_icao: int,
              reference: LocalTangentPlane | None) -> AircraftSpec:
    t = _Table(data, where, _AIRCRAFT_KEYS)
    has_geo = t.has("lat_deg") or t.has("lon_deg")
    has_m = t.has("east_m") or t.has("north_m")
    has_nm = t.has("east_nm") or t.has("north_nm")
    if has_geo + has_m + has_nm != 1:
        raise ValueError(f"{where}: give the position as exactly one of lat_deg/lon_deg, east_m/north_m, "
                         "east_nm/north_nm")
    if has_geo:
        lat, lon = t.number("lat_deg"), t.number("lon_deg")
    else:
        scale, ke, kn = (1.0, "east_m", "north_m") if has_m else (NM, "east_nm", "north_nm")
        east, north = t.number(ke) * scale, t.number(kn) * scale
        if reference is None:
            raise ValueError(f"{where}: {ke}/{kn} need a [reference] table with lat_deg and lon_deg")
        if max(abs(east), abs(north)) > MAX_PLANE_OFFSET_M:
            raise ValueError(f"{where}: east/north offset beyond {MAX_PLANE_OFFSET_M / 1e3:g} km from [reference]")
        lat_a, lon_a = reference.to_geodetic(east, north)
        lat, lon = float(lat_a), float(lon_a)
    legs_data = t.data.get("legs", [])
    if not isinstance(legs_data, list):
        raise ValueError(f"{where}.legs: expected an array of tables ([[...legs]])")
    legs = tuple(_leg(d, f"{where}.legs[{i}]") for i, d in enumerate(legs_data))
    with _context(where):
        return AircraftSpec(
            name=t.string("name", default_name),
            icao_address=_icao(t, default_icao),
            lat_deg=lat,
            lon_deg=lon,
            alt_msl_m=t.one_of({"alt_ft": FT, "alt_m": 1.0}),
            heading_deg=t.number("heading_deg"),
            speed_mps=t.one_of({"speed_kt": KT, "speed_mps": 1.0}),
            vertical_rate_mps=t.one_of({"vs_fpm": FPM, "vs_mps": 1.0}, 0.0),
            legs=legs,
            altitude_datum=_enum(t, "altitude_datum", AltitudeDatum, AltitudeDatum.PRESSURE),
            address_source=_enum(t, "address_source", AddressSource, AddressSource.ES1090),
            callsign=t.string("callsign", ""),
            emitter_type=t.integer("emitter_type", 1),
        )


def parse_scenario_toml(text: str, default_name: str = "scenario") -> Scenario:
    """A Scenario from the text of a TOML scenario file; ValueError says what and where on any problem."""
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as e:
        raise ValueError(f"not valid TOML: {e}") from None
    top = _Table(data, "scenario", _TOP_KEYS)
    reference = None
    origin = None
    if top.has("reference"):
        ref = _Table(data["reference"], "reference", _REFERENCE_KEYS)
        lat, lon = ref.number("lat_deg"), ref.number("lon_deg")
        check_range("reference.lat_deg", lat, -MAX_ABS_LAT_DEG, MAX_ABS_LAT_DEG, " deg")
        check_range("reference.lon_deg", lon, -180.0, 180.0, " deg")
        reference, origin = LocalTangentPlane(lat, lon), (lat, lon)
    if not top.has("ownship"):
        raise ValueError("scenario: missing table [ownship]")
    ownship = _aircraft(data["ownship"], "ownship", "ownship", DEFAULT_ADDRESS_BASE, reference)
    intruder_data = data.get("intruder", [])
    if not isinstance(intruder_data, list):
        raise ValueError("intruder: expected an array of tables ([[intruder]])")
    intruders = tuple(
        _aircraft(d, f"intruder[{i}]", f"intruder-{i + 1}", DEFAULT_ADDRESS_BASE + 1 + i, reference)
        for i, d in enumerate(intruder_data)
    )
    with _context("scenario"):
        return Scenario(
            name=top.string("name", default_name),
            description=top.string("description", ""),
            ownship=ownship,
            intruders=intruders,
            duration_s=top.number("duration_s"),
            ground_elevation_m=top.one_of({"ground_elevation_ft": FT, "ground_elevation_m": 1.0}, 0.0),
            origin=origin,
        )


def load_scenario_file(path: str | Path) -> Scenario:
    """A Scenario from a TOML scenario file; the scenario name defaults to the file's stem."""
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except OSError as e:
        raise ValueError(f"{path}: cannot read: {e}") from None
    try:
        return parse_scenario_toml(text, default_name=path.stem)
    except ValueError as e:
        raise ValueError(f"{path}: {e}") from None
