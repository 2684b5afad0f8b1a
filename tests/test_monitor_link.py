"""The monitor's zenoh link light (issue 26 item 7): a real monitor session in peer mode on loopback (scouting off)
that nobody reached shows NO PEER, not green; an onboard bus connecting and publishing turns it OK (one peer);
silence with the peer connected turns it NO DATA; the peer gone, NO PEER again. The state is the page's `zenoh`
field (FleetState.view) and the terminal view's header. A client whose router is not there shows DOWN."""

import pytest

from avionics.io.params import ZenohConfig
from avionics.io.zenoh_bus import ZenohBus
from avionics.monitor.app import _open_feed
from avionics.monitor.feed import LINK_NO_DATA_S, ZenohFeed, wait_for
from avionics.monitor.state import FleetState
from avionics.monitor.tui import render_text
from tests.conftest import DEADLINE_S

pytestmark = pytest.mark.live


def link(state: FleetState) -> dict:
    return state.view(None)[0]["zenoh"]


def test_the_link_light_follows_the_session_reach_and_the_data(tcp_port):
    endpoint = f"tcp/127.0.0.1:{tcp_port}"
    state = FleetState()
    feed = ZenohFeed(state, ZenohConfig(mode="peer", listen=(endpoint,), connect=(), scouting=False))
    bus = None
    try:
        assert wait_for(lambda: link(state)["state"] == "no_peer", DEADLINE_S), link(state)
        assert "ZENOH NO PEER" in render_text(state, None, 160, 30)
        bus = ZenohBus(ZenohConfig(mode="peer", listen=(), connect=(endpoint,), scouting=False), "uav1")
        assert wait_for(lambda: (bus.publish("status", {"time_s": 1.0}), link(state)["state"] == "ok")[1],
                        DEADLINE_S), link(state)
        assert link(state)["peers"] + link(state)["routers"] == 1
        assert "ZENOH OK" in render_text(state, None, 160, 30)
        # connected but silent: no sample for LINK_NO_DATA_S
        assert wait_for(lambda: link(state)["state"] == "no_data", LINK_NO_DATA_S + DEADLINE_S), link(state)
        assert "ZENOH NO DATA" in render_text(state, None, 160, 30)
        bus.close()
        bus = None
        assert wait_for(lambda: link(state)["state"] == "no_peer", DEADLINE_S), link(state)
    finally:
        if bus is not None:
            bus.close()
        feed.close()


def test_a_client_without_its_router_is_down(tcp_port):
    import threading

    state = FleetState()
    stop = threading.Event()
    opener = threading.Thread(target=_open_feed, args=(state, ZenohConfig(
        mode="client", listen=(), connect=(f"tcp/127.0.0.1:{tcp_port}",), scouting=False), "daa", stop, True))
    opener.start()
    try:
        assert wait_for(lambda: "cannot open the zenoh session" in link(state).get("detail", ""), DEADLINE_S)
        assert link(state)["state"] == "down"
        assert "ZENOH DOWN" in render_text(state, None, 160, 30)
    finally:
        stop.set()
        opener.join(timeout=DEADLINE_S)
