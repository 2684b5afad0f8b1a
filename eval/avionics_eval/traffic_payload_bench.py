"""What one track tick costs to publish on zenoh, per encoding: `python -m avionics_eval.traffic_payload_bench
[--intruders 1000,3000] [--ticks 10]` prints JSON (docs/performance.md, "Publishing the traffic").

The TrackViews are real: the DAA facade (avionics/daa.py, default configuration, IMM) tracks N intruders fed as
core inputs for a few seconds, a third converging on ownship; then each variant publishes the same views `--ticks`
times on a real zenoh session (peer, loopback, scouting off) to a second session that subscribes and counts
what arrives. Per variant and tick: `build_ms` (TrackViews to payload, the onboard loop's share), `publish_ms`
(serialise and put, the publisher thread's share), both wall clock and medians over the ticks; `bytes` per tick
(all samples); `samples` per tick; `decode_ms` what a Python ground tool spends to get the rows back.

Variants:
- `per_track_json`: one JSON sample per track on `tracks/<intruder>` (payloads.track_payload), as before.
- `columns_json`: one sample on `traffic`, JSON columns: a header, {field: [value per track]} (built here).
- `arrow_ipc_from_lists`: the same column lists converted to an Arrow IPC stream (pyarrow).
- `arrow_ipc`: the contract (io/traffic.py encode_traffic): Arrow IPC built straight from the TrackViews, the
  numeric columns stacked and computed with numpy; decode_ms is io/traffic.py decode_traffic (validated).
"""

from __future__ import annotations

import argparse
import io
import json
import math
import statistics
import sys
import time
from collections import Counter

import numpy as np
import zenoh

from avionics.config import load_config
from avionics.base.geodesy import LocalTangentPlane
from avionics.base.types import (
    ASSESSMENT_FIELDS, AddressSource, AltitudeDatum, IntruderKey, IntruderReport, OwnshipFix, OwnshipPressure,
)
from avionics.daa import Daa
from avionics.io.payloads import track_payload
from avionics.base.units import KT
from avionics.io.traffic import decode_traffic, encode_traffic
from avionics.io.zenoh_bus import open_session, to_json

LAT0, LON0, ALT0 = 47.40, 8.55, 1500.0


def traffic_inputs(n: int, seconds: float = 3.0, seed: int = 1):
    """(t, core inputs) every 0.1 s: ownship at 5 Hz, n intruders at 1 Hz each (a tenth per step), a third
    converging on ownship."""
    rng = np.random.default_rng(seed)
    plane = LocalTangentPlane(LAT0, LON0)
    bearing = rng.uniform(0, 2 * math.pi, n)
    distance = rng.uniform(2000.0, 15000.0, n)
    speed = rng.uniform(80, 250, n) * KT
    heading = np.where(np.arange(n) % 3 == 0, bearing + math.pi, rng.uniform(0, 2 * math.pi, n))
    alt = ALT0 + rng.uniform(-300, 300, n)
    own_v = 60 * KT
    for k in range(int(round(seconds * 10)) + 1):
        t = k / 10.0
        inputs = []
        if k % 2 == 0:
            lat, lon = plane.to_geodetic(0.0, own_v * t)
            inputs += [OwnshipFix(t, float(lat), float(lon), ALT0, ALT0, (own_v, 0.0, 0.0)),
                       OwnshipPressure(t, ALT0)]
        for i in range(k % 10, n, 10):
            e = distance[i] * math.sin(bearing[i]) + speed[i] * math.sin(heading[i]) * t
            nn = distance[i] * math.cos(bearing[i]) + speed[i] * math.cos(heading[i]) * t
            lat, lon = plane.to_geodetic(e, nn)
            inputs.append(IntruderReport(IntruderKey(0x100000 + i, AddressSource.ES1090), t, t, float(lat),
                                         float(lon), float(alt[i]), AltitudeDatum.PRESSURE,
                                         (speed[i] * math.sin(heading[i]), speed[i] * math.cos(heading[i])), 0.0,
                                         callsign=f"B{i:05d}"))
        yield t, inputs


def track_views(n: int, seconds: float = 3.0, seed: int = 1, config=None):
    """Real TrackViews of n intruders (traffic_inputs through the facade) and their time."""
    daa = Daa(config or load_config(), Counter())
    t = 0.0
    for t, inputs in traffic_inputs(n, seconds, seed):
        daa.step(t, inputs)
    return daa.tracks(t), t


# -- Arrow variants (bench only) -------------------------------------------------------------------------------------
def _arrow_from_columns(payload: dict) -> bytes:
    import pyarrow as pa

    columns = payload["columns"]
    table = pa.table({name: pa.array(values) for name, values in columns.items()})
    meta = {k: json.dumps(payload[k]) for k in ("schema", "layout", "vehicle", "time_s", "keys")}
    table = table.replace_schema_metadata(meta)
    sink = io.BytesIO()
    with pa.ipc.new_stream(sink, table.schema) as writer:
        writer.write_table(table)
    return sink.getvalue()


# -- JSON columns (bench only: the alternative measured against the contract's Arrow) --------------------------------
ROW_FIELDS = ("intruder", "address", "address_source", "callsign", "squawk", "emitter_type", "simulated",
              "spoof_suspected", "model", "last_report_s", "age_s", "updates", "lat_deg", "lon_deg", "altitude_m",
              "altitude_datum", "velocity_enu_mps", "ground_speed_mps", "track_deg", "vertical_rate_mps",
              "position_sigma_m", "velocity_sigma_mps", "advisory", "integrity", "integrity_fault_m",
              *ASSESSMENT_FIELDS)


def _row(track, now_s: float) -> tuple:
    x, p, altitude_valid = track.x, track.p, track.altitude_valid
    ve, vn, vu = (float(v) for v in x[3:6])
    modes = track.modes
    return (
        str(track.key), track.key.address, track.key.source.value, track.callsign, track.squawk,
        track.emitter_type, track.simulated, track.spoof_suspected,
        modes.get("model", "cv-kalman") if modes else "cv-kalman", track.last_report_s, now_s - track.last_report_s,
        track.n_updates, track.lat_deg, track.lon_deg, float(x[2]) if altitude_valid else None,
        track.datum.value if altitude_valid and track.datum else None, [ve, vn, vu], math.hypot(ve, vn),
        math.degrees(math.atan2(ve, vn)) % 360.0, vu if altitude_valid else None,
        math.sqrt(max(p[0, 0] + p[1, 1], 0.0)), math.sqrt(max(p[3, 3] + p[4, 4], 0.0)),
        track.advisory_level.name, track.integrity, track.integrity_fault_m,
        *(track.assessment or (None,) * len(ASSESSMENT_FIELDS)),
    )


def traffic_payload(vehicle: str, tracks, now_s: float) -> dict:
    """JSON columns: a header and {field: [value per track]}; IMM maps as value lists with their keys once."""
    columns = dict(zip(ROW_FIELDS, (list(c) for c in zip(*(_row(t, now_s) for t in tracks)))))
    for name in ASSESSMENT_FIELDS:
        columns[name] = [None if v is not None and not math.isfinite(v) else v for v in columns[name]]
    keys = {}
    modes = [t.modes for t in tracks]
    for name in (k for k in modes[0] if k != "model") if modes and modes[0] else ():
        values = [m.get(name) if m else None for m in modes]
        if isinstance(values[0], dict):
            keys[name] = list(values[0])
            values = [None if v is None else list(v.values()) for v in values]
        columns[name] = values
    return {"schema": 2, "layout": 1, "vehicle": vehicle, "time_s": now_s, "count": len(tracks), "keys": keys,
            "columns": columns}


def traffic_rows(payload: dict) -> list[dict]:
    columns, keys = payload["columns"], payload["keys"]
    names = list(columns)
    rows = []
    for values in zip(*(columns[name] for name in names)):
        row = {"schema": payload["schema"], "vehicle": payload["vehicle"], "time_s": payload["time_s"]}
        row.update(zip(names, values))
        for name, ks in keys.items():
            if type(row.get(name)) is list:
                row[name] = dict(zip(ks, row[name]))
        rows.append(row)
    return rows


def _arrow_decode(raw: bytes) -> list[dict]:
    import pyarrow as pa

    return pa.ipc.open_stream(raw).read_all().to_pylist()


# -- the run ---------------------------------------------------------------------------------------------------------
class _Sink:
    def __init__(self):
        self.samples = 0
        self.bytes = 0

    def __call__(self, sample: zenoh.Sample) -> None:
        self.samples += 1
        self.bytes += len(sample.payload)


def _sessions(port: int):
    from avionics.io.params import ZenohConfig

    pub = open_session(ZenohConfig(listen=(f"tcp/127.0.0.1:{port}",), connect=(), scouting=False))
    sub = open_session(ZenohConfig(listen=(), connect=(f"tcp/127.0.0.1:{port}",), scouting=False))
    return pub, sub


def _wait(predicate, timeout_s: float = 30.0) -> bool:
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        if predicate():
            return True
        time.sleep(0.005)
    return predicate()


def run_variant(name: str, session, sink: _Sink, tracks, now_s: float, ticks: int) -> dict:
    vehicle = "bench"
    publishers: dict = {}

    def publisher(key: str):
        pub = publishers.get(key)
        if pub is None:
            pub = publishers[key] = session.declare_publisher(f"daa/{vehicle}/{key}",
                                                              congestion_control=zenoh.CongestionControl.BLOCK)
        return pub

    build, publish, decode, sizes, counts = [], [], [], [], []
    for _ in range(ticks + 1):  # the first tick declares the publishers: left out
        before = sink.samples
        t0 = time.perf_counter()
        if name == "per_track_json":
            payloads = [(f"tracks/{t.key}", track_payload(vehicle, t)) for t in tracks]
        elif name == "columns_json":
            payloads = [("traffic", traffic_payload(vehicle, tracks, now_s))]
        elif name == "arrow_ipc_from_lists":
            payloads = [("traffic", _arrow_from_columns(traffic_payload(vehicle, tracks, now_s)))]
        else:
            payloads = [("traffic", encode_traffic(vehicle, tracks, now_s))]
        t1 = time.perf_counter()
        size = 0
        for key, payload in payloads:
            raw = payload if isinstance(payload, bytes) else to_json(payload)
            size += len(raw)
            publisher(key).put(raw)
        t2 = time.perf_counter()
        raws = [p if isinstance(p, bytes) else to_json(p) for _, p in payloads]
        t3 = time.perf_counter()
        if name == "per_track_json":
            rows = [json.loads(r) for r in raws]
        elif name == "columns_json":
            rows = traffic_rows(json.loads(raws[0]))
        elif name == "arrow_ipc_from_lists":
            rows = _arrow_decode(raws[0])
        else:
            rows = decode_traffic(raws[0])[1]
        t4 = time.perf_counter()
        assert len(rows) == len(tracks)
        if not _wait(lambda: sink.samples - before >= len(payloads)):
            raise RuntimeError(f"{name}: samples lost on loopback")
        build.append(t1 - t0)
        publish.append(t2 - t1)
        decode.append(t4 - t3)
        sizes.append(size)
        counts.append(len(payloads))
    for pub in publishers.values():
        pub.undeclare()
    ms = lambda xs: round(statistics.median(xs[1:]) * 1e3, 2)  # noqa: E731
    return {"build_ms": ms(build), "publish_ms": ms(publish), "total_ms": ms([b + p for b, p in zip(build, publish)]),
            "bytes": sizes[-1], "bytes_per_track": round(sizes[-1] / max(1, len(tracks)), 1),
            "samples": counts[-1], "decode_ms": ms(decode)}


VARIANTS = ("per_track_json", "columns_json", "arrow_ipc_from_lists", "arrow_ipc")


def bench(intruders: list[int], ticks: int, port: int) -> dict:
    pub, sub = _sessions(port)
    sink = _Sink()
    subscriber = sub.declare_subscriber("daa/bench/**", sink)
    try:
        probe = pub.declare_publisher("daa/bench/probe")
        if not _wait(lambda: (probe.put(b"x"), sink.samples > 0)[1], 10.0):
            raise RuntimeError("the subscriber session never connected")
        probe.undeclare()
        out = {"command": "python -m avionics_eval.traffic_payload_bench " + " ".join(sys.argv[1:]),
               "date": time.strftime("%Y-%m-%d %H:%M"), "python": sys.version.split()[0], "ticks": ticks,
               "fields_per_track": len(ROW_FIELDS), "results": {}}
        for n in intruders:
            tracks, now_s = track_views(n)
            out["results"][str(n)] = {"tracks": len(tracks), **{v: run_variant(v, pub, sink, tracks, now_s, ticks)
                                                               for v in VARIANTS}}
        return out
    finally:
        subscriber.undeclare()
        sub.close()
        pub.close()


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--intruders", default="1000,3000")
    ap.add_argument("--ticks", type=int, default=10)
    ap.add_argument("--port", type=int, default=17481)
    args = ap.parse_args(argv)
    print(json.dumps(bench([int(x) for x in args.intruders.split(",")], args.ticks, args.port), indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
