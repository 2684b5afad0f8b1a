"""The batched traffic sample, topic `<prefix>/<vehicle>/traffic` (docs/zenoh.md, "Traffic"): every track of one
track tick in ONE zenoh sample, as an Apache Arrow IPC stream (encoding `application/vnd.apache.arrow.stream`).

One record batch, one row per track, one column per field of the per-track payload (payloads.track_payload) with
the types of the contract's TRAFFIC_COLUMNS (avionics/contract/zenoh.py); the header (schema, layout, vehicle,
time_s, and the key names of the IMM's map-valued fields) is the Arrow schema's metadata. `traffic_rows` turns the rows back into per-track payloads in their wire
form (non-finite floats null), field for field; numeric columns computed vectorised (ground speed, track, sigmas)
agree with payloads.track_payload to the last bit or two (numpy's hypot/arctan2 against math's).

Why Arrow and not JSON columns (`python -m avionics_eval.traffic_payload_bench`, docs/performance.md, two runs on a
loaded 2-core machine): one tick of 3000 tracks costs 30-61 ms to build and put as Arrow, 63-183 ms as JSON columns
(38-98 ms of it one json.dumps call, which holds the interpreter lock from the onboard loop all along) and
317-407 ms as 3000 per-track JSON samples; 369 bytes a track against 565 and 1229. Arrow IPC is language-neutral
(C++, Rust, Go, Java, JavaScript, ...).

`TrafficBatch` is what the onboard loop files with the ZenohBus: the TrackViews (immutable) and the time; the
publisher thread encodes it in the loop's idle time, and the snapshot queryable turns it into per-track payloads
only when asked.
"""

from __future__ import annotations

import io
import json
import math
from dataclasses import dataclass

import numpy as np

from avionics.contract.zenoh import KEYED_COLUMNS, SCHEMA_VERSION, TRACK_MODEL_CV, TRAFFIC_LAYOUT
from avionics.base.types import ASSESSMENT_FIELDS
from avionics.base.units import ground_speed_mps, track_deg
from avionics.io.payloads import track_payload

def _finite(values) -> list:
    isfinite = math.isfinite
    return [None if v is None or not isfinite(v) else v for v in values]


def encode_traffic(vehicle: str, tracks, now_s: float) -> bytes:
    """Every track of `tracks` (TrackViews, as DaaResult.tracks) as one Arrow IPC stream published at now_s; each
    row carries the time of its own view (`time_s`, layout 2: the views of a round are built over a few steps)."""
    import pyarrow as pa  # lazily: 0.25 s of import, not on the start-up path

    n = len(tracks)
    f64, i32 = pa.float64(), pa.int32()
    x = np.stack([t.x for t in tracks]) if n else np.empty((0, 6))
    p = np.stack([t.p for t in tracks]) if n else np.empty((0, 6, 6))
    ve, vn, vu = x[:, 3], x[:, 4], x[:, 5]
    alt_ok = np.fromiter((t.altitude_valid for t in tracks), bool, n)
    last = np.fromiter((t.last_report_s for t in tracks), float, n)
    times = np.fromiter((t.time_s for t in tracks), float, n)
    keys = [t.key for t in tracks]
    modes = [t.modes for t in tracks]
    cols = {
        "intruder": pa.array([str(k) for k in keys], pa.string()),
        "address": pa.array(np.fromiter((k.address for k in keys), np.int32, n)),
        "address_source": pa.array([k.source.value for k in keys], pa.string()),
        "callsign": pa.array([t.callsign for t in tracks], pa.string()),
        "squawk": pa.array([t.squawk for t in tracks], i32),
        "emitter_type": pa.array([t.emitter_type for t in tracks], i32),
        "simulated": pa.array([bool(t.simulated) for t in tracks], pa.bool_()),
        "spoof_suspected": pa.array([bool(t.spoof_suspected) for t in tracks], pa.bool_()),
        "model": pa.array([m.get("model", TRACK_MODEL_CV) if m else TRACK_MODEL_CV for m in modes], pa.string()),
        "time_s": pa.array(times), "last_report_s": pa.array(last), "age_s": pa.array(times - last),
        "updates": pa.array(np.fromiter((t.n_updates for t in tracks), np.int64, n)),
        "lat_deg": pa.array(np.fromiter((t.lat_deg for t in tracks), float, n)),
        "lon_deg": pa.array(np.fromiter((t.lon_deg for t in tracks), float, n)),
        "altitude_m": pa.array(x[:, 2], mask=~alt_ok),
        "altitude_datum": pa.array([t.datum.value if a and t.datum else None for t, a in zip(tracks, alt_ok)],
                                   pa.string()),
        "velocity_enu_mps": pa.FixedSizeListArray.from_arrays(pa.array(np.ascontiguousarray(x[:, 3:6]).ravel()), 3),
        "ground_speed_mps": pa.array(ground_speed_mps(ve, vn)),
        "track_deg": pa.array(track_deg(ve, vn)),
        "vertical_rate_mps": pa.array(vu, mask=~alt_ok),
        "position_sigma_m": pa.array(np.sqrt(np.maximum(p[:, 0, 0] + p[:, 1, 1], 0.0))),
        "velocity_sigma_mps": pa.array(np.sqrt(np.maximum(p[:, 3, 3] + p[:, 4, 4], 0.0))),
        "advisory": pa.array([t.advisory_level.name for t in tracks], pa.string()),
        "integrity": pa.array([t.integrity for t in tracks], pa.string()),
        "integrity_fault_m": pa.array(_finite(t.integrity_fault_m for t in tracks), f64),
    }
    for j, name in enumerate(ASSESSMENT_FIELDS):
        cols[name] = pa.array(_finite(t.assessment[j] if t.assessment else None for t in tracks), f64)
    key_names: dict = {}
    first = next((m for m in modes if m), None)
    for name in (k for k in first if k != "model") if first else ():
        values = [m.get(name) if m else None for m in modes]
        sample = next((v for v in values if v is not None), None)
        if name in KEYED_COLUMNS and isinstance(sample, dict):
            names = list(sample)
            key_names[name] = names
            flat = np.array([list(v.values()) if v is not None and list(v) == names else [np.nan] * len(names)
                             for v in values], float).reshape(n, len(names))
            missing = np.fromiter((v is None or list(v) != names for v in values), bool, n)
            cols[name] = pa.FixedSizeListArray.from_arrays(pa.array(flat.ravel()), len(names),
                                                           mask=pa.array(missing))
        elif isinstance(sample, str):
            cols[name] = pa.array(values, pa.string())
        else:
            cols[name] = pa.array(_finite(values), f64)
    meta = {"schema": str(SCHEMA_VERSION), "layout": str(TRAFFIC_LAYOUT), "vehicle": vehicle,
            "time_s": repr(float(now_s)), "keys": json.dumps(key_names)}
    table = pa.table(cols).replace_schema_metadata(meta)
    sink = io.BytesIO()
    with pa.ipc.new_stream(sink, table.schema) as writer:
        writer.write_table(table)
    return sink.getvalue()


class TrafficError(ValueError):
    """Not a traffic stream of this contract; `reason` is short and bounded (monitor/schema.py counts it)."""

    def __init__(self, reason: str):
        super().__init__(reason)
        self.reason = reason


def decode_traffic(raw: bytes, max_rows: int = 100_000) -> tuple[dict, list[dict]]:
    """(header, rows) of an Arrow traffic stream: header {schema, layout, vehicle, time_s, keys}, rows as
    per-track payloads with schema and vehicle from the header (and time_s, from layout 1's, which has no row
    times) and the keyed maps rebuilt. Checks the
    stream's structure only (TrafficError): the values are for the caller to check (monitor/schema.py). Untrusted
    input is safe to pass: the stream is fully validated (offsets, lengths) before a value is read."""
    import pyarrow as pa

    try:
        reader = pa.ipc.open_stream(pa.py_buffer(raw))
        table = reader.read_all()
        table.validate(full=True)
    except Exception:  # noqa: BLE001  (ArrowInvalid, ArrowNotImplementedError, OSError, ...: not a stream)
        raise TrafficError("arrow") from None
    if table.num_rows > max_rows:
        raise TrafficError("rows")
    meta = {k.decode("utf-8", "replace"): v.decode("utf-8", "replace") for k, v in (table.schema.metadata or {}).items()}
    try:
        header = {"schema": int(meta["schema"]), "layout": int(meta["layout"]), "vehicle": meta.get("vehicle"),
                  "time_s": float(meta["time_s"])}
        keys = json.loads(meta.get("keys") or "{}")
    except (KeyError, ValueError, RecursionError):
        raise TrafficError("header") from None
    if type(keys) is not dict or not all(type(v) is list and all(type(s) is str for s in v) for v in keys.values()):
        raise TrafficError("keys")
    header["keys"] = keys
    for name, field in zip(table.column_names, table.schema):
        t = field.type
        if not (pa.types.is_floating(t) or pa.types.is_integer(t) or pa.types.is_boolean(t) or pa.types.is_string(t)
                or pa.types.is_null(t) or (pa.types.is_fixed_size_list(t) and pa.types.is_floating(t.value_type))):
            raise TrafficError(f"type.{name}" if len(name) <= 64 and name.isprintable() else "type")
    if len(set(table.column_names)) != len(table.column_names):
        raise TrafficError("columns")
    try:
        rows = table.to_pylist()
    except Exception:  # noqa: BLE001
        raise TrafficError("arrow") from None
    common = {"schema": header["schema"], "vehicle": header["vehicle"]}
    if "time_s" not in table.column_names:
        common["time_s"] = header["time_s"]
    for row in rows:
        for name, names in keys.items():
            v = row.get(name)
            if type(v) is list:
                row[name] = dict(zip(names, v)) if len(v) == len(names) else v  # a bad length: the check refuses
        row.update(common)
    return header, rows


@dataclass(frozen=True, slots=True)
class TrafficBatch:
    """One track tick for the ZenohBus: the vehicle, the time and the TrackViews (immutable). Encoded on the
    publisher thread (encode), turned into per-track payloads only for the snapshot (payloads)."""

    vehicle: str
    time_s: float
    tracks: tuple

    def encode(self) -> bytes:
        return encode_traffic(self.vehicle, self.tracks, self.time_s)

    def payloads(self) -> list[dict]:
        return [track_payload(self.vehicle, t) for t in self.tracks]

    def names(self) -> list[str]:
        return [str(t.key) for t in self.tracks]
