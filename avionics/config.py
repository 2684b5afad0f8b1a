"""Configuration: TOML -> frozen dataclasses, validated. The dataclass defaults are the built-in (embedded)
configuration; config/default.toml spells out the same values and a test keeps the two equal."""

from __future__ import annotations

import dataclasses
import math
import tomllib
import types
import typing
from dataclasses import dataclass, field
from pathlib import Path


class ConfigError(ValueError):
    """A configuration file or override that cannot be used, with the key that is wrong."""


@dataclass(frozen=True)
class VehicleConfig:
    id: str = "uav1"  # zenoh key segment: daa/<id>/...
    own_icao: int = 0  # our own ADS-B address, ignored in ADSB_VEHICLE (0: we transmit none)


@dataclass(frozen=True)
class MavlinkConfig:
    connection: str = "udpin:127.0.0.1:14550"  # any pymavlink connection string
    baud: int = 57600  # serial links only
    source_system: int = 1  # our HEARTBEAT/COLLISION system id (the vehicle's)
    source_component: int = 191  # MAV_COMP_ID_ONBOARD_COMPUTER
    heartbeat_hz: float = 1.0
    collision_refresh_s: float = 1.0  # re-send an active COLLISION this often
    statustext: bool = True


@dataclass(frozen=True)
class ZenohConfig:
    enabled: bool = True
    mode: str = "peer"
    listen: tuple[str, ...] = ("tcp/127.0.0.1:7447",)
    connect: tuple[str, ...] = ()
    scouting: bool = False  # multicast and gossip scouting
    key_prefix: str = "daa"
    tracks_hz: float = 2.0
    status_hz: float = 1.0


@dataclass(frozen=True)
class InputConfig:
    max_report_age_s: float = 3.0  # tslc older than this: report rejected as stale (tslc 255 = unknown age)
    max_ground_speed_mps: float = 350.0  # faster than any aircraft we protect against: report rejected
    max_vertical_rate_mps: float = 100.0
    min_altitude_m: float = -500.0
    max_altitude_m: float = 20000.0
    ownship_timeout_s: float = 2.0  # no GLOBAL_POSITION_INT for this long: no advisories, status says so
    pressure_timeout_s: float = 3.0  # no SCALED_PRESSURE for this long: ownship pressure altitude unknown


@dataclass(frozen=True)
class TrackingConfig:
    # Default measurement noise (1-sigma) per address source: ADSB_VEHICLE carries no NACp/NACv.
    position_sigma_1090es_m: float = 30.0  # ~NACp 8 (EPU < 92.6 m at 95 %)
    position_sigma_uat_m: float = 30.0
    velocity_sigma_mps: float = 2.0  # ~NACv 2 (< 3 m/s at 95 %) plus heading quantisation
    altitude_sigma_m: float = 8.0  # 25 ft quantisation and altimetry error
    vertical_rate_sigma_mps: float = 1.0  # 64 fpm quantisation
    horizontal_accel_sigma_mps2: float = 1.5  # CV model white-acceleration noise
    vertical_accel_sigma_mps2: float = 0.7
    max_coast_s: float = 6.0  # without reports for longer: advisory dropped, reason "stale"
    delete_after_s: float = 20.0  # without reports for longer: track deleted
    max_innovation_speed_mps: float = 400.0  # a report implying a jump faster than this is not this aircraft


@dataclass(frozen=True)
class AltitudeConfig:
    # When only mismatched datums exist (pressure vs geometric), the vertical uncertainty is widened by this
    # much: pressure and GNSS altitudes differ by up to a few hundred feet with temperature and weather.
    datum_mismatch_margin_m: float = 60.96  # 200 ft
    baro_offset_smoothing_s: float = 10.0  # time constant of the geometric - pressure altitude offset


@dataclass(frozen=True)
class AdvisoryConfig:
    assessment_hz: float = 10.0
    ta_min_duration_s: float = 8.0  # TCAS II: a TA stays at least 8 s
    ra_enabled: bool = True
    hmd_filter: bool = True  # TCAS II v7.1 RA horizontal miss distance filter
    ground_elevation_m: float | None = None  # AGL = MSL - this; None: AGL from height above home


@dataclass(frozen=True)
class Config:
    vehicle: VehicleConfig = field(default_factory=VehicleConfig)
    mavlink: MavlinkConfig = field(default_factory=MavlinkConfig)
    zenoh: ZenohConfig = field(default_factory=ZenohConfig)
    input: InputConfig = field(default_factory=InputConfig)
    tracking: TrackingConfig = field(default_factory=TrackingConfig)
    altitude: AltitudeConfig = field(default_factory=AltitudeConfig)
    advisory: AdvisoryConfig = field(default_factory=AdvisoryConfig)


def _coerce(value, annotation, where: str):
    """Check a TOML value against a dataclass field annotation; convert lists to tuples and ints to floats."""
    origin = typing.get_origin(annotation)
    if origin in (types.UnionType, typing.Union):
        options = typing.get_args(annotation)
        if value is None and type(None) in options:
            return None
        for option in options:
            if option is type(None):
                continue
            try:
                return _coerce(value, option, where)
            except ConfigError:
                pass
        raise ConfigError(f"{where}: {value!r} is not a valid {annotation}")
    if origin is tuple:
        (item_type, _) = typing.get_args(annotation)
        if not isinstance(value, (list, tuple)):
            raise ConfigError(f"{where}: expected a list, got {value!r}")
        return tuple(_coerce(v, item_type, f"{where}[{i}]") for i, v in enumerate(value))
    if dataclasses.is_dataclass(annotation):
        return _build(annotation, value, where)
    if annotation is float:
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
            raise ConfigError(f"{where}: expected a finite number, got {value!r}")
        return float(value)
    if annotation is int:
        if isinstance(value, bool) or not isinstance(value, int):
            raise ConfigError(f"{where}: expected an integer, got {value!r}")
        return value
    if annotation is bool or annotation is str:
        if not isinstance(value, annotation):
            raise ConfigError(f"{where}: expected {annotation.__name__}, got {value!r}")
        return value
    raise ConfigError(f"{where}: unsupported type {annotation}")


def _build(cls, table, where: str):
    if not isinstance(table, dict):
        raise ConfigError(f"{where}: expected a table, got {table!r}")
    hints = typing.get_type_hints(cls)
    names = {f.name for f in dataclasses.fields(cls)}
    unknown = set(table) - names
    if unknown:
        raise ConfigError(f"{where}: unknown key(s) {sorted(unknown)}; known: {sorted(names)}")
    kwargs = {k: _coerce(v, hints[k], f"{where}.{k}" if where else k) for k, v in table.items()}
    return cls(**kwargs)


def _merge(base: dict, update: dict) -> dict:
    out = dict(base)
    for k, v in update.items():
        out[k] = _merge(out[k], v) if isinstance(v, dict) and isinstance(out.get(k), dict) else v
    return out


def _parse_override(text: str) -> dict:
    """'advisory.ta_min_duration_s=10' -> {'advisory': {'ta_min_duration_s': 10}} (value parsed as TOML)."""
    key, sep, raw = text.partition("=")
    if not sep or not key.strip():
        raise ConfigError(f"override {text!r}: expected section.key=value")
    try:
        value = tomllib.loads(f"v = {raw.strip()}")["v"]
    except tomllib.TOMLDecodeError:
        value = raw.strip()  # bare strings need no quotes on the command line
    node: dict = {}
    cursor = node
    parts = key.strip().split(".")
    for part in parts[:-1]:
        cursor = cursor.setdefault(part, {})
    cursor[parts[-1]] = value
    return node


def validate(config: Config) -> Config:
    if config.zenoh.mode not in ("peer", "client", "router"):
        raise ConfigError(f"zenoh.mode: {config.zenoh.mode!r} is not peer, client or router")
    positive = [
        ("mavlink.heartbeat_hz", config.mavlink.heartbeat_hz),
        ("mavlink.collision_refresh_s", config.mavlink.collision_refresh_s),
        ("zenoh.tracks_hz", config.zenoh.tracks_hz),
        ("zenoh.status_hz", config.zenoh.status_hz),
        ("advisory.assessment_hz", config.advisory.assessment_hz),
        ("input.max_report_age_s", config.input.max_report_age_s),
        ("tracking.position_sigma_1090es_m", config.tracking.position_sigma_1090es_m),
        ("tracking.position_sigma_uat_m", config.tracking.position_sigma_uat_m),
        ("tracking.velocity_sigma_mps", config.tracking.velocity_sigma_mps),
        ("tracking.altitude_sigma_m", config.tracking.altitude_sigma_m),
        ("tracking.vertical_rate_sigma_mps", config.tracking.vertical_rate_sigma_mps),
        ("tracking.max_coast_s", config.tracking.max_coast_s),
    ]
    for name, value in positive:
        if value <= 0:
            raise ConfigError(f"{name}: must be > 0, got {value}")
    if config.tracking.delete_after_s < config.tracking.max_coast_s:
        raise ConfigError("tracking.delete_after_s must be >= tracking.max_coast_s")
    if not 0 <= config.vehicle.own_icao <= 0xFFFFFF:
        raise ConfigError(f"vehicle.own_icao: {config.vehicle.own_icao:#x} is not a 24-bit address")
    return config


def load_config(path: str | Path | None = None, overrides: typing.Iterable[str] = ()) -> Config:
    """The embedded defaults, updated by a TOML file (if given) and then by key=value overrides."""
    table: dict = {}
    if path is not None:
        try:
            table = tomllib.loads(Path(path).read_text())
        except (OSError, tomllib.TOMLDecodeError) as exc:
            raise ConfigError(f"{path}: {exc}") from exc
    for text in overrides:
        table = _merge(table, _parse_override(text))
    return validate(_build(Config, table, ""))


def as_dict(config: Config) -> dict:
    return dataclasses.asdict(config)
