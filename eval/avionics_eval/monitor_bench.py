"""Monitor throughput benchmark: how many track updates and advisories per second the monitor takes in with
500 intruders, and the page's frame rate while it does.

A publisher process (`python -m avionics_eval.monitor_bench publish ...`) plays a vehicle `bench` with N intruders:
phase `nominal` sends every track at 2 Hz (as `avionics run` does) plus advisory changes; phase `max` sends
as fast as it can. This process runs the monitor (FleetState + ZenohFeed + web server), counts what it applied
and how late (publisher wall clock in the payload -> applied), and optionally measures the page in headless
Chromium (frames drawn per second with every frame redrawn). Output: JSON.

    python -m avionics_eval.monitor_bench --intruders 500 [--browser] [--out bench.json]
"""

from __future__ import annotations

import argparse
import json
import math
import os
import platform
import subprocess
import sys
import threading
import time

TRACK = ('{"schema":2,"vehicle":"bench","intruder":"1090es-%06X","address":%d,"address_source":"1090es",'
         '"callsign":"B%05d","squawk":null,"emitter_type":1,"simulated":true,"model":"cv-kalman","time_s":%.3f,'
         '"last_report_s":%.3f,"age_s":0.2,"updates":10,"lat_deg":%.7f,"lon_deg":%.7f,"altitude_m":%.1f,'
         '"altitude_datum":"pressure","velocity_enu_mps":[%.2f,%.2f,0.5],"ground_speed_mps":60.0,"track_deg":%.1f,'
         '"vertical_rate_mps":0.5,"position_sigma_m":15.0,"velocity_sigma_mps":2.0,"advisory":"NONE","range_m":%.1f,'
         '"t_cpa_s":30.0,"hmd_m":300.0,"vmd_m":50.0,"range_tau_s":40.0,"mod_tau_s":38.0,"pc_ta":0.05,"pc_ra":0.01,'
         '"bench_wall_s":%.6f,"bench_phase":"%s"}')
ADVISORY = ('{"schema":2,"vehicle":"bench","intruder":"1090es-%06X","address":%d,"address_source":"1090es",'
            '"callsign":"B%05d","level":"%s","reason":"tau","time_s":%.3f,"sensitivity_level":4,"range_m":3000.0,'
            '"closure_rate_mps":100.0,"t_cpa_s":30.0,"hmd_m":100.0,"vmd_m":20.0,"range_tau_s":30.0,"mod_tau_s":28.0,'
            '"vertical_tau_s":null,"altitude_datum":"pressure","datum_mismatch":false,"pc_ta":0.4,"pc_ra":0.2,'
            '"ra_sense":%s,"ra_strength":null,"ra_words":%s,"target_vertical_rate_mps":%s,"ra_reversed":false,'
            '"ra_crossing":false,"ra_separation_m":null,"bench_wall_s":%.6f,"bench_phase":"%s"}')
OWN = ('{"schema":2,"vehicle":"bench","time_s":%.3f,"valid":true,"lat_deg":47.0,"lon_deg":8.0,"alt_msl_m":1000.0,'
       '"pressure_altitude_m":1000.0,"height_above_home_m":900.0,"velocity_enu_mps":[0.0,50.0,0.0],'
       '"ground_speed_mps":50.0,"track_deg":0.0,"vertical_rate_mps":0.0}')
LEVELS = ("TA", "RA", "NONE")


# -- the publisher process ----------------------------------------------------------------------------------------
def publish(endpoint: str, intruders: int, phases: list[tuple[str, float]], advisory_share: float) -> dict:
    import zenoh

    from avionics.config import ZenohConfig
    from avionics.io.zenoh_bus import open_session

    session = open_session(ZenohConfig(listen=(endpoint,), connect=()))
    token = session.liveliness().declare_token("daa/bench/alive")
    picture = json.dumps({"schema": 1, "vehicle": "bench", "time_s": 0.0, "ownship": None, "status": None,
                          "tracks": [], "advisories": [], "advisory_changes": []}).encode()
    queryable = session.declare_queryable("daa/bench/snapshot", lambda q: q.reply("daa/bench/snapshot", picture))
    tracks = [session.declare_publisher(f"daa/bench/tracks/1090es-{0xB00000 + i:06X}",
                                        encoding=zenoh.Encoding.APPLICATION_JSON) for i in range(intruders)]
    advs = [session.declare_publisher(f"daa/bench/advisories/1090es-{0xB00000 + i:06X}",
                                      encoding=zenoh.Encoding.APPLICATION_JSON,
                                      congestion_control=zenoh.CongestionControl.BLOCK,
                                      priority=zenoh.Priority.INTERACTIVE_HIGH) for i in range(intruders)]
    own = session.declare_publisher("daa/bench/ownship", encoding=zenoh.Encoding.APPLICATION_JSON)
    print(json.dumps({"ready": True}), flush=True)
    sys.stdin.readline()  # the monitor is connected: go
    level = [2] * intruders  # index into LEVELS; start at NONE
    t_sim = 0.0
    out = {}
    k_adv = 0
    for name, seconds in phases:
        sent_tracks = sent_advs = 0
        start = time.monotonic()
        nominal = name == "nominal"
        period = 1.0 / 2.0  # 2 Hz per track in the nominal phase
        next_batch = start
        while time.monotonic() - start < seconds:
            if nominal:
                delay = next_batch - time.monotonic()
                if delay > 0:
                    time.sleep(delay)
                next_batch += period
            t_sim += 0.5
            own.put(OWN % t_sim)
            n_adv = int(round(intruders * advisory_share)) if nominal else max(1, int(intruders * advisory_share))
            for i in range(intruders):
                a = 2 * math.pi * i / intruders
                r = 1500.0 + 15000.0 * ((i * 7919) % intruders) / intruders
                lat = 47.0 + r * math.cos(a) / 111200.0
                lon = 8.0 + r * math.sin(a) / 75800.0
                tracks[i].put(TRACK % (0xB00000 + i, 0xB00000 + i, i, t_sim, t_sim - 0.2, lat, lon,
                                       1000.0 + (i % 40 - 20) * 15.0, 60 * math.sin(a + 2), 60 * math.cos(a + 2),
                                       (math.degrees(a) + 180) % 360, r, time.time(), name))
                sent_tracks += 1
            for _ in range(n_adv):
                i = k_adv % intruders
                k_adv += 1
                level[i] = (level[i] + 1) % 3
                lvl = LEVELS[level[i]]
                ra = lvl == "RA"
                advs[i].put(ADVISORY % (0xB00000 + i, 0xB00000 + i, i, lvl, t_sim + 0.001 * (k_adv % 400),
                                        '"climb"' if ra else "null", '"CLIMB"' if ra else "null",
                                        "7.62" if ra else "null", time.time(), name))
                sent_advs += 1
        elapsed = time.monotonic() - start
        out[name] = {"seconds": round(elapsed, 3), "sent_tracks": sent_tracks, "sent_advisories": sent_advs}
        time.sleep(1.0)  # let the monitor drain before the next phase
    print(json.dumps(out), flush=True)
    sys.stdin.readline()
    for p in tracks + advs + [own]:
        p.undeclare()
    queryable.undeclare()
    token.undeclare()
    session.close()
    return out


# -- the monitor side ---------------------------------------------------------------------------------------------
def _pct(values, p):
    if not values:
        return None
    s = sorted(values)
    return s[min(len(s) - 1, int(round(p / 100 * (len(s) - 1))))]


def run_bench(intruders: int = 500, nominal_s: float = 4.0, max_s: float = 3.0, browser: bool = False,
              screenshot: str | None = None) -> dict:
    from avionics.monitor.feed import ZenohFeed, monitor_zenoh_config, wait_for
    from avionics.monitor.state import FleetState
    from avionics.monitor.web import MonitorServer

    import socket

    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    endpoint = f"tcp/127.0.0.1:{port}"
    pub = subprocess.Popen([sys.executable, "-m", "avionics_eval.monitor_bench", "publish", "--connect", endpoint,
                            "--intruders", str(intruders), "--nominal", str(nominal_s), "--max", str(max_s)],
                           stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
    result: dict = {"benchmark": "avionics monitor: zenoh -> FleetState -> SSE -> page", "intruders": intruders,
                    "python": platform.python_version(), "machine": platform.machine(), "cpus": os.cpu_count()}
    state = FleetState(stale_s=30.0, log_size=100000)
    lock = threading.Lock()
    applied = {ph: {"tracks": 0, "advisories": 0, "lat": [], "first": None, "last": None} for ph in ("nominal", "max")}
    original = state.apply

    def apply(vid, kind, name, payload):
        original(vid, kind, name, payload)
        phase = applied.get(payload.get("bench_phase"))
        if phase is not None and kind in phase:
            now = time.monotonic()
            with lock:
                phase[kind] += 1
                phase["first"] = phase["first"] or now
                phase["last"] = now
                if len(phase["lat"]) < 200000:
                    phase["lat"].append(time.time() - payload["bench_wall_s"])

    state.apply = apply
    feed = server = page = None
    try:
        assert json.loads(pub.stdout.readline())["ready"]
        feed = ZenohFeed(state, monitor_zenoh_config([endpoint]))
        server = MonitorServer(state, port=0).start()
        wait_for(lambda: state.vehicles.get("bench") is not None and state.vehicles["bench"].synced, 10.0)
        if page is None and browser:
            from avionics.monitor.browser import Browser

            page = Browser(1600, 1000)
            page.open(server.url + "?vehicle=bench&continuous=1&range=12")
            wait_for(lambda: page.js("return window.daa.link") is True, 10.0)
        frames0 = page.js("return [window.daa.draws, window.daa.drawMs, window.daa.events]") if page else None
        t0 = time.monotonic()
        pub.stdin.write("go\n")
        pub.stdin.flush()
        if page is not None:
            time.sleep(nominal_s)
            dt = time.monotonic() - t0
            frames1 = page.js("return [window.daa.draws, window.daa.drawMs, window.daa.events, window.daa.tracks.size]")
            # the page shows what the monitor holds once the server-sent events in flight have arrived
            in_monitor = len(state.vehicles["bench"].tracks)
            wait_for(lambda: page.js("return window.daa.tracks.size") >= in_monitor, 3.0)
            result["browser"] = {
                "fps": round((frames1[0] - frames0[0]) / dt, 1),
                "draw_ms_mean": round((frames1[1] - frames0[1]) / max(1, frames1[0] - frames0[0]), 2),
                "sse_events_per_s": round((frames1[2] - frames0[2]) / dt, 1),
                "tracks_on_page": page.js("return window.daa.tracks.size"),
                "tracks_in_monitor": in_monitor,
                "window_s": round(dt, 2),
                "note": "headless Chromium, software rendering, every frame redrawn (continuous=1), nominal phase",
            }
            if screenshot:
                page.screenshot(screenshot)
                result["browser"]["screenshot"] = screenshot
        sent = json.loads(pub.stdout.readline())  # the publisher is done
        last, stable_since = None, time.monotonic()
        while time.monotonic() - stable_since < 0.5:  # until nothing more arrives for 0.5 s
            time.sleep(0.1)
            with lock:
                now = tuple(applied[p][k] for p in applied for k in ("tracks", "advisories"))
            if now != last:
                last, stable_since = now, time.monotonic()
        phases = {}
        for name, s in sent.items():
            got = applied[name]
            lat = got["lat"]
            span = max(s["seconds"], (got["last"] or 0) - (got["first"] or 0))  # sent over, or applied over
            phases[name] = {
                "seconds": s["seconds"], "sent_tracks": s["sent_tracks"], "sent_advisories": s["sent_advisories"],
                "received_tracks": got["tracks"], "received_advisories": got["advisories"],
                "offered_tracks_per_s": round(s["sent_tracks"] / s["seconds"], 1),
                "offered_advisories_per_s": round(s["sent_advisories"] / s["seconds"], 1),
                "applied_over_s": round(span, 3),
                "tracks_per_s": round(got["tracks"] / span, 1),
                "advisories_per_s": round(got["advisories"] / span, 1),
                "lost_tracks": s["sent_tracks"] - got["tracks"],
                "lost_advisories": s["sent_advisories"] - got["advisories"],
                "latency_ms_p50": round(_pct(lat, 50) * 1e3, 2) if lat else None,
                "latency_ms_p99": round(_pct(lat, 99) * 1e3, 2) if lat else None,
                "latency_ms_max": round(max(lat) * 1e3, 2) if lat else None,
            }
        result["phases"] = phases
        result["advisory_changes_logged"] = len(state.advisory_log("bench"))
        result["advisories_sent_total"] = sum(s["sent_advisories"] for s in sent.values())
        result["feed_errors"] = feed.errors
        pub.stdin.write("bye\n")
        pub.stdin.flush()
        pub.wait(timeout=10)
    finally:
        if page is not None:
            page.close()
        if server is not None:
            server.close()
        if feed is not None:
            feed.close()
        if pub.poll() is None:
            pub.kill()
            pub.wait()
    return result


def main(argv=None) -> int:
    p = argparse.ArgumentParser(prog="python -m avionics_eval.monitor_bench", description=__doc__.split("\n\n")[0])
    sub = p.add_subparsers(dest="cmd")
    pp = sub.add_parser("publish")
    pp.add_argument("--connect", required=True, help="endpoint to listen on (the monitor connects)")
    pp.add_argument("--intruders", type=int, default=500)
    pp.add_argument("--nominal", type=float, default=4.0)
    pp.add_argument("--max", type=float, default=3.0)
    pp.add_argument("--advisory-share", type=float, default=0.02, help="advisories per track batch, x intruders")
    p.add_argument("--intruders", type=int, default=500)
    p.add_argument("--nominal", type=float, default=4.0)
    p.add_argument("--max", type=float, default=3.0)
    p.add_argument("--browser", action="store_true", help="measure the page in headless Chromium")
    p.add_argument("--out", help="write the JSON here too")
    args = p.parse_args(argv)
    if args.cmd == "publish":
        publish(args.connect, args.intruders, [("nominal", args.nominal), ("max", args.max)], args.advisory_share)
        return 0
    result = run_bench(args.intruders, args.nominal, args.max, args.browser)
    text = json.dumps(result, indent=1)
    print(text)
    if args.out:
        with open(args.out, "w") as fh:
            fh.write(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
