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
    # MAVLink 2 signing (docs/mavlink.md, "Signing"): a file holding the 32-byte key as 64 hex characters;
    # "" = off. With a key our frames are signed, and wrong-key and replayed frames are rejected.
    signing_key_file: str = ""
    signing_required: bool = True  # with a key: unsigned frames rejected (false: accepted, counted)
    # Whose ADSB_VEHICLE is used: "SYS" (any component) or "SYS:COMP" ids; empty = source_system, any component.
    traffic_sources: tuple[int | str, ...] = ()


def traffic_source_ids(m: MavlinkConfig) -> tuple[tuple[int, int | None], ...]:
    """mavlink.traffic_sources as (system, component or None for any); the default is (source_system, any)."""
    if not m.traffic_sources:
        return ((m.source_system, None),)
    out = []
    for i, entry in enumerate(m.traffic_sources):
        system, sep, component = str(entry).strip().partition(":")
        try:
            ids = (int(system), int(component) if sep else None)
        except ValueError:
            ids = None
        if ids is None or not 1 <= ids[0] <= 255 or (ids[1] is not None and not 0 <= ids[1] <= 255):
            raise ConfigError(f"mavlink.traffic_sources[{i}]: {entry!r} is not \"SYS\" or \"SYS:COMP\" "
                              "(system 1..255, component 0..255)")
        out.append(ids)
    return tuple(out)


def _validate_mavlink(m: MavlinkConfig) -> None:
    traffic_source_ids(m)
    if m.signing_key_file:
        from avionics.io.signing import SigningKeyError, load_key

        try:
            load_key(m.signing_key_file)
        except SigningKeyError as exc:
            raise ConfigError(f"mavlink.signing_key_file: {exc}") from None


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
    # Publishing off the loop (docs/zenoh.md, "Queues, snapshot and liveliness"): advisories are never dropped;
    # tracks, ownship and status wait in a FIFO of this many samples that drops its oldest when full.
    queue_size: int = 4096
    snapshot_changes: int = 256  # advisory changes kept for the snapshot queryable (late join, reconnection)
    reconnect_max_s: float = 1.0  # lost connect endpoints are re-dialled from 0.25 s, doubling up to this
    # TLS (endpoints tls/HOST:PORT): PEM file paths, passed to zenoh's transport/link/tls; "" = not set.
    tls_root_ca_certificate: str = ""  # CA that signed the other side's certificate (needed to connect)
    tls_listen_certificate: str = ""  # our certificate and key on tls/ listen endpoints
    tls_listen_private_key: str = ""
    tls_connect_certificate: str = ""  # our client certificate and key, for mutual TLS
    tls_connect_private_key: str = ""
    tls_enable_mtls: bool = False
    tls_verify_name_on_connect: bool = True


def _validate_zenoh(z: ZenohConfig) -> None:
    if z.queue_size < 1:
        raise ConfigError(f"zenoh.queue_size: must be >= 1, got {z.queue_size}")
    if z.snapshot_changes < 0:
        raise ConfigError(f"zenoh.snapshot_changes: must be >= 0, got {z.snapshot_changes}")
    if not 0.0 < z.reconnect_max_s <= 60.0:
        raise ConfigError(f"zenoh.reconnect_max_s: must be in (0, 60], got {z.reconnect_max_s}")
    files = ("tls_root_ca_certificate", "tls_listen_certificate", "tls_listen_private_key",
             "tls_connect_certificate", "tls_connect_private_key")
    for name in files:
        path = getattr(z, name)
        if path and not Path(path).is_file():
            raise ConfigError(f"zenoh.{name}: no such file {path!r}")
    if bool(z.tls_listen_certificate) != bool(z.tls_listen_private_key):
        raise ConfigError("zenoh.tls_listen_certificate and tls_listen_private_key go together")
    if bool(z.tls_connect_certificate) != bool(z.tls_connect_private_key):
        raise ConfigError("zenoh.tls_connect_certificate and tls_connect_private_key go together")
    if any(e.startswith("tls/") for e in z.listen) and not z.tls_listen_certificate:
        raise ConfigError("zenoh.listen has a tls/ endpoint: set zenoh.tls_listen_certificate and "
                          "zenoh.tls_listen_private_key")
    if any(e.startswith("tls/") for e in z.connect) and not z.tls_root_ca_certificate:
        raise ConfigError("zenoh.connect has a tls/ endpoint: set zenoh.tls_root_ca_certificate")
    if z.tls_enable_mtls and not (z.tls_root_ca_certificate and (z.tls_connect_certificate
                                                                 or z.tls_listen_certificate)):
        raise ConfigError("zenoh.tls_enable_mtls needs tls_root_ca_certificate and our own certificate and key")


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
    # Track filter (docs/tracking.md): cv = one Kalman CV filter per track; imm, rmimm (Hwang's residual-mean
    # likelihood), vb-imm, vb-rmimm (Dai's variational-Bayes measurement noise) = the vectorised IMM tracker.
    filter: str = "imm"  # default by measurement: docs/tracking.md "Default filter"
    imm_horizontal_modes: tuple[str, ...] = ("cv", "ct")  # of cv, ca, ct, cs
    imm_vertical_modes: tuple[str, ...] = ("ch", "cad")  # of ch, cad
    imm_switch_probability: float = 0.05  # per second, out of each mode (Hwang eq 21, Baek & Bang eq 30)
    imm_cv_sigma_mps2: float = 0.3  # CV white acceleration (Baek & Bang eq 5)
    imm_ca_sigma_mps2: float = 3.0  # CA acceleration noise, heading-rotated (Baek & Bang eq 31)
    imm_ct_sigma_mps2: float = 2.0  # CT acceleration increment per step (Hwang eq 18)
    imm_cs_alpha_per_s: float = 0.1  # CS manoeuvre frequency (Dai eq 10)
    imm_cs_max_accel_mps2: float = 20.0  # CS acceleration bound (Dai eq 12)
    imm_ch_sigma_mps: float = 0.1  # CH vertical-speed increment per step (Baek & Bang eq 7)
    imm_cad_sigma_mps2: float = 1.0  # CAD vertical acceleration (Baek & Bang eq 8)
    imm_initial_accel_sigma_mps2: float = 3.0  # prior on an intruder's acceleration at track initiation
    gate_probability: float = 0.9999  # chi-square validation gate (Radosavljevic eq 17)
    rmimm_floor: float = 1.0  # RMIMM: floor of the residual-mean norm (Hwang eq 14), in sigmas
    yaw_rate_time_constant_s: float = 11.9  # turn-rate low-pass 1/(T s + 1) (Hwang)
    vb_iterations: int = 5  # VB fixed-point iterations per report (Dai eqs 22-25)
    vb_c1: float = 1000.0  # VB forgetting factor constants (Dai eq 17), on the estimate / nominal variance
    vb_c2: float = 500.0
    vb_c3: float = 5000.0


@dataclass(frozen=True)
class AltitudeConfig:
    # When only mismatched datums exist (pressure vs geometric), the vertical uncertainty is widened by this
    # much: pressure and GNSS altitudes differ by up to a few hundred feet with temperature and weather.
    datum_mismatch_margin_m: float = 60.96  # 200 ft
    baro_offset_smoothing_s: float = 10.0  # time constant of the geometric - pressure altitude offset
    # Barometer cross-check (tracking/baro_check.py; docs/altitude.md, "Barometer cross-check", has the sources).
    baro_noise_sigma_m: float = 3.5  # pressure altitude 1-sigma: PX4 EKF2_BARO_NOISE (ArduPilot EK3_ALT_M_NSE 2-3)
    baro_gate_sigmas: float = 5.0  # residual gate in sigmas: ArduPilot EK3_HGT_I_GATE default 500 (5 sigma)
    baro_offset_drift_mps: float = 0.1  # how fast weather moves the offset (pressure gradients, tendencies)
    baro_offset_drift_per_m: float = 0.2  # offset change per metre climbed: |T_ISA/T - 1| for T >= T_ISA/1.2
    baro_offset_min_m: float = -1000.0  # QNH 1084.8 hPa (world record) = -579 m, plus the temperature term
    baro_offset_max_m: float = 1700.0  # QNH 870 hPa (world record) = +1267 m, plus the temperature term
    baro_stuck_tolerance_m: float = 1.0  # "no change": above a blocked port's sensor noise (MS5611: 0.1 m RMS)
    baro_recovery_s: float = 5.0  # a faulty pressure is used again after this long plausible and consistent


@dataclass(frozen=True)
class AdvisoryConfig:
    assessment_hz: float = 10.0
    ta_min_duration_s: float = 8.0  # TCAS II: a TA stays at least 8 s
    ra_enabled: bool = True
    hmd_filter: bool = True  # TCAS II v7.1 RA horizontal miss distance filter
    profile: str = "tcas2"  # built-in profile (tcas2, small-uas, do365) or a profile .toml path
    profile_overrides: tuple[str, ...] = ()  # e.g. ("sl4.ra_tau_s=25", "response.delay_s=3")
    criterion: str = "tcas"  # tcas | tcas+pc | pc (docs/advisories.md, "Probabilistic gating")
    pc_ta_threshold: float = 0.1  # Pc of the TA volume needed by tcas+pc and pc
    pc_ra_threshold: float = 0.3  # Pc of the RA volume needed by tcas+pc and pc
    persistence: str = "none"  # none | m-of-n | binomial (Radosavljevic eqs 19-24)
    persistence_m: int = 2
    persistence_n: int = 3
    persistence_confidence: float = 0.5  # binomial: P(at least m of n in conflict) needed
    ground_elevation_m: float | None = None  # AGL = MSL - this; None: AGL from height above home


@dataclass(frozen=True)
class ConflictConfig:
    """Conflict prediction and probability (avionics/conflict/assess.py, docs/conflict.md)."""

    method: str = "exact"  # exact | one_block | blocks | pe | mc
    n_blocks: int = 10  # blocks: number of blocks (Baek & Bang eq 29)
    zone_radius_m: float = 1219.2  # conflict disk radius R: 4000 ft (DO-365 well clear, HMD*)
    zone_half_height_m: float = 137.16  # conflict slab half-height H: 450 ft (DO-365 h*)
    lookahead_s: float = 60.0  # prediction horizon
    step_s: float = 1.0  # prediction step
    accel_sigma_h_mps2: float = 2.0  # relative white acceleration (intruder and ownship) of the prediction
    accel_sigma_v_mps2: float = 1.0
    mc_samples: int = 10000  # method mc: samples per pair and time
    within_samples: int = 500  # trajectories per pair for P(conflict within lookahead); 0: not computed
    # At most this many pairs' within-probabilities per second (token bucket, stalest first): the Monte Carlo
    # costs ~2 ms per pair, and its cost must stay bounded however much traffic converges at once.
    within_max_pairs_per_s: float = 50.0
    seed: int = 0  # Monte Carlo seed (reproducible runs)
    prefilter: str = "min_distance"  # min_distance | hwang | none (Hwang condition 2)
    prefilter_alpha: float = 1.5  # test safety distance alpha R (Hwang: 1.5)
    schedule_period_s: float = 1.0  # Hwang tau: every pair at least this often
    schedule_fast_period_s: float = 0.2  # Hwang tau_c: pairs with Pc >= schedule_threshold this often
    schedule_threshold: float = 0.1  # Hwang P-bar


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
        raise ConfigError(f"{where or 'configuration'}: unknown key(s) {sorted(unknown)}; known: {sorted(names)}")
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


TRACK_FILTERS = ("cv", "imm", "rmimm", "vb-imm", "vb-rmimm")


def _validate_tracking_filter(t: TrackingConfig) -> None:
    if t.filter not in TRACK_FILTERS:
        raise ConfigError(f"tracking.filter: {t.filter!r} is not one of {', '.join(TRACK_FILTERS)}")
    for name, modes, allowed in (("imm_horizontal_modes", t.imm_horizontal_modes, ("cv", "ca", "ct", "cs")),
                                 ("imm_vertical_modes", t.imm_vertical_modes, ("ch", "cad"))):
        if not modes or len(set(modes)) != len(modes) or not set(modes) <= set(allowed):
            raise ConfigError(f"tracking.{name}: {list(modes)} must be distinct modes out of {list(allowed)}")
    for name in ("imm_cv_sigma_mps2", "imm_ca_sigma_mps2", "imm_ct_sigma_mps2", "imm_cs_alpha_per_s",
                 "imm_cs_max_accel_mps2", "imm_ch_sigma_mps", "imm_cad_sigma_mps2", "imm_initial_accel_sigma_mps2",
                 "rmimm_floor", "yaw_rate_time_constant_s"):
        if getattr(t, name) <= 0:
            raise ConfigError(f"tracking.{name}: must be > 0, got {getattr(t, name)}")
    for name in ("vb_c1", "vb_c2", "vb_c3"):
        if getattr(t, name) < 0:
            raise ConfigError(f"tracking.{name}: must be >= 0, got {getattr(t, name)}")
    if not 0.0 < t.imm_switch_probability < 0.5:
        raise ConfigError(f"tracking.imm_switch_probability: must be in (0, 0.5), got {t.imm_switch_probability}")
    if not 0.5 < t.gate_probability < 1.0:
        raise ConfigError(f"tracking.gate_probability: must be in (0.5, 1), got {t.gate_probability}")
    if not 1 <= t.vb_iterations <= 100:
        raise ConfigError(f"tracking.vb_iterations: must be in [1, 100], got {t.vb_iterations}")


def _validate_conflict(c: ConflictConfig) -> None:
    methods = ("exact", "one_block", "blocks", "pe", "mc")
    if c.method not in methods:
        raise ConfigError(f"conflict.method: {c.method!r} is not one of {', '.join(methods)}")
    if c.prefilter not in ("min_distance", "hwang", "none"):
        raise ConfigError(f"conflict.prefilter: {c.prefilter!r} is not min_distance, hwang or none")
    for name in ("zone_radius_m", "zone_half_height_m", "step_s", "schedule_period_s", "schedule_fast_period_s"):
        if getattr(c, name) <= 0:
            raise ConfigError(f"conflict.{name}: must be > 0, got {getattr(c, name)}")
    if c.lookahead_s < 0 or abs(c.lookahead_s / c.step_s - round(c.lookahead_s / c.step_s)) > 1e-9:
        raise ConfigError("conflict.lookahead_s: must be a non-negative multiple of conflict.step_s")
    if c.lookahead_s / c.step_s > 3600:
        raise ConfigError("conflict.lookahead_s / step_s: at most 3600 steps")
    if c.accel_sigma_h_mps2 < 0 or c.accel_sigma_v_mps2 < 0:
        raise ConfigError("conflict.accel_sigma_*: must be >= 0")
    if not 1 <= c.n_blocks <= 1000:
        raise ConfigError("conflict.n_blocks: need 1 <= n_blocks <= 1000")
    if c.mc_samples < 1 or c.within_samples < 0:
        raise ConfigError("conflict.mc_samples must be >= 1 and conflict.within_samples >= 0")
    if not c.within_max_pairs_per_s > 0:
        raise ConfigError("conflict.within_max_pairs_per_s must be > 0")
    if c.prefilter_alpha < 1.0:
        raise ConfigError("conflict.prefilter_alpha: must be >= 1 (Hwang's alpha)")
    if c.schedule_fast_period_s > c.schedule_period_s:
        raise ConfigError("conflict.schedule_fast_period_s must be <= conflict.schedule_period_s")
    if not 0.0 <= c.schedule_threshold <= 1.0:
        raise ConfigError("conflict.schedule_threshold: must be a probability in [0, 1]")


def _validate_altitude(a: AltitudeConfig) -> None:
    for name in ("baro_offset_smoothing_s", "baro_noise_sigma_m", "baro_gate_sigmas", "baro_stuck_tolerance_m"):
        if getattr(a, name) <= 0:
            raise ConfigError(f"altitude.{name}: must be > 0, got {getattr(a, name)}")
    for name in ("datum_mismatch_margin_m", "baro_offset_drift_mps", "baro_offset_drift_per_m", "baro_recovery_s"):
        if getattr(a, name) < 0:
            raise ConfigError(f"altitude.{name}: must be >= 0, got {getattr(a, name)}")
    if not a.baro_offset_min_m < a.baro_offset_max_m:
        raise ConfigError("altitude.baro_offset_min_m must be < altitude.baro_offset_max_m")


def validate(config: Config) -> Config:
    if config.zenoh.mode not in ("peer", "client", "router"):
        raise ConfigError(f"zenoh.mode: {config.zenoh.mode!r} is not peer, client or router")
    _validate_zenoh(config.zenoh)
    _validate_mavlink(config.mavlink)
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
    _validate_tracking_filter(config.tracking)
    _validate_conflict(config.conflict)
    a = config.advisory
    if a.criterion not in ("tcas", "tcas+pc", "pc"):
        raise ConfigError(f"advisory.criterion: {a.criterion!r} is not tcas, tcas+pc or pc")
    if a.persistence not in ("none", "m-of-n", "binomial"):
        raise ConfigError(f"advisory.persistence: {a.persistence!r} is not none, m-of-n or binomial")
    if not 1 <= a.persistence_m <= a.persistence_n <= 50:
        raise ConfigError("advisory.persistence_m and persistence_n: need 1 <= m <= n <= 50")
    for name in ("pc_ta_threshold", "pc_ra_threshold", "persistence_confidence"):
        if not 0.0 <= getattr(a, name) <= 1.0:
            raise ConfigError(f"advisory.{name}: must be a probability in [0, 1]")
    from avionics.advisory.tables import ProfileError, load_profile

    try:
        load_profile(config.advisory.profile, config.advisory.profile_overrides)
    except ProfileError as exc:
        raise ConfigError(f"advisory.profile: {exc}") from exc
    if not config.vehicle.id or any(c in config.vehicle.id for c in "/*$?#"):
        raise ConfigError(f"vehicle.id: {config.vehicle.id!r} must be a non-empty zenoh key chunk "
                          "(no '/', '*', '$', '?', '#')")
    if not 1 <= config.mavlink.source_system <= 255 or not 0 <= config.mavlink.source_component <= 255:
        raise ConfigError("mavlink.source_system must be in 1..255 and mavlink.source_component in 0..255")
    _validate_altitude(config.altitude)
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
