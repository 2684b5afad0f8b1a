"""Where an encounter comes from: a built-in name (avionics_sitl.builtin), a TOML scenario file (avionics_sitl.scenario) or a
DAIDALUS .daa file (avionics_sitl.daa_file). Above the three, so that none of them imports another lazily.

`load_encounter` raises ValueError for every bad name, file or field; `load_scenario` is the same for command
lines, with the error as a ScenarioError (exit 2, one line).
"""

from __future__ import annotations

from pathlib import Path

from avionics_sitl.builtin import BUILTIN
from avionics_sitl.daa_file import read_daa
from avionics_sitl.scenario import Scenario, load_scenario_file


class ScenarioError(ValueError):
    """The encounter cannot be loaded: an unknown name, or a scenario file that cannot be read or parsed."""


def load_encounter(spec: str) -> Scenario:
    """A built-in encounter name (avionics_sitl.builtin.BUILTIN), a .toml scenario file or a DAIDALUS .daa file."""
    if spec in BUILTIN:
        return BUILTIN[spec]()
    suffix = Path(spec).suffix.lower()
    if suffix == ".toml":
        return load_scenario_file(spec)
    if suffix == ".daa":
        return read_daa(Path(spec))
    raise ValueError(
        f"unknown encounter {spec!r}: expected a .toml or .daa file or one of {', '.join(sorted(BUILTIN))}"
    )


def load_scenario(spec: str) -> Scenario:
    """load_encounter, with its ValueError (every bad name, file or field) as a ScenarioError."""
    try:
        return load_encounter(spec)
    except ValueError as exc:
        message = str(exc)
        raise ScenarioError(message if spec in message else f"scenario {spec!r}: {message}") from exc
