"""zenoh publishing of the onboard picture as JSON (encoding application/json), off the onboard loop.

Key expressions <prefix>/<vehicle>/<key>: the contract's KEYS (avionics/contract/zenoh.py, docs/zenoh.md); this module
puts the samples, serves the `snapshot` queryable and holds the `alive` liveliness token.

`ZenohBus.publish()` never blocks and never talks to zenoh: it files the sample (a few microseconds) and a
publisher thread puts it. Advisories wait in an unbounded FIFO that is always drained first (an advisory
change is never dropped); status and ownship samples wait in their own small FIFO, drained right after the
advisories and before any track, so no number of tracks can starve them (dropped oldest-first only if the
publisher cannot put even those, counted `zenoh.dropped_status`); track samples wait in one bounded FIFO that
drops its oldest entry when full (`zenoh.dropped_updates`).
A router or peer that goes away costs nothing on the loop: zenoh keeps retrying the connect endpoints, the
token and the queryable come back with the link, and a monitor that lost samples meanwhile asks the snapshot.
Peer mode on loopback with multicast and gossip scouting off unless configured otherwise; TLS from config.
"""

from __future__ import annotations

import json
import threading
import time
from collections import Counter, deque

import zenoh

from avionics.contract.zenoh import ADVISORY_STATE_FIELDS, ARROW_STREAM, SNAPSHOT_SCHEMA
from avionics.base.jsonsafe import dumps
from avionics.io.params import ZenohConfig, read_password, zenoh_error_text
from avionics.io.ros2 import Ros2Publisher
from avionics.io.sinks import SinkHealth
from avionics.io.traffic import TrafficBatch

# The publisher thread is Python too, so it must not take the interpreter lock or a CPU from the onboard
# loop in the middle of a tick (on a loaded machine a thread hand-off costs the loop milliseconds):
# - publish() never wakes it: it polls the queues every POLL_S;
# - it starts once publish() calls have paused for SETTLE_S and a short sleep shows the interpreter free (the
#   loop is blocked on its link), works for at most SLICE_S, and looks again;
# - after SETTLE_MAX_S of a loop that is never idle it works anyway (bounded latency for advisories).
POLL_S = 0.002
SETTLE_S = 0.002
SETTLE_MAX_S = 0.020
SLICE_S = 0.0005
PROBE_S = 0.0002
# advisories and the guidance's decisions (what the aircraft was told to do): reliable, never dropped, ahead of data
RELIABLE_KINDS = ("advisories", "guidance")
VITAL_KINDS = ("status", "ownship", "bands")  # their own queue, ahead of the tracks
VITAL_QUEUE = 32  # samples (16 status periods of status + ownship)
UPDATES_PER_BATCH = 64  # the publisher thread comes back for advisories after this many track updates


class ZenohBusError(RuntimeError):
    """The zenoh session cannot be opened (bad endpoint, port in use), with zenoh's reason."""


def session_config(cfg: ZenohConfig) -> zenoh.Config:
    """zenoh's configuration: zenoh.config_file (if any), then every [zenoh] key on top of it."""
    config = zenoh.Config.from_file(cfg.config_file) if cfg.config_file else zenoh.Config()  # checked by validate()
    config.insert_json5("mode", json.dumps(cfg.mode))
    config.insert_json5("scouting/multicast/enabled", json.dumps(cfg.scouting))
    config.insert_json5("scouting/gossip/enabled", json.dumps(cfg.scouting))
    config.insert_json5("listen/endpoints", json.dumps(list(cfg.listen)))
    config.insert_json5("connect/endpoints", json.dumps(list(cfg.connect)))
    # Re-dial a lost router or peer quickly (zenoh's default backs off to 4 s).
    max_ms = max(1, int(round(cfg.reconnect_max_s * 1000)))
    config.insert_json5("connect/retry", json.dumps({"period_init_ms": min(250, max_ms), "period_max_ms": max_ms,
                                                     "period_increase_factor": 2}))
    tls = {
        "root_ca_certificate": cfg.tls_root_ca_certificate,
        "listen_certificate": cfg.tls_listen_certificate,
        "listen_private_key": cfg.tls_listen_private_key,
        "connect_certificate": cfg.tls_connect_certificate,
        "connect_private_key": cfg.tls_connect_private_key,
    }
    for key, value in tls.items():
        if value:
            config.insert_json5(f"transport/link/tls/{key}", json.dumps(value))
    if cfg.tls_enable_mtls:
        config.insert_json5("transport/link/tls/enable_mtls", "true")
    if not cfg.tls_verify_name_on_connect:
        config.insert_json5("transport/link/tls/verify_name_on_connect", "false")
    if cfg.auth_user:  # zenoh DEFAULT_CONFIG.json5, transport/auth/usrpwd
        config.insert_json5("transport/auth/usrpwd/user", json.dumps(cfg.auth_user))
        config.insert_json5("transport/auth/usrpwd/password", json.dumps(read_password(cfg.auth_password_file)))
    if cfg.auth_dictionary_file:
        config.insert_json5("transport/auth/usrpwd/dictionary_file", json.dumps(cfg.auth_dictionary_file))
    return config


# zenoh's Rust errors end with where they were raised, e.g. "... !  at /root/.cargo/git/checkouts/zenoh-.../
# orchestrator.rs:447." : the user needs the message, not the source path.
def open_session(cfg: ZenohConfig) -> zenoh.Session:
    try:
        return zenoh.open(session_config(cfg))
    except zenoh.ZError as exc:
        raise ZenohBusError(f"cannot open zenoh session (listen={list(cfg.listen)}, "
                            f"connect={list(cfg.connect)}): {zenoh_error_text(exc)}") from exc


def to_json(payload: dict) -> bytes:
    """The payload as compact JSON; JSON has no inf/NaN: an infinite tau becomes null."""
    return dumps(payload).encode()


def advisory_state(payload: dict) -> tuple:
    """The part of an advisory payload whose change is an advisory change (level, RA sense/strength/...)."""
    return tuple(payload.get(k) for k in ADVISORY_STATE_FIELDS)


class ZenohBus:
    """One vehicle's zenoh outputs: queued publishing, liveliness token, snapshot queryable.

    publish(suffix, payload) is called by the onboard loop with a fresh dict it will not touch again.
    counters (the node's Counter, optional) gets `zenoh.dropped_updates`; it is only touched on the
    caller's thread. stats (a Counter) has the publisher thread's view: published, put_errors, ...
    sinks (optional, io/sinks.py): the publisher thread's failed puts are reported there by publish(), on the
    caller's thread (`sink.zenoh.errors`; each sample is tried, the next one is tried again).
    """

    def __init__(self, cfg: ZenohConfig, vehicle_id: str, session: zenoh.Session | None = None,
                 counters: Counter | None = None, sinks: SinkHealth | None = None):
        self.cfg = cfg
        self.vehicle = vehicle_id
        self.prefix = f"{cfg.key_prefix}/{vehicle_id}"
        self.counters = counters
        self.stats: Counter = Counter()
        self.sinks = sinks
        self._put_error: Exception | None = None  # the publisher thread's last one
        self._put_errors_reported = 0
        self._own_session = session is None
        self.session = session if session is not None else open_session(cfg)
        self._publishers: dict[str, zenoh.Publisher] = {}
        self._cond = threading.Condition(threading.Lock())
        self._advisories: deque = deque()  # never dropped
        self._vital: deque = deque(maxlen=VITAL_QUEUE)  # status, ownship: drained before any track
        self._updates: deque = deque(maxlen=cfg.queue_size)  # tracks: oldest dropped
        self._forget: set[str] = set()  # publishers to undeclare (tracks gone from the picture)
        self._busy = False  # the publisher thread holds samples it has not put yet
        self._closing = False
        # The current picture, for the snapshot queryable (payload dicts are never mutated once published).
        self._ownship: dict | None = None
        self._status: dict | None = None
        self._bands: dict | None = None  # a DO-365 alerter's latest guidance bands
        self._tracks: dict[str, dict] = {}  # per-track payloads, for the snapshot while no traffic batch came
        self._traffic: TrafficBatch | None = None  # the latest batch: the snapshot's tracks once there is one
        self._traffic_names: set[str] = set()
        self._active: dict[str, dict] = {}  # intruder -> latest advisory, while TA or RA
        self._state: dict[str, tuple] = {}  # intruder -> advisory_state of its latest advisory
        self._changes: deque = deque(maxlen=cfg.snapshot_changes)  # recent advisory changes, oldest first
        self.changes_published = 0
        self._last_time_s: float | None = None
        self._last_publish = 0.0
        # the same samples as ROS 2 messages (avionics/io/ros2.py), encoded on the publisher thread
        self._ros2 = Ros2Publisher(self.session, cfg.ros2_namespace or vehicle_id) if cfg.ros2 else None
        self._thread = threading.Thread(target=self._drain, name=f"zenoh-publisher-{vehicle_id}", daemon=True)
        self._thread.start()
        try:
            self._queryable = self.session.declare_queryable(f"{self.prefix}/snapshot", self._on_query)
            self._token = self.session.liveliness().declare_token(f"{self.prefix}/alive")
        except Exception:
            self.close()
            raise

    # -- the onboard loop's side -------------------------------------------------------------------------------
    def publish(self, suffix: str, payload: dict) -> None:
        """File one sample for publication: never blocks on zenoh, O(1) except once per status."""
        kind, _, name = suffix.partition("/")
        self._report_put_errors()
        with self._cond:
            if self._closing:
                return
            if kind in RELIABLE_KINDS:
                self._advisories.append((suffix, payload))
                if kind == "advisories":
                    self._note_advisory(name, payload)
            elif kind in VITAL_KINDS:
                if len(self._vital) == self._vital.maxlen:
                    self.stats["dropped_status"] += 1
                    if self.counters is not None:
                        self.counters["zenoh.dropped_status"] += 1
                self._vital.append((suffix, payload))
                if kind == "ownship":
                    self._ownship = payload
                elif kind == "bands":
                    self._bands = payload
                else:
                    self._status = payload
                    self._prune(payload.get("time_s"))
            else:
                if len(self._updates) == self._updates.maxlen:
                    self.stats["dropped_updates"] += 1
                    if self.counters is not None:
                        self.counters["zenoh.dropped_updates"] += 1
                self._updates.append((suffix, payload))
                if kind == "traffic":
                    self._new_traffic(payload)
                elif kind == "tracks" and self._traffic is None:
                    self._tracks[name] = payload
            t = payload.time_s if kind == "traffic" else payload.get("time_s")
            if isinstance(t, (int, float)):
                self._last_time_s = t if self._last_time_s is None else max(self._last_time_s, t)
            self._last_publish = time.perf_counter()  # no notify(): see POLL_S

    def _report_put_errors(self) -> None:
        failed = self.stats["put_errors"] - self._put_errors_reported
        if failed > 0 and self.sinks is not None and self._put_error is not None:
            self._put_errors_reported += failed
            self.sinks.failed("zenoh", self._put_error, closed=False, errors=failed)

    def _note_advisory(self, intruder: str, payload: dict) -> None:
        state = advisory_state(payload)
        previous = self._state.get(intruder)
        if (previous != state) if previous is not None else payload.get("level") != "NONE":
            self._changes.append(payload)
            self.changes_published += 1
        self._state[intruder] = state
        if payload.get("level") in ("TA", "RA"):
            self._active[intruder] = payload
        else:
            self._active.pop(intruder, None)

    def _new_traffic(self, batch: TrafficBatch) -> None:
        """The latest batch is the picture's tracks: a track missing from it is gone (publisher undeclared)."""
        names = set(batch.names())
        for name in self._traffic_names - names:
            self._forget_track(name)
        self._traffic, self._traffic_names = batch, names
        self._tracks.clear()

    def _forget_track(self, name: str) -> None:
        self._forget.add(f"tracks/{name}")
        if self._state.get(name, ("NONE",))[0] == "NONE":  # no alert left to end
            self._state.pop(name, None)
            self._forget.add(f"advisories/{name}")

    def _prune(self, now_s) -> None:
        """Tracks not republished for two track periods are gone: out of the picture, publisher undeclared."""
        if not isinstance(now_s, (int, float)):
            return
        horizon = now_s - 2.0 / self.cfg.tracks_hz - 0.05
        for name in [n for n, p in self._tracks.items() if p.get("time_s", now_s) < horizon]:
            del self._tracks[name]
            self._forget_track(name)

    def flush(self, timeout_s: float = 2.0) -> bool:
        """Wait until every queued sample has been put (for tests and shutdown). True if the queues emptied."""
        deadline = time.monotonic() + timeout_s
        with self._cond:
            while self._advisories or self._vital or self._updates or self._busy:
                left = deadline - time.monotonic()
                if left <= 0 or not self._thread.is_alive():
                    return False
                self._cond.wait(min(left, 0.05))
        return True

    def forget(self, suffix: str) -> None:
        """Undeclare the publisher of a deleted track (done on the publisher thread)."""
        with self._cond:
            self._forget.add(suffix)

    def queue_depths(self) -> dict:
        with self._cond:
            return {"advisories": len(self._advisories), "status": len(self._vital), "updates": len(self._updates)}

    # -- the publisher thread ----------------------------------------------------------------------------------
    def _drain(self) -> None:
        while True:
            with self._cond:
                self._busy = False
                self._cond.notify_all()  # flush() waiters
            while not (self._advisories or self._vital or self._updates or self._forget or self._closing):
                time.sleep(POLL_S)
            if self._closing and not (self._advisories or self._vital or self._updates):
                return
            self._await_idle()
            with self._cond:
                batch = [(s, p, True) for s, p in self._advisories]
                self._advisories.clear()
                batch += [(s, p, False) for s, p in self._vital]  # status and ownship before any track
                self._vital.clear()
                for _ in range(min(len(self._updates), UPDATES_PER_BATCH)):
                    s, p = self._updates.popleft()
                    batch.append((s, p, False))
                forget = list(self._forget)
                self._forget.clear()
                self._busy = bool(batch or forget)
            slice_start = time.perf_counter()
            for suffix, payload, is_advisory in batch:
                self._put(suffix, payload, is_advisory)
                if time.perf_counter() - slice_start > SLICE_S:
                    self._await_idle()
                    slice_start = time.perf_counter()
            for suffix in forget:
                pub = self._publishers.pop(f"{self.prefix}/{suffix}", None)
                if pub is not None:
                    try:
                        pub.undeclare()
                    except zenoh.ZError:
                        pass

    def _await_idle(self) -> None:
        """Return when the caller looks idle (see SLICE_S), or after SETTLE_MAX_S."""
        deadline = time.perf_counter() + SETTLE_MAX_S
        while not self._closing:
            t0 = time.perf_counter()
            time.sleep(PROBE_S)  # gives the interpreter lock away; late back = someone else was running
            now = time.perf_counter()
            if (now - t0 < PROBE_S + 0.001 and now - self._last_publish >= SETTLE_S) or now >= deadline:
                return

    def _put(self, suffix: str, payload: dict, is_advisory: bool) -> None:
        key = f"{self.prefix}/{suffix}"
        try:
            pub = self._publishers.get(key)
            if suffix == "traffic":
                if pub is None:  # one sample per tick, dropped rather than queued by zenoh like the tracks
                    pub = self._publishers[key] = self.session.declare_publisher(
                        key, encoding=zenoh.Encoding(ARROW_STREAM), congestion_control=zenoh.CongestionControl.DROP,
                        priority=zenoh.Priority.DATA)
                pub.put(payload.encode())
                self.stats["published_updates"] += 1
                if self._ros2 is not None:
                    self._ros2.put("traffic", payload)
                return
            if pub is None:
                if is_advisory:  # reliable, never dropped by zenoh's congestion control, ahead of data
                    pub = self.session.declare_publisher(key, encoding=zenoh.Encoding.APPLICATION_JSON,
                                                         congestion_control=zenoh.CongestionControl.BLOCK,
                                                         priority=zenoh.Priority.INTERACTIVE_HIGH)
                else:  # status and ownship ahead of tracks in zenoh's queues too
                    vital = suffix in VITAL_KINDS
                    pub = self.session.declare_publisher(key, encoding=zenoh.Encoding.APPLICATION_JSON,
                                                         congestion_control=zenoh.CongestionControl.DROP,
                                                         priority=zenoh.Priority.DATA_HIGH if vital
                                                         else zenoh.Priority.DATA)
                self._publishers[key] = pub
            pub.put(to_json(payload))
            self.stats["published_advisories" if is_advisory else "published_updates"] += 1
            if self._ros2 is not None:
                self._ros2.put(suffix.partition("/")[0], payload)
        except Exception as exc:  # noqa: BLE001  (a closed session must not kill the thread)
            self._put_error = exc
            self.stats["put_errors"] += 1

    # -- the snapshot queryable (zenoh's thread) ---------------------------------------------------------------
    def snapshot(self) -> dict:
        """The current picture: latest ownship and status, live tracks, active advisories, recent changes."""
        with self._cond:
            traffic = self._traffic
        tracks = traffic.payloads() if traffic is not None else None  # off the lock: the views are immutable
        with self._cond:
            picture = {
                "schema": SNAPSHOT_SCHEMA,
                "vehicle": self.vehicle,
                "time_s": self._last_time_s,
                "ownship": self._ownship,
                "status": self._status,
                "bands": self._bands,
                "tracks": tracks if tracks is not None else list(self._tracks.values()),
                "advisories": list(self._active.values()),
                "advisory_changes": list(self._changes),
                "advisory_changes_total": self.changes_published,
                "queue": {"advisories": len(self._advisories), "status": len(self._vital),
                          "updates": len(self._updates), "updates_max": self.cfg.queue_size,
                          "dropped_updates": self.stats["dropped_updates"],
                          "dropped_status": self.stats["dropped_status"]},
            }
        return picture

    def _on_query(self, query: zenoh.Query) -> None:
        try:
            query.reply(f"{self.prefix}/snapshot", to_json(self.snapshot()),
                        encoding=zenoh.Encoding.APPLICATION_JSON)
        except Exception:  # noqa: BLE001
            self.stats["query_errors"] += 1

    # -- lifecycle ---------------------------------------------------------------------------------------------
    def close(self, flush_timeout_s: float = 1.0) -> None:
        """Put what is queued (up to flush_timeout_s; advisories first, e.g. the shutdown NONEs), then withdraw
        the liveliness token (subscribers see its DELETE: the vehicle's DAA is gone) and the queryable, close the
        session. Samples still queued after the timeout are counted in stats["unflushed_at_close"]."""
        try:
            flushed = self.flush(flush_timeout_s)
        except Exception:  # noqa: BLE001  (the token must go whatever happened to the queues)
            flushed = False
        with self._cond:
            if not flushed:
                self.stats["unflushed_at_close"] += len(self._advisories) + len(self._vital) + len(self._updates)
            self._closing = True
            self._advisories.clear()
            self._vital.clear()
            self._updates.clear()
            self._cond.notify_all()
        self._thread.join(timeout=2.0)
        for name in ("_token", "_queryable"):
            entity = getattr(self, name, None)
            if entity is not None:
                try:
                    entity.undeclare()
                except zenoh.ZError:
                    pass
                setattr(self, name, None)
        for pub in self._publishers.values():
            try:
                pub.undeclare()
            except zenoh.ZError:
                pass
        self._publishers.clear()
        if self._own_session:
            self.session.close()
