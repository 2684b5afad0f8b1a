"""`avionics monitor`: the zenoh feed plus the web page (default) or the terminal view (--tui)."""

from __future__ import annotations

import re
import signal
import sys
import threading

from avionics.base.params import ConfigError
from avionics.extras import import_extra
from avionics.io.params import ZenohConfig
from avionics.io.zenoh_bus import ZenohBusError
from avionics.monitor.feed import ZenohFeed
from avionics.monitor.state import FleetState


IP_PROTOCOLS = ("tcp", "udp", "tls", "quic", "ws")  # ADDRESS is HOST:PORT
OTHER_PROTOCOLS = ("unixsock-stream", "unixpipe", "serial", "vsock")


class HttpServerError(RuntimeError):
    """The page cannot be served on --http (port in use, address not on this machine): exit 1."""


def check_endpoint(endpoint: str, listen: bool = False) -> None:
    """ConfigError (exit 2) unless endpoint reads PROTOCOL/ADDRESS[?metadata][#config], with HOST:PORT for the IP
    protocols. zenoh takes `foo` or `tcp/host` as it comes and fails only when it connects, where a client
    monitor would retry forever. Port 0 (any free port) is allowed only for listening."""
    what = f"zenoh {'listen' if listen else 'connect'} endpoint {endpoint!r}"
    protocol, slash, rest = endpoint.partition("/")
    address = re.split(r"[?#]", rest, maxsplit=1)[0]
    if not slash or not protocol or not address:
        raise ConfigError(f"{what}: expected PROTOCOL/ADDRESS, e.g. tcp/127.0.0.1:7447")
    if protocol in IP_PROTOCOLS:
        host, colon, port = address.rpartition(":")
        low = 0 if listen else 1
        if not colon or not host or not port.isdigit() or not low <= int(port) <= 65535:
            raise ConfigError(f"{what}: expected {protocol}/HOST:PORT with PORT in {low}..65535")
        if host.startswith("[") != host.endswith("]"):
            raise ConfigError(f"{what}: unbalanced brackets around the IPv6 address {host!r}")
    elif protocol not in OTHER_PROTOCOLS:
        raise ConfigError(f"{what}: unknown protocol {protocol!r}; expected one of "
                          f"{', '.join(IP_PROTOCOLS + OTHER_PROTOCOLS)}")


def check_endpoints(cfg: ZenohConfig) -> None:
    for endpoint in cfg.connect:
        check_endpoint(endpoint)
    for endpoint in cfg.listen:
        check_endpoint(endpoint, listen=True)


def parse_http(address: str) -> tuple[str, int]:
    """--http HOST:PORT (HOST defaults to 127.0.0.1, [::1] style brackets are removed; port 0 picks a free one)."""
    host, colon, port = address.rpartition(":")
    if not colon or not port.isdigit() or not 0 <= int(port) <= 65535:
        raise ConfigError(f"--http {address!r}: expected HOST:PORT with PORT in 0..65535, e.g. 127.0.0.1:8047")
    return host.removeprefix("[").removesuffix("]") or "127.0.0.1", int(port)


def _serve(state: FleetState, host: str, port: int):
    from avionics.monitor.web import MonitorServer

    try:
        return MonitorServer(state, host, port).start()
    except OSError as exc:  # bind: in use, not an address of this machine, unknown host name
        raise HttpServerError(f"cannot serve the monitor page on {host}:{port}: {exc.strerror or exc}") from exc


def _open_feed(state: FleetState, cfg: ZenohConfig, prefix: str, stop: threading.Event, quiet: bool):
    """A client session needs its router at start-up: keep trying (once a second) until it is there."""
    told = False
    while not stop.is_set():
        try:
            return ZenohFeed(state, cfg, prefix=prefix)
        except ZenohBusError as exc:
            state.set_zenoh_link({"state": "down", "detail": f"cannot open the zenoh session: {exc}"})
            if not told and not quiet:
                print(f"avionics monitor: {exc}; retrying every second", file=sys.stderr, flush=True)
                told = True
            stop.wait(1.0)
    return None


def run_monitor(cfg: ZenohConfig, prefix: str = "daa", http: str = "127.0.0.1:8047", tui: bool = False,
                vehicle: str | None = None, duration_s: float | None = None) -> int:
    check_endpoints(cfg)
    if not tui:
        host, port = parse_http(http)
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
            run_tui = import_extra("avionics.monitor.tui", "avionics monitor --tui").run_tui

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
        server = _serve(state, host, port)
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
