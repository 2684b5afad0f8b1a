"""`avionics monitor`: the zenoh feed plus the web page (default) or the terminal view (--tui)."""

from __future__ import annotations

import signal
import sys
import threading

from avionics.config import ZenohConfig
from avionics.io.zenoh_bus import ZenohBusError
from avionics.monitor.feed import ZenohFeed
from avionics.monitor.state import FleetState


def _open_feed(state: FleetState, cfg: ZenohConfig, prefix: str, stop: threading.Event, quiet: bool):
    """A client session needs its router at start-up: keep trying (once a second) until it is there."""
    told = False
    while not stop.is_set():
        try:
            return ZenohFeed(state, cfg, prefix=prefix)
        except ZenohBusError as exc:
            if not told and not quiet:
                print(f"avionics monitor: {exc}; retrying every second", file=sys.stderr, flush=True)
                told = True
            stop.wait(1.0)
    return None


def run_monitor(cfg: ZenohConfig, prefix: str = "daa", http: str = "127.0.0.1:8047", tui: bool = False,
                vehicle: str | None = None, duration_s: float | None = None) -> int:
    stop = threading.Event()
    if threading.current_thread() is threading.main_thread():
        signal.signal(signal.SIGTERM, lambda *_: stop.set())
    if duration_s:
        timer = threading.Timer(duration_s, stop.set)
        timer.daemon = True
        timer.start()
    state = FleetState()
    feed = None
    try:
        if tui:
            from avionics.monitor.tui import run_tui

            holder: list = []  # the feed, once its session is open (the TUI shows "waiting" until then)
            opener = threading.Thread(target=lambda: holder.append(_open_feed(state, cfg, prefix, stop, quiet=True)),
                                      daemon=True)
            opener.start()
            try:
                return run_tui(state, vehicle, stop=stop)
            finally:
                stop.set()
                opener.join(timeout=3.0)
                feed = holder[0] if holder else None
        from avionics.monitor.web import MonitorServer

        host, _, port = http.rpartition(":")
        server = MonitorServer(state, host or "127.0.0.1", int(port)).start()
        query = f"?vehicle={vehicle}" if vehicle else ""
        print(f"avionics monitor: {server.url}{query}  (zenoh {cfg.mode} -> {list(cfg.connect)}; Ctrl-C to stop)",
              file=sys.stderr, flush=True)
        try:
            feed = _open_feed(state, cfg, prefix, stop, quiet=False)
            while not stop.wait(0.5):
                pass
        except KeyboardInterrupt:
            pass
        finally:
            server.close()
        return 0
    finally:
        if feed is not None:
            feed.close()
