"""Trajectory tables: OpenSky Network state vectors and `traffic`-library Flight/Traffic data, CSV or Parquet, as
encounters (a `Scenario` with one sampled trajectory per aircraft), so that `sitl replay`, `sitl live`, `--out`
and `--misses` work on recorded traffic unchanged.

Column names are those the two sources write (docs/scenarios.md, "Trajectory tables", has the table):

    time       timestamp (traffic: a UTC datetime; or epoch seconds)  |  time (OpenSky Impala: epoch seconds)
    address    icao24 (hex string)                                       callsign (optional)
    position   latitude | lat, longitude | lon (WGS-84 degrees)
    altitude   baroaltitude (OpenSky, m) | altitude (traffic, ft: the barometric one) | geoaltitude (m or ft)
    speed      velocity (OpenSky, m/s) | groundspeed (traffic, kt)
    direction  heading (OpenSky: the true track over ground) | track (both, degrees from true north)
    climb      vertrate (OpenSky, m/s) | vertical_rate (traffic, ft/min)

Units follow the convention the column names belong to: OpenSky's state vectors are SI, `traffic` converts them
to feet, knots and ft/min when it renames them (traffic.data.adsb.opensky.format_history: altitude / 0.3048,
groundspeed / 1852 * 3600, vertical_rate / 0.3048 * 60). `geoaltitude` is in both conventions, so it decides
nothing; names from both conventions in one table are ambiguous and an error unless `units` says which.

Each aircraft's rows are sorted by time; rows sharing a timestamp keep the last one in file order (as DAIDALUS's
SequenceReader keeps one state per time and aircraft); a row with a missing (empty/NaN) position, altitude or
velocity field is not a sample (missing is never read as zero); a silence longer than `gap_s` between an
intruder's samples is a gap in its reports, not an interpolation through it (`TableTrajectory.heard_at`).
"""

from __future__ import annotations

import bisect
import csv
import io
import math
import re
from dataclasses import dataclass
from datetime import datetime, timezone
from pathlib import Path

import numpy as np

from avionics_sitl.progress import progress_bar

from avionics.base.geodesy import LocalTangentPlane
from avionics.base.types import AltitudeDatum
from avionics.base.units import FPM, FT, KT
from avionics_sitl.aircraft import (ALT_RANGE_M, MAX_ABS_LAT_DEG, MAX_PLANE_OFFSET_M, MAX_SPEED_MPS,
                                    MAX_VERTICAL_RATE_MPS, AircraftSpec)
from avionics_sitl.scenario import Scenario
from avionics_sitl.trajectory import SampledTrajectory

TABLE_SUFFIXES = (".csv", ".parquet", ".pq")
DEFAULT_GAP_S = 20.0  # > OpenSky's 10 s REST resolution; = the tracker's default delete_after_s (config/default.toml)
TABLE_EMITTER_TYPE = 0  # MAVLink ADSB_EMITTER_TYPE_NO_INFO: the tables say nothing about the airframe

# Unit conventions: factor to SI for (altitude, speed, vertical rate).
# OpenSky state vectors: baro/geo altitude in metres, velocity over ground in m/s, vertical rate in m/s
# (OpenSky REST API documentation, "State Vectors"; the Impala state_vectors_data4 columns are the same fields).
# traffic: feet, knots, feet per minute (traffic.data.adsb.opensky.format_history converts OpenSky's SI this way:
# altitude / 0.3048, groundspeed / 1852 * 3600, vertical_rate / 0.3048 * 60).
UNITS = {
    "opensky": {"altitude": 1.0, "speed": 1.0, "vertical": 1.0, "text": "m, m/s, m/s"},
    "traffic": {"altitude": FT, "speed": KT, "vertical": FPM, "text": "ft, kt, ft/min"},
}
_FAMILY = {  # unit-bearing column names -> the convention they belong to (geoaltitude is in both)
    "baroaltitude": "opensky", "velocity": "opensky", "vertrate": "opensky",
    "altitude": "traffic", "groundspeed": "traffic", "vertical_rate": "traffic",
}
_SYNONYMS = {  # quantity -> accepted column names
    "time": ("timestamp", "time"),
    "lat": ("latitude", "lat"),
    "lon": ("longitude", "lon"),
    "speed": ("groundspeed", "velocity"),
    "direction": ("track", "heading"),
    "vertical": ("vertical_rate", "vertrate"),
}
_PRESSURE_ALT = ("altitude", "baroaltitude")
_MISSING = {"", "nan", "NaN", "NAN", "null", "NULL", "None", "none", "<NA>", "NaT", "nat"}
_HEX_RE = re.compile(r"(0x)?([0-9a-fA-F]{1,6})")


def is_table(spec: str | Path) -> bool:
    return Path(spec).suffix.lower() in TABLE_SUFFIXES


def icao_of(text: str) -> int:
    """A 24-bit address from an icao24 hex string ('3944e7', '0x3944E7')."""
    m = _HEX_RE.fullmatch(str(text).strip())
    if m is None:
        raise ValueError(f"{text!r} is not an ICAO 24-bit address (1 to 6 hex digits)")
    return int(m.group(2), 16)


# --- reading the raw columns ---------------------------------------------------------------------------------

class _CountingReader(io.RawIOBase):
    """A binary file that counts what has been read from it (the progress of a CSV read)."""

    def __init__(self, raw, on_read):
        self.raw, self.on_read = raw, on_read

    def readable(self) -> bool:
        return True

    def readinto(self, buffer) -> int:
        n = self.raw.readinto(buffer)
        self.on_read(n or 0)
        return n


def _read_csv(path: Path, progress: bool | None) -> tuple[list[str], dict[str, list]]:
    size = path.stat().st_size
    bar, task = progress_bar(progress, f"reading {path.name}", size)
    try:
        with open(path, "rb") as raw:
            counted = _CountingReader(raw, (lambda n: bar.advance(task, n)) if bar else (lambda n: None))
            text = io.TextIOWrapper(io.BufferedReader(counted), encoding="utf-8-sig", newline="")
            reader = csv.reader(text)
            header = next(reader, None)
            if header is None:
                raise ValueError("empty file: no header line")
            names = [h.strip().lower() for h in header]
            columns: dict[str, list] = {n: [] for n in names}
            lists = [columns[n] for n in names]
            for row_no, row in enumerate(reader, start=2):
                if not row:
                    continue
                if len(row) != len(names):
                    raise ValueError(f"line {row_no}: {len(row)} fields, header has {len(names)}")
                for values, v in zip(lists, row):
                    values.append(v)
    except UnicodeDecodeError as e:
        raise ValueError(f"not a UTF-8 text table: {e}") from None
    except csv.Error as e:
        raise ValueError(f"malformed CSV: {e}") from None
    finally:
        if bar:
            bar.stop()
    return names, columns


def _read_parquet(path: Path, progress: bool | None) -> tuple[list[str], dict[str, list]]:
    import pyarrow as pa  # a dependency (also the zenoh traffic batch's); lazily, as only Parquet needs it
    import pyarrow.compute as pc
    import pyarrow.parquet as pq

    try:
        parquet = pq.ParquetFile(path)
    except (pa.ArrowException, OSError) as e:
        raise ValueError(f"not a readable Parquet file: {e}") from None
    names = [n.strip().lower() for n in parquet.schema_arrow.names]
    if len(set(names)) != len(names):
        raise ValueError("a column is named twice")
    columns: dict[str, list] = {n: [] for n in names}
    bar, task = progress_bar(progress, f"reading {path.name}", parquet.metadata.num_rows)
    try:
        for batch in parquet.iter_batches():
            for name, array in zip(names, batch.columns):
                if pa.types.is_timestamp(array.type):
                    # epoch seconds, whatever the stored unit; a zone-less timestamp is read as UTC, as pandas does
                    scale = {"s": 1.0, "ms": 1e3, "us": 1e6, "ns": 1e9}[array.type.unit]
                    array = pc.divide(pc.cast(pc.cast(array, pa.timestamp(array.type.unit)), pa.int64()
                                              ).cast(pa.float64()), scale)
                columns[name].extend(array.to_pylist())
            if bar:
                bar.advance(task, batch.num_rows)
    except pa.ArrowException as e:
        raise ValueError(f"not a readable Parquet file: {e}") from None
    finally:
        if bar:
            bar.stop()
    return names, columns


def read_columns(path: str | Path, progress: bool | None = None) -> tuple[list[str], dict[str, list]]:
    """(lower-cased column names, {name: values in row order}) of a CSV or Parquet table; values are what the file
    holds (strings from CSV; numbers, strings or None from Parquet, timestamps as epoch seconds)."""
    path = Path(path)
    if not path.is_file():
        raise ValueError(f"{path}: cannot read: No such file" if not path.exists() else f"{path}: not a file")
    try:
        if path.suffix.lower() == ".csv":
            return _read_csv(path, progress)
        return _read_parquet(path, progress)
    except OSError as e:
        raise ValueError(f"cannot read: {e}") from None


# --- columns -> rows ------------------------------------------------------------------------------------------

@dataclass(frozen=True)
class Layout:
    """Which column holds each quantity, and the unit convention."""

    time: str
    lat: str
    lon: str
    altitude: str
    datum: AltitudeDatum
    speed: str
    direction: str
    vertical: str
    units: str  # "opensky" or "traffic"
    units_from: str  # "column names" or "--units"
    callsign: str | None


def layout_of(names: list[str], units: str | None = None) -> Layout:
    """The columns to read and their units; ValueError naming what is missing, duplicated or ambiguous."""
    have = set(names)
    if len(have) != len(names):
        raise ValueError("a column is named twice")
    chosen: dict[str, str] = {}
    for quantity, options in _SYNONYMS.items():
        present = [c for c in options if c in have]
        if len(present) > 1:
            raise ValueError(f"columns {' and '.join(present)} both give the {quantity}: keep one")
        if present:
            chosen[quantity] = present[0]
    altitude = next((c for c in _PRESSURE_ALT if c in have), None)
    if sum(c in have for c in _PRESSURE_ALT) > 1:
        raise ValueError("columns altitude and baroaltitude both give the pressure altitude: keep one")
    datum = AltitudeDatum.PRESSURE
    if altitude is None and "geoaltitude" in have:
        altitude, datum = "geoaltitude", AltitudeDatum.GEOMETRIC
    missing = [("icao24" if "icao24" not in have else None)]
    missing += [" or ".join(_SYNONYMS[q]) for q in ("time", "lat", "lon", "speed", "direction", "vertical")
                if q not in chosen]
    if altitude is None:
        missing.append("baroaltitude, altitude or geoaltitude")
    missing = [m for m in missing if m]
    if missing:
        raise ValueError(f"missing column(s): {'; '.join(missing)} (columns: {', '.join(names)})")
    families = {_FAMILY[c] for c in names if c in _FAMILY}
    if units is None:
        if len(families) != 1:
            by = {f: [c for c in names if _FAMILY.get(c) == f] for f in sorted(families)}
            raise ValueError(
                "units are ambiguous: the column names mix OpenSky's (SI: " + ", ".join(by.get("opensky", []))
                + ") and traffic's (ft, kt, ft/min: " + ", ".join(by.get("traffic", [])) + "); give --units "
                "opensky or --units traffic")
        units, units_from = families.pop(), "column names"
    else:
        if units not in UNITS:
            raise ValueError(f"unknown units {units!r}: opensky or traffic")
        units_from = "--units"
    if chosen["direction"] == "heading" and units == "traffic":
        raise ValueError("in a traffic table heading is the aircraft's heading (Comm-B), not its track over "
                         "ground: give a track column (or --units opensky if this is an OpenSky table)")
    return Layout(chosen["time"], chosen["lat"], chosen["lon"], altitude, datum, chosen["speed"],
                  chosen["direction"], chosen["vertical"], units, units_from,
                  "callsign" if "callsign" in have else None)


def _missing(value) -> bool:
    if value is None:
        return True
    if isinstance(value, str):
        return value.strip() in _MISSING
    return isinstance(value, float) and math.isnan(value)


def _number(value, column: str, row: int) -> float:
    """A finite float, NaN for a missing value; ValueError for anything else."""
    if _missing(value):
        return math.nan
    if isinstance(value, bool):
        raise ValueError(f"row {row}: {column} {value!r} is not a number")
    try:
        x = float(value)
    except (TypeError, ValueError):
        raise ValueError(f"row {row}: {column} {value!r} is not a number") from None
    if not math.isfinite(x):
        raise ValueError(f"row {row}: {column} {value!r} is not finite")
    return x


def _epoch_s(value, column: str, row: int) -> float:
    """Epoch seconds from a number (seconds) or an ISO 8601 datetime (zone-less: UTC)."""
    if _missing(value):
        raise ValueError(f"row {row}: no {column}")
    if isinstance(value, (int, float)) and not isinstance(value, bool):
        t = float(value)
    else:
        text = str(value).strip()
        try:
            t = float(text)
        except ValueError:
            try:
                when = datetime.fromisoformat(text.replace("Z", "+00:00"))
            except ValueError:
                raise ValueError(f"row {row}: {column} {text!r} is neither epoch seconds nor an ISO 8601 "
                                 "datetime") from None
            if when.tzinfo is None:
                when = when.replace(tzinfo=timezone.utc)
            return when.timestamp()
    if not math.isfinite(t):
        raise ValueError(f"row {row}: {column} {value!r} is not finite")
    if abs(t) > 1e11:  # 5138 AD in seconds, 1973 in milliseconds: not guessed
        raise ValueError(f"row {row}: {column} {value!r} looks like milliseconds: give epoch seconds")
    return t


@dataclass(frozen=True, slots=True)
class Sample:
    """One usable row: epoch seconds, WGS-84 degrees, altitude m, true east/north/up m/s."""

    t: float
    lat: float
    lon: float
    alt_m: float
    ve: float
    vn: float
    vu: float


@dataclass
class Aircraft:
    icao24: str  # six lower-case hex digits
    callsign: str
    samples: list[Sample]  # time-ordered, one per time
    incomplete_rows: int = 0  # rows with a missing field: not samples


@dataclass(frozen=True)
class Table:
    path: Path
    layout: Layout
    aircraft: dict[str, Aircraft]  # by icao24, in order of first appearance
    rows: int


def _callsign(text) -> str:
    return "" if _missing(text) else re.sub(r"[^A-Z0-9 ]", "", str(text).upper()).strip()[:8]


def read_table(path: str | Path, units: str | None = None, progress: bool | None = None) -> Table:
    """A trajectory table's aircraft and their samples; ValueError (naming the file, row and column) on any
    malformed content. Rows are numbered from 1 (the first data row; a CSV's line number is row + 1)."""
    path = Path(path)
    try:
        names, columns = read_columns(path, progress)
        layout = layout_of(names, units)
        return _rows_to_table(path, layout, columns)
    except ValueError as e:
        message = str(e)
        raise ValueError(message if message.startswith(str(path)) else f"{path}: {message}") from None


def _check_physical(layout: Layout, factors: dict, row: int, lat: float, alt: float, speed: float, direction: float,
                    vertical: float) -> None:
    """A complete row within the simulator's aircraft limits (sitl/avionics_sitl/aircraft.py: those of a scenario
    file's aircraft, ALT_RANGE_M the span of the standard atmosphere the simulator computes pressure with), so that
    an extreme but finite value (1e20 ft, 1e9 kt) is an error naming its row, not a crash of the MAVLink encoder or
    of the tangent plane later."""
    def bad(column: str, value: float, what: str) -> ValueError:
        return ValueError(f"row {row}: {column} {value:g} is {what}")

    if abs(lat) > MAX_ABS_LAT_DEG:
        raise bad(layout.lat, lat, f"beyond ±{MAX_ABS_LAT_DEG:g}° (the tangent plane's limit)")
    lo, hi = ALT_RANGE_M
    if not lo <= alt * factors["altitude"] <= hi:
        raise bad(layout.altitude, alt, f"outside {lo:g}..{hi:g} m")
    if speed * factors["speed"] > MAX_SPEED_MPS:
        raise bad(layout.speed, speed, f"above {MAX_SPEED_MPS:g} m/s")
    if abs(direction) > 720.0:
        raise bad(layout.direction, direction, "not a direction in degrees")
    if abs(vertical * factors["vertical"]) > MAX_VERTICAL_RATE_MPS:
        raise bad(layout.vertical, vertical, f"beyond ±{MAX_VERTICAL_RATE_MPS:g} m/s")


def _rows_to_table(path: Path, layout: Layout, columns: dict[str, list]) -> Table:
    factors = UNITS[layout.units]
    n = len(columns[layout.time])
    entries: dict[str, list[tuple[float, int, Sample | None]]] = {}
    callsigns: dict[str, str] = {}
    cols = [columns[c] for c in (layout.lat, layout.lon, layout.altitude, layout.speed, layout.direction,
                                  layout.vertical)]
    names = (layout.lat, layout.lon, layout.altitude, layout.speed, layout.direction, layout.vertical)
    call_col = columns[layout.callsign] if layout.callsign else None
    for i in range(n):
        row = i + 1
        raw_icao = columns["icao24"][i]
        if _missing(raw_icao):
            raise ValueError(f"row {row}: no icao24")
        try:
            icao24 = f"{icao_of(raw_icao):06x}"
        except ValueError as e:
            raise ValueError(f"row {row}: icao24 {e}") from None
        t = _epoch_s(columns[layout.time][i], layout.time, row)
        lat, lon, alt, speed, direction, vertical = (_number(c[i], name, row) for c, name in zip(cols, names))
        if not math.isnan(lat) and not -90.0 <= lat <= 90.0:
            raise ValueError(f"row {row}: {layout.lat} {lat:g} is outside [-90, 90]")
        if not math.isnan(lon) and not -180.0 <= lon <= 360.0:
            raise ValueError(f"row {row}: {layout.lon} {lon:g} is outside [-180, 360]")
        if not math.isnan(speed) and speed < 0.0:
            raise ValueError(f"row {row}: {layout.speed} {speed:g} is negative")
        values = (lat, lon, alt, speed, direction, vertical)
        if any(math.isnan(v) for v in values):
            sample = None  # a field is missing: not a sample (never read as zero)
        else:
            _check_physical(layout, factors, row, lat, alt, speed, direction, vertical)
            gs = speed * factors["speed"]
            trk = math.radians(direction)
            sample = Sample(t, lat, (lon + 180.0) % 360.0 - 180.0, alt * factors["altitude"], gs * math.sin(trk),
                            gs * math.cos(trk), vertical * factors["vertical"])
        entries.setdefault(icao24, []).append((t, i, sample))
        if call_col is not None and icao24 not in callsigns and _callsign(call_col[i]):
            callsigns[icao24] = _callsign(call_col[i])
    aircraft = {}
    for icao24, rows in entries.items():
        rows.sort(key=lambda r: (r[0], r[1]))  # by time, file order within a time
        samples: list[Sample] = []
        incomplete = 0
        for k, (t, _, sample) in enumerate(rows):
            if k + 1 < len(rows) and rows[k + 1][0] == t:
                continue  # a later row has this time: the last row wins
            if sample is None:
                incomplete += 1
            else:
                samples.append(sample)
        aircraft[icao24] = Aircraft(icao24, callsigns.get(icao24, ""), samples, incomplete)
    return Table(path, layout, aircraft, n)


# --- tables -> a Scenario -------------------------------------------------------------------------------------

class TableTrajectory(SampledTrajectory):
    """A `SampledTrajectory` through an aircraft's table samples that also knows when the aircraft was heard:
    inside a stretch of samples no more than gap_s apart. The schedule (avionics_sitl.autopilot) sends no report
    of it outside those stretches. Its truth (state_at, enu_at, used for the misses) still goes through a gap, on
    the straight line between the samples either side (a cubic over a long gap would swing by velocity x gap)."""

    def __init__(self, times, lat, lon, alt, vel_e, vel_n, vel_u, plane, gap_s: float):
        super().__init__(times, lat, lon, alt, vel_e, vel_n, vel_u, plane=plane)
        self.gap_s = gap_s
        t = self.times
        breaks = np.nonzero(np.diff(t) > gap_s)[0]
        starts = np.concatenate([[0], breaks + 1])
        ends = np.concatenate([breaks, [len(t) - 1]])
        self.heard = [(float(t[a]), float(t[b])) for a, b in zip(starts, ends)]
        self._starts = [a for a, _ in self.heard]

    def _interpolate(self, t_s: float):
        t = self._t
        i = bisect.bisect_right(t, t_s) - 1
        if 0 <= i < len(t) - 1 and t[i + 1] - t[i] > self.gap_s:
            h = t[i + 1] - t[i]
            u = (t_s - t[i]) / h
            a, b = self._pos[i], self._pos[i + 1]
            return tuple((1.0 - u) * p + u * q for p, q in zip(a, b)), tuple((q - p) / h for p, q in zip(a, b))
        return super()._interpolate(t_s)

    def heard_at(self, t_s: float) -> bool:
        i = int(np.searchsorted(self._starts, t_s, side="right")) - 1
        return i >= 0 and t_s <= self.heard[i][1]


def _trajectory(samples: list[Sample], t0: float, plane: LocalTangentPlane, gap_s: float) -> TableTrajectory:
    cols = list(zip(*[(s.t - t0, s.lat, s.lon, s.alt_m, s.ve, s.vn, s.vu) for s in samples]))
    return TableTrajectory(*cols, plane=plane, gap_s=gap_s)


def _spec(ac: Aircraft, state, datum: AltitudeDatum, where: str) -> AircraftSpec:
    try:
        return AircraftSpec(
            name=ac.icao24, icao_address=int(ac.icao24, 16), lat_deg=state.lat_deg, lon_deg=state.lon_deg,
            alt_msl_m=state.alt_msl_m, heading_deg=state.track_deg % 360.0 if state.ground_speed_mps > 0 else 0.0,
            speed_mps=state.ground_speed_mps, vertical_rate_mps=state.vel_up_mps, altitude_datum=datum,
            callsign=ac.callsign, emitter_type=TABLE_EMITTER_TYPE,
        )
    except ValueError as e:
        raise ValueError(f"{where}: aircraft {ac.icao24}: {e}") from None


def _pick_ownship(table: Table, ownship: str | None, source: str) -> Aircraft:
    if ownship is None:
        if len(table.aircraft) != 1:
            raise ValueError(f"{table.path}: {len(table.aircraft)} aircraft in the ownship file: choose one with "
                             "--ownship ICAO24")
        return next(iter(table.aircraft.values()))
    key = f"{icao_of(ownship):06x}"
    if key not in table.aircraft:
        some = ", ".join(list(table.aircraft)[:8]) + (", ..." if len(table.aircraft) > 8 else "")
        raise ValueError(f"{table.path}: no row of ownship {key} ({source}; aircraft: {some})")
    return table.aircraft[key]


def read_trajectory_tables(path: str | Path, ownship: str | None = None, ownship_file: str | Path | None = None,
                           units: str | None = None, gap_s: float = DEFAULT_GAP_S,
                           progress: bool | None = None) -> Scenario:
    """The encounter of a trajectory table: the ownship is the table's aircraft `ownship` (an icao24), or the
    aircraft of `ownship_file` (another table; `ownship` picks one there if it holds several); every other aircraft
    of the table is an intruder. A one-sample ownship flies straight at that sample's velocity forever (a UAV
    hovering at a point: speed and vertical rate 0). Simulation time 0 is the first time both the ownship and an
    intruder are known; the run ends when the ownship's samples or all intruders' end."""
    if ownship is None and ownship_file is None:
        raise ValueError(f"{path}: a trajectory table needs --ownship ICAO24 (one of its aircraft) or "
                         "--ownship-file FILE")
    if not (isinstance(gap_s, (int, float)) and math.isfinite(gap_s) and gap_s > 0):
        raise ValueError(f"gap {gap_s!r} s must be a positive number of seconds")
    table = read_table(path, units, progress)
    if ownship_file is not None:
        own_table = read_table(ownship_file, units, progress)
        own = _pick_ownship(own_table, ownship, "--ownship-file")
        own_datum = own_table.layout.datum
    else:
        own = _pick_ownship(table, ownship, "--ownship")
        own_datum = table.layout.datum
    if not own.samples:
        raise ValueError(f"{path}: ownship {own.icao24} has no complete row (position, altitude and velocity)")
    intruders = [ac for key, ac in table.aircraft.items() if key != own.icao24 and ac.samples]
    if not intruders:
        raise ValueError(f"{path}: no intruder with a complete row besides ownship {own.icao24}")
    hovering = len(own.samples) == 1
    first = min(s.t for ac in intruders for s in ac.samples)
    last = max(ac.samples[-1].t for ac in intruders)
    t0 = first if hovering else max(own.samples[0].t, first)
    t_end = last if hovering else min(own.samples[-1].t, last)
    if not t_end > t0:
        raise ValueError(f"{path}: the intruders' rows ({first:.0f}..{last:.0f} s) do not overlap ownship "
                         f"{own.icao24}'s ({own.samples[0].t:.0f}..{own.samples[-1].t:.0f} s)")
    ref = min(own.samples, key=lambda s: abs(s.t - t0))
    plane = LocalTangentPlane(ref.lat, ref.lon)
    for ac in (own, *intruders):  # as a scenario file's [reference] offsets: keep the tangent plane honest
        east, north = plane.to_en(np.array([s.lat for s in ac.samples]), np.array([s.lon for s in ac.samples]))
        far = float(np.max(np.hypot(east, north)))
        if not far <= MAX_PLANE_OFFSET_M:
            raise ValueError(f"{path}: aircraft {ac.icao24} is {far / 1e3:.0f} km from ownship's start, beyond the "
                             f"{MAX_PLANE_OFFSET_M / 1e3:.0f} km the simulator's tangent plane covers")
    own_traj = _trajectory(own.samples, t0, plane, gap_s)  # its own navigation: reported through its gaps
    duration = t_end - t0
    kept: list[tuple[Aircraft, TableTrajectory]] = []
    for ac in intruders:
        traj = _trajectory(ac.samples, t0, plane, gap_s)
        if any(a <= duration and b >= 0.0 for a, b in traj.heard):
            kept.append((ac, traj))
    if not kept:
        raise ValueError(f"{path}: no intruder is heard while ownship {own.icao24} flies")
    where = str(path)
    own_spec = _spec(own, own_traj.state_at(0.0), own_datum, where)
    # an intruder's spec: its state when first heard in the run (not an extrapolation or a gap's chord)
    specs = [_spec(ac, traj.state_at(next(max(a, 0.0) for a, b in traj.heard if b >= 0.0)), table.layout.datum,
                   where) for ac, traj in kept]
    dropped = sum(ac.incomplete_rows for ac in table.aircraft.values())
    stamp = datetime.fromtimestamp(t0, timezone.utc).isoformat()
    description = (
        f"trajectory table {Path(path).name}: ownship {own.icao24}"
        + (f" from {Path(ownship_file).name}" if ownship_file is not None else "")
        + (" (one sample: straight at its velocity, hovering if 0)" if hovering else "")
        + f", {len(kept)} intruder(s); units {table.layout.units} ({UNITS[table.layout.units]['text']}, from "
        f"{table.layout.units_from}); altitude {table.layout.altitude}; {table.rows} rows, {dropped} incomplete; "
        f"simulation time 0 = {stamp}"
    )
    return Scenario(
        name=Path(path).stem, description=description, ownship=own_spec, intruders=tuple(specs),
        duration_s=duration, precomputed_trajectories=(own_traj, tuple(t for _, t in kept)),
        origin=(ref.lat, ref.lon),
    )
