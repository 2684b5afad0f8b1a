"""Mutated configurations, profiles and trajectory tables are accepted or refused with a clear error (ConfigError /
ScenarioError: exit 2), never an exception of another kind (exit 70 with a traceback).

In-process against the validation the commands run (avionics.config.load_config: what `avionics config`, `run`
and `sitl replay` call; avionics_sitl.encounters.load_scenario), for speed. An accepted configuration must also
build the onboard core and take a step: `avionics config` accepting what `run` then crashes on was the bug
(advisory.assessment_hz = 1e-320)."""

from __future__ import annotations

import dataclasses
import random
from pathlib import Path

import pytest
from hypothesis import example, given, settings, strategies as st

from avionics.config import Config, ConfigError, load_config

ROOT = Path(__file__).resolve().parent.parent
PROFILES = sorted((ROOT / "config" / "profiles").glob("*.toml"))

KEYS = [f"{section.name}.{f.name}" for section in dataclasses.fields(Config)
        for f in dataclasses.fields(section.default_factory())]

# TOML values of every kind and the extremes the fuzzing found: wrong types, inf/nan, subnormal and huge floats,
# integers past int64 and past Python's 4300-digit int-str limit.
EXTREMES = ["1e-320", "-1e-320", "5e-324", "1e308", "-1e308", "inf", "-inf", "nan", "0", "-0.0", "-1", "1e-12",
            "1e12", f"{2**63}", f"-{2**63 + 1}", "9" * 400, "9" * 4400, '"x"', '""', "{a = 1}", "[]", '[1, "a"]',
            "true", "false", "1979-05-27", '"do365"', '"nope"']
values = st.one_of(
    st.sampled_from(EXTREMES),
    st.integers(min_value=-(2**70), max_value=2**70).map(str),
    st.floats(allow_nan=True, allow_infinity=True).map(lambda x: repr(x).replace("nan", "nan").replace("inf", "inf")),
    st.text(alphabet="abc/*$ .", max_size=8).map(lambda s: f'"{s}"'),
)


def _accepted_config_runs(config: Config) -> None:
    """The core is built from it and steps (what `avionics run` does first with a configuration)."""
    from avionics.daa import Daa

    daa = Daa(config)
    daa.step(0.0)
    daa.shutdown(1.0)


def _load(path: Path | None, overrides=()) -> None:
    try:
        config = load_config(path, overrides)
    except ConfigError as exc:
        assert str(exc) and "\n" not in str(exc).strip()
        return
    _accepted_config_runs(config)


def _toml(assignments: list[tuple[str, str]]) -> str:
    tables: dict[str, list[str]] = {}
    for key, value in assignments:
        section, name = key.split(".", 1)
        tables.setdefault(section, []).append(f"{name} = {value}")
    return "".join(f"[{section}]\n" + "\n".join(lines) + "\n" for section, lines in tables.items())


@settings(max_examples=150)
@given(st.lists(st.tuples(st.sampled_from(KEYS), values), min_size=1, max_size=3, unique_by=lambda kv: kv[0]),
       st.booleans(), st.binary(min_size=1, max_size=4))
def test_a_mutated_config_file_is_accepted_or_refused_in_one_line(tmp_path_factory, assignments, corrupt, noise):
    text = _toml(assignments).encode()
    if corrupt:  # bytes that may not be UTF-8, inside a string or anywhere
        at = random.Random(len(text)).randrange(len(text))
        text = text[:at] + noise + b"\xff" + text[at:]
    path = tmp_path_factory.mktemp("config") / "mutated.toml"
    path.write_bytes(text)
    _load(path)


@settings(max_examples=150)
@given(st.sampled_from(KEYS), values)
@example("conflict.seed", "-1")  # found by CI 2026-12-05: numpy's SeedSequence raised ValueError in the core
@example("zenoh.tls_root_ca_certificate", "9" * 4400)  # the same run: a file name the OS refuses (ENAMETOOLONG)
@example("vehicle.profile", "9" * 4400)
@example("advisory.profile", "9" * 4400)
def test_a_mutated_override_is_accepted_or_refused_in_one_line(key, value):
    _load(None, [f"{key}={value}"])


def _profile_lines(path: Path) -> list[int]:
    lines = path.read_text().splitlines()
    return [i for i, line in enumerate(lines) if "=" in line and not line.lstrip().startswith("#")]


@settings(max_examples=200)
@given(st.sampled_from(PROFILES), st.data(), st.lists(values, min_size=1, max_size=3))
def test_a_mutated_profile_is_accepted_or_refused_in_one_line(tmp_path_factory, profile, data, new_values):
    lines = profile.read_text().splitlines()
    for value in new_values:
        i = data.draw(st.sampled_from(_profile_lines(profile)))
        key = lines[i].split("=", 1)[0]
        lines[i] = f"{key}= {value}"
    path = tmp_path_factory.mktemp("profile") / "mutated.toml"
    path.write_text("\n".join(lines) + "\n")
    _load(None, [f'advisory.profile="{path}"'])


@pytest.mark.parametrize("column,value", [("altitude", "1e20"), ("altitude", "-1e9"), ("groundspeed", "1e300"),
                                          ("vertical_rate", "-1e12"), ("track", "1e300"), ("latitude", "89.9"),
                                          ("longitude", "-170.0"), ("altitude", "65000"), ("groundspeed", "5000")])
def test_a_trajectory_table_with_an_extreme_finite_value_is_a_scenario_error(tmp_path, column, value):
    """Extreme finite values once crashed the simulator's MAVLink encoder (struct.error) or the tangent plane
    (NaN): now each is refused naming its row, or replayed within the MAVLink fields' ranges."""
    from avionics_sitl.autopilot import Packer, schedule
    from avionics_sitl.encounters import ScenarioError, load_scenario
    from avionics_sitl.impairments import PRESETS

    rows = (ROOT / "tests" / "data" / "opensky_cdg_crossing.csv").read_text().splitlines()
    header = rows[0].split(",")
    fields = rows[7].split(",")
    fields[header.index(column)] = value
    path = tmp_path / "extreme.csv"
    path.write_text("\n".join(rows[:7] + [",".join(fields)] + rows[8:]) + "\n")
    try:
        scenario = load_scenario(str(path), ownship="3944e7")
    except ScenarioError as exc:
        assert "row 7" in str(exc) or "km from ownship" in str(exc), exc
        return
    packer = Packer()
    for event in schedule(scenario, PRESETS["default"], 0):
        packer.pack(event.msg)
