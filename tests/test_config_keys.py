"""Every documented configuration key and value runs a short fast-time replay through the real chain.

A setting must never validate and then fail at run time (issue 12). The keys are read from the section dataclasses
(avionics/*/params.py) and checked to be documented in docs/configuration.md, so that a new key cannot be missed:
each key gets every value of its enumerated set (cross-checked against the values the documentation names) or a
valid non-default value, is loaded as an override with `zenoh.enabled=false` (as `sitl replay` does) and drives a
7 s head-on encounter through `avionics_sitl.replay.replay`: MAVLink framing, decoder, tracker, conflict, advisories and
the MAVLink output decoded on the autopilot's side. The replay must raise no `fault.*` counter and alert.

Keys that cannot run in a replay (a link, key or certificate file, zenoh endpoints) are listed in VALIDATION_ONLY
with the reason, and only validated.
"""

from __future__ import annotations

import contextlib
import dataclasses
import fnmatch
import io
import re
import tomllib
import typing
from pathlib import Path

import pytest

from avionics.advisory.params import CRITERIA, PERSISTENCE
from avionics.advisory.vehicle import builtin_vehicles
from avionics.config import Config, ConfigError, load_config
from avionics.conflict.params import CONFLICT_METHODS, PREFILTERS
from avionics.base.units import FT, KT
from avionics.guidance.params import GUIDANCE_MODES
from avionics.io.params import ZENOH_MODES
from avionics.tracking.params import IMM_HORIZONTAL_MODES, IMM_VERTICAL_MODES, TRACK_FILTERS

ROOT = Path(__file__).resolve().parents[1]
DOC = ROOT / "docs" / "configuration.md"
DEFAULT_TOML = ROOT / "config" / "default.toml"
PROFILES = ROOT / "avionics" / "advisory" / "profiles"

SECTIONS = {f.name: f.default_factory for f in dataclasses.fields(Config)}
KEYS = [f"{section}.{f.name}" for section, cls in SECTIONS.items() for f in dataclasses.fields(cls)]


def _field(key: str) -> dataclasses.Field:
    section, name = key.split(".")
    return next(f for f in dataclasses.fields(SECTIONS[section]) if f.name == name)


def _type(key: str):
    section, name = key.split(".")
    return typing.get_type_hints(SECTIONS[section])[name]


def _default(key: str):
    section, name = key.split(".")
    return getattr(SECTIONS[section](), name)


# --- what the documentation says -------------------------------------------------------------------------------

def documented_rows() -> dict[str, list[tuple[str, str]]]:
    """{section: [(key or key pattern, the table row)]} from the "## Keys" tables of docs/configuration.md."""
    text = DOC.read_text()
    keys_part = text.split("\n## Keys\n", 1)[1].split("\n## ", 1)[0]
    rows: dict[str, list[tuple[str, str]]] = {}
    section = None
    for line in keys_part.splitlines():
        heading = re.match(r"### `\[(\w+)\]`", line)
        if heading:
            section = heading.group(1)
            rows[section] = []
        elif section and line.startswith("| `"):
            first_cell = line.split("|")[1]
            for key in re.findall(r"`([^`]+)`", first_cell):
                rows[section].append((key, line))
    return rows


def documented_row(key: str) -> str:
    section, name = key.split(".")
    return next(row for pattern, row in documented_rows()[section] if fnmatch.fnmatchcase(name, pattern))


def default_toml_keys() -> list[str]:
    table = tomllib.loads(DEFAULT_TOML.read_text())
    return [f"{section}.{name}" for section, keys in table.items() for name in keys]


# --- the values --------------------------------------------------------------------------------------------------

BUILTIN_PROFILES = tuple(sorted(p.stem for p in PROFILES.glob("*.toml")))

# Enumerated keys: every value the code accepts (the test checks the documentation names the same set).
ENUMS: dict[str, tuple[str, ...]] = {
    "tracking.filter": TRACK_FILTERS,
    "conflict.method": CONFLICT_METHODS,
    "conflict.prefilter": PREFILTERS,
    "advisory.criterion": CRITERIA,
    "advisory.persistence": PERSISTENCE,
    "advisory.profile": BUILTIN_PROFILES,
    "vehicle.profile": tuple(builtin_vehicles()),
    "zenoh.mode": ZENOH_MODES,  # no session is opened in a replay: every mode is safe
    "guidance.mode": GUIDANCE_MODES,
}
# Mode-set keys: each mode alone and all of them together.
MODE_SETS = {"tracking.imm_horizontal_modes": IMM_HORIZONTAL_MODES,
             "tracking.radar_horizontal_modes": IMM_HORIZONTAL_MODES, "tracking.imm_vertical_modes": IMM_VERTICAL_MODES}

ADSB_COMPONENT = 156  # MAV_COMP_ID_ADSB: the simulated receiver's component (avionics_sitl.autopilot.AutopilotConfig)

# Values given by hand (TOML text as typed after --set): where default * 1.5 is not valid, not meaningful or slow.
EXPLICIT: dict[str, list[str]] = {
    "vehicle.id": ["uav7"],
    "vehicle.own_icao": ["0xA1B2C3"],  # not the intruder's address (0xA10001)
    "mavlink.baud": ["921600"],
    "mavlink.source_system": ["2"],  # the simulated autopilot then uses system 2 (AUTOPILOT below)
    "mavlink.source_component": ["195"],
    "mavlink.traffic_rebroadcast_component": ["193"],
    "mavlink.traffic_sources": ['["1"]', f'["1:{ADSB_COMPONENT}"]', "[1]"],
    "mavlink.ownship_component": ["1"],  # the simulated autopilot's component (it sends no HEARTBEAT)
    "zenoh.key_prefix": ["fleet"],
    "tracking.gate_probability": ["0.999"],
    "advisory.profile": [str(ROOT / "config" / "profiles" / "small-uas.toml")],  # a profile .toml path
    "advisory.profile_overrides": ['["sl4.ra_tau_s=25", "response.delay_s=3", "descend_inhibit_below_agl_ft=1200"]'],
    "advisory.persistence_n": ["5"],
    "advisory.guidance_band_kinds": ['["track_deg"]', '["altitude_m", "ground_speed_mps"]'],
    "advisory.ground_elevation_m": ["150.0"],
    "conflict.mc_samples": ["2000"],  # with method mc; 15000 samples would cost seconds per replay
    "conflict.seed": ["7"],
    "guidance.ceiling_m": ["120.0"],
    "guidance.retries": ["5"],
    "guidance.track_margin_deg": ["10.0"],
    "guidance.ladder": ['["warn", "hold", "land"]', '["none", "return"]'],
}

# Overrides a key needs to have any effect (applied before the key's own override).
CONTEXT: dict[str, tuple[str, ...]] = {
    "tracking.horizontal_accel_sigma_mps2": ("tracking.filter=cv",),
    "tracking.vertical_accel_sigma_mps2": ("tracking.filter=cv",),
    "tracking.imm_ca_sigma_mps2": ('tracking.imm_horizontal_modes=["cv", "ca"]',),
    "tracking.imm_cs_alpha_per_s": ('tracking.imm_horizontal_modes=["cv", "cs"]',),
    "tracking.imm_turn_rate_dps": ('tracking.imm_horizontal_modes=["cv", "turn_left", "turn_right"]',),
    "tracking.imm_turn_sigma_mps2": ('tracking.imm_horizontal_modes=["cv", "turn_left", "turn_right"]',),
    "tracking.imm_turn_exit_probability": ('tracking.imm_horizontal_modes=["cv", "turn_left", "turn_right"]',),
    "tracking.imm_cs_max_accel_mps2": ('tracking.imm_horizontal_modes=["cv", "cs"]',),
    "tracking.rmimm_floor": ("tracking.filter=rmimm",),
    "tracking.vb_iterations": ("tracking.filter=vb-imm",),
    "tracking.vb_c1": ("tracking.filter=vb-rmimm",),
    "tracking.vb_c2": ("tracking.filter=vb-rmimm",),
    "tracking.vb_c3": ("tracking.filter=vb-rmimm",),
    "advisory.pc_ta_threshold": ("advisory.criterion=tcas+pc",),
    "advisory.pc_ra_threshold": ("advisory.criterion=tcas+pc",),
    "advisory.persistence_m": ("advisory.persistence=m-of-n",),
    "advisory.persistence_n": ("advisory.persistence=m-of-n",),
    "advisory.persistence_confidence": ("advisory.persistence=binomial",),
    "advisory.guidance_band_kinds": ("advisory.profile=do365",),  # the bands of a DO-365 alerter
    "conflict.n_blocks": ("conflict.method=blocks",),
    "conflict.mc_samples": ("conflict.method=mc",),
    "conflict.prefilter_alpha": ("conflict.prefilter=hwang",),
    # guidance: any mode but passive flies within a vehicle profile; its keys act in execute
    "guidance.mode": ("vehicle.profile=multirotor",),
    **{f"guidance.{k}": ("vehicle.profile=multirotor", "guidance.mode=execute") for k in (
        "floor_m", "ceiling_m", "quiet_time_s", "setpoint_period_s", "ack_timeout_s", "retries", "require_signing",
        "ladder")},
    "guidance.track_margin_deg": ("vehicle.profile=multirotor", "guidance.mode=execute", "advisory.profile=do365"),
}

# Keys that cannot run in a replay, with the reason: validated only (test_validation_only_keys).
VALIDATION_ONLY: dict[str, str] = {
    "mavlink.connection": "the replay has no link: the schedule is framed and fed in memory",
    "mavlink.signing_key_file": "needs a key file, and the simulated autopilot does not sign its frames",
    "zenoh.enabled": "sitl replay always forces zenoh.enabled=false (it publishes nothing)",
    "zenoh.listen": "endpoints are opened only by a zenoh session, which a replay never opens",
    "zenoh.connect": "endpoints are opened only by a zenoh session, which a replay never opens",
    "zenoh.ros2_namespace": "the ROS 2 keys are declared only by a zenoh session (tests/test_ros2.py runs one)",
    "zenoh.tls_root_ca_certificate": "a PEM file path, used only by a zenoh session",
    "zenoh.tls_listen_certificate": "a PEM file path, used only by a zenoh session",
    "zenoh.tls_listen_private_key": "a PEM file path, used only by a zenoh session",
    "zenoh.tls_connect_certificate": "a PEM file path, used only by a zenoh session",
    "zenoh.tls_connect_private_key": "a PEM file path, used only by a zenoh session",
    "zenoh.tls_enable_mtls": "needs the certificate files, used only by a zenoh session",
    "zenoh.auth_user": "goes with auth_password_file, used only by a zenoh session",
    "zenoh.auth_password_file": "a file path, used only by a zenoh session",
    "zenoh.auth_dictionary_file": "a file path, used only by a zenoh session",
    "zenoh.config_file": "a zenoh configuration file, read only by a zenoh session",
    "mavlink.tcpin_idle_timeout_s": "the replay has no link (tcpin connections: tests/test_link.py)",
}

# (key, value) cases that may legitimately end the replay without any alert, with the reason. None today.
MAY_NOT_ALERT: dict[tuple[str, str], str] = {}


def _toml(value) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, (tuple, list)):
        return "[" + ", ".join(_toml(v) for v in value) + "]"
    if isinstance(value, str):
        return f'"{value}"'
    return repr(value)


def values_for(key: str) -> list[str]:
    """The values a key is replayed with, as TOML text."""
    if key in ENUMS:
        return [_toml(v) for v in ENUMS[key]] + EXPLICIT.get(key, [])
    if key in MODE_SETS:
        modes = MODE_SETS[key]
        return [_toml([m]) for m in modes] + [_toml(list(modes))]
    if key in EXPLICIT:
        return EXPLICIT[key]
    annotation, default = _type(key), _default(key)
    if annotation is bool:
        return [_toml(not default)]
    if annotation is int and default:
        return [_toml(round(default * 1.5))]
    if annotation is float and default:
        return [_toml(float(f"{default * 1.5:.12g}"))]
    raise AssertionError(f"{key}: no replay value; add one to EXPLICIT or the key to VALIDATION_ONLY")


CASES = [(key, value) for key in KEYS if key not in VALIDATION_ONLY for value in values_for(key)]


# --- the encounter -----------------------------------------------------------------------------------------------

# tcas2 SL4 (3000 ft): inside the TA tau (30 s) from the first report, TA at ~0.6 s and RA (tau 20 s) at ~5 s. A
# replay costs ~0.3 s of CPU: the whole file must stay within the CI budget (~90 s).
T_CPA_S = 26.0
DURATION_S = 7.0


def short_head_on():
    """Head-on at 3000 ft MSL, 125 kt each, on one meridian, CPA (0 m) 26 s in, flown for 7 s."""
    from avionics_sitl.scenario import AircraftSpec, Scenario

    speed, alt = 125 * KT, 3000 * FT
    north_m = 2 * speed * T_CPA_S
    own = AircraftSpec("ownship", 0xC00001, 0.0, 0.0, alt, 0.0, speed, emitter_type=14)  # UAV
    intruder = AircraftSpec("intruder", 0xA10001, north_m / 111_320.0, 0.0, alt, 180.0, speed)
    return Scenario("short-head-on", "test_config_keys", own, (intruder,), duration_s=DURATION_S)


@pytest.fixture(scope="module")
def encounter():
    return short_head_on()


def _autopilot(key: str, value: str):
    from avionics_sitl.autopilot import AutopilotConfig

    if key == "mavlink.source_system":
        return AutopilotConfig(system_id=int(value))
    return AutopilotConfig()


def _expected(value: str, annotation):
    """The TOML text as load_config stores it (lists as tuples, integers of float keys as floats)."""
    try:
        parsed = tomllib.loads(f"v = {value}")["v"]
    except tomllib.TOMLDecodeError:
        parsed = value
    if isinstance(parsed, list):
        return tuple(parsed)
    if isinstance(parsed, int) and not isinstance(parsed, bool) and float in typing.get_args(annotation) + (annotation,):
        return float(parsed)
    return parsed


# --- the tests ---------------------------------------------------------------------------------------------------

def test_every_key_of_every_section_is_documented_and_nothing_else():
    rows = documented_rows()
    assert set(rows) == set(SECTIONS), "docs/configuration.md has one '### `[section]`' table per section"
    for key in KEYS:
        section, name = key.split(".")
        assert any(fnmatch.fnmatchcase(name, p) for p, _ in rows[section]), f"{key} is not in docs/configuration.md"
    for section, entries in rows.items():
        names = [f.name for f in dataclasses.fields(SECTIONS[section])]
        for pattern, _ in entries:
            assert fnmatch.filter(names, pattern), f"docs/configuration.md documents {section}.{pattern}: no such key"


def test_default_toml_keys_are_known_and_documented():
    for key in default_toml_keys():
        assert key in KEYS, f"config/default.toml: {key} is not a configuration key"
        documented_row(key)


@pytest.mark.parametrize("key", sorted({*ENUMS, *MODE_SETS}))
def test_enumerated_values_are_the_documented_ones(key):
    """The values the code accepts (and this test replays) are those the key's row in docs/configuration.md names."""
    section, name = key.split(".")
    allowed = set(ENUMS.get(key) or MODE_SETS[key])
    row = documented_row(key)
    cells = row.split("|")[1:-1]
    keys = {f.name for f in dataclasses.fields(SECTIONS[section])}
    text = "|".join(cells[:1] + cells[2:])  # every cell but the default
    named = {t for t in re.findall(r"`([^`]+)`", text) if t not in keys and not re.search(r"[./\[\]\"=]", t)}
    assert named == allowed, f"{key}: documented {sorted(named)}, accepted {sorted(allowed)}"
    for value in allowed:
        load_config(overrides=[f"{key}={_toml([value]) if key in MODE_SETS else _toml(value)}"])
    with pytest.raises(ConfigError, match=re.escape(key)):
        load_config(overrides=[f"{key}={_toml(['nope']) if key in MODE_SETS else _toml('nope')}"])


def test_every_key_is_replayed_or_listed_as_validation_only():
    replayed = {key for key, _ in CASES}
    assert replayed | set(VALIDATION_ONLY) == set(KEYS)
    assert not replayed & set(VALIDATION_ONLY)
    assert set(VALIDATION_ONLY) <= set(KEYS) and set(EXPLICIT) | set(CONTEXT) <= set(KEYS)
    for key, value in CASES:  # a non-default value, except the defaults among enumerated values
        if key not in ENUMS and key not in MODE_SETS:
            assert _expected(value, _type(key)) != _default(key), key


@pytest.mark.parametrize("key, value", CASES, ids=[f"{k}={v}" for k, v in CASES])
def test_documented_value_runs_a_short_replay(key, value, encounter):
    from avionics_sitl.impairments import PRESETS
    from avionics_sitl.replay import replay

    config = load_config(overrides=[*CONTEXT.get(key, ()), f"{key}={value}", "zenoh.enabled=false"])
    section, name = key.split(".")
    assert getattr(getattr(config, section), name) == _expected(value, _type(key))
    with contextlib.redirect_stdout(io.StringIO()):  # the node's STATUSTEXT log lines
        result = replay(encounter, config, PRESETS["default"], seed=1, autopilot=_autopilot(key, value))
    faults = {k: v for k, v in result.counters.items() if k.startswith("fault.")}
    assert not faults, f"{key}={value}: {faults}"
    if (key, value) not in MAY_NOT_ALERT:
        levels = {c.level.name for c in result.changes}
        assert levels & {"TA", "RA"}, f"{key}={value}: no alert in {DURATION_S} s ({result.counters})"
        assert result.collisions, f"{key}={value}: the autopilot got no COLLISION"


# --- keys that cannot run in a replay: validation only -----------------------------------------------------------

def _pem(tmp_path: Path, name: str) -> str:
    path = tmp_path / name
    path.write_text("-----BEGIN CERTIFICATE-----\n-----END CERTIFICATE-----\n")
    return str(path)


def test_validation_only_keys(tmp_path):
    # mavlink.connection: any string is taken (opened at start-up); not a string is an error.
    for text in ("/dev/ttyAMA0", "udpout:127.0.0.1:14660", "tcp:127.0.0.1:5760", "tcpin:0.0.0.0:5760"):
        assert load_config(overrides=[f"mavlink.connection={text}"]).mavlink.connection == text
    with pytest.raises(ConfigError, match="mavlink.connection"):
        load_config(overrides=["mavlink.connection=14550"])
    # mavlink.signing_key_file: a file of 64 hex characters loads; a wrong one names the key.
    key = tmp_path / "signing.key"
    key.write_text("0123456789abcdef" * 4 + "\n")
    assert load_config(overrides=[f"mavlink.signing_key_file={key}"]).mavlink.signing_key_file == str(key)
    bad = tmp_path / "bad.key"
    bad.write_text("not hex\n")
    for path in (bad, tmp_path / "missing.key"):
        with pytest.raises(ConfigError, match="mavlink.signing_key_file"):
            load_config(overrides=[f"mavlink.signing_key_file={path}"])
    # zenoh.enabled: both booleans; not a boolean is an error.
    assert load_config(overrides=["zenoh.enabled=false"]).zenoh.enabled is False
    assert load_config(overrides=["zenoh.enabled=true"]).zenoh.enabled is True
    with pytest.raises(ConfigError, match="zenoh.enabled"):
        load_config(overrides=["zenoh.enabled=yes"])
    # zenoh.listen / connect: lists of endpoints.
    cfg = load_config(overrides=['zenoh.listen=["tcp/0.0.0.0:7447"]', 'zenoh.connect=["tcp/10.10.0.1:7447"]'])
    assert cfg.zenoh.listen == ("tcp/0.0.0.0:7447",) and cfg.zenoh.connect == ("tcp/10.10.0.1:7447",)
    assert load_config(overrides=["zenoh.listen=[]"]).zenoh.listen == ()
    for name in ("listen", "connect"):
        with pytest.raises(ConfigError, match=f"zenoh.{name}: expected a list"):
            load_config(overrides=[f"zenoh.{name}=tcp/0.0.0.0:7447"])
    # zenoh.tls_*: existing PEM files, in pairs, and mutual TLS needs a CA and our own certificate.
    ca, cert, pkey = _pem(tmp_path, "ca.pem"), _pem(tmp_path, "cert.pem"), _pem(tmp_path, "key.pem")
    cfg = load_config(overrides=[f"zenoh.tls_root_ca_certificate={ca}", f"zenoh.tls_listen_certificate={cert}",
                                 f"zenoh.tls_listen_private_key={pkey}", f"zenoh.tls_connect_certificate={cert}",
                                 f"zenoh.tls_connect_private_key={pkey}", "zenoh.tls_enable_mtls=true",
                                 'zenoh.listen=["tls/127.0.0.1:7448"]', 'zenoh.connect=["tls/127.0.0.1:7449"]'])
    assert cfg.zenoh.tls_enable_mtls and cfg.zenoh.tls_root_ca_certificate == ca
    for name in ("tls_root_ca_certificate", "tls_listen_certificate", "tls_listen_private_key",
                 "tls_connect_certificate", "tls_connect_private_key"):
        with pytest.raises(ConfigError, match=f"zenoh.{name}: no such file"):
            load_config(overrides=[f"zenoh.{name}={tmp_path / 'missing.pem'}"])
    for name in ("tls_listen_certificate", "tls_connect_certificate"):
        with pytest.raises(ConfigError, match="go together"):
            load_config(overrides=[f"zenoh.{name}={cert}"])
    with pytest.raises(ConfigError, match="zenoh.tls_enable_mtls"):
        load_config(overrides=["zenoh.tls_enable_mtls=true"])
    # zenoh.auth_*, config_file: a user with a password file whose first line is the password, existing files,
    # a file zenoh reads as its configuration.
    password, users, conf = tmp_path / "pw", tmp_path / "users.txt", tmp_path / "z.json5"
    password.write_text("s3cret\n")
    users.write_text("uav1:s3cret\n")
    conf.write_text("{ access_control: { enabled: false } }")
    cfg = load_config(overrides=["zenoh.auth_user=uav1", f"zenoh.auth_password_file={password}",
                                 f"zenoh.auth_dictionary_file={users}", f"zenoh.config_file={conf}"])
    assert (cfg.zenoh.auth_user, cfg.zenoh.config_file) == ("uav1", str(conf))
    for override in ("zenoh.auth_user=uav1", f"zenoh.auth_password_file={password}"):
        with pytest.raises(ConfigError, match="go together"):
            load_config(overrides=[override])
    for name in ("auth_password_file", "auth_dictionary_file", "config_file"):
        with pytest.raises(ConfigError, match=f"zenoh.{name}: no such file"):
            load_config(overrides=[f"zenoh.{name}={tmp_path / 'missing'}"])
    (tmp_path / "empty").write_text("\n")
    with pytest.raises(ConfigError, match="holds no password"):
        load_config(overrides=["zenoh.auth_user=uav1", f"zenoh.auth_password_file={tmp_path / 'empty'}"])
    (tmp_path / "bad.json5").write_text("{ mode: ")
    with pytest.raises(ConfigError, match="zenoh.config_file: .* is not a zenoh configuration"):
        load_config(overrides=[f"zenoh.config_file={tmp_path / 'bad.json5'}"])
    # mavlink.tcpin_idle_timeout_s: > 0.
    assert load_config(overrides=["mavlink.tcpin_idle_timeout_s=0.5"]).mavlink.tcpin_idle_timeout_s == 0.5
    with pytest.raises(ConfigError, match="mavlink.tcpin_idle_timeout_s"):
        load_config(overrides=["mavlink.tcpin_idle_timeout_s=0"])


# --- each component validates its own section --------------------------------------------------------------------

@pytest.mark.parametrize("override", [
    "vehicle.id=a/b", "mavlink.heartbeat_hz=0", "mavlink.source_system=0", 'mavlink.traffic_sources=["x"]',
    "mavlink.ownship_component=256", "input.ownship_jump_m=0", "input.ownship_jump_persist_s=0",
    "zenoh.mode=router2", "zenoh.tracks_hz=0", "zenoh.queue_size=0", 'zenoh.key_prefix=""', "zenoh.key_prefix=a//b",
    "zenoh.key_prefix=/daa", "zenoh.key_prefix=daa/*", "input.max_report_age_s=0",
    "tracking.max_coast_s=0", "tracking.filter=kf", "tracking.gate_probability=1.0", "altitude.baro_noise_sigma_m=0",
    'tracking.radar_horizontal_modes=["cv", "zz"]', "tracking.radar_switch_probability=0.5",
    "tracking.imm_turn_exit_probability=0", "tracking.imm_turn_rate_dps=0", "tracking.range_track_bearing_sigma_deg=0",
    "tracking.range_rate_correlation_s=-1",
    "altitude.baro_offset_min_m=2000", "advisory.assessment_hz=0", "advisory.criterion=x", "advisory.profile=nope",
    "conflict.method=x", "conflict.step_s=0", "conflict.n_blocks=0",
])
def test_each_section_rejects_a_bad_value_naming_its_key(override):
    """The section's own validate() rejects the value alone (the component checks itself), and so does load_config."""
    from avionics.config import _parse_override
    from avionics.base.params import _build

    section = override.split(".")[0]
    with pytest.raises(ConfigError, match=re.escape(section) + r"\."):
        load_config(overrides=[override])
    params = _build(SECTIONS[section], _parse_override(override)[section], section)
    with pytest.raises(ConfigError, match=re.escape(section) + r"\."):
        params.validate()
