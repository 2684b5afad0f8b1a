"""Component parameters: TOML tables -> frozen dataclasses, type-checked. Core layer: imports nothing above core.

Each component declares its parameters as a frozen dataclass next to its code (avionics/<package>/params.py), with
the units in the field names and comments, and checks its own values in a `validate(self)` method that raises
ConfigError naming `section.key`. avionics/config.py assembles the sections into one configuration."""

from __future__ import annotations

import dataclasses
import math
import types
import typing


class ConfigError(ValueError):
    """A configuration file or override that cannot be used, with the key that is wrong."""


# The numbers a configuration can hold at all, before each component checks its own ranges. No parameter of this
# project is a physical quantity below a nanounit or above a billion units (the largest are distances in metres and
# seeds); values outside these reach arithmetic that overflows or divides to infinity (1e-320 Hz is a period of
# inf s, int(inf) raises) and so are refused here, naming the key. Integers stay within int64: they go to numpy.
FLOAT_MIN_MAGNITUDE = 1e-9  # nonzero floats smaller than this are refused (subnormal 1e-320 among them)
FLOAT_MAX_MAGNITUDE = 1e9
INT_MIN, INT_MAX = -(2**63), 2**63 - 1


def check_float(value, where: str) -> float:
    """value as a float if it is a finite number of sane magnitude (0 or within FLOAT_MIN..MAX_MAGNITUDE)."""
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise ConfigError(f"{where}: expected a finite number, got {_show(value)}")
    try:
        x = float(value)
    except OverflowError:  # an int beyond float
        raise ConfigError(f"{where}: {_show(value)} is out of range (|x| <= {FLOAT_MAX_MAGNITUDE:g})") from None
    if not math.isfinite(x):
        raise ConfigError(f"{where}: expected a finite number, got {_show(value)}")
    if x != 0.0 and not FLOAT_MIN_MAGNITUDE <= abs(x) <= FLOAT_MAX_MAGNITUDE:
        raise ConfigError(f"{where}: {_show(value)} is out of range (0 or {FLOAT_MIN_MAGNITUDE:g} <= |x| <= "
                          f"{FLOAT_MAX_MAGNITUDE:g})")
    return x


def is_file(path) -> bool:
    """path (a Path or an importlib.resources Traversable) names a file; False, not OSError, for a name the OS
    refuses (ENAMETOOLONG: a 4400-character override is a string the configuration must refuse, not crash on)."""
    try:
        return path.is_file()
    except OSError:
        return False


def _show(value) -> str:
    """repr of a value, shortened: an error line stays one readable line whatever was given."""
    huge = isinstance(value, int) and value.bit_length() > 100  # str() of an int has a limit (4300 digits)
    text = f"<an integer of {value.bit_length()} bits>" if huge else repr(value)
    return text if len(text) <= 80 else text[:77] + "..."


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
        raise ConfigError(f"{where}: {_show(value)} is not a valid {annotation}")
    if origin is tuple:
        (item_type, _) = typing.get_args(annotation)
        if not isinstance(value, (list, tuple)):
            raise ConfigError(f"{where}: expected a list, got {_show(value)}")
        return tuple(_coerce(v, item_type, f"{where}[{i}]") for i, v in enumerate(value))
    if dataclasses.is_dataclass(annotation):
        return _build(annotation, value, where)
    if annotation is float:
        return check_float(value, where)
    if annotation is int:
        if isinstance(value, bool) or not isinstance(value, int):
            raise ConfigError(f"{where}: expected an integer, got {_show(value)}")
        if not INT_MIN <= value <= INT_MAX:
            raise ConfigError(f"{where}: {_show(value)} is out of range (a 64-bit integer)")
        return value
    if annotation is bool or annotation is str:
        if not isinstance(value, annotation):
            raise ConfigError(f"{where}: expected {annotation.__name__}, got {_show(value)}")
        return value
    raise ConfigError(f"{where}: unsupported type {annotation}")


def _build(cls, table, where: str):
    """An instance of dataclass cls from a TOML table (missing keys: the defaults); unknown keys are an error.
    Type-checks only: the values are checked by the dataclass's validate()."""
    if not isinstance(table, dict):
        raise ConfigError(f"{where}: expected a table, got {_show(table)}")
    hints = typing.get_type_hints(cls)
    names = {f.name for f in dataclasses.fields(cls)}
    unknown = set(table) - names
    if unknown:
        raise ConfigError(f"{where or 'configuration'}: unknown key(s) {sorted(unknown)}; known: {sorted(names)}")
    kwargs = {k: _coerce(v, hints[k], f"{where}.{k}" if where else k) for k, v in table.items()}
    return cls(**kwargs)


coerce = _coerce
build = _build


def require_positive(section: str, params, names: typing.Iterable[str]) -> None:
    """ConfigError `section.name: must be > 0, got V` for the first of names that is not > 0."""
    for name in names:
        value = getattr(params, name)
        if not value > 0:
            raise ConfigError(f"{section}.{name}: must be > 0, got {value}")


def require_non_negative(section: str, params, names: typing.Iterable[str]) -> None:
    """ConfigError `section.name: must be >= 0, got V` for the first of names that is negative."""
    for name in names:
        value = getattr(params, name)
        if not value >= 0:
            raise ConfigError(f"{section}.{name}: must be >= 0, got {value}")
