"""The batched traffic sample (`<prefix>/<vehicle>/traffic`, Arrow IPC, io/traffic.py) over real zenoh sessions
(peer mode on loopback, scouting off): its rows equal the per-track payloads of the TrackViews the facade
published; the monitor's picture from batches equals its picture from per-track samples; malformed batches are
counted and rejected whole or row by row, never crash the feed. Plus the per-track keys' schedule (ports.py)."""

from __future__ import annotations

import io
import json
import math
import random
from collections import Counter

import pyarrow as pa
import pytest

from avionics.config import load_config
from avionics.daa import Daa
from avionics.io.payloads import track_payload
from avionics.contract.zenoh import ARROW_STREAM
from avionics.io.traffic import TrafficBatch, decode_traffic, encode_traffic
from avionics.io.zenoh_bus import ZenohBus, open_session, to_json
from avionics.loop import Batch, Loop, MavlinkInput
from avionics.monitor.feed import ZenohFeed, monitor_zenoh_config
from avionics.monitor.schema import Rejected, clean_traffic
from avionics.monitor.state import FleetState
from avionics.ports import TRACK_KEYS_PERIOD_S, ZenohOut
from avionics_eval.traffic_payload_bench import track_views, traffic_inputs
from tests.conftest import DEADLINE_S, free_port, wait_for

N = 40  # intruders


def wire(payload: dict) -> dict:
    """A per-track payload as a subscriber of tracks/<intruder> gets it (JSON: inf and NaN are null)."""
    return json.loads(to_json(payload))


def same(a, b) -> bool:
    """Equal, floats to 1e-12 relative (vectorised hypot/arctan2 against math's may differ in the last bits)."""
    if isinstance(a, float) and isinstance(b, float):
        return math.isclose(a, b, rel_tol=1e-12, abs_tol=1e-12)
    if isinstance(a, dict) and isinstance(b, dict):
        return a.keys() == b.keys() and all(same(a[k], b[k]) for k in a)
    if isinstance(a, list) and isinstance(b, list):
        return len(a) == len(b) and all(same(x, y) for x, y in zip(a, b))
    return a == b and type(a) is type(b)


class Recorder:
    """A port that keeps every result's TrackViews (the oracle: what the facade published)."""

    def __init__(self):
        self.views: dict[float, tuple] = {}

    def wants(self, now_s):
        from avionics.ports import NOTHING
        return NOTHING

    def publish(self, result):
        if result.tracks is not None:
            self.views[result.time_s] = result.tracks

    def close(self):
        pass


@pytest.fixture
def endpoint():
    return f"tcp/127.0.0.1:{free_port()}"


@pytest.mark.live
@pytest.mark.parametrize("n", [N, 300])
def test_batched_sample_carries_every_track_as_its_per_track_payload(endpoint, n):
    """300 tracks are more than a slice (advisory.assessment_slice, 128): their views are built over the steps of
    a quarter second (ports.VIEWS_WITHIN_PERIODS of the 2 Hz period), each row at its own time; 40 in one step."""
    config = load_config(overrides=[f'zenoh.listen=["{endpoint}"]'])
    bus = ZenohBus(config.zenoh, "uav1")
    sub = open_session(monitor_zenoh_config([endpoint], mode="peer"))
    got: dict[float, tuple] = {}  # time_s -> (encoding, header, rows)
    per_track: list = []

    def on_sample(sample):
        raw = sample.payload.to_bytes()
        if str(sample.key_expr) == "daa/uav1/traffic":
            header, rows = decode_traffic(raw)
            got[header["time_s"]] = (str(sample.encoding), header, rows)
        elif "/tracks/" in str(sample.key_expr):
            per_track.append(json.loads(raw))

    subscriber = sub.declare_subscriber("daa/uav1/**", on_sample)
    recorder = Recorder()
    loop = Loop(Daa(config, Counter()), MavlinkInput(config, Counter()), [ZenohOut(bus.publish, config), recorder])
    try:
        # the subscription must reach the bus's session before the run counts: a probe batch until one arrives
        assert wait_for(lambda: bus.publish("traffic", TrafficBatch("uav1", -1.0, ())) or -1.0 in got)
        for t, inputs in traffic_inputs(n, seconds=4.0):
            loop.step(Batch(t, inputs))
        ticks = sorted(recorder.views)
        assert len(ticks) >= 7 and len(recorder.views[ticks[-1]]) == n  # 2 Hz for 4 s, every intruder tracked
        assert wait_for(lambda: all(t in got for t in ticks)), sorted(set(ticks) - set(got))
        for t in ticks:
            encoding, header, rows = got[t]
            views = recorder.views[t]
            assert encoding == ARROW_STREAM
            assert header["schema"] == 2 and header["layout"] == 2 and header["vehicle"] == "uav1"
            assert len(rows) == len(views)
            times = [row["time_s"] for row in rows]  # the round's slices: built at most a quarter second apart
            assert max(times) == t and t - min(times) <= 0.25 + 1e-9
            assert (min(times) < t) == (n > config.advisory.assessment_slice and len(rows) > 128)
            for view, row in zip(views, rows):
                expected = wire(track_payload("uav1", view))
                assert set(row) == set(expected)
                bad = {k: (row[k], expected[k]) for k in expected if not same(row[k], expected[k])}
                assert not bad, (t, str(view.key), bad)
                # and against the view itself, not only through track_payload
                assert row["intruder"] == str(view.key) and row["lat_deg"] == view.lat_deg
                assert row["lon_deg"] == view.lon_deg and row["altitude_m"] == float(view.x[2])
                assert row["velocity_enu_mps"] == [float(v) for v in view.x[3:6]]
                assert row["updates"] == view.n_updates and row["callsign"] == view.callsign
        # per-track keys are still there, but not every track at every tick
        assert wait_for(lambda: {p["intruder"] for p in per_track} == {str(v.key) for v in recorder.views[ticks[-1]]})
        assert len(per_track) < n * len(ticks) / 2
    finally:
        subscriber.undeclare()
        sub.close()
        bus.close()


@pytest.mark.live
def test_monitor_picture_from_batches_equals_picture_from_per_track_samples(endpoint):
    """Vehicle b publishes only batches, vehicle p only per-track samples, of the same TrackViews; one monitor
    feed gets both over zenoh: its two pictures are the same."""
    config = load_config(overrides=[f'zenoh.listen=["{endpoint}"]'])
    bus_b = ZenohBus(config.zenoh, "b")
    bus_p = ZenohBus(config.zenoh, "p", session=bus_b.session)
    state = FleetState(stale_s=60.0)
    feed = ZenohFeed(state, monitor_zenoh_config([endpoint], mode="peer"), query_timeout_s=0.5)
    daa = Daa(config, Counter())
    try:
        probe = TrafficBatch("b", -1.0, ())
        assert wait_for(lambda: bus_b.publish("traffic", probe) or state.stats["samples.traffic"] > 0)
        last = None
        for t, inputs in traffic_inputs(N, seconds=3.0):
            daa.step(t, inputs)
            if round(t * 10) % 5 == 0:
                views = daa.tracks(t)
                bus_b.publish("traffic", TrafficBatch("b", t, views))
                for view in views:
                    bus_p.publish(f"tracks/{view.key}", track_payload("p", view))
                last = (t, views)
        t_end, views = last

        def caught_up(vid):
            with state.cond:
                v = state.vehicles.get(vid)
                return v is not None and len(v.tracks) == N and all(
                    e["raw"].get("time_s") == t_end for e in v.tracks.values())

        assert wait_for(lambda: caught_up("b") and caught_up("p"))
        with state.cond:
            raw_b = {k: {f: x for f, x in e["raw"].items() if f != "vehicle"} for k, e in state.vehicles["b"].tracks.items()}
            raw_p = {k: {f: x for f, x in e["raw"].items() if f != "vehicle"} for k, e in state.vehicles["p"].tracks.items()}
        assert raw_b.keys() == raw_p.keys() == {str(v.key) for v in views}
        for k in raw_b:
            assert same(raw_b[k], raw_p[k]), k
        views_b = sorted(state.tracks("b"), key=lambda x: x["id"])
        views_p = sorted(state.tracks("p"), key=lambda x: x["id"])
        assert all(same(a, b) for a, b in zip(views_b, views_p)) and len(views_b) == N
        assert state.stats["rejected"] == 0 and feed.errors == 0
    finally:
        feed.close()
        bus_p.close()
        bus_b.close()


def _stream(table: pa.Table) -> bytes:
    sink = io.BytesIO()
    with pa.ipc.new_stream(sink, table.schema) as writer:
        writer.write_table(table)
    return sink.getvalue()


@pytest.fixture(scope="module")
def views():
    return track_views(12, seconds=2.0)


def test_a_bad_row_is_left_out_and_counted_the_good_rows_kept(views):
    tracks, t = views
    table = pa.ipc.open_stream(encode_traffic("v", tracks, t)).read_all()
    lat = table.column("lat_deg").to_pylist()
    lat[3] = 200.0  # out of range
    callsign = table.column("callsign").to_pylist()
    callsign[5] = "\x1b]0;owned\x07"  # a terminal escape
    table = table.set_column(table.schema.get_field_index("lat_deg"), "lat_deg", pa.array(lat))
    table = table.set_column(table.schema.get_field_index("callsign"), "callsign", pa.array(callsign))
    dropped: dict = {}
    rows = clean_traffic(_stream(table), "v", dropped)
    assert dropped == {"row.lat_deg": 1, "row.callsign": 1}
    assert [r["intruder"] for r in rows] == [str(v.key) for i, v in enumerate(tracks) if i not in (3, 5)]


@pytest.mark.parametrize("mutate, reason", [
    (lambda raw, table: b"", "arrow"),
    (lambda raw, table: b"{\"schema\": 2}", "arrow"),
    (lambda raw, table: raw[: len(raw) // 2], "arrow"),
    (lambda raw, table: _stream(table.replace_schema_metadata({**table.schema.metadata, b"vehicle": b"w"})),
     "vehicle_key"),
    (lambda raw, table: _stream(table.replace_schema_metadata({b"vehicle": b"v"})), "header"),
    (lambda raw, table: _stream(table.replace_schema_metadata({**table.schema.metadata, b"time_s": b"nan"})),
     "header.time_s"),
    (lambda raw, table: _stream(table.replace_schema_metadata({**table.schema.metadata, b"keys": b"[1]"})), "keys"),
    (lambda raw, table: _stream(table.append_column("x", pa.array([{"a": 1}] * table.num_rows))), "type.x"),
])
def test_a_malformed_batch_is_rejected_whole(views, mutate, reason):
    tracks, t = views
    raw = encode_traffic("v", tracks, t)
    with pytest.raises(Rejected) as exc:
        clean_traffic(mutate(raw, pa.ipc.open_stream(raw).read_all()), "v")
    assert exc.value.reason == reason


def test_corrupted_streams_are_rejected_or_checked_never_an_error(views):
    """Bit flips and cuts anywhere in a real stream: clean_traffic returns checked rows or raises Rejected."""
    tracks, t = views
    raw = encode_traffic("v", tracks, t)
    rng = random.Random(13)
    outcomes = Counter()
    for _ in range(400):
        b = bytearray(raw)
        for _ in range(rng.randint(1, 8)):
            b[rng.randrange(len(b))] = rng.randrange(256)
        if rng.random() < 0.3:
            b = b[: rng.randrange(len(b))]
        try:
            rows = clean_traffic(bytes(b), "v")
            assert len(rows) <= len(tracks)
            outcomes["rows"] += 1
        except Rejected:
            outcomes["rejected"] += 1
    assert outcomes["rejected"] > 0


@pytest.mark.live
def test_feed_counts_malformed_batches_and_applies_the_good_rows(endpoint, views):
    tracks, t = views
    good = encode_traffic("v", tracks, t)
    table = pa.ipc.open_stream(good).read_all()
    lat = table.column("lat_deg").to_pylist()
    lat[0] = float("nan")
    one_bad_row = _stream(table.set_column(table.schema.get_field_index("lat_deg"), "lat_deg", pa.array(lat)))
    pub = open_session(monitor_zenoh_config([], mode="peer", listen=[endpoint]))
    state = FleetState()
    feed = ZenohFeed(state, monitor_zenoh_config([endpoint], mode="peer"), query_timeout_s=0.5)
    try:
        def round_trip():
            pub.put("daa/v/traffic", b"\xff" * 100)
            pub.put("daa/v/traffic", good[:-20])
            pub.put("daa/v/traffic", one_bad_row)
            return (len(state.tracks("v")) == len(tracks) - 1 and state.stats["rejected.traffic.arrow"] >= 2
                    and state.stats["rejected.traffic.row.lat_deg"] >= 1)

        assert wait_for(round_trip, DEADLINE_S, period_s=0.1)
        assert str(tracks[0].key) not in {x["id"] for x in state.tracks("v")}
        assert feed.errors == 0
    finally:
        feed.close()
        pub.close()


def test_per_track_keys_new_at_once_then_each_within_the_period():
    config = load_config()
    out: list = []
    port = ZenohOut(lambda suffix, payload: out.append((suffix, payload)), config)
    loop = Loop(Daa(config, Counter()), MavlinkInput(config, Counter()), [port])
    n, seconds = 45, 24.0
    first: dict = {}
    last: dict = {}
    gaps: list = []
    batches = 0
    for t, inputs in traffic_inputs(n, seconds):
        out.clear()
        loop.step(Batch(t, inputs))
        keyed = [p for s, p in out if s.startswith("tracks/")]
        batch = [p for s, p in out if s == "traffic"]
        batches += len(batch)
        if batch:
            assert len(keyed) <= math.ceil(n / (TRACK_KEYS_PERIOD_S * config.zenoh.tracks_hz)) + len(
                [v for v in batch[0].tracks if str(v.key) not in first])
        for p in keyed:
            name = p["intruder"]
            first.setdefault(name, t)
            if name in last:
                gaps.append(t - last[name])
            last[name] = t
    assert batches == pytest.approx(seconds * config.zenoh.tracks_hz, abs=1)
    assert len(first) == n and max(first.values()) <= 1.5  # every track's key as soon as it is tracked
    assert gaps and max(gaps) <= TRACK_KEYS_PERIOD_S + 1e-6  # then each at least once per period
