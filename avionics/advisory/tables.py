"""Alerting profiles as data: sensitivity-level tables, low-altitude inhibits and the pilot/autopilot response
model, loaded from TOML (avionics/advisory/profiles/*.toml, also reachable as config/profiles/).

Built-in profiles: `tcas2` (TCAS II v7.1), `small-uas` (well clear for small UAS, ASTM F3442), `daidalus-tcas3d`
(DAIDALUS TCAS3D.conf), and the DO-365 well-clear alerters with an [alerter] table (kind "wcv"):
`daidalus-do365b-no-sum` (DAIDALUS DO_365B_no_SUM.conf, Phase I DWC), `do365` (the project's: the same levels),
`do365-non-coop` (the DO-365B non-cooperative volume) and `small-uas-wcv` (ASTM F3442-like small-UAS volumes). A profile is chosen by name or path (advisory.profile) and any value overridden
with advisory.profile_overrides, e.g. ["sl4.ra_tau_s=25", "response.delay_s=3"].
"""

from __future__ import annotations

import math
import tomllib
from dataclasses import dataclass, replace
from importlib import resources
from pathlib import Path

from avionics.advisory.levels import AlertLevel
from avionics.advisory.wcv import WCV_TAUMOD, WcvThresholds
from avionics.advisory.wcv_sum import WCV_TAUMOD_SUM, SumZScores
from avionics.base.params import ConfigError, _show, check_float, is_file
from avionics.base.types import AdvisoryLevel
from avionics.base.units import FT, FPM, G0, NM

PROFILE_DIR = "profiles"
DISTANCE_UNITS = {"_nm": NM, "_ft": FT, "_m": 1.0}


@dataclass(frozen=True, slots=True)
class SensitivityLevel:
    sl: int
    ceiling_m: float  # the band holds altitudes <= this (an AGL band below 1000 ft: < this)
    agl_band: bool  # band bounds are above ground level (TCAS SL 2, 3); else pressure altitude
    ta_tau_s: float
    ta_dmod_m: float
    ta_zthr_m: float
    ra_tau_s: float | None = None  # None: no RA at this level
    ra_dmod_m: float | None = None
    ra_zthr_m: float | None = None
    alim_m: float | None = None
    ra_hmd_m: float | None = None  # RA horizontal miss distance filter


@dataclass(frozen=True, slots=True)
class ResponseModel:
    """How ownship answers an RA: after delay_s, accelerate at accel to rate (DO-185B standard response). A
    vehicle that descends slower than it climbs (avionics/vehicle.py: a multirotor's autopilot limits) has its own
    descent rates; None: the same as the climb."""

    delay_s: float
    accel_mps2: float
    rate_mps: float
    strengthen_delay_s: float  # strengthening and reversal
    strengthen_accel_mps2: float
    strengthen_rate_mps: float
    descent_rate_mps: float | None = None
    strengthen_descent_rate_mps: float | None = None

    def rate(self, climb: bool, strong: bool = False) -> float:
        """The corrective (strong: increase) rate's magnitude in the sense, climb or descend."""
        if climb:
            return self.strengthen_rate_mps if strong else self.rate_mps
        if strong:
            return self.strengthen_rate_mps if self.strengthen_descent_rate_mps is None else self.strengthen_descent_rate_mps
        return self.rate_mps if self.descent_rate_mps is None else self.descent_rate_mps


@dataclass(frozen=True, slots=True)
class WcvAlerterSpec:
    """A DO-365 well-clear alerter ([alerter] kind = "wcv" of a profile): its levels 1..n (least severe first; each
    an advisory/levels.py AlertLevel, DAIDALUS's AlertThresholds, read by the alerter and the guidance bands alike)
    and DAIDALUS's alerting hysteresis (HysteresisData: M of N over evaluations every period_s, persistence,
    reset after hysteresis_time_s without an evaluation). source: where the numbers come from."""

    source: str
    levels: tuple[AlertLevel, ...]
    hysteresis_time_s: float
    persistence_time_s: float
    alerting_m: int
    alerting_n: int
    period_s: float
    sum: SumZScores | None = None  # [alerter.sum]: the levels' detector is WCV_TAUMOD_SUM with these z-scores
    lookahead_s: float = 180.0  # DAIDALUS lookahead_time: the SUM detector's detection interval [0, lookahead]
    # the profile whose [alerter] judges the intruders seen only by the ownship's sensors (DAIDALUS's per-intruder
    # alerter; DO-365B: DWC_Non_Coop beside the Phase I volume); None: this one judges every intruder
    non_cooperative: str | None = None


@dataclass(frozen=True, slots=True)
class AlertProfile:
    name: str
    description: str
    levels: tuple[SensitivityLevel, ...]
    response: ResponseModel
    ra_inhibit_below_agl_m: float
    descend_inhibit_below_agl_m: float
    increase_descent_inhibit_below_agl_m: float
    sl_hysteresis_m: float
    inhibit_hysteresis_m: float = 0.0  # each inhibit engages below its height - this, releases above + this
    max_threat_vertical_rate_mps: float = math.inf  # no RA against an intruder whose |vertical rate| exceeds this
    alerter: WcvAlerterSpec | None = None  # None: the TCAS II alerter over the sensitivity-level table
    bands: object | None = None  # advisory/bands.py BandsParams of a DO-365 alerter's guidance ([bands] table)


class ProfileError(ValueError):
    """A profile file or override that cannot be used, naming the key."""


def _distance(table: dict, key: str, where: str, required: bool = True) -> float | None:
    found = [(suffix, k) for suffix in DISTANCE_UNITS if (k := key + suffix) in table]
    if not found:
        if required:
            raise ProfileError(f"{where}: missing {key}_nm, {key}_ft or {key}_m")
        return None
    if len(found) > 1:
        raise ProfileError(f"{where}: give {key} in one unit only")
    suffix, k = found[0]
    return _number(table[k], f"{where}.{k}") * DISTANCE_UNITS[suffix]


def _number(value, where: str, infinite: bool = False) -> float:
    """A number >= 0 of the magnitudes a configuration can hold (avionics/base/params.py check_float); inf only
    where it means "no limit" (a last ceiling, no vertical-rate rule)."""
    if infinite and isinstance(value, float) and value == math.inf:
        return value
    try:
        x = check_float(value, where)
    except ConfigError as exc:
        raise ProfileError(str(exc)) from None
    if x < 0:
        raise ProfileError(f"{where}: expected a number >= 0, got {value!r}")
    return x


def _integer(value, where: str, low: int, high: int) -> int:
    """A whole number in low..high (an override's number arrives as a float: 2.0 is 2)."""
    if isinstance(value, float) and value.is_integer():
        value = int(value)
    if isinstance(value, bool) or not isinstance(value, int) or not low <= value <= high:
        raise ProfileError(f"{where}: expected a whole number in {low}..{high}, got {_show(value)}")
    return value


def _table(value, where: str) -> dict:
    if not isinstance(value, dict):
        raise ProfileError(f"{where}: expected a table, got {_show(value)}")
    return value


def _tables(value, where: str) -> list[dict]:
    """An array of tables ([[levels]])."""
    if not isinstance(value, list):
        raise ProfileError(f"{where}: expected an array of tables, got {_show(value)}")
    return [_table(row, f"{where}[{i}]") for i, row in enumerate(value)]


def _text(value, where: str) -> str:
    if not isinstance(value, str):
        raise ProfileError(f"{where}: expected a string, got {_show(value)}")
    return value


SL_MAX = 99  # sensitivity levels are small numbers (TCAS II: 1..7, DO-185B; our tables: up to 8)
LEVEL_KEYS = {"sl", "ceiling_ft", "agl", "ta_tau_s", "ra_tau_s"} | {
    f"{name}{suffix}" for name in ("ta_dmod", "ta_zthr", "ra_dmod", "ra_zthr", "alim", "ra_hmd")
    for suffix in DISTANCE_UNITS}


def _level(table: dict, where: str) -> SensitivityLevel:
    unknown = set(table) - LEVEL_KEYS
    if unknown:
        raise ProfileError(f"{where}: unknown key(s) {sorted(unknown)}")
    has_ra = "ra_tau_s" in table
    ra = lambda key: _distance(table, key, where, required=has_ra)  # noqa: E731
    agl = table.get("agl", False)
    if not isinstance(agl, bool):
        raise ProfileError(f"{where}.agl: expected true or false, got {_show(agl)}")
    return SensitivityLevel(
        sl=_integer(table["sl"], f"{where}.sl", 1, SL_MAX),
        ceiling_m=_number(table["ceiling_ft"], f"{where}.ceiling_ft", infinite=True) * FT,
        agl_band=agl, ta_tau_s=_number(table["ta_tau_s"], f"{where}.ta_tau_s"),
        ta_dmod_m=_distance(table, "ta_dmod", where), ta_zthr_m=_distance(table, "ta_zthr", where),
        ra_tau_s=_number(table["ra_tau_s"], f"{where}.ra_tau_s") if has_ra else None,
        ra_dmod_m=ra("ra_dmod"), ra_zthr_m=ra("ra_zthr"), alim_m=ra("alim"), ra_hmd_m=ra("ra_hmd"),
    )


ALERTER_KEYS = {"kind", "source", "hysteresis_time_s", "persistence_time_s", "alerting_m", "alerting_n", "period_s",
                "levels", "sum", "lookahead_s", "non_cooperative"}
# [alerter.sum]: DAIDALUS's SUM parameters (DaidalusParameters h_pos_z_score ... v_vel_z_score), advisory/wcv_sum.py
SUM_KEYS = {"h_pos_z_score", "h_vel_z_score_min", "h_vel_z_score_max", "v_pos_z_score", "v_vel_z_score"} | {
    f"h_vel_z_distance{suffix}" for suffix in DISTANCE_UNITS}
WCV_LEVEL_KEYS = {"name", "advisory", "region", "tthr_s", "tcoa_s", "alerting_time_s", "early_alerting_time_s"} | {
    f"{name}{suffix}" for name in ("dthr", "zthr") for suffix in DISTANCE_UNITS}
REGIONS = ("NONE", "FAR", "MID", "NEAR")
MAX_BAND_CELLS = 10_000  # per kind of guidance band (see _bands_params)


def _wcv_alerter(table: dict, where: str) -> WcvAlerterSpec:
    unknown = set(table) - ALERTER_KEYS
    if unknown:
        raise ProfileError(f"{where}: unknown key(s) {sorted(unknown)}")
    if table.get("kind") != "wcv":
        raise ProfileError(f"{where}.kind: expected \"wcv\" (the TCAS alerter needs no [alerter] table)")
    sum_z = None
    if "sum" in table:
        at = f"{where}.sum"
        sum_table = _table(table["sum"], at)
        unknown = set(sum_table) - SUM_KEYS
        if unknown:
            raise ProfileError(f"{at}: unknown key(s) {sorted(unknown)}")
        try:
            sum_z = SumZScores(
                h_pos=_number(sum_table["h_pos_z_score"], f"{at}.h_pos_z_score"),
                h_vel_min=_number(sum_table["h_vel_z_score_min"], f"{at}.h_vel_z_score_min"),
                h_vel_max=_number(sum_table["h_vel_z_score_max"], f"{at}.h_vel_z_score_max"),
                h_vel_distance_m=_distance(sum_table, "h_vel_z_distance", at),
                v_pos=_number(sum_table["v_pos_z_score"], f"{at}.v_pos_z_score"),
                v_vel=_number(sum_table["v_vel_z_score"], f"{at}.v_vel_z_score"))
        except KeyError as exc:
            raise ProfileError(f"{at}: missing key {exc}") from None
        if sum_z.h_vel_distance_m <= 0.0:
            raise ProfileError(f"{at}.h_vel_z_distance: must be > 0")
    lookahead = _number(table.get("lookahead_s", 180.0), f"{where}.lookahead_s")
    levels = []
    for i, row in enumerate(_tables(table.get("levels", []), f"{where}.levels")):
        at = f"{where}.levels[{i}]"
        unknown = set(row) - WCV_LEVEL_KEYS
        if unknown:
            raise ProfileError(f"{at}: unknown key(s) {sorted(unknown)}")
        if row.get("advisory") not in ("TA", "RA"):
            raise ProfileError(f"{at}.advisory: expected \"TA\" or \"RA\"")
        if row.get("region", "NONE") not in REGIONS:
            raise ProfileError(f"{at}.region: expected one of {list(REGIONS)}")
        try:
            thresholds = WcvThresholds(_distance(row, "dthr", at), _distance(row, "zthr", at),
                                       _number(row["tthr_s"], f"{at}.tthr_s"), _number(row.get("tcoa_s", 0.0), f"{at}.tcoa_s"))
            alerting = _number(row["alerting_time_s"], f"{at}.alerting_time_s")
            early = _number(row.get("early_alerting_time_s", alerting), f"{at}.early_alerting_time_s")
            name = _text(row["name"], f"{at}.name")
        except KeyError as exc:
            raise ProfileError(f"{at}: missing key {exc}") from None
        # a level that raises an RA needs the intruder's altitude (the manoeuvre is vertical); the others show an
        # intruder without altitude on range alone
        ra = row["advisory"] == "RA"
        detector = WCV_TAUMOD(altitude_required=ra) if sum_z is None else \
            WCV_TAUMOD_SUM(altitude_required=ra, z_scores=sum_z, lookahead_s=lookahead)
        advisory = int(AdvisoryLevel.RA if ra else AdvisoryLevel.TA)
        levels.append(AlertLevel(i + 1, name, detector, thresholds, alerting_time_s=alerting,
                                 early_alerting_time_s=early, advisory=advisory, region=row.get("region", "NONE")))
    if not levels:
        raise ProfileError(f"{where}: no [[alerter.levels]]")
    ra = int(AdvisoryLevel.RA)
    if any(a.advisory == ra and b.advisory != ra for a, b in zip(levels, levels[1:])):
        raise ProfileError(f"{where}: a level that raises an RA cannot be below one that raises a TA")
    m, n = table.get("alerting_m", 1), table.get("alerting_n", 1)
    if not (type(m) is int and type(n) is int and 1 <= m <= n <= 50):
        raise ProfileError(f"{where}: need integers 1 <= alerting_m <= alerting_n <= 50")
    return WcvAlerterSpec(
        sum=sum_z, lookahead_s=lookahead,
        source=_text(table.get("source", ""), f"{where}.source"), levels=tuple(levels),
        hysteresis_time_s=_number(table.get("hysteresis_time_s", 0.0), f"{where}.hysteresis_time_s"),
        persistence_time_s=_number(table.get("persistence_time_s", 0.0), f"{where}.persistence_time_s"),
        alerting_m=m, alerting_n=n, period_s=_number(table.get("period_s", 1.0), f"{where}.period_s"),
        non_cooperative=_text(table["non_cooperative"], f"{where}.non_cooperative")
        if "non_cooperative" in table else None)


def _bands_params(table: dict, alerter: WcvAlerterSpec, where: str):
    """BandsParams (advisory/bands.py; DAIDALUS DO_365B_no_SUM.conf by default) with the profile's [bands] values
    (keys are BandsParams' fields, SI units) and the alerter's hysteresis, persistence and M of N."""
    from dataclasses import fields

    from avionics.advisory.bands import BandsParams

    known = {f.name: f.type for f in fields(BandsParams)}
    unknown = set(table) - set(known)
    if unknown:
        raise ProfileError(f"{where}: unknown key(s) {sorted(unknown)}; known: {sorted(known)}")
    values = {}
    for key, value in table.items():
        if known[key] in ("bool", bool):
            if isinstance(value, float) and value in (0.0, 1.0):  # an override (key=number): 0 or 1
                value = bool(value)
            if not isinstance(value, bool):
                raise ProfileError(f"{where}.{key}: expected true or false")
            values[key] = value
        elif known[key] in ("str", str):
            if value not in REGIONS:
                raise ProfileError(f"{where}.{key}: expected one of {list(REGIONS)}")
            values[key] = value
        elif key == "min_vs_mps":  # the only signed one (a descent rate)
            try:
                values[key] = check_float(value, f"{where}.{key}")
            except ConfigError as exc:
                raise ProfileError(str(exc)) from None
        else:
            values[key] = _number(value, f"{where}.{key}")
    values.setdefault("hysteresis_time_s", alerter.hysteresis_time_s)
    values.setdefault("persistence_time_s", alerter.persistence_time_s)
    values.setdefault("alerting_m", alerter.alerting_m)
    values.setdefault("alerting_n", alerter.alerting_n)
    for key in ("alerting_m", "alerting_n"):
        values[key] = _integer(values[key], f"{where}.{key}", 1, 50)
    if values["alerting_m"] > values["alerting_n"]:
        raise ProfileError(f"{where}: need alerting_m <= alerting_n")
    params = BandsParams(**values)
    # Each kind of band is searched cell by cell: a step of 1e-9 would be billions of cells per second. DAIDALUS's
    # DO_365B_no_SUM.conf has at most ~500 (altitude: 100 to 50000 ft by 100 ft); allow far more, not unbounded.
    for kind in ("track_deg", "gs_mps", "vs_mps", "alt_m"):
        step = getattr(params, f"step_{kind}")
        span = 360.0 if kind == "track_deg" else getattr(params, f"max_{kind}") - getattr(params, f"min_{kind}")
        if not span > 0:
            raise ProfileError(f"{where}: min_{kind} must be below max_{kind}")
        if not step > 0 or span / step > MAX_BAND_CELLS:
            raise ProfileError(f"{where}.step_{kind}: {step:g} is 0 or makes more than {MAX_BAND_CELLS} cells")
    return params


def _apply_override(data: dict, text: str) -> None:
    """'sl4.ra_tau_s=25' (every row of SL 4), 'response.delay_s=3' or 'sl_hysteresis_ft=50'."""
    key, sep, raw = text.partition("=")
    try:
        value = float(raw)
    except ValueError:
        raise ProfileError(f"profile override {text!r}: expected key=number") from None
    if not sep:
        raise ProfileError(f"profile override {text!r}: expected key=number")
    head, dot, leaf = key.strip().partition(".")
    if not dot:
        if head not in data or isinstance(data[head], (dict, list)):
            raise ProfileError(f"profile override {text!r}: unknown key {head!r}")
        data[head] = value
    elif head == "response":
        if not isinstance(data.get("response"), dict) or leaf not in data["response"]:
            raise ProfileError(f"profile override {text!r}: unknown response key {leaf!r}")
        data["response"][leaf] = value
    elif head == "bands":  # a guidance-bands parameter (advisory/bands.py BandsParams; checked when built)
        if "alerter" not in data:
            raise ProfileError(f"profile override {text!r}: the profile has no DO-365 alerter, hence no bands")
        _table(data.setdefault("bands", {}), "bands")[leaf] = value
    elif head.startswith("sl") and head[2:].isdigit():
        rows = [row for row in _tables(data.get("levels", []), "levels") if row.get("sl") == int(head[2:])]
        if not rows:
            raise ProfileError(f"profile override {text!r}: the profile has no {head}")
        for row in rows:
            for suffix in DISTANCE_UNITS:  # a distance given in another unit replaces the profile's
                if leaf.endswith(suffix):
                    for other in DISTANCE_UNITS:
                        row.pop(leaf[: -len(suffix)] + other, None)
            row[leaf] = value
    else:
        raise ProfileError(f"profile override {text!r}: expected slN.key, response.key or a top-level key")


def profile_text(name_or_path: str) -> tuple[str, str]:
    """(source description, TOML text) of a built-in profile name or a profile file path."""
    builtin = resources.files("avionics.advisory").joinpath(PROFILE_DIR, f"{name_or_path}.toml")
    if is_file(builtin):
        return f"built-in profile {name_or_path!r}", builtin.read_text()
    path = Path(name_or_path)
    if path.suffix == ".toml" and is_file(path):
        try:
            return str(path), path.read_bytes().decode("utf-8")
        except OSError as exc:
            raise ProfileError(f"{path}: {exc.strerror or exc}") from None
        except UnicodeDecodeError as exc:
            raise ProfileError(f"{path}: not UTF-8 text (byte {exc.start}): a TOML file is UTF-8") from None
    names = sorted(p.name[:-5] for p in resources.files("avionics.advisory").joinpath(PROFILE_DIR).iterdir()
                   if p.name.endswith(".toml"))
    raise ProfileError(f"unknown profile {name_or_path!r}: expected one of {names} or a .toml file")


def load_profile(name_or_path: str = "tcas2", overrides=()) -> AlertProfile:
    profile = _load_profile(name_or_path, overrides)
    if profile.alerter is not None and profile.alerter.non_cooperative is not None:
        _check_non_cooperative(profile, _load_profile(profile.alerter.non_cooperative))
    return profile


def _check_non_cooperative(profile: AlertProfile, other: AlertProfile) -> None:
    """[alerter] non_cooperative names a well-clear alerter with the same alerting hysteresis (one
    AlertingHysteresis serves both, advisory/alerting.py Alerter.non_cooperative), the same SUM (the bands test
    every intruder with one, advisory/bands.py) and the same levels (one advisory logic reads both); checked here,
    at load, so that `avionics config` refuses what `run` could not build."""
    spec, name = profile.alerter, profile.alerter.non_cooperative
    if other.alerter is None or other.alerter.non_cooperative is not None:
        raise ProfileError(f"profile {profile.name}: [alerter] non_cooperative = {name!r} needs a well-clear "
                           "[alerter] of its own and none further")
    same = ("hysteresis_time_s", "persistence_time_s", "alerting_m", "alerting_n", "period_s")
    if any(getattr(spec, k) != getattr(other.alerter, k) for k in same):
        raise ProfileError(f"profile {profile.name}: the non-cooperative alerter {name!r} must share its alerting "
                           f"hysteresis ({', '.join(same)})")
    if spec.sum != other.alerter.sum:  # one SUM for both: the guidance bands test every intruder with the profile's
        raise ProfileError(f"profile {profile.name}: the non-cooperative alerter {name!r} must use SUM as it does "
                           "(the same z-scores, or none)")
    if [(lv.name, lv.advisory_level) for lv in spec.levels] != [(lv.name, lv.advisory_level)
                                                               for lv in other.alerter.levels]:
        raise ProfileError(f"profile {profile.name}: the non-cooperative alerter {name!r} must have the same levels "
                           "(number, name, advisory)")


def _load_profile(name_or_path: str, overrides=()) -> AlertProfile:
    where, text = profile_text(name_or_path)
    try:
        data = tomllib.loads(text)
    except ValueError as exc:  # TOMLDecodeError, or an integer beyond Python's int-str limit (4300 digits)
        raise ProfileError(f"{where}: {str(exc).splitlines()[0]}") from None
    for override in overrides:
        _apply_override(data, override)
    try:
        r = _table(data["response"], f"{where} [response]")
        response = ResponseModel(
            _number(r["delay_s"], "response.delay_s"), _number(r["accel_g"], "response.accel_g") * G0,
            _number(r["rate_fpm"], "response.rate_fpm") * FPM,
            _number(r["strengthen_delay_s"], "response.strengthen_delay_s"),
            _number(r["strengthen_accel_g"], "response.strengthen_accel_g") * G0,
            _number(r["strengthen_rate_fpm"], "response.strengthen_rate_fpm") * FPM)
        levels = tuple(_level(row, f"{where} levels[{i}]") for i, row in enumerate(_tables(data["levels"], "levels")))
        profile = AlertProfile(
            name=_text(data["name"], "name"), description=_text(data.get("description", ""), "description"),
            levels=levels, response=response,
            ra_inhibit_below_agl_m=_number(data["ra_inhibit_below_agl_ft"], "ra_inhibit_below_agl_ft") * FT,
            descend_inhibit_below_agl_m=_number(data["descend_inhibit_below_agl_ft"],
                                                "descend_inhibit_below_agl_ft") * FT,
            increase_descent_inhibit_below_agl_m=_number(data["increase_descent_inhibit_below_agl_ft"],
                                                         "increase_descent_inhibit_below_agl_ft") * FT,
            sl_hysteresis_m=_number(data["sl_hysteresis_ft"], "sl_hysteresis_ft") * FT,
            inhibit_hysteresis_m=_number(data.get("inhibit_hysteresis_ft", 0.0), "inhibit_hysteresis_ft") * FT,
            max_threat_vertical_rate_mps=_number(data.get("max_threat_vertical_rate_fpm", math.inf),
                                                 "max_threat_vertical_rate_fpm", infinite=True) * FPM,
            alerter=_wcv_alerter(_table(data["alerter"], f"{where} [alerter]"), f"{where} [alerter]")
            if "alerter" in data else None)
        if profile.alerter is not None:
            profile = replace(profile, bands=_bands_params(_table(data.get("bands", {}), f"{where} [bands]"),
                                                           profile.alerter, f"{where} [bands]"))
        elif "bands" in data:
            raise ProfileError(f"{where}: a [bands] table needs a DO-365 [alerter]")
    except KeyError as exc:
        raise ProfileError(f"{where}: missing key {exc}") from None
    if not levels or not math.isinf(levels[-1].ceiling_m):
        raise ProfileError(f"{where}: the last level must have ceiling_ft = inf")
    if any(b.ceiling_m <= a.ceiling_m for a, b in zip(levels, levels[1:])):
        raise ProfileError(f"{where}: level ceilings must increase")
    return profile


TCAS_II_V71: tuple[SensitivityLevel, ...] = load_profile("tcas2").levels


def select_level(agl_m: float | None, altitude_m: float, table=TCAS_II_V71) -> SensitivityLevel:
    """The row whose band holds ownship: AGL for the AGL bands (TCAS SL 2, 3), pressure altitude above.
    Without AGL the AGL bands are skipped (docs/advisories.md, low-altitude inhibits)."""
    return table[level_index(agl_m, altitude_m, table)]


def level_index(agl_m: float | None, altitude_m: float, table) -> int:
    for i, row in enumerate(table):
        if row.agl_band:
            lowest = i == 0
            if agl_m is not None and (agl_m < row.ceiling_m if lowest else agl_m <= row.ceiling_m):
                return i
        elif altitude_m <= row.ceiling_m:
            return i
    return len(table) - 1


class LevelSelector:
    """Sensitivity level with hysteresis: the band only changes once ownship is hysteresis_m past the
    boundary, so a flight along a band boundary does not toggle thresholds."""

    def __init__(self, profile: AlertProfile):
        self.profile = profile
        self.index: int | None = None

    def select(self, agl_m: float | None, altitude_m: float) -> SensitivityLevel:
        levels, h = self.profile.levels, self.profile.sl_hysteresis_m
        shift = lambda dz: level_index(None if agl_m is None else agl_m + dz, altitude_m + dz, levels)  # noqa: E731
        if self.index is None:
            self.index = level_index(agl_m, altitude_m, levels)
        elif shift(-h) > self.index:
            self.index = shift(-h)
        elif shift(+h) < self.index:
            self.index = shift(+h)
        return levels[self.index]
