"""`avionics router`: a zenoh router in Python, standing in for zenohd (not on PyPI) in tests and small
deployments. Routes between clients, and between peers and clients (monitors connect as clients: with gossip
scouting off, a router does not broker peer-to-peer traffic). Stores nothing."""

from __future__ import annotations

import signal
import sys
import threading

from avionics.io.params import ZenohConfig
from avionics.io.zenoh_bus import open_session


def router_config(listen: list[str], connect: list[str] = (), **security) -> ZenohConfig:
    """security: ZenohConfig's tls_*, auth_* and config_file keys."""
    return ZenohConfig(mode="router", listen=tuple(listen), connect=tuple(connect), scouting=False, **security)


def run_router(cfg: ZenohConfig, stop: threading.Event | None = None, ready=None) -> int:
    """Open a router session and hold it until stop is set (or SIGTERM/SIGINT on the main thread)."""
    stop = stop or threading.Event()
    session = open_session(cfg)
    if threading.current_thread() is threading.main_thread():
        signal.signal(signal.SIGTERM, lambda *_: stop.set())
        signal.signal(signal.SIGINT, lambda *_: stop.set())
    print(f"avionics router: zid {session.zid()}, listening on {list(cfg.listen)}"
          + (f", connected to {list(cfg.connect)}" if cfg.connect else ""), file=sys.stderr, flush=True)
    if ready is not None:
        ready()
    try:
        while not stop.wait(0.5):
            pass
    finally:
        session.close()
    return 0
