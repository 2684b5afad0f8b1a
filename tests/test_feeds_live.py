"""Receiver feeds over real sockets on 127.0.0.1, with the real reader threads (avionics/io/feeds/source.py):

- the head-on encounter served by the simulated receiver's SBS or Beast output (sitl/avionics_sitl/sbs.py, beast.py)
  while ownship arrives as MAVLink messages gives the TA and RA onsets of the ADSB_VEHICLE path (within 1 s), run
  in fast time: the server, the loop and the feed's clock are one scenario clock running SPEED times real time;
- the same aircraft on both paths (ADSB_VEHICLE and SBS) is one track;
- a killed and restarted SBS server is reconnected to (reports flow again) and, while down, is a status warning;
- readsb-json from a file and from an http server carries nac_p/nac_v into the tracks' measurement noise.

Waits poll with generous deadlines (conftest.wait_for); durations are printed, never asserted.
"""

from __future__ import annotations

import http.server
import json
import math
import random
import threading
import time
from collections import Counter

import avionics.io  # noqa: F401  (MAVLink 2)
import numpy as np
import pytest
from pyModeS import Message

from avionics.config import load_config
from avionics.base.geodesy import WGS84_A
from avionics.base.types import IntruderKey
from avionics.daa import Daa
from avionics.io.feeds.sbs import SbsParser
from avionics.io.framing import FrameScanner
from avionics.io.feeds.source import FeedSet, TrafficSource
from avionics.loop import Batch, Loop, MavlinkInput
from avionics.tracking.integrity import position_sigma_per_axis
from avionics_sitl.autopilot import AutopilotConfig, Packer, schedule
from avionics_sitl.beast import CLOCK_HZ as BEAST_CLOCK_HZ, BeastConfig, BeastEvent, BeastServer, beast_frame, \
    beast_schedule, df17
from avionics_sitl.encounters import load_encounter
from avionics_sitl.impairments import PRESETS
from avionics_sitl.sbs import SbsServer, sbs_schedule
from conftest import wait_for
from harness import Harness

SCENARIO = load_encounter("head-on")
INTRUDER = SCENARIO.intruders[0]
KEY = IntruderKey(INTRUDER.icao_address, INTRUDER.address_source)
DURATION_S = 72.0  # TA at ~55 s, RA at ~65 s
SPEED = 6.0  # scenario seconds per real second: 72 s in 12 s
TICK_S = 0.1
CONFIG = load_config(None, ["zenoh.enabled=false"])


class Framed:
    """Messages through real MAVLink framing with the autopilot's sender ids (system 1: trusted, our vehicle)."""

    def __init__(self, counters: Counter):
        self.packer, self.scanner = Packer(), FrameScanner(counters)

    def __call__(self, msgs) -> list:
        return self.scanner.feed(b"".join(self.packer.pack(m) for m in msgs), end_of_datagram=True) if msgs else []


def onsets(changes) -> dict[str, float]:
    out: dict[str, float] = {}
    for t, level in changes:
        out.setdefault(level.name, t)
    return out


def mavlink_reference() -> dict[str, float]:
    """The ADSB_VEHICLE path in fast time (no sockets): TA and RA onsets."""
    node = Harness(CONFIG)
    framed = Framed(node.counters)
    events = schedule(SCENARIO, PRESETS["default"], duration_s=DURATION_S)
    changes, i = [], 0
    for k in range(int(DURATION_S / TICK_S) + 1):
        t = k * TICK_S
        msgs = []
        while i < len(events) and events[i].deliver_s <= t:
            msgs.append(events[i].msg)
            i += 1
        result = node.handle(framed(msgs), t)
        changes += [(t, a.level) for a in result.changes if a.intruder == KEY]
    return onsets(changes)


class OwnshipOverMavlink:
    """A loop Source: the autopilot's ownship messages (no ADSB_VEHICLE) decoded at their delivery times, one batch
    per tick of a scenario clock that runs in real time times SPEED."""

    def __init__(self, mavlink: MavlinkInput, clock, end_s: float):
        self.events = [e for e in schedule(SCENARIO, PRESETS["default"], duration_s=end_s)
                       if e.msg.get_type() != "ADSB_VEHICLE"]
        self.mavlink, self.clock, self.end_s = mavlink, clock, end_s
        self.framed = Framed(mavlink.decoder.counters)

    def __iter__(self):
        i, tick = 0, 0.0
        while tick <= self.end_s:
            while self.clock() < tick:
                time.sleep(max(0.0, (tick - self.clock()) / SPEED))  # pacing the clock, not waiting for a result
            now = self.clock()
            msgs = []
            while i < len(self.events) and self.events[i].deliver_s <= now:
                msgs.append(self.events[i].msg)
                i += 1
            yield Batch(now, self.mavlink.decode(self.framed(msgs), now))
            tick += TICK_S

    def status(self):
        return self.mavlink.status()


@pytest.mark.parametrize("scheme, server_type, make_schedule", [("sbs", SbsServer, sbs_schedule),
                                                                  ("beast", BeastServer, beast_schedule)])
def test_receiver_feed_gives_the_onsets_of_the_adsb_vehicle_path(tcp_port, scheme, server_type, make_schedule):
    """SBS-1 lines or Beast frames of the head-on over a real socket, ownship over MAVLink: the ADSB_VEHICLE path's
    TA and RA onsets within 1 s, one track."""
    reference = mavlink_reference()
    assert set(reference) >= {"TA", "RA"}, reference
    t0 = time.monotonic()

    def clock():
        return (time.monotonic() - t0) * SPEED

    counters = Counter()
    with server_type(make_schedule(SCENARIO, PRESETS["default"], duration_s=DURATION_S), port=tcp_port,
                     clock=clock) as server:
        feeds = FeedSet.open([f"{scheme}:127.0.0.1:{server.port}"], CONFIG, clock, counters)
        source = TrafficSource(OwnshipOverMavlink(MavlinkInput(CONFIG, counters), clock, DURATION_S), feeds)
        loop = Loop(Daa(CONFIG, counters), source, [])
        changes, tracks = [], set()
        for batch in source:
            result = loop.step(batch)
            changes += [(batch.now_s, a.level) for a in result.changes if a.intruder == KEY]
            tracks |= set(loop.daa._core.tracker.tracks)
        assert not feeds.feeds[0]._thread.is_alive()  # the iteration's end joined the reader thread
    got = onsets(changes)
    print(json.dumps({"reference_onsets_s": reference, f"{scheme}_onsets_s": got, "counters": {
        k: v for k, v in counters.items() if k.startswith("traffic.")}}))
    assert tracks == {KEY}
    assert counters[f"traffic.{scheme}.reports"] >= 0.8 * DURATION_S  # at least 1 Hz less the default 5 % dropouts
    # Nothing valid is rejected. The one exception left: positions of one aircraft read in one batch while the
    # receiver clock slews to a lower envelope, all mapped to their common receipt (io/feeds/clock.py); on this
    # 2-core CI under load, reads are that late. At most 2 % of positions, and never anything else.
    rejected = {k: v for k, v in counters.items() if k.startswith(f"traffic.{scheme}.rejected")}
    assert set(rejected) <= {f"traffic.{scheme}.rejected.not_newer"}, counters
    assert sum(rejected.values()) <= 0.02 * counters[f"traffic.{scheme}.reports"], counters
    assert abs(got["TA"] - reference["TA"]) <= 1.0 and abs(got["RA"] - reference["RA"]) <= 1.0


def test_the_same_aircraft_on_both_paths_is_one_track():
    """ADSB_VEHICLE (1 Hz) from the autopilot's receiver and SBS (2 Hz) from a ground receiver: one track, fed by
    both (more updates than either path alone), and the MAVLink first-sender rule drops none of the feed's."""
    node = Harness(CONFIG)
    sbs = SbsParser("sbs:127.0.0.1:30003", CONFIG, node.counters)
    framed = Framed(node.counters)
    events = schedule(SCENARIO, PRESETS["default"], duration_s=40.0)
    lines = [(e.deliver_s, line) for e in sbs_schedule(SCENARIO, PRESETS["default"], seed=1, duration_s=40.0,
                                                       config=AutopilotConfig(adsb_hz=2.0))
             for line in e.data.split(b"\r\n") if line]
    i = j = 0
    for k in range(401):
        t = k * TICK_S
        msgs, reports = [], []
        while i < len(events) and events[i].deliver_s <= t:
            msgs.append(events[i].msg)
            i += 1
        while j < len(lines) and lines[j][0] <= t:
            r = sbs.line(lines[j][1], t)
            reports += [r] if r is not None else []
            j += 1
        node.loop.step(Batch(t, node.input.decode(framed(msgs), t) + reports))
    c = node.counters
    tracks = node.core.tracker.tracks
    assert set(tracks) == {KEY}
    assert c["rx.adsb_vehicle"] >= 35 and c["traffic.sbs.reports"] >= 70  # 1 Hz and 2 Hz, the default 5 % dropouts
    print(json.dumps({"n_updates": tracks[KEY].n_updates, "rx.adsb_vehicle": c["rx.adsb_vehicle"], "sbs": c["traffic.sbs.reports"], "dup": c["report.duplicate"], "ooo": c["report.out_of_order"]}))
    # both paths update it (more than SBS alone; a MAVLink report not newer than an SBS one is out of order)
    assert tracks[KEY].n_updates > c["traffic.sbs.reports"] + 5
    assert c["adsb.second_sender"] == 0 and not node.decoder.spoof_suspected


def test_a_restarted_sbs_server_is_reconnected_and_a_dead_one_is_a_warning(tcp_port):
    """Lines served in real time; the server is killed (connections closed, port refused), the feed is down and the
    status says so while the loop goes on; a new server on the same port gets the reports flowing again."""
    t0 = time.monotonic()

    def clock():
        return time.monotonic() - t0

    events = sbs_schedule(SCENARIO, PRESETS["none"], duration_s=SCENARIO.duration_s)
    counters = Counter()
    daa = Daa(CONFIG, counters)
    server = SbsServer(events, port=tcp_port).start()
    feeds = FeedSet.open([f"sbs:127.0.0.1:{tcp_port}"], CONFIG, clock, counters)
    feeds.start()
    try:
        def reports_flow(before: int):
            return lambda: feeds.drain(clock()) and counters["traffic.sbs.reports"] > before

        assert wait_for(reports_flow(0))
        server.stop()
        assert wait_for(lambda: not feeds.drain(clock()) and not feeds.health[0].connected)
        status = daa.status(clock(), TrafficSource(MavlinkInput(CONFIG, counters), feeds).status())
        assert any(w.startswith(f"traffic source sbs:127.0.0.1:{tcp_port} down") for w in status["warnings"])
        assert status["traffic_feeds"][0]["connected"] is False
        before = counters["traffic.sbs.reports"]
        restarted = time.monotonic()
        server = SbsServer(events, port=tcp_port, start_s=clock()).start()
        assert wait_for(reports_flow(before))
        print(json.dumps({"recovered_after_restart_s": round(time.monotonic() - restarted, 3),
                          "reconnects": counters["traffic.sbs.reconnects"]}))
        assert feeds.health[0].connected and counters["traffic.sbs.disconnects"] >= 1
    finally:
        feeds.close()
        server.stop()
    assert not feeds.feeds[0]._thread.is_alive()


def readsb_document(now: float, t: float) -> bytes:
    """Two aircraft flying north side by side, one with NACp 11 / NACv 4, the other NACp 5 / NACv 1."""
    aircraft = []
    for hex_, lon, nac_p, nac_v in (("c00001", 8.50, 11, 4), ("c00002", 8.60, 5, 1)):
        aircraft.append({"hex": hex_, "lat": 47.0 + 60.0 * t / 111_200.0, "lon": lon, "alt_baro": 3000,
                         "gs": 116.6, "track": 0.0, "baro_rate": 0, "nac_p": nac_p, "nac_v": nac_v, "nic": 8,
                         "seen_pos": 0.2, "seen": 0.1})
    return json.dumps({"now": now, "messages": 10, "aircraft": aircraft}).encode()


class Aircraft_json_http(http.server.BaseHTTPRequestHandler):
    body = b""

    def do_GET(self):  # noqa: N802
        body = type(self).body
        self.send_response(200)
        self.send_header("Content-Type", "application/json")
        self.send_header("Content-Length", str(len(body)))
        self.end_headers()
        self.wfile.write(body)

    def log_message(self, *args):
        pass


@pytest.mark.parametrize("transport", ["file", "http"])
def test_readsb_json_nac_reaches_the_tracks_measurement_noise(transport, tmp_path):
    config = load_config(None, ["zenoh.enabled=false", "traffic.readsb_poll_s=0.2"])
    t0 = time.monotonic()

    def clock():
        return time.monotonic() - t0

    path = tmp_path / "aircraft.json"
    httpd = None
    if transport == "http":
        httpd = http.server.ThreadingHTTPServer(("127.0.0.1", 0), Aircraft_json_http)
        threading.Thread(target=httpd.serve_forever, daemon=True).start()
        target = f"http://127.0.0.1:{httpd.server_address[1]}/data/aircraft.json"
    else:
        target = str(path)

    def publish(t: float):
        body = readsb_document(1.7e9 + t, t)
        if httpd is not None:
            Aircraft_json_http.body = body
        else:
            tmp = path.with_suffix(".tmp")
            tmp.write_bytes(body)
            tmp.replace(path)  # as readsb writes it: a new file renamed over the old

    counters = Counter()
    daa = Daa(config, counters)
    publish(0.0)
    feeds = FeedSet.open([f"readsb-json:{target}"], config, clock, counters)
    feeds.start()
    keys = set()
    try:
        def updated_enough() -> bool:
            now = clock()
            publish(now)
            daa.step(now, feeds.drain(now))
            keys.update(daa._core.tracker.tracks)
            tracks = daa._core.tracker.tracks
            return len(tracks) == 2 and min(t.n_updates for t in tracks.values()) >= 5

        assert wait_for(updated_enough, period_s=0.1)
        views = {str(v.key): v for v in daa.tracks(clock())}
    finally:
        feeds.close()
        if httpd is not None:
            httpd.shutdown()
            httpd.server_close()
    precise, coarse = views["1090es-C00001"], views["1090es-C00002"]
    # the horizontal position variance follows the reported accuracy (NACp 11: 1.2 m; NACp 5: 378 m, 1-sigma)
    assert np.trace(precise.p[:2, :2]) < np.trace(coarse.p[:2, :2]) / 10
    assert np.trace(precise.p[3:5, 3:5]) < np.trace(coarse.p[3:5, 3:5])
    assert counters["traffic.readsb-json.reports"] >= 10 and counters["traffic.readsb-json.documents"] >= 5
    assert position_sigma_per_axis(3.0) < 1.3  # NACp 11's sigma, the precise track's measurement noise


# --- a readsb HTTP source that stalls, or serves too much, is a feed fault (issue 25) --------------------------------

TRICKLE_S = 0.5  # a byte every 0.5 s: each read returns well within the 2 s socket timeout (readsb_json.py)


def aircraft_json_server(body: bytes, length: bool = True):
    """A threaded HTTP server on 127.0.0.1 serving `handler.body` whole, or a byte every TRICKLE_S from its headers
    (`handler.mode = "headers"`) or its body ("body"): a source that keeps the connection alive and never completes
    a document. Returns (server, handler class, URL)."""

    class Handler(http.server.BaseHTTPRequestHandler):
        mode = "whole"
        stop = threading.Event()

        def do_GET(self):  # noqa: N802
            cls = type(self)
            size = f"Content-Length: {len(cls.body)}\r\n" if length else ""
            head = f"HTTP/1.0 200 OK\r\nContent-Type: application/json\r\n{size}\r\n".encode()
            data, start = head + cls.body, {"whole": None, "body": len(head), "headers": 0}[cls.mode]
            try:
                if start is None:
                    self.wfile.write(data)
                    return
                self.wfile.write(data[:start])
                for i in range(start, len(data)):
                    if cls.stop.wait(TRICKLE_S):
                        return
                    self.wfile.write(data[i:i + 1])
            except OSError:
                pass  # the client gave up (its deadline cut the connection)

        def log_message(self, *args):
            pass

    Handler.body = body
    server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), Handler)
    threading.Thread(target=server.serve_forever, daemon=True).start()
    return server, Handler, f"http://127.0.0.1:{server.server_address[1]}/data/aircraft.json"


def stop_server(server, handler) -> None:
    handler.stop.set()
    server.shutdown()
    server.server_close()


@pytest.mark.live
@pytest.mark.parametrize("stalls", ["body", "headers"])
def test_a_readsb_http_source_that_never_completes_a_document_is_down_with_a_warning(stalls):
    """Before: a byte a second kept the feed "connected", without a warning, while it delivered nothing. Now a fetch
    that has not completed within input.max_report_age_s (3 s) fails the session: the status warns, the source is
    retried and reads again once the server answers whole documents."""
    config = load_config(None, ["zenoh.enabled=false", "traffic.readsb_poll_s=0.2"])
    t0 = time.monotonic()

    def clock():
        return time.monotonic() - t0

    server, handler, url = aircraft_json_server(readsb_document(1.7e9, 0.0))
    counters = Counter()
    feeds = FeedSet.open([f"readsb-json:{url}"], config, clock, counters)
    feeds.start()
    try:
        def delivering() -> bool:
            handler.body = readsb_document(1.7e9 + clock(), clock())
            before = counters["traffic.readsb-json.reports"]
            feeds.drain(clock())
            return feeds.health[0].connected and counters["traffic.readsb-json.reports"] > before

        assert wait_for(delivering, period_s=0.1)
        handler.mode = stalls
        stalled_at = time.monotonic()
        assert wait_for(lambda: not feeds.drain(clock()) and not feeds.health[0].connected)
        health = feeds.health[0]
        print(json.dumps({"stalls": stalls, "down_after_s": round(time.monotonic() - stalled_at, 2),
                          "error": health.error}))
        assert health.error.startswith("TimeoutError") and "within 3 s" in health.error
        assert health.warning.startswith(f"traffic source readsb-json:{url} down (TimeoutError")
        assert counters["traffic.readsb-json.document_timeouts"] >= 1
        handler.mode = "whole"
        assert wait_for(delivering, period_s=0.1)  # retried: reads again
    finally:
        feeds.close()
        stop_server(server, handler)
    assert not feeds.feeds[0]._thread.is_alive()


@pytest.mark.live
@pytest.mark.parametrize("transport", ["http", "http-without-length", "file"])
def test_a_readsb_document_above_the_size_limit_is_refused_with_a_warning(transport, tmp_path):
    """Before: a 50 MB aircraft.json was read and parsed (the loop stalled 2.2-4.8 s, 290 MB kept). Now a document
    above MAX_DOCUMENT_BYTES (4,096,000 bytes: 4000 aircraft, the merge's limit, at 1 KiB) is refused: the source is
    down with a warning and a count, and is read again once the document is back to size."""
    config = load_config(None, ["zenoh.enabled=false", "traffic.readsb_poll_s=0.2"])
    t0 = time.monotonic()

    def clock():
        return time.monotonic() - t0

    good = readsb_document(1.7e9, 0.0)
    big = good[:-1] + b', "padding": "' + b"x" * (4 * 2**20) + b'"}'
    server = handler = None
    if transport == "file":
        target = tmp_path / "aircraft.json"
        target.write_bytes(big)
    else:
        server, handler, target = aircraft_json_server(big, length=transport == "http")
    counters = Counter()
    feeds = FeedSet.open([f"readsb-json:{target}"], config, clock, counters)
    feeds.start()
    try:
        assert wait_for(lambda: counters["traffic.readsb-json.rejected.document_too_large"] >= 2
                        or feeds.drain(clock()) is None)
        health = feeds.health[0]
        print(json.dumps({"transport": transport, "error": health.error}))
        assert not health.connected and health.error.startswith("DocumentTooLarge")
        assert health.warning.startswith("traffic source readsb-json:") and "down (DocumentTooLarge" in health.warning
        assert counters["traffic.readsb-json.reports"] == 0 and not counters["traffic.readsb-json.documents"]
        if handler is not None:
            handler.body = good
        else:
            target.write_bytes(good)
        assert wait_for(lambda: feeds.drain(clock()) is None or counters["traffic.readsb-json.reports"] > 0)
        assert feeds.health[0].connected
    finally:
        feeds.close()
        if server is not None:
            stop_server(server, handler)


@pytest.mark.live
def test_a_readsb_document_with_a_400_digit_number_and_a_unicode_squawk_still_tracks_the_good_aircraft():
    """Before: one such entry made every poll fail (document() raised), and no aircraft of the receiver was
    tracked while `reports` counted them. Now each bad field is its entry's: counted, the good aircraft tracked."""
    config = load_config(None, ["zenoh.enabled=false", "traffic.readsb_poll_s=0.2"])
    t0 = time.monotonic()

    def clock():
        return time.monotonic() - t0

    def document(t: float) -> bytes:
        doc = json.loads(readsb_document(1.7e9 + t, t))
        good = doc["aircraft"][0]
        doc["aircraft"] = [dict(good, hex="c00003", alt_baro=int("9" * 400)), good, dict(good, hex="c00004",
                                                                                          squawk="²")]
        return json.dumps(doc).encode()

    server, handler, url = aircraft_json_server(document(0.0))
    counters = Counter()
    daa = Daa(config, counters)
    feeds = FeedSet.open([f"readsb-json:{url}"], config, clock, counters)
    feeds.start()
    try:
        def tracked() -> bool:
            now = clock()
            handler.body = document(now)
            daa.step(now, feeds.drain(now))
            track = daa._core.tracker.tracks.get(IntruderKey(0xC00001, INTRUDER.address_source))
            return track is not None and track.n_updates >= 5

        assert wait_for(tracked, period_s=0.1)
    finally:
        feeds.close()
        stop_server(server, handler)
    assert feeds.health[0].connected and not counters["traffic.readsb-json.errors"]
    assert counters["traffic.readsb-json.rejected.altitude_out_of_range"] >= 5
    assert counters["traffic.readsb-json.rejected.squawk_invalid"] >= 5
    assert counters["traffic.readsb-json.reports"] == feeds.feeds[0].reports  # counted = delivered


# --- CRC-valid Beast junk under a real aircraft's address cannot own its track (issue 25) ----------------------------

def beast_junk(address: int, hz: float, duration_s: float, seed: int) -> list[BeastEvent]:
    """CRC-valid DF17 airborne positions with random content under `address`, `hz` a second: TC 9-18 and the other
    51 ME bits random (surveillance status, altitude, CPR format, latitude, longitude), the parity the CRC-24 of ICAO
    Annex 10 Vol IV §3.1.2.3.3 (avionics_sitl.beast.df17; checked with pyModeS below), stamped as received."""
    rng = random.Random(seed)
    events = []
    for k in range(int(duration_s * hz)):
        t = (k + rng.random()) / hz
        message = df17(address, rng.randint(9, 18) << 51 | rng.getrandbits(51))
        ticks = BeastConfig().clock_start_ticks + int(round(t * BEAST_CLOCK_HZ))
        events.append(BeastEvent(t, beast_frame(message, ticks), t, "junk"))
    return events


def metres_between(lat1: float, lon1: float, lat2: float, lon2: float) -> float:
    north = math.radians(lat2 - lat1) * WGS84_A
    east = math.radians(lon2 - lon1) * WGS84_A * math.cos(math.radians(lat1))
    return math.hypot(east, north)


@pytest.mark.live
def test_crc_valid_beast_junk_at_8_hz_under_the_intruders_address_never_moves_its_track(tcp_port):
    """The head-on's intruder over Beast (no noise: the truth is exact to the CPR quantum) and, on the same TCP
    connection, 8 junk positions a second under its address. Before: at 8 Hz the track restarted from junk, its
    samples tens to thousands of km off, no TA or RA. Now every junk position is rejected before the tracker: at every
    batch the track is within 3 sigma of the truth, its sigma what the real reports give, and the TA and RA come when
    the ADSB_VEHICLE path gives them."""
    reference = mavlink_reference()
    _, (truth, *_) = SCENARIO.trajectories()
    real = beast_schedule(SCENARIO, PRESETS["none"], duration_s=DURATION_S)
    junk = beast_junk(INTRUDER.icao_address, 8.0, DURATION_S, seed=25)
    assert all(Message(e.frame[2:].replace(b"\x1a\x1a", b"\x1a")[-14:]).crc_valid for e in junk)  # pyModeS agrees
    t0 = time.monotonic()

    def clock():
        return (time.monotonic() - t0) * SPEED

    counters = Counter()
    with BeastServer(real + junk, port=tcp_port, clock=clock) as server:
        feeds = FeedSet.open([f"beast:127.0.0.1:{server.port}"], CONFIG, clock, counters)
        source = TrafficSource(OwnshipOverMavlink(MavlinkInput(CONFIG, counters), clock, DURATION_S), feeds)
        daa = Daa(CONFIG, counters)
        loop = Loop(daa, source, [])
        changes, samples = [], []  # (time, error m, sigma m) of the intruder's track at each batch
        for batch in source:
            result = loop.step(batch)
            changes += [(batch.now_s, a.level) for a in result.changes if a.intruder == KEY]
            for view in daa.tracks(batch.now_s):
                state = truth.state_at(batch.now_s)
                samples.append((batch.now_s, metres_between(state.lat_deg, state.lon_deg, view.lat_deg, view.lon_deg),
                                math.sqrt(view.p[0, 0] + view.p[1, 1])))
    got = onsets(changes)
    worst = max(samples, key=lambda s: s[1] / s[2])
    print(json.dumps({"samples": len(samples), "worst_error_m": round(worst[1], 2), "its_sigma_m": round(worst[2], 2),
                      "max_sigma_m": round(max(s[2] for s in samples[20:]), 2), "onsets_s": got,
                      "reference_s": reference,
                      "beast": {k: v for k, v in counters.items() if k.startswith("traffic.beast.cpr")}}))
    assert len(samples) >= 0.9 * DURATION_S / TICK_S and len({s[0] for s in samples}) == len(samples)  # one track
    assert all(error <= 3.0 * sigma for _, error, sigma in samples), worst
    settled = [sigma for t, _, sigma in samples if t >= samples[0][0] + 2.0]  # after its first reports' 2 s
    assert max(settled) <= 30.0  # the NACp 9 reports' bound (EPU 30 m): a track as good as its reports
    assert abs(got["TA"] - reference["TA"]) <= 1.0 and abs(got["RA"] - reference["RA"]) <= 1.0
    assert counters["traffic.beast.cpr_global"] == 1  # one reference for the whole encounter
    assert counters["traffic.beast.cpr_implausible"] >= 0.5 * len(junk)  # the junk was heard, and rejected
    assert counters["traffic.beast.reports"] >= 0.95 * sum(e.kind == "position" for e in real)
