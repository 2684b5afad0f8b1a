"""What one field of an output is: its name, type, unit and meaning, and the range a receiver may hold it to.

Types are written as docs/zenoh.md writes them: `int`, `float`, `string`, `bool`, `float[3]` (a JSON array of three
numbers), `{string: float}` (an object of that value type, e.g. a map of names to probabilities), `[string]`,
`object` (its `fields`), `[object]` (a list of objects, each of its `fields`). Units: `—` (none), `s`, `m`, `m/s`,
`deg`, `deg/s`, `ms`, `Hz`, `dB`. Every field may be null (the contract's unknown and infinite values are null).

`limit` is what a receiver may reject outside: (low, high) for numbers (and for the values of a map), the largest
length for strings and for the items of a [string], the largest magnitude of each component of a float[3].
`size` bounds the entries of a list or map. The bounds are physical and generous (the monitor's checks,
avionics/monitor/schema.py): they tell garbage and hostile samples from data, not normal from abnormal flight.
"""

from __future__ import annotations

from dataclasses import dataclass

# -- limits (numbers: (low, high); strings: the largest length) ------------------------------------------------------
TIME = (-1e6, 1e10)  # s, on the onboard process's clock
DURATION = (-1e7, 1e7)  # s
DISTANCE = (0.0, 1e8)  # m
SIGNED_DISTANCE = (-1e8, 1e8)  # m
ALTITUDE = (-2_000.0, 100_000.0)  # m
SPEED = (0.0, 10_000.0)  # m/s
RATE = (-10_000.0, 10_000.0)  # m/s (vertical), deg/s (turn)
ANGLE = (-360.0, 720.0)  # deg
LATITUDE = (-90.0, 90.0)
LONGITUDE = (-360.0, 360.0)
PROBABILITY = (-1e-6, 1.0 + 1e-6)  # the last bits of a sum of floats
SCHEMA = (0, 1_000_000)
ALERT_LEVEL = (0, 9)
SENSITIVITY_LEVEL = (0, 1_000)
ID_LEN = 64  # vehicle and intruder ids (key expression chunks), callsigns, enumerations
TEXT_LEN = 256  # reasons, RA words, warnings


@dataclass(frozen=True, slots=True)
class Field:
    name: str
    type: str
    unit: str
    meaning: str
    limit: tuple | int | float | None = None
    size: int | None = None  # entries of a list or map
    fields: tuple["Field", ...] = ()  # of an object, or of each object of a [object]
    key_len: int = ID_LEN  # the longest key of a map


def number(name: str, unit: str, limit: tuple, meaning: str) -> Field:
    return Field(name, "float", unit, meaning, limit)


def integer(name: str, limit: tuple, meaning: str, unit: str = "—") -> Field:
    return Field(name, "int", unit, meaning, limit)


def ident(name: str, meaning: str) -> Field:
    """An id or enumeration: a string of at most ID_LEN characters (a future value is shown, not refused)."""
    return Field(name, "string", "—", meaning, ID_LEN)


def text(name: str, meaning: str) -> Field:
    return Field(name, "string", "—", meaning, TEXT_LEN)


def flag(name: str, meaning: str) -> Field:
    return Field(name, "bool", "—", meaning)


def names(fields) -> tuple[str, ...]:
    return tuple(f.name for f in fields)


def by_name(fields) -> dict[str, Field]:
    return {f.name: f for f in fields}
