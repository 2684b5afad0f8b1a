"""A simulated ADS-B receiver's TCP output: the server both receiver formats share (sbs.py: SBS-1 BaseStation lines,
beast.py: Beast binary frames).

Scenario time is `start_s` + `speed` x wall time since start() (speed 1: live), or since the first client connected
(start_on_connect: a receiver switched on before the process that reads it), or `clock()` when given (scenario
seconds: one clock shared with another schedule, sitl live's MAVLink). Every client receives what is due from its
connection on (a receiver does not replay the past); nothing due before start_s is sent. Fast time is the caller's
(real_time=False): `send_until(t)` sends everything due by scenario time t, and nothing else moves time. `stop()`
closes the listener and every client (a receiver that goes away); a new server on the same port is a receiver that
came back. Loopback by default.
"""

from __future__ import annotations

import socket
import threading
import time

PACE_S = 0.02  # how often the real-time server looks for what is due


class FeedServer:
    """events: objects with `deliver_s` (scenario seconds), sorted here; `payload(event)` gives their bytes."""

    name = "feed"
    sent_key = "sent"  # what `sent` counts, as sitl live's summary names it

    def __init__(self, events, host: str = "127.0.0.1", port: int = 0, real_time: bool = True, speed: float = 1.0,
                 start_s: float = 0.0, start_on_connect: bool = False, clock=None):
        self.events = sorted(events, key=lambda e: e.deliver_s)
        self.real_time, self.speed, self.start_s, self.start_on_connect = real_time, speed, start_s, start_on_connect
        self._clock = clock
        self._listener = socket.create_server((host, port))  # OSError (in use, not an address here) to the caller
        self._listener.settimeout(0.05)
        self.port = self._listener.getsockname()[1]
        self._clients: list[socket.socket] = []
        self._lock = threading.Lock()
        self._stop = threading.Event()
        self._threads: list[threading.Thread] = []
        self._next = 0
        self._t0: float | None = None
        self.sent = 0  # units sent (units(event) each)

    @staticmethod
    def payload(event) -> bytes:
        raise NotImplementedError

    @staticmethod
    def units(event) -> int:
        """How many of what `sent` counts one event carries."""
        return 1

    def start(self):
        if not self.start_on_connect:
            self._t0 = time.monotonic()
        while self._next < len(self.events) and self.events[self._next].deliver_s < self.start_s:
            self._next += 1  # a late start: what was due before it is not sent
        self._threads.append(threading.Thread(target=self._accept, name=f"{self.name} accept", daemon=True))
        if self.real_time:
            self._threads.append(threading.Thread(target=self._pace, name=f"{self.name} pace", daemon=True))
        for thread in self._threads:
            thread.start()
        return self

    def scenario_time(self) -> float:
        """Scenario time now (start_s until the clock starts)."""
        if self._clock is not None:
            return self._clock()
        t0 = self._t0
        return self.start_s if t0 is None else self.start_s + (time.monotonic() - t0) * self.speed

    def started(self) -> bool:
        return self._t0 is not None

    def clients(self) -> int:
        with self._lock:
            return len(self._clients)

    def done(self) -> bool:
        return self._next >= len(self.events)

    def _accept(self) -> None:
        while not self._stop.is_set():
            try:
                client, _ = self._listener.accept()
            except (TimeoutError, socket.timeout):
                continue
            except OSError:
                return
            client.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
            with self._lock:
                self._clients.append(client)
                if self._t0 is None:
                    self._t0 = time.monotonic()

    def _pace(self) -> None:
        while not self._stop.is_set():
            if self._t0 is not None:
                self.send_until(self.scenario_time())
            self._stop.wait(PACE_S)

    def send_until(self, t: float) -> int:
        """Send every event due by scenario time t to every client; the number of events."""
        with self._lock:
            start = self._next
            while self._next < len(self.events) and self.events[self._next].deliver_s <= t:
                self._next += 1
            data = b"".join(self.payload(e) for e in self.events[start:self._next])
            if data:
                self._send(data)
            self.sent += sum(self.units(e) for e in self.events[start:self._next])
            return self._next - start

    def send_raw(self, data: bytes) -> None:
        """Bytes to every client as they are (garbage, a line or frame split in two, ...)."""
        with self._lock:
            self._send(data)

    def _send(self, data: bytes) -> None:
        for client in list(self._clients):
            try:
                client.sendall(data)
            except OSError:
                self._clients.remove(client)
                client.close()

    def stop(self) -> None:
        """Close the listener and every connection (the clients see the connection end), join the threads."""
        self._stop.set()
        self._listener.close()
        for thread in self._threads:
            thread.join(timeout=5.0)
        with self._lock:
            for client in self._clients:
                try:
                    client.shutdown(socket.SHUT_RDWR)
                except OSError:
                    pass
                client.close()
            self._clients.clear()

    def __enter__(self):
        return self.start()

    def __exit__(self, *exc) -> None:
        self.stop()
