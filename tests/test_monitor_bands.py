"""The ground monitor draws DO-365 guidance bands, and its display defects are fixed (issue 16, item 4): a real zenoh
session (peer on 127.0.0.1, scouting off) publishes a vehicle's ownship, tracks, DO-365 advisories and bands, and
the page in headless Chromium is checked at 1200 px and at a narrow width:

- the track bands are arcs on the compass rose, the ground-speed, vertical-speed and altitude bands strips on their
  tapes, each with its region (the page's `#display-model` says what it drew and where; the canvas pixels there are
  the region's colour), listed as text in the GUIDANCE BANDS panel; DO-365 level names in the tables;
- nothing is cut off (document no wider than the window, every panel inside it), the RA banner does not cover the
  ALT/GS text, an altitude tag covers neither its selection ring nor, at close range, the ownship symbol;
- a cleared intruder shows no Pc (its NONE advisory carries the last alerting Pc, 1.0);
- bands not refreshed turn stale on the page (greyed, `BANDS STALE`), an empty kind draws nothing and says so;
- a malformed bands sample is a counted rejection and never hides the good ones.

Every wait polls for its condition with a generous deadline (DEADLINE_S), no fixed sleeps. Screenshots go to
$AVIONICS_ARTIFACTS (default <tmp>/avionics-artifacts); their paths are printed."""

import json
import math
import threading

import pytest

from avionics.monitor.feed import ZenohFeed, monitor_zenoh_config, wait_for
from avionics.base.units import FT, NM
from avionics.monitor.state import FleetState
from avionics.monitor.web import MonitorServer
from tests.conftest import DEADLINE_S, free_port
from tests.test_monitor_live import ARTIFACTS, browser_or_skip, report

pytestmark = [pytest.mark.live, pytest.mark.browser]

V = "uav1"
RA_ID, TA_ID, CLEAR_ID = "1090es-A1B2C3", "1090es-D4E5F6", "1090es-C0FFEE"
ALT_M = 1219.2
OWN = {"schema": 2, "vehicle": V, "time_s": 12.0, "valid": True, "lat_deg": 47.0, "lon_deg": 8.0, "alt_msl_m": ALT_M,
       "pressure_altitude_m": ALT_M, "velocity_enu_mps": [51.4, 0.0, 0.0], "track_deg": 90.0,
       "ground_speed_mps": 51.4, "vertical_rate_mps": 0.0}


def track(intruder, north_m, east_m, rel_alt_ft, t=12.0, **extra):
    return {"schema": 2, "vehicle": V, "intruder": intruder, "callsign": "C" + intruder[-5:], "time_s": t,
            "lat_deg": 47.0 + north_m / 111_229.0, "lon_deg": 8.0 + east_m / (111_229.0 * math.cos(math.radians(47.0))),
            "altitude_m": ALT_M + rel_alt_ft * FT, "altitude_datum": "pressure", "vertical_rate_mps": 0.0,
            "ground_speed_mps": 50.0, "track_deg": 270.0, "advisory": "NONE", "mod_tau_s": 30.0, "pc_ta": 0.3,
            **extra}


def adv(intruder, level, alert_level, alert_name, t=12.0, **extra):
    return {"schema": 2, "vehicle": V, "intruder": intruder, "callsign": "C" + intruder[-5:], "level": level,
            "alert_level": alert_level, "alert_name": alert_name, "reason": "tau", "time_s": t, "range_m": 500.0,
            "mod_tau_s": 12.0, "pc_ta": 0.8, **extra}


# Regions chosen so that every drawn style appears (daa-displays: FAR dashed yellow, MID yellow, NEAR red,
# RECOVERY dashed green; NONE not drawn) and every tape band lies within its tape's window around ownship.
TRACK_BANDS = [{"lower": 0.0, "upper": 60.0, "region": "NONE"}, {"lower": 60.0, "upper": 87.0, "region": "FAR"},
               {"lower": 87.0, "upper": 113.0, "region": "MID"}, {"lower": 113.0, "upper": 140.0, "region": "NEAR"},
               {"lower": 140.0, "upper": 200.0, "region": "RECOVERY"}, {"lower": 200.0, "upper": 360.0, "region": "NONE"}]
GS_BANDS = [{"lower": 0.0, "upper": 40.0, "region": "NONE"}, {"lower": 40.0, "upper": 50.0, "region": "MID"},
            {"lower": 50.0, "upper": 62.0, "region": "NEAR"}, {"lower": 62.0, "upper": 300.0, "region": "NONE"}]
VS_BANDS = [{"lower": -30.48, "upper": -5.0, "region": "NONE"}, {"lower": -5.0, "upper": 10.0, "region": "NEAR"},
            {"lower": 10.0, "upper": 30.48, "region": "FAR"}]
ALT_BANDS = [{"lower": 30.0, "upper": 1150.0, "region": "NONE"}, {"lower": 1150.0, "upper": 1300.0, "region": "MID"},
             {"lower": 1300.0, "upper": 15240.0, "region": "NONE"}]


def bands_payload(t=12.0, **extra):
    return {"schema": 2, "vehicle": V, "time_s": t, "alerter": "daidalus-do365b-no-sum",
            "ownship": {"track_deg": 90.0, "ground_speed_mps": 51.4, "vertical_rate_mps": 0.0, "altitude_m": ALT_M},
            "track_deg": TRACK_BANDS, "ground_speed_mps": GS_BANDS, "vertical_rate_mps": VS_BANDS,
            "altitude_m": ALT_BANDS,
            "recovery": {"track_deg": False, "ground_speed_mps": False, "vertical_rate_mps": False, "altitude_m": False},
            "intruders": [{"intruder": RA_ID, "alert_level": 3, "alert_name": "WARNING"},
                          {"intruder": TA_ID, "alert_level": 2, "alert_name": "CORRECTIVE"}], **extra}


SAMPLES = [
    ("ownship", OWN),
    ("status", {"schema": 2, "vehicle": V, "time_s": 12.0, "sensitivity_level": 4, "ownship_valid": True,
                "advisories": {"TA": 1, "RA": 1}, "warnings": []}),
    # RA intruder 0.05 NM north, 200 ft below: its tag's usual place (below the symbol) is on the ownship symbol
    (f"tracks/{RA_ID}", track(RA_ID, 0.05 * NM, 0.0, -200, advisory="RA")),
    (f"advisories/{RA_ID}", adv(RA_ID, "RA", 3, "WARNING", ra_sense="descend", ra_words="INCREASE DESCENT",
                                target_vertical_rate_mps=-12.7)),
    (f"tracks/{TA_ID}", track(TA_ID, 0.4 * NM, -0.4 * NM, 500, advisory="TA")),
    (f"advisories/{TA_ID}", adv(TA_ID, "TA", 2, "CORRECTIVE")),
    # cleared at the closest approach: the track is older than the clear, the NONE advisory carries Pc 1.0
    (f"tracks/{CLEAR_ID}", track(CLEAR_ID, -0.5 * NM, -0.3 * NM, 0, t=11.5, advisory="RA", pc_ta=1.0)),
    (f"advisories/{CLEAR_ID}", adv(CLEAR_ID, "NONE", 0, "NONE", reason="diverging", pc_ta=1.0, pc_ra=1.0)),
]
BAD_BANDS = [  # each a counted rejection; none may hide the good bands published after it
    bands_payload(track_deg=[{"lower": 113.0, "upper": 87.0, "region": "MID"}]),
    bands_payload(ground_speed_mps=[{"lower": 0.0, "upper": 10.0, "region": ["NEAR"]}]),
    bands_payload(altitude_m="everything"),
]

MODEL_JS = "return [...document.querySelectorAll('#display-model i')].map(i => ({...i.dataset}))"
LAYOUT_JS = """
const vw = window.innerWidth, vh = window.innerHeight, doc = document.documentElement;
const rect = (sel) => { const r = document.querySelector(sel).getBoundingClientRect();
  return {x: r.left, y: r.top, w: r.width, h: r.height}; };
const panels = {};
for (const sel of ["header", "#display", "#plot", "#statusbar", "#bands-panel", "#tracks-panel", "#log-panel"])
  panels[sel] = rect(sel);
return {vw, vh, scrollWidth: doc.scrollWidth, bodyScrollWidth: document.body.scrollWidth, panels,
        canvas: rect("#display"), boxes: window.daa.boxes, draws: window.daa.draws};
"""
PIXEL_JS = """
const c = document.getElementById('display'), dpr = c.width / c.getBoundingClientRect().width;
const d = c.getContext('2d').getImageData(Math.round(arguments[0] * dpr), Math.round(arguments[1] * dpr), 1, 1).data;
return [d[0], d[1], d[2]];
"""


def overlap(a, b) -> bool:
    return a["x"] < b["x"] + b["w"] and b["x"] < a["x"] + a["w"] and a["y"] < b["y"] + b["h"] and b["y"] < a["y"] + a["h"]


def inside(box, outer, slack=0.5) -> bool:
    return (box["x"] >= outer["x"] - slack and box["y"] >= outer["y"] - slack
            and box["x"] + box["w"] <= outer["x"] + outer["w"] + slack
            and box["y"] + box["h"] <= outer["y"] + outer["h"] + slack)


def check_layout(lay: dict, vertical: bool) -> None:
    """Nothing cut off; the canvas's texts and symbols where they belong, not covering each other."""
    vw, vh = lay["vw"], lay["vh"]
    assert lay["scrollWidth"] <= vw and lay["bodyScrollWidth"] <= vw, lay  # no sideways scrolling
    viewport = {"x": 0, "y": 0, "w": vw, "h": vh if vertical else 1e9}
    for sel, box in lay["panels"].items():
        assert box["w"] > 0 and inside(box, viewport), (sel, box, vw, vh)
    b = lay["boxes"]
    canvas = b["canvas"]
    for name in ("banner", "altgs", "ownship", "compass"):
        assert b[name] and inside(b[name], canvas), (name, b[name], canvas)
    for box in b["text"]:
        assert inside(box, canvas), box
        assert not overlap(box, b["banner"]), (box, b["banner"])  # the RA banner covers no strip text
    assert not overlap(b["banner"], b["altgs"])
    for tape in b["tapes"].values():
        assert inside(tape, canvas) and not overlap(tape, b["compass"]), (tape, b["compass"])
    tags = {t["id"]: t for t in b["tags"]}
    assert set(tags) == {RA_ID, TA_ID, CLEAR_ID}
    rings = {r["id"]: r for r in b["rings"]}
    assert list(rings) == [RA_ID]  # the most threatening intruder is selected
    for tag in tags.values():
        assert not overlap(tag, b["ownship"]), (tag, b["ownship"])
        for ring in rings.values():
            assert not overlap(tag, ring), (tag, ring)
    # the RA intruder is 0.05 NM from the ownship: its symbol is on the ownship, its tag is not
    assert overlap(b["symbols"][[s["id"] for s in b["symbols"]].index(RA_ID)], b["ownship"])


def close_to(rgb, want, tol=40) -> bool:
    return all(abs(a - b) <= tol for a, b in zip(rgb, want))


def test_page_draws_do365_bands_and_nothing_is_cut_off_or_covered(capsys):
    from avionics.io.zenoh_bus import open_session

    browser = browser_or_skip()
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    pub = open_session(monitor_zenoh_config([], mode="peer", listen=[endpoint]))
    token = pub.liveliness().declare_token(f"daa/{V}/alive")
    state = FleetState(stale_s=1e6, bands_stale_s=6.0)  # tracks never leave the picture here; bands can go stale
    feed = server = None
    current_bands = {"payload": bands_payload(), "on": True}
    stop = threading.Event()
    shots = []

    def publish_all():
        for key, payload in SAMPLES:
            pub.put(f"daa/{V}/{key}", json.dumps(payload).encode())
        for bad in BAD_BANDS:
            pub.put(f"daa/{V}/bands", json.dumps(bad).encode())
        if current_bands["on"]:
            pub.put(f"daa/{V}/bands", json.dumps(current_bands["payload"]).encode())

    def keep_publishing():  # the vehicle at ~3 Hz, until the bands are made to go stale
        while not stop.wait(0.3):
            publish_all()

    publisher = threading.Thread(target=keep_publishing, daemon=True)
    try:
        feed = ZenohFeed(state, monitor_zenoh_config([endpoint], mode="peer"), query_timeout_s=0.5)
        server = MonitorServer(state, port=0).start()

        def monitor_has_all():
            publish_all()
            v = state.vehicles.get(V)
            return (v is not None and v.synced and len(v.tracks) == 3 and len(v.advisories) == 3
                    and state.bands(V) is not None and state.stats["rejected.bands"] >= len(BAD_BANDS))

        assert wait_for(monitor_has_all, DEADLINE_S, period_s=0.1), state.stats_copy()
        publisher.start()
        stats = state.stats_copy()
        assert feed.errors == 0 and stats["rejected.bands"] >= len(BAD_BANDS)
        assert stats.get("rejected.bands.track_deg", 0) >= 1 and stats.get("rejected.bands.altitude_m", 0) >= 1
        assert stats.get("rejected.bands.ground_speed_mps.region", 0) >= 1
        assert state.bands(V)["track_deg"] == TRACK_BANDS  # the good bands, not hidden by the bad ones

        browser.driver.set_window_size(1200, 800)
        browser.open(server.url + "?range=1")
        js = browser.js
        want = {("arc", "track_deg", r) for r in ("FAR", "MID", "NEAR", "RECOVERY")} | {
            ("tape", "ground_speed_mps", "MID"), ("tape", "ground_speed_mps", "NEAR"),
            ("tape", "vertical_rate_mps", "NEAR"), ("tape", "vertical_rate_mps", "FAR"),
            ("tape", "altitude_m", "MID")}

        def drawn():
            return {(d["el"], d["kind"], d["region"]) for d in js(MODEL_JS) if d["stale"] == "false"}

        assert wait_for(lambda: js("return window.daa.tracks.size") == 3 and drawn() == want
                        and js("return window.daa.boxes && window.daa.boxes.banner !== null"), DEADLINE_S), \
            (js(MODEL_JS), js("return window.daa.boxes"))
        model = js(MODEL_JS)
        # the arcs and strips are on the canvas in their region's colour (daa-displays: yellow, red; solid ones)
        colours = {"MID": (255, 255, 0), "NEAR": (255, 0, 0)}
        for d in model:
            assert d["dash"] == ("true" if d["region"] in ("FAR", "RECOVERY") else "false"), d
            assert d["color"] == {"FAR": "#ffff00", "MID": "#ffff00", "NEAR": "#ff0000", "RECOVERY": "#07dc0a"}[d["region"]]
            if d["region"] in colours:
                rgb = js(PIXEL_JS, float(d["px"]), float(d["py"]))
                assert close_to(rgb, colours[d["region"]]), (d, rgb)
        arcs = {d["region"]: d for d in model if d["el"] == "arc"}
        assert (float(arcs["MID"]["lower"]), float(arcs["MID"]["upper"])) == (87.0, 113.0)
        # north up: the MID arc (87-113 deg) is east of the centre, the RECOVERY arc (140-200) south
        box = js("return window.daa.boxes.compass")
        centre = (box["x"] + box["w"] / 2, box["y"] + box["h"] / 2)
        assert float(arcs["MID"]["px"]) > centre[0] + box["w"] / 3
        assert float(arcs["RECOVERY"]["py"]) > centre[1] + box["h"] / 3
        # the text panel lists every interval with its region; tables show the DO-365 level names
        # (the panel and the tables are rendered at most every 0.5 s: wait for them)
        texts = ("MID 87–113", "NEAR 113–140", "RECOVERY 140–200", "NONE 200–360", f"{RA_ID} WARNING")
        seen = {}

        def panel_shows():
            seen["panel"] = js("return document.querySelector('#bands-text').innerText")
            return all(text in seen["panel"] for text in texts)

        assert wait_for(panel_shows, DEADLINE_S), seen
        assert wait_for(lambda: "WARNING" in js("return document.querySelector('#tracks tbody').innerText")
                        and "CORRECTIVE" in js("return document.querySelector('#tracks tbody').innerText"), DEADLINE_S)
        # the cleared intruder: no Pc (its NONE advisory's 1.0 is the last alerting assessment's)
        row_js = ("const r = document.querySelector(`#tracks tbody tr[data-id='${arguments[0]}']`);"
                  "return r ? [...r.cells].map(c => c.textContent) : null")
        assert wait_for(lambda: js(row_js, CLEAR_ID) is not None, DEADLINE_S)
        row = js(row_js, CLEAR_ID)
        assert js("return window.daa.tracks.get(arguments[0]).pc", CLEAR_ID) is None
        assert row[8] == "—" and "1.000" not in " ".join(row), row
        assert wait_for(lambda: js("return window.daa.boxes.banner.text") == "WARNING  INCREASE DESCENT  -2500 fpm",
                        DEADLINE_S), js("return window.daa.boxes.banner")

        lay_wide = js(LAYOUT_JS)
        check_layout(lay_wide, vertical=True)
        shots.append(browser.screenshot(ARTIFACTS / "monitor_bands_1200.png"))

        # a narrow window: one column, the page scrolls down, never sideways
        draws = js("return window.daa.draws")
        browser.driver.set_window_size(600, 1000)
        assert wait_for(lambda: js("return window.innerWidth") < 700 and js("return window.daa.draws") > draws
                        and js("return window.daa.boxes.canvas.w") < 600, DEADLINE_S)
        assert wait_for(lambda: drawn() == want, DEADLINE_S)
        lay_narrow = js(LAYOUT_JS)
        check_layout(lay_narrow, vertical=False)
        shots.append(browser.screenshot(ARTIFACTS / "monitor_bands_narrow.png"))

        # the altitude kind becomes empty (ownship outside its range): nothing drawn, and said so
        current_bands["payload"] = bands_payload(t=13.0, altitude_m=[])
        assert wait_for(lambda: ("tape", "altitude_m", "MID") not in drawn() and len(drawn()) == len(want) - 1
                        and "no bands computed" in js("return document.querySelector('#bands-text').innerText"),
                        DEADLINE_S)
        # no more bands: after bands_stale_s the page shows them stale (greyed, BANDS STALE), still drawn
        current_bands["on"] = False
        assert wait_for(lambda: js("return document.getElementById('bands-panel').dataset.stale") == "true"
                        and all(d["stale"] == "true" for d in js(MODEL_JS)) and len(js(MODEL_JS)) == len(want) - 1
                        and "BANDS STALE" in (js("return window.daa.boxes.bandsText.text") or ""), DEADLINE_S)
        assert "STALE" in js("return document.getElementById('bands-note').textContent")
        assert state.bands(V)["stale"] is True
        d = next(d for d in js(MODEL_JS) if d["region"] == "NEAR" and d["el"] == "arc")
        rgb = js(PIXEL_JS, float(d["px"]), float(d["py"]))
        assert rgb[0] < 160 and close_to(rgb, (0.35 * 255, 0, 0), 30), rgb  # greyed: drawn at 35 % over black
        shots.append(browser.screenshot(ARTIFACTS / "monitor_bands_stale_narrow.png"))
        errors = [e for e in browser.driver.get_log("browser") if e.get("level") == "SEVERE"] \
            if hasattr(browser.driver, "get_log") else []
    finally:
        stop.set()
        browser.close()
        for closable in (feed, server):
            if closable is not None:
                closable.close()
        token.undeclare()
        pub.close()
    report(capsys, f"bands screenshots: {', '.join(str(s) for s in shots)}")
    report(capsys, "layout 1200: viewport {vw}x{vh}, scroll width {scrollWidth}; narrow: viewport {nvw}, scroll width "
                   "{nsw}".format(nvw=lay_narrow["vw"], nsw=lay_narrow["scrollWidth"], **lay_wide))
    assert not [e for e in errors if "favicon" not in e.get("message", "")], errors
