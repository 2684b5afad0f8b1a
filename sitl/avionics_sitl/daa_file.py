"""NASA DAIDALUS .daa encounter files: read into a Scenario, and write a Scenario out for cross-checks.

Format (as DAIDALUS's DaidalusFileWalker reads it): fields separated by commas and/or whitespace; lines
starting with '#' are comments; the first other line is the header naming the columns (case-insensitive);
an optional next line of units in brackets; then one row per aircraft and time. Columns:

    NAME                     aircraft name; the first name in the file is the ownship
    lat lon alt | sx sy sz   position: geodetic (deg, deg, ft) or Euclidean (nmi, nmi, ft)
    trk gs vs   | vx vy vz   velocity: track/ground speed/vertical speed (deg, knot, fpm) or ENU (knot, knot, fpm)
    time                     seconds (optional: without it the file is one snapshot)

    s_EW_std s_NS_std s_EN_std sz_std v_EW_std v_NS_std v_EN_std vz_std
                             the aircraft's stated 1-sigma uncertainties (optional; SI without a units line, as
                             DAIDALUS's "unspecified"): each row's become the aircraft's SumData
                             (base/uncertainty.py), as DaidalusFileWalker passes them to setHorizontalPosition-
                             Uncertainty(s_EW_std, s_NS_std, s_EN_std), setVerticalPositionUncertainty(sz_std),
                             setHorizontalVelocityUncertainty(v_EW_std, v_NS_std, v_EN_std) and
                             setVerticalSpeedUncertainty(vz_std); a column left out is 0. Positions take length
                             units (daidalus_H1_SUM.daa: [nmi], sz_std included), velocities speed units ([nmi/s]).

Other DAIDALUS columns (alerter, heading, airspeed) are recognised and ignored, units included: like DAIDALUS's
reader, which never converts a column it does not use, the units of ignored columns are not checked. Rows of one
aircraft must
not go back in time (DAIDALUS would sort them); a row with the same time as that aircraft's previous row
replaces it: the last row wins, as in DAIDALUS's SequenceReader, which keeps one state per (time, name)
(daa-displays' sim3.daa repeats stamps).
Euclidean positions are placed on the tangent plane at EUCLIDEAN_ORIGIN. Times are shifted so that the
file's first time is simulation time 0. Extension: a comment '# ground_ft = N' sets the ground elevation.
docs/scenarios.md has the details and the reasons.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from avionics.base.geodesy import LocalTangentPlane
from avionics.base.types import AltitudeDatum
from avionics.base.uncertainty import SumData
from avionics.base.units import FPM, FT, KT, NM, ground_speed_mps, track_deg
from avionics_sitl.aircraft import AircraftSpec
from avionics_sitl.scenario import DEFAULT_ADDRESS_BASE, Scenario
from avionics_sitl.trajectory import SampledTrajectory, Trajectory, plane_velocity_to_true

# DAIDALUS reads geodetic positions on a sphere of this radius (gov.nasa.larcfm.Util GreatCircle
# .spherical_earth_radius: 1 nmi per minute of arc) and projects them onto the plane at the ownship
# (Projection: ENUProjection). The same lat/lon on WGS-84 lie up to 0.3 % farther apart (at 37 N), enough to turn
# an encounter that grazes the well-clear radius in DAIDALUS (daa-displays s_1_turn_*) into a miss; the reader
# therefore keeps DAIDALUS's geometry: spherical ENU offsets from the ownship's first position, placed on the
# WGS-84 tangent plane there.
DAIDALUS_EARTH_RADIUS_M = 1852.0 * 60.0 * 180.0 / math.pi  # 6366707.0195 m
EUCLIDEAN_ORIGIN = (47.4, 8.5)  # lat, lon where sx = sy = 0 lands (same point as the built-in encounters)
SNAPSHOT_DURATION_S = 120.0  # a single-time file: long enough for a 2-minute look-ahead encounter to unfold
DURATION_MARGIN_S = 60.0  # multi-sample files run this long past their last time
DAA_EMITTER_TYPE = 1  # the file says nothing about the airframe

# Unit name -> (dimension, factor). Names match case-insensitively, without brackets. Factors convert to SI,
# except angles, which are kept in degrees.
_UNITS: dict[str, tuple[str, float]] = {
    "deg": ("angle", 1.0), "degree": ("angle", 1.0), "degrees": ("angle", 1.0), "rad": ("angle", math.degrees(1.0)),
    "m": ("length", 1.0), "ft": ("length", FT), "nmi": ("length", NM), "nm": ("length", NM), "km": ("length", 1000.0),
    "knot": ("speed", KT), "knots": ("speed", KT), "kn": ("speed", KT), "kt": ("speed", KT), "kts": ("speed", KT),
    "m/s": ("speed", 1.0), "mps": ("speed", 1.0), "fpm": ("speed", FPM), "ft/min": ("speed", FPM),
    "nmi/s": ("speed", NM), "ft/s": ("speed", FT),
    "s": ("time", 1.0), "sec": ("time", 1.0), "ms": ("time", 1e-3), "min": ("time", 60.0),
    "unitless": ("none", 1.0), "none": ("none", 1.0),
}
_UNITLESS = {"unitless", "none", "[none]", "[unitless]"}

# Column -> (dimension, default unit).
_COLUMNS: dict[str, tuple[str, str]] = {
    "name": ("none", "unitless"),
    "lat": ("angle", "deg"), "lon": ("angle", "deg"), "alt": ("length", "ft"),
    "sx": ("length", "nmi"), "sy": ("length", "nmi"), "sz": ("length", "ft"),
    "trk": ("angle", "deg"), "gs": ("speed", "knot"), "vs": ("speed", "fpm"),
    "vx": ("speed", "knot"), "vy": ("speed", "knot"), "vz": ("speed", "fpm"),
    "time": ("time", "s"),
    "s_ew_std": ("length", "m"), "s_ns_std": ("length", "m"), "s_en_std": ("length", "m"), "sz_std": ("length", "m"),
    "v_ew_std": ("speed", "m/s"), "v_ns_std": ("speed", "m/s"), "v_en_std": ("speed", "m/s"),
    "vz_std": ("speed", "m/s"),
}
# the uncertainty columns in SumData's field order (base/uncertainty.py UNCERTAINTY_FIELDS)
_STD_COLUMNS = ("s_ew_std", "s_ns_std", "s_en_std", "sz_std", "v_ew_std", "v_ns_std", "v_en_std", "vz_std")
_IGNORED_COLUMNS = {"alerter", "heading", "airspeed"}
_GROUND_RE = re.compile(r"#+\s*ground_ft\s*=\s*(\S+)\s*$", re.IGNORECASE)
_PARAMETER_RE = re.compile(r"^[A-Za-z_][\w.]*\s*=")  # DAIDALUS configuration lines: not ours, ignored
_SPLIT_RE = re.compile(r"[,\s]+")


@dataclass(frozen=True)
class _Row:
    line: int
    name: str
    t: float
    lat: float
    lon: float
    alt_m: float
    ve: float
    vn: float
    vu: float
    std: SumData | None = None  # the row's stated uncertainties; None: the file has no *_std column


def _fields(line: str) -> list[str]:
    return [f for f in _SPLIT_RE.split(line.strip()) if f]


def _is_units_line(fields: list[str], columns: list[str]) -> bool:
    """Every field under a column we use is a bracketed unit or unitless; under ignored columns anything goes."""
    return all(
        f.startswith("[") or f.lower() in _UNITLESS
        for i, f in enumerate(fields)
        if not (i < len(columns) and columns[i] in _IGNORED_COLUMNS)
    )


def _parse_units(fields: list[str], columns: list[str], line_no: int) -> list[float]:
    if len(fields) != len(columns):
        raise ValueError(f"line {line_no}: units line has {len(fields)} fields, header has {len(columns)}")
    factors = []
    for col, text in zip(columns, fields):
        if col in _IGNORED_COLUMNS:  # never converted, so never checked (DAIDALUS: unknown -> "unspecified")
            factors.append(1.0)
            continue
        unit = text.strip("[]").lower()
        if unit not in _UNITS:
            raise ValueError(f"line {line_no}: unknown unit {text!r} for column {col!r}")
        dim, factor = _UNITS[unit]
        if col in _COLUMNS and _COLUMNS[col][0] != dim and not (dim == "none" and col == "name"):
            raise ValueError(f"line {line_no}: unit {text!r} is not a {_COLUMNS[col][0]} unit (column {col!r})")
        factors.append(factor)
    return factors


def _check_columns(columns: list[str], line_no: int) -> None:
    for col in columns:
        if col not in _COLUMNS and col not in _IGNORED_COLUMNS:
            raise ValueError(f"line {line_no}: unknown column {col!r}")
    if len(set(columns)) != len(columns):
        raise ValueError(f"line {line_no}: a column is named twice")
    have = set(columns)
    if "name" not in have:
        raise ValueError(f"line {line_no}: header has no NAME column")
    geo, euclid = {"lat", "lon", "alt"}, {"sx", "sy", "sz"}
    polar, cartesian = {"trk", "gs", "vs"}, {"vx", "vy", "vz"}
    for a, b, what in ((geo, euclid, "position"), (polar, cartesian, "velocity")):
        if a & have and b & have:
            raise ValueError(f"line {line_no}: mixes {' '.join(sorted(a))} and {' '.join(sorted(b))} {what} columns")
        if not (a & have or b & have):
            raise ValueError(f"line {line_no}: header lacks {what} columns ({' '.join(sorted(a))} or "
                             f"{' '.join(sorted(b))})")
        missing = (a if a & have else b) - have
        if missing:
            raise ValueError(f"line {line_no}: header lacks {what} column(s) {' '.join(sorted(missing))}")


def _text_of(path_or_text: str | Path) -> tuple[str, str]:
    """(text, scenario name). A Path, or a str without a newline, is a file; any other str is the content."""
    if isinstance(path_or_text, Path) or "\n" not in path_or_text:
        path = Path(path_or_text)
        try:
            return path.read_text(encoding="utf-8"), path.stem
        except OSError as e:
            raise ValueError(f"{path}: cannot read: {e}") from None
    return path_or_text, "daa"


def _parse_rows(text: str, euclid_plane: LocalTangentPlane) -> tuple[list[_Row], float, bool]:
    """The data rows (positions in degrees, SI otherwise), the ground elevation in metres, and whether the
    positions were Euclidean (sx, sy, sz)."""
    columns: list[str] | None = None
    factors: list[float] = []
    rows: list[_Row] = []
    ground_m = 0.0
    expect_units = False
    for line_no, raw in enumerate(text.splitlines(), start=1):
        stripped = raw.strip()
        if not stripped:
            continue
        if stripped.startswith("#"):
            m = _GROUND_RE.match(stripped)
            if m:
                try:
                    ground_ft = float(m.group(1))
                except ValueError:
                    raise ValueError(f"line {line_no}: ground_ft {m.group(1)!r} is not a number") from None
                if not math.isfinite(ground_ft):
                    raise ValueError(f"line {line_no}: ground_ft must be finite")
                ground_m = ground_ft * FT
            continue
        if _PARAMETER_RE.match(stripped):
            continue
        fields = _fields(stripped)
        if columns is None:
            columns = [f.lower() for f in fields]
            _check_columns(columns, line_no)
            factors = [_UNITS[_COLUMNS[c][1]][1] if c in _COLUMNS else 1.0 for c in columns]
            expect_units = True
            continue
        if expect_units:
            expect_units = False
            if _is_units_line(fields, columns):
                factors = _parse_units(fields, columns, line_no)
                continue
        rows.append(_parse_row(fields, columns, factors, line_no, euclid_plane))
    if columns is None:
        raise ValueError("no header line (NAME, lat/lon/alt or sx/sy/sz, trk/gs/vs or vx/vy/vz, time)")
    return rows, ground_m, "sx" in columns


def _parse_row(fields: list[str], columns: list[str], factors: list[float], line_no: int,
               euclid_plane: LocalTangentPlane) -> _Row:
    if len(fields) != len(columns):
        raise ValueError(f"line {line_no}: {len(fields)} fields, header has {len(columns)}")
    values: dict[str, float] = {}
    name = ""
    for col, text, factor in zip(columns, fields, factors):
        if col == "name":
            name = text
            continue
        if col in _IGNORED_COLUMNS:
            continue
        try:
            value = float(text)
        except ValueError:
            raise ValueError(f"line {line_no}: column {col!r}: {text!r} is not a number") from None
        if not math.isfinite(value):
            raise ValueError(f"line {line_no}: column {col!r}: {text!r} is not finite")
        values[col] = value * factor
    if "lat" in values:
        lat, lon, alt = values["lat"], values["lon"], values["alt"]
        if not (-90.0 <= lat <= 90.0 and -180.0 <= lon <= 360.0):
            raise ValueError(f"line {line_no}: latitude/longitude ({lat:g}, {lon:g}) out of range")
        lon = (lon + 180.0) % 360.0 - 180.0
    else:
        lat_a, lon_a = euclid_plane.to_geodetic(values["sx"], values["sy"])
        lat, lon, alt = float(lat_a), float(lon_a), values["sz"]
    if "trk" in values:
        trk, gs, vu = math.radians(values["trk"]), values["gs"], values["vs"]
        ve, vn = gs * math.sin(trk), gs * math.cos(trk)
    else:
        ve, vn, vu = values["vx"], values["vy"], values["vz"]
    if "sx" in values:
        # Velocities share their positions' frame: Euclidean axes here, true north at the aircraft otherwise.
        ve, vn = plane_velocity_to_true(euclid_plane, lat, lon, ve, vn)
    std = None
    if any(c in values for c in _STD_COLUMNS):
        try:
            std = SumData(*(values.get(c, 0.0) for c in _STD_COLUMNS))
        except ValueError as e:
            raise ValueError(f"line {line_no}: {e}") from None
    return _Row(line_no, name, values.get("time", 0.0), lat, lon, alt, ve, vn, vu, std)


def _spec(name: str, index: int, first: _Row) -> AircraftSpec:
    speed = ground_speed_mps(first.ve, first.vn)
    heading = track_deg(first.ve, first.vn) if speed > 0 else 0.0
    callsign = re.sub(r"[^A-Z0-9]", "", name.upper())[:8]
    where = f"line {first.line}: aircraft {name!r}"
    try:
        return AircraftSpec(
            name=name, icao_address=DEFAULT_ADDRESS_BASE + index, lat_deg=first.lat, lon_deg=first.lon,
            alt_msl_m=first.alt_m, heading_deg=heading if heading < 360.0 else 0.0, speed_mps=speed,
            vertical_rate_mps=first.vu, altitude_datum=AltitudeDatum.PRESSURE, callsign=callsign,
            emitter_type=DAA_EMITTER_TYPE,
        )
    except ValueError as e:
        raise ValueError(f"{where}: {e}") from None


def _rows_by_aircraft(rows: list[_Row]) -> dict[str, list[_Row]]:
    """Each aircraft's rows in time order, in order of the names' first appearance (the first is the ownship,
    as in DAIDALUS's name index). A row at the same time as the aircraft's previous row replaces it (the last
    row wins, as DAIDALUS's SequenceReader keeps it); an earlier time is an error."""
    by_name: dict[str, list[_Row]] = {}
    for row in rows:
        ac_rows = by_name.setdefault(row.name, [])
        if ac_rows:
            prev = ac_rows[-1]
            if row.t == prev.t:
                ac_rows[-1] = row
                continue
            if row.t < prev.t:
                raise ValueError(
                    f"line {row.line}: time {row.t:g} s of {row.name!r} is not after its previous row's "
                    f"(line {prev.line}, {prev.t:g} s)"
                )
        ac_rows.append(row)
    return by_name


def _spherical_en(lat_deg, lon_deg, lat0_deg: float, lon0_deg: float):
    """East/north of points on DAIDALUS's sphere on the tangent plane at (lat0, lon0) (ENUProjection: the ECEF
    offset rotated into east-north-up, up dropped)."""
    lat, lon = np.radians(lat_deg), np.radians(lon_deg)
    lat0, lon0 = math.radians(lat0_deg), math.radians(lon0_deg)
    r = DAIDALUS_EARTH_RADIUS_M
    x, y, z = r * np.cos(lat) * np.cos(lon), r * np.cos(lat) * np.sin(lon), r * np.sin(lat)
    x0, y0, z0 = r * math.cos(lat0) * math.cos(lon0), r * math.cos(lat0) * math.sin(lon0), r * math.sin(lat0)
    dx, dy, dz = x - x0, y - y0, z - z0
    east = -math.sin(lon0) * dx + math.cos(lon0) * dy
    north = -math.sin(lat0) * math.cos(lon0) * dx - math.sin(lat0) * math.sin(lon0) * dy + math.cos(lat0) * dz
    return east, north


def _spherical_geodetic(east_m, north_m, lat0_deg: float, lon0_deg: float):
    """Inverse of _spherical_en: the point of DAIDALUS's sphere whose tangent-plane projection is (east, north)."""
    e, n = np.asarray(east_m, float), np.asarray(north_m, float)
    lat0, lon0 = math.radians(lat0_deg), math.radians(lon0_deg)
    r = DAIDALUS_EARTH_RADIUS_M
    up = np.sqrt(r * r - e * e - n * n)  # distance from the centre along the origin's vertical
    axes_e = np.array([-math.sin(lon0), math.cos(lon0), 0.0])
    axes_n = np.array([-math.sin(lat0) * math.cos(lon0), -math.sin(lat0) * math.sin(lon0), math.cos(lat0)])
    axes_u = np.array([math.cos(lat0) * math.cos(lon0), math.cos(lat0) * math.sin(lon0), math.sin(lat0)])
    p = np.multiply.outer(e, axes_e) + np.multiply.outer(n, axes_n) + np.multiply.outer(up, axes_u)
    return np.degrees(np.arcsin(p[..., 2] / r)), np.degrees(np.arctan2(p[..., 1], p[..., 0]))


def _as_daidalus_places(rows: list[_Row], plane: LocalTangentPlane) -> list[_Row]:
    """The rows moved to where DAIDALUS's geometry puts them (DAIDALUS_EARTH_RADIUS_M): the same east/north
    offsets from the plane's origin on WGS-84. Velocities (true east/north) are kept."""
    east, north = _spherical_en([r.lat for r in rows], [r.lon for r in rows], plane.lat0_deg, plane.lon0_deg)
    lat, lon = plane.to_geodetic(east, north)
    return [_Row(r.line, r.name, r.t, float(la), float(lo), r.alt_m, r.ve, r.vn, r.vu, r.std)
            for r, la, lo in zip(rows, np.atleast_1d(lat), np.atleast_1d(lon))]


def read_daa(path_or_text: str | Path) -> Scenario:
    """A Scenario from a DAIDALUS .daa file (a Path, or a path string) or from its text (a str with newlines)."""
    text, name = _text_of(path_or_text)
    euclid_plane = LocalTangentPlane(*EUCLIDEAN_ORIGIN)
    rows, ground_m, euclidean = _parse_rows(text, euclid_plane)
    by_name = _rows_by_aircraft(rows)
    if len(by_name) < 2:
        raise ValueError(f"need at least two aircraft (ownship and an intruder), found {len(by_name)}")
    kept = [r for ac_rows in by_name.values() for r in ac_rows]
    t0 = min(r.t for r in kept)
    t_last = max(r.t for r in kept)
    first_own = next(iter(by_name.values()))[0]  # the ownship's first kept row (an earlier duplicate lost)
    # Euclidean files are exact on their own plane; geodetic ones are integrated around the ownship.
    origin = EUCLIDEAN_ORIGIN if euclidean else (first_own.lat, first_own.lon)
    plane = euclid_plane if euclidean else LocalTangentPlane(*origin)
    if not euclidean:
        by_name = {ac: _as_daidalus_places(ac_rows, plane) for ac, ac_rows in by_name.items()}
    specs: list[AircraftSpec] = []
    trajectories: list[Trajectory] = []
    for index, (ac, ac_rows) in enumerate(by_name.items()):
        first = ac_rows[0]
        # The spec holds the state at simulation time 0 (the file's first time), extrapolated if the
        # aircraft's first row is later.
        traj = SampledTrajectory(
            [r.t - t0 for r in ac_rows], [r.lat for r in ac_rows], [r.lon for r in ac_rows],
            [r.alt_m for r in ac_rows], [r.ve for r in ac_rows], [r.vn for r in ac_rows], [r.vu for r in ac_rows],
            plane=plane,
        )
        s0 = traj.state_at(0.0)
        at_zero = _Row(first.line, ac, 0.0, s0.lat_deg, s0.lon_deg, s0.alt_msl_m, s0.vel_east_mps,
                       s0.vel_north_mps, s0.vel_up_mps)
        specs.append(_spec(ac, index, at_zero))
        trajectories.append(traj)
    snapshot = all(len(r) == 1 for r in by_name.values()) and t_last == t0
    duration = SNAPSHOT_DURATION_S if snapshot else (t_last - t0) + DURATION_MARGIN_S
    n_samples = len(kept)
    description = (
        f"DAIDALUS file {name}: {len(by_name)} aircraft, "
        + ("one snapshot, straight-line extrapolation" if snapshot else
           f"{n_samples} samples over {t_last - t0:g} s, Hermite-interpolated")
        + f"; file time {t0:g} s is simulation time 0."
    )
    return Scenario(
        name=name, description=description, ownship=specs[0], intruders=tuple(specs[1:]), duration_s=duration,
        ground_elevation_m=ground_m,
        # A snapshot is exactly the specs' straight lines; samples need the sampled trajectories.
        precomputed_trajectories=None if snapshot else (trajectories[0], tuple(trajectories[1:])),
        origin=origin,
        stated_uncertainty={
            ac: (tuple(r.t - t0 for r in ac_rows), tuple(r.std for r in ac_rows))
            for ac, ac_rows in by_name.items() if ac_rows[0].std is not None} or None,
    )


# --- writing ------------------------------------------------------------------------------------------------

_WRITE_HEADER = "NAME, lat, lon, alt, trk, gs, vs, time"
_WRITE_UNITS = "[none], [deg], [deg], [ft], [deg], [knot], [fpm], [s]"


def format_daa(scenario: Scenario, times_s) -> str:
    """The scenario's truth trajectories sampled at times_s as .daa text (ownship first at each time).

    Geodetic columns in the DAIDALUS default units and geometry (DAIDALUS_EARTH_RADIUS_M), with enough digits (1e-12 deg, 1e-9 kt) that reading the
    text back is limited by the geodesy inverse, not by the file: < 1 cm even 50 nm from the plane origin."""
    own, intruders = scenario.trajectories()
    # positions in DAIDALUS's geometry, as read_daa reads them: the plane offsets from the ownship's first
    # position, on DAIDALUS's sphere
    first = own.state_at(float(np.asarray(times_s, dtype=float).reshape(-1)[0]))
    plane = LocalTangentPlane(first.lat_deg, first.lon_deg)
    lines = [
        f"# {scenario.name}: written by avionics_sitl.daa_file.format_daa",
        f"# ground_ft = {scenario.ground_elevation_m / FT:.6f}",
        _WRITE_HEADER,
        _WRITE_UNITS,
    ]
    for t in np.asarray(times_s, dtype=float):
        for spec, traj in zip(scenario.aircraft, (own, *intruders)):
            s = traj.state_at(float(t))
            name = re.sub(r"[\s,#]", "_", spec.name) or "aircraft"
            lat, lon = _spherical_geodetic(*plane.to_en(s.lat_deg, s.lon_deg), plane.lat0_deg, plane.lon0_deg)
            lines.append(
                f"{name}, {float(lat):.12f}, {float(lon):.12f}, {s.alt_msl_m / FT:.6f}, {s.track_deg:.9f}, "
                f"{s.ground_speed_mps / KT:.9f}, {s.vel_up_mps / FPM:.6f}, {t:.6f}"
            )
    return "\n".join(lines) + "\n"
