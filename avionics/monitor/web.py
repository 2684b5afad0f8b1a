"""The monitor's local web server (stdlib only): the page, and the picture pushed to it as server-sent events.

  GET /                                the traffic display (static/index.html)
  GET /events?vehicle=ID               text/event-stream: one `full` event, then `delta` events (<= 10 Hz;
                                       at once when an advisory or a vehicle's liveliness changes)
  GET /api/fleet                       vehicles: online, synced, track and alert counts
  GET /api/vehicle/ID                  the full picture of one vehicle (as the `full` event)
  GET /api/history?vehicle=ID&intruder=ID    [time_s, tau_s, pc, pc_ra, level] points of one intruder
  GET /api/log?vehicle=ID              the advisory log
  GET /api/stats                       feed counters
"""

from __future__ import annotations

import json
import math
import threading
import time
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from importlib import resources
from urllib.parse import parse_qs, unquote, urlparse

from avionics.monitor.state import Cursor, FleetState

MIN_PUSH_PERIOD_S = 0.1  # track updates are batched to at most 10 pushes per second
KEEPALIVE_S = 5.0


def _clean(value):
    if isinstance(value, float) and not math.isfinite(value):
        return None
    if isinstance(value, dict):
        return {k: _clean(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_clean(v) for v in value]
    return value


def dumps(obj) -> str:
    return json.dumps(_clean(obj), separators=(",", ":"), allow_nan=False)


def page_html() -> bytes:
    return resources.files("avionics.monitor").joinpath("static/index.html").read_bytes()


class MonitorServer:
    """ThreadingHTTPServer on (host, port); port 0 picks a free one. start() serves on a daemon thread."""

    def __init__(self, state: FleetState, host: str = "127.0.0.1", port: int = 8047, expire_period_s: float = 0.5):
        self.state = state
        self.stop_event = threading.Event()
        self.page = page_html()
        handler = type("Handler", (_Handler,), {"monitor": self})
        self.httpd = ThreadingHTTPServer((host, port), handler)
        self.httpd.daemon_threads = True
        self.host, self.port = self.httpd.server_address[:2]
        self.clients = 0
        self.events_sent = 0
        self._threads: list[threading.Thread] = []
        self._expire_period_s = expire_period_s

    @property
    def url(self) -> str:
        return f"http://{self.host}:{self.port}/"

    def start(self) -> "MonitorServer":
        for target, name in ((self.httpd.serve_forever, "monitor-http"), (self._expire_loop, "monitor-expire")):
            t = threading.Thread(target=target, name=name, daemon=True)
            t.start()
            self._threads.append(t)
        return self

    def _expire_loop(self) -> None:
        while not self.stop_event.wait(self._expire_period_s):
            self.state.expire()

    def close(self) -> None:
        self.stop_event.set()
        with self.state.cond:
            self.state.cond.notify_all()
        self.httpd.shutdown()
        self.httpd.server_close()


class _Handler(BaseHTTPRequestHandler):
    monitor: MonitorServer
    server_version = "avionics-monitor"

    def log_message(self, fmt, *args):  # quiet
        pass

    def _send(self, code: int, body: bytes, ctype: str) -> None:
        self.send_response(code)
        self.send_header("Content-Type", ctype)
        self.send_header("Content-Length", str(len(body)))
        self.send_header("Cache-Control", "no-store")
        self.end_headers()
        self.wfile.write(body)

    def _json(self, obj, code: int = 200) -> None:
        self._send(code, dumps(obj).encode(), "application/json")

    def do_GET(self):  # noqa: N802
        url = urlparse(self.path)
        q = {k: v[-1] for k, v in parse_qs(url.query).items()}
        state = self.monitor.state
        try:
            if url.path in ("/", "/index.html"):
                self._send(200, self.monitor.page, "text/html; charset=utf-8")
            elif url.path == "/events":
                self._events(q.get("vehicle") or None)
            elif url.path == "/api/fleet":
                self._json(state.fleet())
            elif url.path.startswith("/api/vehicle/"):
                self._json(state.view(unquote(url.path[len("/api/vehicle/"):]))[0])
            elif url.path == "/api/history":
                self._json(state.history(q.get("vehicle", ""), q.get("intruder", "")))
            elif url.path == "/api/log":
                self._json(state.advisory_log(q.get("vehicle", "")))
            elif url.path == "/api/stats":
                self._json({"feed": dict(state.stats), "version": state.version, "clients": self.monitor.clients,
                            "events_sent": self.monitor.events_sent})
            elif url.path == "/favicon.ico":
                self._send(204, b"", "image/x-icon")
            else:
                self._send(404, b"not found\n", "text/plain")
        except (BrokenPipeError, ConnectionResetError):
            pass

    def _events(self, vehicle: str | None) -> None:
        state = self.monitor.state
        self.send_response(200)
        self.send_header("Content-Type", "text/event-stream")
        self.send_header("Cache-Control", "no-store")
        self.send_header("X-Accel-Buffering", "no")
        self.end_headers()
        self.monitor.clients += 1
        cursor: Cursor | None = None
        urgent_seen = -1
        last_push = 0.0
        last_write = time.monotonic()
        try:
            self.wfile.write(b"retry: 1000\n\n")
            while not self.monitor.stop_event.is_set():
                if vehicle is None:
                    vehicle = state.default_vehicle()
                if cursor is not None:
                    state.wait(cursor, 1.0)
                    if self.monitor.stop_event.is_set():
                        break
                    urgent = state.urgent != urgent_seen
                    wait = MIN_PUSH_PERIOD_S - (time.monotonic() - last_push)
                    if not urgent and wait > 0:
                        time.sleep(wait)
                urgent_seen = state.urgent
                if cursor is not None and state.version == cursor.version \
                        and state.fleet_version == cursor.fleet_version:
                    if time.monotonic() - last_write > KEEPALIVE_S:
                        self.wfile.write(b": keepalive\n\n")
                        self.wfile.flush()
                        last_write = time.monotonic()
                    continue
                view, cursor = state.view(vehicle, cursor)
                view["server_wall_ms"] = time.time() * 1000.0
                self.wfile.write(f"event: {view['type']}\ndata: {dumps(view)}\n\n".encode())
                self.wfile.flush()
                self.monitor.events_sent += 1
                last_push = last_write = time.monotonic()
        except (BrokenPipeError, ConnectionResetError, ValueError, OSError):
            pass
        finally:
            self.monitor.clients -= 1
