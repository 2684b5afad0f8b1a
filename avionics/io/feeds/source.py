"""Traffic feeds beside the MAVLink link: a reader thread per source, reconnection with backoff, a bounded queue,
and the loop's side (FeedSet, TrafficSource).

    --traffic sbs:HOST:PORT | readsb-json:PATH_OR_HTTP_URL | beast:HOST:PORT          (parse_spec, open_feeds)

Each `Feed` runs its scheme's session (sbs.py, readsb_json.py, beast.py: `make_session(path, target, config)`
returns `session(ctx)`, which connects, reads and parses until its source fails or ctx.stop is set) on its own
thread; when a session ends (refused, closed, timed out, a file that stopped changing) the thread waits
traffic.reconnect_initial_s, doubling up to traffic.reconnect_max_s, and runs it again; a session that connected
resets the wait. A session's exception never leaves its thread: it is counted (`traffic.<scheme>.errors`) and the
source is retried. The session emits validated IntruderReports (stamped on the loop's clock, `ctx.clock`) into a
bounded queue (traffic.queue_size, the oldest dropped when full: `traffic.<scheme>.dropped.queue_full`) and counts
into a private Counter (`ctx.counters`) that ctx.flush() hands to the loop.

The loop thread drains every feed at each batch (FeedSet.drain: the reports received up to the batch's time, in
arrival order, and the counters into the shared Counter) and reads their health (FeedHealth: a source not
connected is a status warning, never a failure: the loop goes on with MAVLink alone). TrafficSource wraps any
loop Source (avionics/loop.py) to add the feeds' reports to its batches; iterating it starts the threads, and its
end (or close()) stops and joins them.
"""

from __future__ import annotations

import logging
import re
import threading
from collections import Counter, deque
from dataclasses import dataclass, replace
from typing import Callable, Iterator

from avionics.base.params import ConfigError
from avionics.base.types import IntruderReport
from avionics.extras import import_extra
from avionics.io.diagnostics import feed_diagnostics

log = logging.getLogger("avionics.traffic")
JOIN_TIMEOUT_S = 5.0  # a session polls ctx.stop at least every 0.25 s (transport.py); this is a generous bound

# scheme -> module providing make_session(path, target, config) -> session(ctx)
SESSIONS = {"sbs": "avionics.io.feeds.sbs", "readsb-json": "avionics.io.feeds.readsb_json",
            "beast": "avionics.io.feeds.beast"}


def parse_spec(spec: str) -> tuple[str, str]:
    """"sbs:127.0.0.1:30003" -> ("sbs", "127.0.0.1:30003"); ConfigError naming what is wrong."""
    scheme, sep, target = spec.strip().partition(":")
    if not sep or scheme not in SESSIONS or not target:
        raise ConfigError(f"--traffic {spec!r}: expected sbs:HOST:PORT, readsb-json:PATH_OR_HTTP_URL or "
                          "beast:HOST:PORT")
    return scheme, target


def parse_host_port(spec: str, target: str) -> tuple[str, int]:
    host, sep, port = target.rpartition(":")
    try:
        number = int(port)
    except ValueError:
        number = 0
    if not sep or not host or not 1 <= number <= 65535:
        raise ConfigError(f"--traffic {spec!r}: expected HOST:PORT with a port in 1..65535 after the scheme")
    return host.strip("[]"), number


# The warning is one line of at most 256 characters without control or bidi-override characters: the monitor rejects a
# status sample with any other warning text whole (avionics/monitor/schema.py MAX_TEXT_LEN, _BAD_CHARS), and would
# lose every warning exactly while a feed is down. A long readsb-json URL or a multi-line exception text is shortened.
WARNING_PATH_CHARS, WARNING_ERROR_CHARS = 80, 100
_UNPRINTABLE = re.compile("[\x00-\x1f\x7f-\x9f\u061c\u200e\u200f\u202a-\u202e\u2066-\u2069]+")


def _one_line(text: str, limit: int) -> str:
    text = " ".join(_UNPRINTABLE.sub(" ", text).split())
    return text if len(text) <= limit else text[:limit - 1] + "…"


@dataclass(frozen=True, slots=True)
class FeedHealth:
    """One feed as the status shows it (daa.py status: `traffic_feeds`, and a warning while it is down)."""

    path: str
    connected: bool
    error: str | None  # why it is not connected (the last failure), None while connected
    reports: int  # reports delivered to the loop since start
    last_report_s: float | None  # loop time of its last report

    @property
    def warning(self) -> str | None:
        if self.connected:
            return None
        return (f"traffic source {_one_line(self.path, WARNING_PATH_CHARS)} down "
                f"({_one_line(self.error or 'connecting', WARNING_ERROR_CHARS)}): retrying; DAA goes on without it")

    def as_dict(self) -> dict:
        return {"path": self.path, "connected": self.connected, "error": self.error, "reports": self.reports,
                "last_report_s": self.last_report_s}


class FeedContext:
    """What a session (running on the feed's thread) gets: the loop clock, a stop event, its counters, emit."""

    def __init__(self, feed: "Feed"):
        self._feed = feed
        self.clock: Callable[[], float] = feed.clock
        self.stop: threading.Event = feed._stop
        self.counters: Counter = Counter()  # this thread's only: flush() hands them over
        self.prefix = f"traffic.{feed.scheme}."

    def connected(self) -> None:
        """The source is up (a TCP connection made, a document read): health says so, the backoff restarts."""
        feed = self._feed
        feed._connected, feed._error, feed._delay_s = True, None, feed._initial_s

    def emit(self, report: IntruderReport) -> None:
        self._feed._put(report)

    def flush(self) -> None:
        """Hand this thread's counts to the loop (call after each chunk of input)."""
        if self.counters:
            with self._feed._lock:
                self._feed._pending.update(self.counters)
            self.counters.clear()


class Feed:
    """One traffic source on its own thread (module docstring). clock: the loop's clock (seconds, same origin as
    the batches' now_s)."""

    def __init__(self, path: str, scheme: str, session, config, clock: Callable[[], float]):
        t = config.traffic
        self.path, self.scheme, self.session, self.clock = path, scheme, session, clock
        self._initial_s, self._max_s = t.reconnect_initial_s, t.reconnect_max_s
        self._delay_s = self._initial_s
        self._queue: deque[IntruderReport] = deque()
        self._capacity = t.queue_size
        self._lock = threading.Lock()
        self._pending: Counter = Counter()
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._connected = False
        self._error: str | None = None
        self.reports = 0
        self.last_report_s: float | None = None

    def _put(self, report: IntruderReport) -> None:
        with self._lock:
            if len(self._queue) >= self._capacity:
                self._queue.popleft()
                self._pending[f"traffic.{self.scheme}.dropped.queue_full"] += 1
            self._queue.append(report)

    def start(self) -> None:
        if self._thread is None:
            self._thread = threading.Thread(target=self._run, name=f"traffic {self.path}", daemon=True)
            self._thread.start()

    def _run(self) -> None:
        prefix = f"traffic.{self.scheme}."
        first = True
        while not self._stop.is_set():
            ctx = FeedContext(self)
            if not first:
                ctx.counters[prefix + "reconnects"] += 1
            first = False
            try:
                self.session(ctx)
                error = "closed" if not self._stop.is_set() else None
            except Exception as exc:  # noqa: BLE001  (a source's failure is retried, never propagated)
                error = f"{type(exc).__name__}: {exc}" if str(exc) else type(exc).__name__
                if not isinstance(exc, (OSError, ValueError)):
                    ctx.counters[prefix + "errors"] += 1  # not a network or format error: a bug, logged
                    log.exception("traffic source %s failed", self.path)
            was_connected = self._connected
            self._connected, self._error = False, error
            if error is not None:
                ctx.counters[prefix + "disconnects" if was_connected else prefix + "connect_failures"] += 1
                if was_connected:
                    log.warning("traffic source %s lost: %s; retrying", self.path, error)
            ctx.flush()
            self._stop.wait(self._delay_s)
            self._delay_s = min(self._delay_s * 2.0, self._max_s)

    def drain(self, now_s: float, counters: Counter) -> list[IntruderReport]:
        """The reports received up to now_s (later ones wait for the next batch); counters merged into counters."""
        out = []
        with self._lock:
            queue = self._queue
            while queue and queue[0].received_s <= now_s:
                out.append(queue.popleft())
            pending, self._pending = self._pending, Counter()
        counters.update(pending)
        if out:
            self.reports += len(out)
            self.last_report_s = out[-1].received_s
        return out

    def health(self) -> FeedHealth:
        return FeedHealth(self.path, self._connected, self._error, self.reports, self.last_report_s)

    def close(self) -> None:
        self._stop.set()
        if self._thread is not None:
            self._thread.join(JOIN_TIMEOUT_S)


def open_feed(spec: str, config, clock: Callable[[], float]) -> Feed:
    """A Feed for one --traffic SPEC (not started). ConfigError for a malformed spec or an unknown scheme."""
    scheme, target = parse_spec(spec)
    try:
        module = import_extra(SESSIONS[scheme], f"--traffic {spec!r}")
    except ImportError as exc:  # a scheme whose module is not installed in this build
        raise ConfigError(f"--traffic {spec!r}: the {scheme} source is not available ({exc})") from None
    path = f"{scheme}:{target}"
    return Feed(path, scheme, module.make_session(path, target, config), config, clock)


class FeedSet:
    """The feeds of one process: started together, drained into each batch, closed (threads joined) together."""

    def __init__(self, feeds: list[Feed], counters: Counter):
        self.feeds, self.counters = list(feeds), counters
        self.health: tuple[FeedHealth, ...] = tuple(f.health() for f in self.feeds)

    @classmethod
    def open(cls, specs, config, clock: Callable[[], float], counters: Counter) -> "FeedSet":
        return cls([open_feed(spec, config, clock) for spec in specs], counters)

    def start(self) -> None:
        for feed in self.feeds:
            feed.start()

    def drain(self, now_s: float) -> list[IntruderReport]:
        out: list[IntruderReport] = []
        for feed in self.feeds:
            out.extend(feed.drain(now_s, self.counters))
        self.health = tuple(f.health() for f in self.feeds)
        return out

    def close(self) -> None:
        for feed in self.feeds:
            feed._stop.set()  # all stop at once, then each is joined
        for feed in self.feeds:
            feed.close()
            feed.drain(float("inf"), self.counters)  # the last counts; undelivered reports are dropped


class TrafficSource:
    """A loop Source (avionics/loop.py) with the feeds' reports added to its batches, and their health to its
    status. Iterating it starts the feeds; the iteration's end stops and joins them."""

    def __init__(self, inner, feeds: FeedSet):
        self.inner, self.feeds = inner, feeds

    def __iter__(self) -> Iterator:
        self.feeds.start()
        try:
            for batch in self.inner:
                reports = self.feeds.drain(batch.now_s)
                yield replace(batch, inputs=batch.inputs + reports) if reports else batch  # a loop.Batch
        finally:
            self.feeds.close()

    def status(self):
        inner = self.inner.status()
        health = self.feeds.health
        return replace(inner, feeds=health, wiring=inner.wiring + feed_diagnostics(health))

    def close(self) -> None:
        self.feeds.close()
