"""The monitor's local web server (stdlib only): the page, and the picture pushed to it as server-sent events.

  GET /                                the traffic display (static/index.html)
  GET /events?vehicle=ID               text/event-stream: one `full` event, then `delta` events (<= 10 Hz;
                                       at once when an advisory or a vehicle's liveliness changes); both carry
                                       `bands` (DO-365 guidance, with `stale`) when they changed
  GET /api/fleet                       vehicles: online, synced, track and alert counts
  GET /api/vehicle/ID                  the full picture of one vehicle (as the `full` event)
  GET /api/history?vehicle=ID&intruder=ID    [time_s, tau_s, pc, pc_ra, level] points of one intruder
  GET /api/log?vehicle=ID              the advisory log
  GET /api/stats                       feed counters (samples, rejected by the schema check, expired), HTTP counters

Hardening (the page has no authentication; keep it on loopback):
  - every request must name this server in its Host header (the bound host, localhost, 127.0.0.1 or [::1], with
    the port): anything else gets 421, so a DNS-rebinding page cannot read the picture; a request that carries an
    Origin header must come from one of those origins (403 otherwise), which covers the event stream;
  - a request has `request_timeout_s` to arrive in full, and each socket operation after that `io_timeout_s`
    (an event stream whose reader stops reading is closed); at most `max_connections` connections are served at
    once. When they are all taken, a new connection takes the slot of the oldest one whose request has not
    arrived in full yet (a browser sends its request at once; a held slow one is what slowloris is), so 64 slow
    connections cannot keep the page from its own user; only when every slot serves a request is the new one
    answered 503 and closed at once, without a thread;
  - the page is sent with a Content-Security-Policy that allows only its own inline script and style (by hash):
    even markup that got into the page could not run script. The page itself renders payload data as text.
"""

from __future__ import annotations

import base64
import hashlib
import io
import re
import socket
import sys
import threading
import time
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from importlib import resources
from urllib.parse import parse_qs, unquote, urlparse

from avionics.contract.bands import BAND_KINDS
from avionics.base.jsonsafe import dumps  # inf/NaN as null
from avionics.base.units import FPM, FT, KT, NM
from avionics.monitor.state import Cursor, FleetState

MIN_PUSH_PERIOD_S = 0.1  # track updates are batched to at most 10 pushes per second
KEEPALIVE_S = 5.0
MAX_CONNECTIONS = 64
REQUEST_TIMEOUT_S = 10.0  # the request line and headers must arrive within this
IO_TIMEOUT_S = 15.0  # every later send (the event stream) must progress within this
LOOPBACK_NAMES = ("localhost", "127.0.0.1", "[::1]")
_BUSY_BODY = b"too many connections\n"
_BUSY = (b"HTTP/1.0 503 Service Unavailable\r\nContent-Type: text/plain\r\nContent-Length: %d\r\n"
         b"Retry-After: 1\r\nConnection: close\r\n\r\n%s") % (len(_BUSY_BODY), _BUSY_BODY)


CONTRACT_MARK = b"/*contract*/null"  # where the page gets what it shares with the outputs


def page_contract() -> dict:
    """What the page takes from the output contract: the band kinds and the display units (base/units.py)."""
    return {"units": {"FT": FT, "NM": NM, "KT": KT, "FPM": FPM},
            "band_kinds": [{"name": k.name, "label": k.label, "display_unit": k.display_unit,
                            "per_display_unit": k.per_display_unit} for k in BAND_KINDS]}


def page_html() -> bytes:
    page = resources.files("avionics.monitor").joinpath("static/index.html").read_bytes()
    return page.replace(CONTRACT_MARK, dumps(page_contract()).encode(), 1)


def content_security_policy(page: bytes) -> str:
    """Only the page's own inline <script> and <style> (by SHA-256), fetches and the event stream to this origin."""

    def hashes(tag: str) -> str:
        bodies = re.findall(rb"<%s>(.*?)</%s>" % (tag.encode(), tag.encode()), page, re.S)
        return " ".join(f"'sha256-{base64.b64encode(hashlib.sha256(b).digest()).decode()}'" for b in bodies)

    return (f"default-src 'none'; script-src {hashes('script')}; style-src {hashes('style')}; connect-src 'self'; "
            "img-src 'self'; base-uri 'none'; form-action 'none'; frame-ancestors 'none'")


def _host_name(host: str) -> str:
    return f"[{host}]" if ":" in host and not host.startswith("[") else host


class _HttpServer(ThreadingHTTPServer):
    """ThreadingHTTPServer with a cap on concurrent connections. One more takes the slot of the oldest connection
    still sending its request (closed, counted `evicted_slow`); when every connection is serving a request, it is
    answered 503 and closed by the accepting thread itself (no handler thread)."""

    daemon_threads = True
    block_on_close = False  # close() does not wait for a connection's timeout
    request_queue_size = 128  # listen backlog (socketserver's 5 makes a burst of connections retry SYNs for seconds)

    def __init__(self, address, handler, max_connections: int):
        self.max_connections = max_connections
        self._slots: dict[socket.socket, bool] = {}  # connection -> its request has arrived; oldest first
        self.refused = 0
        self.evicted_slow = 0
        self.served = 0
        self._count_lock = threading.Lock()
        super().__init__(address, handler)

    @property
    def active(self) -> int:
        return len(self._slots)

    def request_arrived(self, request) -> None:
        with self._count_lock:
            if request in self._slots:
                self._slots[request] = True

    def process_request(self, request, client_address):
        slow = None
        with self._count_lock:
            if len(self._slots) >= self.max_connections:
                slow = next((sock for sock, arrived in self._slots.items() if not arrived), None)
                if slow is not None:
                    del self._slots[slow]  # its thread ends on the shutdown below; the slot is the new one's
                    self.evicted_slow += 1
            full = len(self._slots) >= self.max_connections
            if full:
                self.refused += 1
            else:
                self._slots[request] = False
                self.served += 1
        if slow is not None:
            try:
                slow.shutdown(socket.SHUT_RDWR)  # its handler's read ends at once
            except OSError:
                pass
        if full:
            try:
                request.setblocking(False)
                request.send(_BUSY)  # a few bytes into an empty send buffer: never blocks
                try:
                    request.recv(65536)  # what the client already sent, so that close does not reset
                except OSError:
                    pass
            except OSError:
                pass
            self.shutdown_request(request)
            return
        try:
            super().process_request(request, client_address)  # starts the handler thread
        except BaseException:
            self._release(request)
            raise

    def process_request_thread(self, request, client_address):
        try:
            super().process_request_thread(request, client_address)
        finally:
            self._release(request)

    def _release(self, request) -> None:
        with self._count_lock:
            self._slots.pop(request, None)

    def handle_error(self, request, client_address) -> None:
        if not isinstance(sys.exc_info()[1], OSError):  # a client that went away is not worth a traceback
            super().handle_error(request, client_address)


class _DeadlineRaw(io.RawIOBase):
    """The request's input stream with a deadline for the whole request: before every recv the socket timeout is
    set to what is left, so a client that sends its request a byte at a time (slowloris), even within one header
    line, cannot hold a thread longer than request_timeout_s."""

    def __init__(self, sock: socket.socket, timeout_s: float):
        super().__init__()
        self.sock = sock
        self.deadline = time.monotonic() + timeout_s

    def readable(self) -> bool:
        return True

    def readinto(self, buffer) -> int:
        left = self.deadline - time.monotonic()
        if left <= 0:
            raise TimeoutError("request not received in time")
        self.sock.settimeout(left)
        return self.sock.recv_into(buffer)


class MonitorServer:
    """ThreadingHTTPServer on (host, port); port 0 picks a free one. start() serves on a daemon thread.

    allowed_hosts: more names (without port) the page may be reached by, e.g. a hostname used through a tunnel;
    the bound host, localhost, 127.0.0.1 and [::1] are always allowed."""

    def __init__(self, state: FleetState, host: str = "127.0.0.1", port: int = 8047, expire_period_s: float = 0.5,
                 max_connections: int = MAX_CONNECTIONS, request_timeout_s: float = REQUEST_TIMEOUT_S,
                 io_timeout_s: float = IO_TIMEOUT_S, allowed_hosts: tuple[str, ...] = ()):
        self.state = state
        self.stop_event = threading.Event()
        self.page = page_html()
        self.csp = content_security_policy(self.page)
        self.request_timeout_s = request_timeout_s
        self.io_timeout_s = io_timeout_s
        handler = type("Handler", (_Handler,), {"monitor": self, "timeout": io_timeout_s})
        self.httpd = _HttpServer((host, port), handler, max_connections)
        self.host, self.port = self.httpd.server_address[:2]
        names = {_host_name(n).lower() for n in (host, self.host, *LOOPBACK_NAMES, *allowed_hosts) if n}
        self.allowed_hosts = frozenset({f"{n}:{self.port}" for n in names} | (names if self.port == 80 else set()))
        self.allowed_origins = frozenset(f"http://{h}" for h in self.allowed_hosts)
        self.rejected_host = 0
        self.rejected_origin = 0
        self._lock = threading.Lock()
        self.clients = 0
        self.events_sent = 0
        self._threads: list[threading.Thread] = []
        self._expire_period_s = expire_period_s

    @property
    def url(self) -> str:
        return f"http://{_host_name(self.host)}:{self.port}/"

    @property
    def connections(self) -> int:
        """Connections being served now (each has a thread)."""
        return self.httpd.active

    def http_stats(self) -> dict:
        return {"connections": self.httpd.active, "max_connections": self.httpd.max_connections,
                "served": self.httpd.served, "refused_busy": self.httpd.refused,
                "evicted_slow": self.httpd.evicted_slow,
                "rejected_host": self.rejected_host, "rejected_origin": self.rejected_origin,
                "event_streams": self.clients}

    def _count(self, name: str, delta: int = 1) -> None:
        with self._lock:
            setattr(self, name, getattr(self, name) + delta)

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

    def setup(self) -> None:
        super().setup()  # socket timeout io_timeout_s (the class's `timeout`), wfile
        self.rfile.close()
        self.rfile = io.BufferedReader(_DeadlineRaw(self.connection, self.monitor.request_timeout_s))

    def _security_headers(self) -> None:
        self.send_header("X-Content-Type-Options", "nosniff")
        self.send_header("Referrer-Policy", "no-referrer")
        self.send_header("X-Frame-Options", "DENY")

    def _send(self, code: int, body: bytes, ctype: str, headers: dict | None = None) -> None:
        self.send_response(code)
        self.send_header("Content-Type", ctype)
        self.send_header("Content-Length", str(len(body)))
        self.send_header("Cache-Control", "no-store")
        self._security_headers()
        for k, v in (headers or {}).items():
            self.send_header(k, v)
        self.end_headers()
        self.wfile.write(body)

    def _allowed(self) -> bool:
        """Host names this server (DNS rebinding: 421); an Origin, when sent, is this server's (403)."""
        monitor = self.monitor
        host = (self.headers.get("Host") or "").strip().lower()
        if host not in monitor.allowed_hosts:
            monitor._count("rejected_host")
            self._send(421, b"misdirected request: this server is not reachable by that name\n", "text/plain")
            return False
        origin = self.headers.get("Origin")
        if origin is not None and origin.strip().lower() not in monitor.allowed_origins:
            monitor._count("rejected_origin")
            self._send(403, b"forbidden: cross-origin request\n", "text/plain")
            return False
        return True

    def _json(self, obj, code: int = 200) -> None:
        self._send(code, dumps(obj).encode(), "application/json")

    def do_GET(self):  # noqa: N802
        self.server.request_arrived(self.connection)  # from now on this slot is not a slow one's
        self.connection.settimeout(self.monitor.io_timeout_s)  # the request is in: now the send timeout
        try:
            if not self._allowed():
                return
            self._route()
        except (BrokenPipeError, ConnectionResetError, TimeoutError):
            self.close_connection = True

    def _route(self) -> None:
        url = urlparse(self.path)
        q = {k: v[-1] for k, v in parse_qs(url.query).items()}
        state = self.monitor.state
        try:
            if url.path in ("/", "/index.html"):
                self._send(200, self.monitor.page, "text/html; charset=utf-8",
                           {"Content-Security-Policy": self.monitor.csp})
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
                self._json({"feed": state.stats_copy(), "version": state.version, "clients": self.monitor.clients,
                            "events_sent": self.monitor.events_sent, "http": self.monitor.http_stats()})
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
        self._security_headers()
        self.end_headers()
        self.monitor._count("clients")
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
            self.monitor._count("clients", -1)
