"""The ground monitor against hostile input (issue 11, deliverable 6): payload strings rendered as text in a real
browser (stored XSS), the schema check on what the monitor takes from zenoh, rich markup in the terminal view,
the HTTP server's Host/Origin checks, timeouts and connection cap, and bounded per-vehicle memory with expiry.

Every wait polls for its condition with a generous deadline; nothing asserts a duration. The browser test skips
when Chromium is not installed on a developer machine and fails in CI (CI set), like tests/test_monitor_live.py."""

import io
import json
import math
import os
import select
import socket
import threading
import time

import pytest
from rich.console import Console

from avionics.monitor.feed import ZenohFeed, monitor_zenoh_config, wait_for
from avionics.monitor.schema import MAX_UNKNOWN_FIELDS, Rejected, check_id, clean_sample, clean_snapshot
from avionics.base.units import NM
from avionics.monitor.state import FleetState
from avionics.monitor.tui import TuiView, render_text, run_tui
from avionics.monitor.web import MAX_CONNECTIONS, MonitorServer
from tests.conftest import free_port

DEADLINE_S = float(os.environ.get("AVIONICS_TEST_DEADLINE_S", "60"))
# `<img src=x onerror=...>`, led by `">` so that it also breaks out of an attribute (the old page put `level` in one)
XSS = "\"><img src=x onerror=\"window.__xss=1;document.title='XSS'\">"
XSS2 = "\"><img src=y onerror=\"window.__xss=2;document.title='XSS'\">"

OWN = {"schema": 2, "vehicle": "v", "time_s": 10.0, "valid": True, "lat_deg": 47.0, "lon_deg": 8.0,
       "alt_msl_m": 1000.0, "pressure_altitude_m": 990.0, "velocity_enu_mps": [0.0, 50.0, 0.0], "track_deg": 0.0,
       "ground_speed_mps": 50.0, "vertical_rate_mps": 0.0}


def track(intruder="1090es-A10001", t=10.0, north_m=NM, **extra):
    return {"schema": 2, "vehicle": "v", "intruder": intruder, "address": 0xA10001, "address_source": "1090es",
            "callsign": "HEADON", "squawk": 7000, "emitter_type": 1, "simulated": True, "model": "imm", "time_s": t,
            "last_report_s": t, "age_s": 0.0, "updates": 3, "lat_deg": 47.0 + north_m / 111_229.0, "lon_deg": 8.0,
            "altitude_m": 1000.0, "altitude_datum": "pressure", "velocity_enu_mps": [0.0, -60.0, 0.0],
            "ground_speed_mps": 60.0, "track_deg": 180.0, "vertical_rate_mps": 0.0, "position_sigma_m": 10.0,
            "velocity_sigma_mps": 1.0, "advisory": "NONE", "range_m": NM, "mod_tau_s": 25.0, "pc_ta": 0.2,
            "mode_probabilities": {"cv": 0.9, "ct": 0.1}, "most_likely_mode": "cv", "vb_noise": None, **extra}


def adv(level, t, intruder="1090es-A10001", **extra):
    return {"schema": 2, "vehicle": "v", "intruder": intruder, "address": 0xA10001, "address_source": "1090es",
            "callsign": "HEADON", "level": level, "reason": "tau", "time_s": t, "sensitivity_level": 4,
            "range_m": 3000.0, "mod_tau_s": 20.0, "pc_ta": 0.4, "pc_ra": 0.2, "ra_sense": None, "ra_words": None,
            "target_vertical_rate_mps": None, "ra_reversed": False, "ra_crossing": False, **extra}


def status(**extra):
    return {"schema": 2, "vehicle": "v", "version": "0.1.0", "time_s": 10.0, "ownship": None, "ownship_valid": True,
            "pressure_altitude_available": True, "datum_mismatch_intruders": [], "sensitivity_level": 4,
            "tracks": 1, "advisories": {"TA": 0, "RA": 0}, "warnings": [], "counters": {"rx.adsb_vehicle": 3},
            **extra}


# -- (b) the schema check --------------------------------------------------------------------------------------------
def test_schema_accepts_the_contract_keeps_short_unknown_fields_and_bounds_the_rest():
    t = clean_sample("tracks", track(), "1090es-A10001")
    assert t == track()
    assert clean_sample("advisories", adv("RA", 1.0, ra_words="CLIMB"), "1090es-A10001")["ra_words"] == "CLIMB"
    assert clean_sample("status", status(ownship={k: v for k, v in OWN.items() if k != "schema"}))["tracks"] == 1
    # a newer schema's extra scalar fields (and the benchmark's tags) pass; containers and the surplus do not
    extra = {f"x{i}": i for i in range(MAX_UNKNOWN_FIELDS + 10)}
    out = clean_sample("tracks", track(bench_wall_s=1.5, future_flags=[1, "a"], blob={"a": [1] * 1000}, **extra))
    assert out["bench_wall_s"] == 1.5 and out["future_flags"] == [1, "a"] and "blob" not in out
    assert sum(1 for k in out if k.startswith("x")) <= MAX_UNKNOWN_FIELDS
    # the intruder comes from the key expression when the payload has none
    assert clean_sample("tracks", {"time_s": 1.0}, "uat-000001")["intruder"] == "uat-000001"


@pytest.mark.parametrize("kind, payload, reason", [
    ("tracks", track(lat_deg=float("nan")), "lat_deg"),
    ("tracks", track(lat_deg=91.0), "lat_deg"),
    ("tracks", track(lon_deg="8.0"), "lon_deg"),
    ("tracks", track(altitude_m=float("inf")), "altitude_m"),
    ("tracks", track(updates=True), "updates"),  # a bool is not an int
    ("tracks", track(velocity_enu_mps=[1.0, 2.0]), "velocity_enu_mps"),
    ("tracks", track(velocity_enu_mps=[1.0, None, 0.0]), "velocity_enu_mps"),
    ("tracks", track(callsign="X" * 65), "callsign"),
    ("tracks", track(callsign="A\x1b[2J"), "callsign"),  # a terminal escape
    ("tracks", track(callsign="\u202eNOSLAC"), "callsign"),  # displays reversed
    ("tracks", track(advisory=["RA"]), "advisory"),
    ("tracks", track(mode_probabilities={"cv": 2.0}), "mode_probabilities"),
    ("tracks", track(intruder="1090es-BBBBBB"), "intruder_key"),
    ("tracks", [track()], "type"),
    ("advisories", adv({"level": "RA"}, 1.0), "level"),
    ("advisories", adv("RA", 1.0, pc_ra=1.5), "pc_ra"),
    ("advisories", adv("RA", 1.0, reason="r" * 300), "reason"),
    ("status", status(warnings=[None]), "warnings"),
    ("status", status(warnings="no ownship"), "warnings"),
    ("status", status(advisories={"RA": -1}), "advisories"),
    ("status", status(ownship={"lat_deg": 1e9}), "ownship.lat_deg"),
    ("ownship", dict(OWN, valid="yes"), "valid"),
])
def test_schema_rejects_bad_fields_naming_them(kind, payload, reason):
    with pytest.raises(Rejected) as exc:
        clean_sample(kind, payload, "1090es-A10001" if kind in ("tracks", "advisories") else None)
    assert exc.value.reason == reason


def test_schema_ids_and_snapshot_elements():
    assert check_id("1090es-A10001") == "1090es-A10001" and check_id("[/]") == "[/]" and check_id(XSS) == XSS
    for bad in ("", "x" * 65, "a\nb", "a\x00"):
        with pytest.raises(Rejected):
            check_id(bad)
    dropped = {}
    snap = clean_snapshot({"schema": 1, "time_s": 10.0, "ownship": OWN, "status": None,
                           "tracks": [track(), track("b", lat_deg="north"), {"time_s": 1.0}],
                           "advisories": [adv("TA", 9.0)], "advisory_changes": [adv("TA", 8.0), 7]}, dropped)
    assert [t["intruder"] for t in snap["tracks"]] == ["1090es-A10001"] and len(snap["advisory_changes"]) == 1
    assert dropped == {"tracks.lat_deg": 1, "tracks.key": 1, "advisory_changes.type": 1}
    for bad in ([], {"time_s": "soon"}, {"ownship": {"lat_deg": "x"}}, {"tracks": {"a": 1}}):
        with pytest.raises(Rejected):
            clean_snapshot(bad)


# -- bands (DO-365 guidance, issue 16 item 4): the contract's example passes, every malformed form is rejected ----------
def bands(**extra):
    """docs/monitor.md's example bands payload (the lead's contract)."""
    return {"schema": 2, "vehicle": "v", "time_s": 12.0, "alerter": "daidalus-do365b-no-sum",
            "ownship": {"track_deg": 90.0, "ground_speed_mps": 51.4, "vertical_rate_mps": 0.0, "altitude_m": 1219.2},
            "track_deg": [{"lower": 0.0, "upper": 87.0, "region": "NONE"}, {"lower": 87.0, "upper": 113.0, "region": "MID"},
                          {"lower": 113.0, "upper": 360.0, "region": "NONE"}],
            "ground_speed_mps": [{"lower": 0.0, "upper": 40.0, "region": "NONE"},
                                 {"lower": 40.0, "upper": 60.0, "region": "NEAR"}],
            "vertical_rate_mps": [{"lower": -30.48, "upper": 30.48, "region": "RECOVERY"}],
            "altitude_m": [],
            "recovery": {"track_deg": False, "ground_speed_mps": False, "vertical_rate_mps": True, "altitude_m": False},
            "intruders": [{"intruder": "1090es-A1B2C3", "alert_level": 2, "alert_name": "CORRECTIVE"}], **extra}


def test_schema_accepts_the_bands_contract_a_future_region_and_keeps_only_interval_fields():
    assert clean_sample("bands", bands()) == bands()
    out = clean_sample("bands", bands(track_deg=[{"lower": 0.0, "upper": 360.0, "region": "SOMEDAY", "extra": 1}]))
    assert out["track_deg"] == [{"lower": 0.0, "upper": 360.0, "region": "SOMEDAY"}]
    assert clean_sample("bands", bands(altitude_m=None))["altitude_m"] is None


@pytest.mark.parametrize("payload, reason", [
    (bands(track_deg=[{"lower": 113.0, "upper": 87.0, "region": "MID"}]), "track_deg"),  # lower > upper
    (bands(track_deg=[{"lower": 87.0, "upper": 113.0, "region": "MID"},
                      {"lower": 0.0, "upper": 87.0, "region": "NONE"}]), "track_deg"),  # not in increasing order
    (bands(track_deg=[{"lower": 0.0, "upper": 400.0, "region": "NONE"}]), "track_deg.upper"),  # beyond 360
    (bands(track_deg=[{"lower": 0.0, "upper": float("nan"), "region": "NONE"}]), "track_deg.upper"),
    (bands(track_deg=[{"lower": 0.0, "upper": 10.0}]), "track_deg"),  # no region
    (bands(track_deg=[{"lower": 0.0, "upper": 10.0, "region": 3}]), "track_deg.region"),
    (bands(track_deg=[{"lower": 0.0, "upper": 10.0, "region": "MID\x1b[2J"}]), "track_deg.region"),
    (bands(track_deg=[[0.0, 10.0, "MID"]]), "track_deg"),
    (bands(track_deg={"MID": [87.0, 113.0]}), "track_deg"),
    (bands(track_deg=[{"lower": float(i), "upper": float(i), "region": "NONE"} for i in range(300)]), "track_deg"),
    (bands(ground_speed_mps=[{"lower": -1.0, "upper": 10.0, "region": "NONE"}]), "ground_speed_mps.lower"),
    (bands(altitude_m=[{"lower": 0.0, "upper": 1e9, "region": "NONE"}]), "altitude_m.upper"),
    (bands(recovery={"track_deg": "yes"}), "recovery"),
    (bands(intruders=[{"intruder": "a", "alert_level": "2"}]), "intruders.alert_level"),
    (bands(intruders={"a": 2}), "intruders"),
    (bands(ownship={"track_deg": "east"}), "ownship.track_deg"),
    (bands(alerter="x" * 65), "alerter"),
])
def test_schema_rejects_malformed_bands_naming_the_field(payload, reason):
    with pytest.raises(Rejected) as exc:
        clean_sample("bands", payload)
    assert exc.value.reason == reason


def test_snapshot_bands_are_taken_when_present_and_left_out_when_bad():
    assert clean_snapshot({"time_s": 1.0, "bands": bands()})["bands"] == bands()
    dropped = {}
    snap = clean_snapshot({"time_s": 1.0, "bands": bands(track_deg=7), "tracks": [track()]}, dropped)
    assert "bands" not in snap and len(snap["tracks"]) == 1 and dropped == {"bands.track_deg": 1}
    s = FleetState()
    s.apply_snapshot("v", clean_snapshot({"time_s": 12.0, "bands": bands()}))
    assert s.bands("v")["track_deg"][1]["region"] == "MID"


# -- (c) the terminal view -------------------------------------------------------------------------------------------
def _markup_state(vehicle="[/]") -> FleetState:
    s = FleetState()
    s.apply_snapshot(vehicle, None)
    s.set_alive(vehicle, True)
    s.apply(vehicle, "ownship", "", OWN)
    s.apply(vehicle, "status", "", status(warnings=["[/]", "[bold red]warn[/]"], version="[/]"))
    s.apply(vehicle, "tracks", "[/]", track("[/]", callsign="[/]", most_likely_mode="[/]", mode_probabilities=None))
    s.apply(vehicle, "tracks", "1090es-B00002", track("1090es-B00002", north_m=2 * NM, callsign="[b]:smile:"))
    s.apply(vehicle, "advisories", "[/]", adv("RA", 10.5, intruder="[/]", callsign="[/]", reason="[/]",
                                              ra_sense="descend", ra_words="[/]", target_vertical_rate_mps=-7.62))
    return s


def test_tui_renders_markup_in_callsigns_and_ids_as_literal_text():
    s = _markup_state()
    buf = io.StringIO()
    console = Console(file=buf, width=150, height=44, color_system=None, force_terminal=False)
    console.print(TuiView(s, "[/]").render(150, 44), height=44)
    out = buf.getvalue()
    assert out.count("[/]") >= 5  # vehicle (header and display title), track id, callsign, log and RA banner
    assert "[b]:smile:" in out and "[bold red]warn[/]" in out  # neither markup nor emoji codes are interpreted
    assert "RA [/] -1500 fpm" in out
    assert "[/]" in render_text(s, "[/]", 150, 44)


def test_run_tui_with_a_bracket_callsign_draws_a_frame_and_returns_0():
    """What `avionics monitor --tui` runs: one frame into a string buffer, then stop."""
    s = _markup_state()
    stop = threading.Event()
    expire = s.expire

    def expire_then_stop():  # run_tui expires, renders, then waits: stop after the first frame
        n = expire()
        stop.set()
        return n

    s.expire = expire_then_stop
    buf = io.StringIO()
    console = Console(file=buf, width=150, height=44, force_terminal=True, color_system=None)
    assert run_tui(s, "[/]", stop=stop, console=console) == 0
    assert "[/]" in buf.getvalue()


# -- (b) over zenoh: bad samples counted and dropped, the feed goes on ------------------------------------------------
@pytest.mark.live
def test_feed_counts_and_drops_bad_samples_and_keeps_applying_good_ones():
    from avionics.io.zenoh_bus import open_session

    endpoint = f"tcp/127.0.0.1:{free_port()}"
    pub = open_session(monitor_zenoh_config([], mode="peer", listen=[endpoint]))
    state = FleetState()
    feed = ZenohFeed(state, monitor_zenoh_config([endpoint], mode="peer"), query_timeout_s=0.5)
    bad = [
        ("daa/v/tracks/1090es-A10001", b"{not json"),
        ("daa/v/tracks/1090es-A10001", b"[" * 100_000 + b"]" * 100_000),  # too deep
        ("daa/v/tracks/1090es-A10001", b'{"callsign": "' + b"A" * 300_000 + b'"}'),  # too big
        ("daa/v/tracks/1090es-A10001", b"[1, 2]"),
        ("daa/v/tracks/1090es-A10001", json.dumps(track(lat_deg="47")).encode()),
        ("daa/v/tracks/1090es-A10001", b'{"time_s": 11.0, "lat_deg": NaN, "lon_deg": 8.0}'),
        ("daa/v/tracks/1090es-A10001", json.dumps(track(intruder="1090es-FFFFFF")).encode()),
        ("daa/v/tracks/1090es-A10001", json.dumps(track(callsign="\x1b]0;owned\x07")).encode()),
        ("daa/v/advisories/1090es-A10001", json.dumps(adv(7, 11.0)).encode()),
        ("daa/v/status", json.dumps(status(warnings=[{"html": "<b>"}])).encode()),
        ("daa/v/ownship", json.dumps(dict(OWN, velocity_enu_mps="fast")).encode()),
        ("daa/v/tracks/1090es-A10001/extra", json.dumps(track()).encode()),
        ("daa/" + "v" * 100 + "/status", json.dumps(status()).encode()),
        ("daa/v/bands", json.dumps(bands(track_deg=[{"lower": 9.0, "upper": 1.0, "region": "MID"}])).encode()),
        ("daa/v/bands", b'{"track_deg": [{"lower": 0, "upper": Infinity, "region": "MID"}]}'),
        ("daa/v/bands/extra", json.dumps(bands()).encode()),
    ]
    good = [("daa/v/ownship", OWN), ("daa/v/tracks/1090es-A10001", track(callsign="[/]")),
            ("daa/v/advisories/1090es-A10001", adv("TA", 10.0, callsign="[/]")), ("daa/v/bands", bands())]
    try:
        # samples published before the monitor's subscription reaches the publisher are lost: publish until the
        # last good one is seen; the bad ones go first in every round
        def round_trip():
            for key, raw in bad:
                pub.put(key, raw)
            for key, payload in good:
                pub.put(key, json.dumps(payload).encode())
            return (state.tracks("v") and state.vehicles["v"].advisories and state.bands("v")
                    and state.stats["rejected"] >= len(bad))

        assert wait_for(round_trip, DEADLINE_S, period_s=0.1)
        stats = state.stats_copy()
        assert feed.errors == 0  # nothing raised: every bad sample was a counted rejection
        for reason in ("tracks.json", "tracks.size", "tracks.type", "tracks.lat_deg", "tracks.intruder_key",
                       "tracks.callsign", "tracks.key", "advisories.level", "status.warnings",
                       "ownship.velocity_enu_mps", "status.key", "bands.track_deg", "bands.track_deg.upper",
                       "bands.key"):
            assert stats.get(f"rejected.{reason}", 0) >= 1, (reason, stats)
        [t] = state.tracks("v")
        assert t["callsign"] == "[/]" and math.isfinite(t["range_m"]) and t["level"] == "TA"
        assert list(state.vehicles) == ["v"]  # the 100-character vehicle id never became a vehicle
        assert state.bands("v")["track_deg"] == bands()["track_deg"]  # the bad bands never hid the good ones
        assert "[/]" in render_text(state, "v", 150, 44)  # what the decoder accepts, the terminal view shows
    finally:
        feed.close()
        pub.close()


# -- (d), (e) the HTTP server over real sockets ------------------------------------------------------------------------
def _get(port: int, path: str = "/api/fleet", host: str | None = "default", headers: dict | None = None,
         timeout: float = DEADLINE_S) -> tuple[int, bytes]:
    """One GET on a raw socket (so that Host can be anything or absent): (status, body). The server closes the
    connection after each response (HTTP/1.0), except an event stream: for /events only the head is read."""
    lines = [f"GET {path} HTTP/1.1"]
    if host == "default":
        host = f"127.0.0.1:{port}"
    if host is not None:
        lines.append(f"Host: {host}")
    lines += [f"{k}: {v}" for k, v in (headers or {}).items()]
    with socket.create_connection(("127.0.0.1", port), timeout=timeout) as s:
        s.sendall(("\r\n".join(lines) + "\r\n\r\n").encode())
        data = b""
        while path != "/events" or b"\r\n\r\n" not in data:
            chunk = s.recv(65536)
            if not chunk:
                break
            data += chunk
    head, _, body = data.partition(b"\r\n\r\n")
    return int(head.split()[1]), body


@pytest.mark.live
def test_host_header_must_name_this_server_and_origin_must_be_its_own():
    server = MonitorServer(FleetState(), port=0).start()
    port = server.port
    try:
        for host in (f"127.0.0.1:{port}", f"localhost:{port}", f"LOCALHOST:{port}", f"[::1]:{port}"):
            assert _get(port, host=host)[0] == 200, host
        for host in ("evil.example", f"evil.example:{port}", f"127.0.0.1:{port + 1}", f"127.0.0.1.evil.example:{port}",
                     "", None):
            assert _get(port, host=host)[0] == 421, host  # DNS rebinding: the page was reached by another name
        for path in ("/", "/events", "/api/stats", "/api/vehicle/v"):
            assert _get(port, path, host="attacker.example:80")[0] == 421
        assert _get(port, "/events", headers={"Origin": "http://evil.example"})[0] == 403
        assert _get(port, "/api/fleet", headers={"Origin": "null"})[0] == 403
        assert _get(port, "/api/fleet", headers={"Origin": f"http://127.0.0.1:{port}"})[0] == 200
        status_code, body = _get(port, "/events", headers={"Origin": f"http://localhost:{port}"})
        assert status_code == 200
        http = json.loads(_get(port, "/api/stats")[1])["http"]
        assert http["rejected_host"] >= 9 and http["rejected_origin"] == 2
    finally:
        server.close()


def _closed_by_peer(sock: socket.socket, deadline_s: float, drip: bytes = b"") -> bytes | None:
    """Wait (select, never a fixed sleep) until the server closes the connection: returns what it sent, or None if
    it was still open at the deadline. drip: send one byte of it each time select times out (slowloris)."""
    received = b""
    deadline = time.monotonic() + deadline_s
    i = 0
    while time.monotonic() < deadline:
        readable, _, _ = select.select([sock], [], [], 0.2)
        if readable:
            try:
                chunk = sock.recv(4096)
            except ConnectionResetError:
                return received
            if not chunk:
                return received
            received += chunk
        elif i < len(drip):
            try:
                sock.send(drip[i:i + 1])
            except (BrokenPipeError, ConnectionResetError):
                return received
            i += 1
    return None


@pytest.mark.live
def test_idle_and_slow_connections_time_out():
    """request_timeout_s 1 s for the whole request; the per-operation timeout is far longer, so only the request
    deadline can close a client that sends a byte every 0.2 s (slowloris)."""
    server = MonitorServer(FleetState(), port=0, request_timeout_s=1.0, io_timeout_s=DEADLINE_S * 2).start()
    socks = []
    try:
        idle = socket.create_connection(("127.0.0.1", server.port))
        socks.append(idle)
        assert wait_for(lambda: server.connections == 1, DEADLINE_S)
        assert _closed_by_peer(idle, DEADLINE_S) == b""  # sent nothing: closed, no answer
        assert wait_for(lambda: server.connections == 0, DEADLINE_S)  # and its thread is gone
        slow = socket.create_connection(("127.0.0.1", server.port))
        socks.append(slow)
        slow.sendall(f"GET / HTTP/1.1\r\nHost: 127.0.0.1:{server.port}\r\n".encode())
        got = _closed_by_peer(slow, DEADLINE_S, drip=b"X-Slow: " + b"a" * 10_000)  # one header line, never ending
        assert got is not None and b" 200 " not in got
        assert wait_for(lambda: server.connections == 0, DEADLINE_S)
        assert _get(server.port)[0] == 200
    finally:
        for s in socks:
            s.close()
        server.close()


def _handler_threads() -> int:
    return sum(1 for t in threading.enumerate() if "process_request_thread" in t.name)


@pytest.mark.live
def _event_stream(port: int) -> socket.socket:
    """A page's event stream, open: its request is served (the slot is not a slow one's)."""
    sock = socket.create_connection(("127.0.0.1", port))
    sock.sendall(f"GET /events HTTP/1.1\r\nHost: 127.0.0.1:{port}\r\n\r\n".encode())
    sock.settimeout(DEADLINE_S)
    assert sock.recv(4096).startswith(b"HTTP/1.0 200 ")
    return sock


@pytest.mark.live
def test_connection_cap_holds_and_extra_connections_get_503_without_a_thread():
    cap = 4
    server = MonitorServer(FleetState(), port=0, max_connections=cap, request_timeout_s=DEADLINE_S * 2).start()
    held, extra = [], []
    try:
        threads_before = _handler_threads()
        for _ in range(cap):
            held.append(_event_stream(server.port))
        assert wait_for(lambda: server.connections == cap, DEADLINE_S)
        for _ in range(50):
            extra.append(socket.create_connection(("127.0.0.1", server.port)))
        answers = [_closed_by_peer(s, DEADLINE_S) for s in extra]
        assert all(a is not None for a in answers)  # every extra connection was closed at once ...
        assert all(a == b"" or a.startswith(b"HTTP/1.0 503 ") for a in answers)  # ... with a 503, never served
        assert sum(a.startswith(b"HTTP/1.0 503 ") for a in answers) >= 1
        assert server.connections == cap and _handler_threads() - threads_before <= cap
        assert server.http_stats()["refused_busy"] == 50 and server.http_stats()["evicted_slow"] == 0
        for s in held:
            s.close()
        assert wait_for(lambda: server.connections == 0, DEADLINE_S)
        assert _get(server.port)[0] == 200  # and it serves again
    finally:
        for s in held + extra:
            s.close()
        server.close()


@pytest.mark.live
def test_slow_connections_holding_every_slot_do_not_keep_the_page_from_its_user():
    """64 connections that never finish their request (slowloris, within request_timeout_s) took every slot and the
    page's own user got 503 until they timed out. Now a new connection takes the oldest slow one's slot."""
    server = MonitorServer(FleetState(), port=0, request_timeout_s=DEADLINE_S * 2).start()
    slow = []
    try:
        for _ in range(MAX_CONNECTIONS):
            sock = socket.create_connection(("127.0.0.1", server.port))
            sock.sendall(f"GET / HTTP/1.1\r\nHost: 127.0.0.1:{server.port}\r\nX-Slow: ".encode())
            slow.append(sock)
        assert wait_for(lambda: server.connections == MAX_CONNECTIONS, DEADLINE_S)
        for _ in range(3):
            assert _get(server.port)[0] == 200
            # its slot is given back once the server's thread has finished with it (not at once on a busy machine)
            assert wait_for(lambda: server.connections == MAX_CONNECTIONS - 1, DEADLINE_S)
        # one slow connection made room; the page's requests, once answered, give their slot back
        assert server.http_stats()["evicted_slow"] == 1 and server.http_stats()["refused_busy"] == 0
        assert _closed_by_peer(slow[0], DEADLINE_S) == b""  # the oldest slow one lost its slot: closed, no answer
    finally:
        for s in slow:
            s.close()
        server.close()


# -- (f) bounded memory: expiry on an injected clock, caps -------------------------------------------------------------
def test_intruders_not_heard_are_forgotten_and_their_number_is_capped():
    now = [0.0]
    s = FleetState(stale_s=5.0, forget_s=60.0, max_intruders=50, clock=lambda: now[0])
    s.apply_snapshot("v", None)
    s.apply("v", "ownship", "", OWN)
    for i in range(10):
        s.apply("v", "tracks", f"i{i}", track(f"i{i}"))
        s.apply("v", "advisories", f"i{i}", adv("TA", 10.0, intruder=f"i{i}"))
    assert s.memory()["v"]["heard"] == 10 and len(s.advisory_log("v")) == 10
    now[0] = 6.0
    s.apply("v", "tracks", "i0", track("i0", t=16.0))  # i0 is still heard from
    assert s.expire() == 9  # the others' tracks leave the picture after stale_s ...
    mem = s.memory()["v"]
    assert mem["tracks"] == 1 and mem["history"] == 10 and mem["baseline"] == 10  # ... what is known of them stays
    now[0] = 61.0
    s.apply("v", "tracks", "i0", track("i0", t=71.0))
    s.expire()
    mem = s.memory()["v"]
    assert (mem["heard"], mem["tracks"], mem["advisories"], mem["baseline"], mem["history"]) == (1, 1, 1, 1, 1)
    assert s.stats["expired.intruders"] == 9
    # one of them comes back: a new intruder as far as the log is concerned (its onset is logged again)
    s.apply("v", "advisories", "i5", adv("TA", 70.0, intruder="i5"))
    assert len(s.advisory_log("v")) == 11 and s.advisory_log("v")[-1]["intruder"] == "i5"
    now[0] = 200.0
    s.expire()
    assert s.memory()["v"]["heard"] == 0 and s.tracks("v") == []
    # address churn: 10 000 intruders ever seen, at most max_intruders remembered, the most recent ones
    for i in range(10_000):
        now[0] += 0.001
        s.apply("v", "tracks", f"c{i}", track(f"c{i}", t=300.0 + i * 0.001))
    mem = s.memory()["v"]
    assert max(mem["heard"], mem["tracks"], mem["history"]) == 50
    assert {t["id"] for t in s.tracks("v")} == {f"c{i}" for i in range(9_950, 10_000)}
    assert s.stats["evicted.intruders"] == 9_950
    full, _ = s.view("v")
    assert len(full["tracks"]) == 50


def test_vehicles_are_capped_and_offline_ones_expire():
    now = [0.0]
    s = FleetState(max_vehicles=3, vehicle_forget_s=100.0, clock=lambda: now[0])
    for vid in ("a", "b", "c"):
        now[0] += 1.0
        s.set_alive(vid, True)
    s.apply("d", "status", "", status())  # three online vehicles: no room, the sample is dropped and counted
    assert sorted(s.vehicles) == ["a", "b", "c"] and s.stats["dropped.vehicle_cap"] == 1
    s.set_alive("b", False)
    s.apply("d", "status", "", status())  # b is offline: it makes room
    assert sorted(s.vehicles) == ["a", "c", "d"] and s.stats["evicted.vehicles"] == 1
    now[0] += 50.0
    s.set_alive("c", False)
    now[0] += 60.0  # d (never online, heard 110 s ago) expires; c (offline, heard 60 s ago) not yet; a is online
    s.expire()
    assert sorted(s.vehicles) == ["a", "c"] and s.stats["expired.vehicles"] == 1


# -- (a) the page in a real browser: payload markup is text, no script runs -------------------------------------------
def _browser_or_skip():
    """tests/test_monitor_live.py's helper: skip without Chromium on a developer machine, fail in CI."""
    from test_monitor_live import browser_or_skip

    return browser_or_skip()


@pytest.mark.live
@pytest.mark.browser
def test_browser_renders_markup_in_every_payload_string_as_text_and_runs_no_script():
    """A vehicle and its intruders over a real zenoh session (peer on loopback, scouting off) whose every string
    field is `<img src=x onerror=...>`: a track (incl. its `advisory`), an advisory (incl. `level`), the status,
    and the vehicle id itself; one intruder and a change come only from the snapshot."""
    from avionics.io.zenoh_bus import open_session

    browser = _browser_or_skip()
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    vid = XSS
    strings = dict(vehicle=XSS, address_source=XSS, callsign=XSS, model=XSS, altitude_datum=XSS)
    track_a = track(XSS, **strings, advisory=XSS, most_likely_mode=XSS, vertical_mode=XSS,
                    mode_probabilities={XSS: 0.9})
    track_b = track(XSS2, north_m=2 * NM, **strings, advisory="TA", most_likely_mode=XSS, mode_probabilities=None)
    adv_strings = {k: v for k, v in strings.items() if k != "model"}
    adv_b = adv(XSS, 10.0, intruder=XSS2, **adv_strings, reason=XSS, ra_sense=XSS, ra_strength=XSS, ra_words=XSS)
    stat = status(vehicle=XSS, version=XSS, warnings=[XSS], datum_mismatch_intruders=[XSS])
    snapshot = {"schema": 1, "vehicle": XSS, "time_s": 10.0, "ownship": dict(OWN, vehicle=XSS), "status": stat,
                "tracks": [track_a], "advisories": [],
                "advisory_changes": [adv(XSS, 9.0, intruder=XSS, **adv_strings, reason=XSS, ra_words=XSS)]}
    pub = open_session(monitor_zenoh_config([], mode="peer", listen=[endpoint]))
    token = pub.liveliness().declare_token(f"daa/{vid}/alive")
    queryable = pub.declare_queryable(f"daa/{vid}/snapshot",
                                      lambda q: q.reply(f"daa/{vid}/snapshot", json.dumps(snapshot).encode()))
    state = FleetState()
    feed = server = None
    try:
        feed = ZenohFeed(state, monitor_zenoh_config([endpoint], mode="peer"))
        server = MonitorServer(state, port=0).start()

        def published():
            for key, payload in (("ownship", dict(OWN, vehicle=XSS)), ("status", stat),
                                 (f"tracks/{XSS2}", track_b), (f"advisories/{XSS2}", adv_b)):
                pub.put(f"daa/{vid}/{key}", json.dumps(payload).encode())
            v = state.vehicles.get(vid)
            return v is not None and v.synced and len(v.tracks) == 2 and len(v.log) == 2

        assert wait_for(published, DEADLINE_S, period_s=0.1), state.stats_copy()
        assert state.stats["rejected"] == 0
        browser.open(server.url)
        js = browser.js
        text_of = "return document.querySelector(arguments[0]).textContent"
        assert wait_for(lambda: js("return window.daa.tracks.size") == 2 and len(js("return window.daa.log")) == 2
                        and XSS2 in js(text_of, "#tracks tbody") and XSS2 in js(text_of, "#log tbody"), DEADLINE_S)
        # positive control: an image that fails to load reports its error by now (set from this script, which the
        # page's Content-Security-Policy does not govern); an injected one would have done the same
        js("window.__control = 0; const i = new Image(); i.onerror = () => { window.__control = 1; };"
           "i.src = '/x?control';")
        assert wait_for(lambda: js("return window.__control") == 1, DEADLINE_S)
        tracks_text, log_text = js(text_of, "#tracks tbody"), js(text_of, "#log tbody")
        status_text = js(text_of, "#statusbar") + js(text_of, "#warnings")
        select_text = js(text_of, "#vehicle")
        result = js("return {xss: window.__xss === undefined ? null : window.__xss, title: document.title,"
                    " imgs: document.querySelectorAll('img').length, vehicle: window.daa.vehicle}")
        page_rows = js("return [...document.querySelectorAll('#tracks tbody tr')].map(r => r.dataset.id)")
    finally:
        browser.close()
        for closable in (feed, server):
            if closable is not None:
                closable.close()
        queryable.undeclare()
        token.undeclare()
        pub.close()
    assert result == {"xss": None, "title": "DAA ground monitor", "imgs": 0, "vehicle": XSS}
    assert sorted(page_rows) == sorted([XSS, XSS2])
    # the literal text, in every place a payload string is shown
    assert tracks_text.count(XSS) >= 3  # track A: id, callsign, advisory (level); track B: callsign
    assert XSS.upper() in tracks_text  # IMM mode (upper-cased by the monitor), still text
    assert log_text.count(XSS) >= 4 and XSS2 in log_text  # intruder, callsign, level, RA words, reason
    assert XSS in status_text and XSS in select_text
