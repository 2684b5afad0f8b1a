"""Configuration: the assembler. TOML file and key=value overrides -> one frozen Config of the components' sections,
each validated by its own component. The dataclass defaults are the built-in (embedded) configuration;
config/default.toml spells out the same values and a test keeps the two equal.

Each section is declared, with its units and its checks (`validate()`), next to the component that uses it:

    [vehicle] [mavlink] [zenoh]    avionics/io/params.py
    [input] [tracking] [altitude]  avionics/tracking/params.py
    [advisory]                     avionics/advisory/params.py
    [conflict]                     avionics/conflict/params.py
    [traffic]                      avionics/io/feeds/params.py (receiver feeds: avionics run --traffic)
    [guidance]                     avionics/guidance/params.py (commanding the autopilot, issue 27)

The generic TOML -> dataclass coercion and ConfigError are avionics/base/params.py. This module is the shells'
layer (the composition root and the command lines): no component imports it. It re-exports the section classes
and ConfigError so that `from avionics.config import X` keeps working."""

from __future__ import annotations

import dataclasses
import tomllib
import typing
from dataclasses import dataclass, field
from pathlib import Path

from avionics.advisory.params import AdvisoryConfig
from avionics.conflict.params import ConflictConfig
from avionics.base.params import ConfigError, _build
from avionics.guidance.params import BAND_KINDS_READ, GuidanceConfig
from avionics.io.feeds.params import TrafficConfig
from avionics.io.params import ROS_NAMESPACE, MavlinkConfig, VehicleConfig, ZenohConfig, traffic_source_ids
from avionics.tracking.params import TRACK_FILTERS, AltitudeConfig, InputConfig, TrackingConfig

__all__ = [
    "AdvisoryConfig", "AltitudeConfig", "Config", "ConfigError", "ConflictConfig", "GuidanceConfig", "InputConfig",
    "MavlinkConfig",
    "TRACK_FILTERS", "TrackingConfig", "TrafficConfig", "VehicleConfig", "ZenohConfig", "as_dict", "load_config",
    "read_toml", "traffic_source_ids", "validate",
]


@dataclass(frozen=True)
class Config:
    vehicle: VehicleConfig = field(default_factory=VehicleConfig)
    mavlink: MavlinkConfig = field(default_factory=MavlinkConfig)
    zenoh: ZenohConfig = field(default_factory=ZenohConfig)
    input: InputConfig = field(default_factory=InputConfig)
    tracking: TrackingConfig = field(default_factory=TrackingConfig)
    altitude: AltitudeConfig = field(default_factory=AltitudeConfig)
    advisory: AdvisoryConfig = field(default_factory=AdvisoryConfig)
    conflict: ConflictConfig = field(default_factory=ConflictConfig)
    traffic: TrafficConfig = field(default_factory=TrafficConfig)
    guidance: GuidanceConfig = field(default_factory=GuidanceConfig)


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
    except ValueError:  # TOMLDecodeError, or an integer beyond Python's int-str limit (4300 digits)
        value = raw.strip()  # bare strings need no quotes on the command line
    node: dict = {}
    cursor = node
    parts = key.strip().split(".")
    for part in parts[:-1]:
        cursor = cursor.setdefault(part, {})
    cursor[parts[-1]] = value
    return node


def validate(config: Config) -> Config:
    """Every section by its own component's rules, in the order of Config's fields, then the rules that span
    sections: the guidance's band kinds are computed; the ROS 2 namespace defaults to the vehicle id, which must
    then be a ROS name."""
    for section in dataclasses.fields(Config):
        getattr(config, section.name).validate()
    g, a = config.guidance, config.advisory
    missing = [k for k in BAND_KINDS_READ if k not in a.guidance_band_kinds]
    if g.mode != "passive" and not g.ladder and a.guidance_bands and missing:
        raise ConfigError(f"advisory.guidance_band_kinds: guidance.mode {g.mode!r} turns by the {', '.join(missing)} "
                          f"bands: keep them (or guidance.ladder = true, or advisory.guidance_bands = false)")
    z = config.zenoh
    if z.ros2 and not z.ros2_namespace and not ROS_NAMESPACE.fullmatch(config.vehicle.id):
        raise ConfigError(f"zenoh.ros2: the ROS 2 namespace defaults to vehicle.id {config.vehicle.id!r}, which is not a "
                          "ROS 2 name (letters, digits and '_', not starting with a digit): set zenoh.ros2_namespace")
    return config


def load_config(path: str | Path | None = None, overrides: typing.Iterable[str] = ()) -> Config:
    """The embedded defaults, updated by a TOML file (if given) and then by key=value overrides."""
    table = read_toml(path) if path is not None else {}
    for text in overrides:
        table = _merge(table, _parse_override(text))
    return validate(_build(Config, table, ""))


def read_toml(path: str | Path) -> dict:
    """The table of a TOML file; ConfigError naming the file when it cannot be read or is not TOML (TOML is UTF-8:
    other bytes are refused, not guessed; an integer beyond Python's int-str limit, 4300 digits, is refused too)."""
    try:
        data = Path(path).read_bytes()
    except OSError as exc:
        raise ConfigError(f"{path}: {exc.strerror or exc}") from None
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise ConfigError(f"{path}: not UTF-8 text (byte {exc.start}): a TOML file is UTF-8") from None
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError(f"{path}: {exc}") from None
    except ValueError as exc:  # tomllib's int(): "Exceeds the limit (4300 digits) for integer string conversion"
        raise ConfigError(f"{path}: {str(exc).splitlines()[0]}") from None


def as_dict(config: Config) -> dict:
    return dataclasses.asdict(config)
