"""A receiver feed that is down (avionics run --traffic) reaches the monitor: the onboard status (Daa.status with the
feeds' FeedHealth, status_payload, JSON) passes the monitor's schema with `traffic_feeds` in it, and the feed-down
warning shows in the page's status view and the terminal view, also for a long readsb-json URL or an exception text
of several lines (a warning the schema refused would cost the whole status sample, every warning with it)."""

import json
from collections import Counter

import pytest

from avionics.config import load_config
from avionics.daa import Daa, SourceStatus
from avionics.io.feeds.source import FeedHealth
from avionics.io.payloads import status_payload
from avionics.monitor.schema import MAX_TEXT_LEN, clean_sample, text_ok
from avionics.monitor.state import FleetState
from avionics.monitor.tui import render_text

CONFIG = load_config(None, ["zenoh.enabled=false"])
LONG_URL = "readsb-json:http://receiver.example.org:8080/skyaware/data/aircraft.json?token=" + "a1b2" * 40


def published_status(*feeds: FeedHealth) -> dict:
    """The status sample as the onboard process puts it on zenoh (its JSON)."""
    status = Daa(CONFIG, Counter()).status(12.0, SourceStatus(feeds=feeds))
    return json.loads(json.dumps(status_payload("uav1", 12.0, status, {"traffic.sbs.reports": 40})))


@pytest.mark.parametrize("path, error, shown", [
    ("sbs:127.0.0.1:30003", "ConnectionRefusedError: [Errno 111] Connection refused",
     "traffic source sbs:127.0.0.1:30003 down (ConnectionRefusedError: [Errno 111] Connection refused): retrying; "
     "DAA goes on without it"),
    ("beast:127.0.0.1:30005", None, "traffic source beast:127.0.0.1:30005 down (connecting): retrying; DAA goes on "
                                    "without it"),
    (LONG_URL, "HTTPError: HTTP Error 503: Service Unavailable", "traffic source readsb-json:http://receiver.example"),
    ("readsb-json:/run/readsb/aircraft.json", "ValueError: first line\nsecond line\x1b[2J\u202eevil",
     "traffic source readsb-json:/run/readsb/aircraft.json down (ValueError: first line second line [2J evil)"),
])
def test_a_feed_down_warning_passes_the_schema_and_shows_on_page_and_terminal(path, error, shown):
    up = FeedHealth("sbs:10.0.0.9:30003", True, None, 40, 11.5)
    down = FeedHealth(path, False, error, 0, None)
    payload = published_status(up, down)
    assert [f["connected"] for f in payload["traffic_feeds"]] == [True, False]  # the onboard side lists both
    assert payload["traffic_feeds"][1] == {"path": path, "connected": False, "error": error, "reports": 0,
                                           "last_report_s": None}
    clean = clean_sample("status", payload)  # raises Rejected if the monitor refused the sample
    feed_warnings = [w for w in clean["warnings"] if w.startswith("traffic source")]
    assert len(feed_warnings) == 1 and feed_warnings[0].startswith(shown), feed_warnings  # only the feed down
    assert len(feed_warnings[0]) <= MAX_TEXT_LEN and text_ok(feed_warnings[0], MAX_TEXT_LEN)
    assert feed_warnings[0].endswith("retrying; DAA goes on without it")

    state = FleetState()
    state.apply_snapshot("uav1", None)
    state.set_alive("uav1", True)
    state.apply("uav1", "status", "", clean)
    view, _ = state.view("uav1")
    assert feed_warnings[0] in view["status"]["warnings"]  # the page joins these into its amber line
    text = render_text(state, "uav1", 400, 30)
    assert "traffic source " + path[:20] in text and "DAA goes on without it" in text


def test_every_feed_connected_is_no_warning_and_traffic_feeds_is_accepted():
    payload = published_status(FeedHealth("sbs:127.0.0.1:30003", True, None, 40, 11.5))
    clean = clean_sample("status", payload)
    assert not any(w.startswith("traffic source") for w in clean["warnings"])
    assert payload["traffic_feeds"][0]["reports"] == 40
