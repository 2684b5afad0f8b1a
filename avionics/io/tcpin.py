"""The `tcpin` transport: a TCP listener whose link belongs to the connection the autopilot speaks on.

pymavlink's mavtcpin accepts one connection and stops listening: an idle client that connected first, or one
queued while the autopilot reconnected, held the only slot and the DAA ran without ownship. Here the listener is
watched all the time and every connection is framed on its own (avionics/io/framing.py):
- the link's **owner** is the first connection that delivers a valid frame (CRC-checked, authentic when signing
  is on) from the vehicle's system (mavlink.source_system); only the owner's frames are used and only it is
  written to;
- a connection that delivers no such frame for `idle_timeout_s` (idle, garbage only, another system, or an owner
  that went silent) is closed and counted `link.tcpin_idle_closed`; once the owner is gone the next connection
  that delivers the vehicle's frames owns the link. A second valid connection while the owner is live waits
  (its frames are counted `link.tcpin_standby_frames`, not used): a reconnecting autopilot takes over at most
  `idle_timeout_s` after its old, silent connection's last frame, and a forger cannot take a live link;
- at most MAX_CONNECTIONS are open; a new one beyond that closes the longest-waiting connection that has not
  sent the vehicle's frames (else the oldest waiting one), counted `link.tcpin_evicted`.
"""

from __future__ import annotations

import select
import socket
import time
from collections import Counter
from typing import Callable

from avionics.io.framing import FrameScanner

READ_CHUNK = 65536
LISTEN_BACKLOG = 8
MAX_CONNECTIONS = 8  # the owner and the connections waiting for it
# mavlink.tcpin_idle_timeout_s's default. mavlink.io/en/services/heartbeat.html: "components typically publish their
# heartbeat at 1 Hz and consider another system to have disconnected if four or five messages are not received".
IDLE_TIMEOUT_S = 5.0


class _Connection:
    def __init__(self, sock: socket.socket, scanner: FrameScanner, now: float):
        self.sock = sock
        self.scanner = scanner
        self.last_valid = now  # accepted, or the vehicle's last valid frame: the idle clock starts here
        self.spoke = False  # has delivered a valid frame from the vehicle


class TcpInServer:
    """Listens on (host, port); receive() returns the owner's frames. `accept(msgs)` is the link's authenticity
    check (signing), called once per frame; `new_scanner()` makes a connection's framer."""

    def __init__(self, host: str, port: int, counters: Counter, vehicle_system: int,
                 new_scanner: Callable[[], FrameScanner], idle_timeout_s: float):
        self.counters = counters
        self.vehicle_system = vehicle_system
        self.new_scanner = new_scanner
        self.idle_timeout_s = idle_timeout_s
        self.listen = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
        try:
            self.listen.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
            self.listen.bind((host, port))
            self.listen.listen(LISTEN_BACKLOG)
        except OSError:
            self.listen.close()
            raise
        self.listen.setblocking(False)
        self.connections: list[_Connection] = []
        self.owner: _Connection | None = None

    def receive(self, timeout_s: float, accept: Callable[[list], list]) -> tuple[list, list]:
        """(every frame the owner sent, those of them accepted) within timeout_s; other connections are read
        (so that they can take over and their EOF is seen), not used."""
        self._close_idle(time.monotonic())
        fds = [self.listen] + [c.sock for c in self.connections]
        readable, _, _ = select.select(fds, [], [], max(timeout_s, 0.0))
        raw, used = [], []
        for sock in readable:
            if sock is self.listen:
                self._accept()
                continue
            conn = next((c for c in self.connections if c.sock is sock), None)
            if conn is None:
                continue
            try:
                data = sock.recv(READ_CHUNK)
            except (BlockingIOError, InterruptedError):
                continue
            except OSError:
                self.counters["link.receive_error"] += 1
                data = b""
            if not data:
                self._close(conn, "link.disconnected")
                continue
            msgs = conn.scanner.feed(data)
            accepted = accept(msgs)
            if any(m.get_srcSystem() == self.vehicle_system for m in accepted):
                conn.last_valid, conn.spoke = time.monotonic(), True
                if self.owner is None:
                    self.owner = conn
                    self.counters["link.tcpin_owner"] += 1
            if conn is self.owner:
                raw.extend(msgs)
                used.extend(accepted)
            else:
                self.counters["link.tcpin_standby_frames"] += len(accepted)
        return raw, used

    def _accept(self) -> None:
        try:
            sock, _ = self.listen.accept()
        except OSError:
            return
        sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        sock.setblocking(False)
        waiting = [c for c in self.connections if c is not self.owner]
        if len(self.connections) >= MAX_CONNECTIONS and waiting:
            victim = next((c for c in waiting if not c.spoke), waiting[0])  # oldest first
            self._close(victim, "link.tcpin_evicted")
        self.connections.append(_Connection(sock, self.new_scanner(), time.monotonic()))
        self.counters["link.tcpin_accepted"] += 1

    def _close_idle(self, now: float) -> None:
        for conn in [c for c in self.connections if now - c.last_valid > self.idle_timeout_s]:
            self._close(conn, "link.tcpin_idle_closed")

    def _close(self, conn: _Connection, counter: str) -> None:
        self.connections.remove(conn)
        try:
            conn.sock.close()
        except OSError:
            pass
        if conn is self.owner:
            self.owner = None
        self.counters[counter] += 1

    def write(self, buf: bytes) -> None:
        """To the owner only (nobody owns the link yet: nothing is sent, as pymavlink's tcpin without a peer)."""
        if self.owner is None:
            return
        try:
            sent = self.owner.sock.send(buf)
        except (BlockingIOError, InterruptedError):
            sent = 0
        except OSError:
            self._close(self.owner, "link.disconnected")
            return
        if sent < len(buf):  # its send buffer is full: the frame is lost (the reader resynchronises), not the loop
            self.counters["link.send_dropped"] += 1

    def close(self) -> None:
        for conn in list(self.connections):
            conn.sock.close()
        self.connections.clear()
        self.owner = None
        self.listen.close()
