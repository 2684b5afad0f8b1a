"""Where an encounter comes from: a built-in name (avionics_sitl.builtin), a TOML scenario file (avionics_sitl.scenario), a
DAIDALUS .daa file (avionics_sitl.daa_file) or an OpenSky/traffic trajectory table, .csv or .parquet
(avionics_sitl.tables). Above them, so that none of them imports another lazily.

`load_encounter` raises ValueError for every bad name, file or field; `load_scenario` is the same for command
lines, with the error as a ScenarioError (exit 2, one line).
"""

from __future__ import annotations

from pathlib import Path

from avionics_sitl.builtin import BUILTIN
from avionics_sitl.daa_file import read_daa
from avionics_sitl.scenario import Scenario, load_scenario_file
from avionics_sitl.tables import DEFAULT_GAP_S, TABLE_SUFFIXES, is_table, read_trajectory_tables


class ScenarioError(ValueError):
    """The encounter cannot be loaded: an unknown name, or a scenario file that cannot be read or parsed."""


def load_encounter(spec: str, *, ownship: str | None = None, ownship_file: str | None = None,
                   units: str | None = None, gap_s: float = DEFAULT_GAP_S, progress: bool | None = None) -> Scenario:
    """A built-in encounter name (avionics_sitl.builtin.BUILTIN), a .toml scenario file, a DAIDALUS .daa file, or a
    trajectory table (.csv, .parquet) with its ownship (`ownship` icao24 and/or `ownship_file`), unit convention,
    gap and progress options (avionics_sitl.tables.read_trajectory_tables); those options are for tables only."""
    if is_table(spec):
        return read_trajectory_tables(spec, ownship=ownship, ownship_file=ownship_file, units=units, gap_s=gap_s,
                                      progress=progress)
    given = [o for o, v in (("--ownship", ownship), ("--ownship-file", ownship_file), ("--units", units),
                            ("--gap", gap_s != DEFAULT_GAP_S or None)) if v is not None]
    if given:
        raise ValueError(f"{', '.join(given)}: only for trajectory tables ({', '.join(TABLE_SUFFIXES)})")
    if spec in BUILTIN:
        return BUILTIN[spec]()
    suffix = Path(spec).suffix.lower()
    if suffix == ".toml":
        return load_scenario_file(spec)
    if suffix == ".daa":
        return read_daa(Path(spec))
    raise ValueError(
        f"unknown encounter {spec!r}: expected a .toml, .daa, .csv or .parquet file or one of "
        f"{', '.join(sorted(BUILTIN))}"
    )


def load_scenario(spec: str, **table_options) -> Scenario:
    """load_encounter, with its ValueError (every bad name, file or field) as a ScenarioError."""
    try:
        return load_encounter(spec, **table_options)
    except ValueError as exc:
        message = str(exc)
        raise ScenarioError(message if spec in message else f"scenario {spec!r}: {message}") from exc
