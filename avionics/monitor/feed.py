"""The monitor's zenoh side: one session, one subscriber for every vehicle's samples, a liveliness subscriber,
and a worker that asks a vehicle's snapshot whenever it appears (start-up, late join, reconnection).

Topics: `<prefix>/<vehicle>/{ownship,status,bands,traffic}` and `<prefix>/<vehicle>/{tracks,advisories}/<intruder>`.
`traffic` (every track of a tick in one Arrow sample) is what keeps the picture's tracks current; the per-track
`tracks/<intruder>` samples (a new track at once, then each every 10 s) and the snapshot are applied as well.
Every sample and snapshot passes the schema check (schema.py) before it is applied: a bad one is counted in
`FleetState.stats` (`rejected`, `rejected.<kind>`, `rejected.<kind>.<reason>`; `/api/stats`) and dropped."""

from __future__ import annotations

import json
import logging
import queue
import threading
import time

import zenoh

from avionics.io.params import ZenohConfig
from avionics.io.zenoh_bus import open_session
from avionics.monitor.schema import (KIND_FIELDS, MAX_SAMPLE_BYTES, MAX_SNAPSHOT_BYTES, Rejected, check_id,
                                     clean_sample, clean_snapshot, clean_traffic)
from avionics.monitor.state import FleetState

log = logging.getLogger("avionics.monitor")
KINDS = tuple(KIND_FIELDS)  # the contract's topics the monitor checks and shows (not guidance)
INBOX_LIMIT = 100_000  # samples received but not yet applied (then zenoh is pushed back on)
# The link light: no sample for this long with a router or peer connected is "no_data". Every onboard node sends
# ownship and status at zenoh.status_hz (1 Hz by default, io/params.py): 5 periods, the track stale_s as well.
LINK_NO_DATA_S = 5.0
LINK_PERIOD_S = 0.5  # how often the session's routers and peers are read (session.info, a local call)


def monitor_zenoh_config(connect: list[str] | tuple[str, ...] = ("tcp/127.0.0.1:7447",), mode: str = "client",
                         listen: list[str] | tuple[str, ...] = (), **security) -> ZenohConfig:
    """A monitor's session: client of a router (or of the onboard peer) by default, scouting off.
    security: ZenohConfig's tls_*, auth_* and config_file keys, e.g. tls_root_ca_certificate="ca.pem"."""
    return ZenohConfig(mode=mode, listen=tuple(listen), connect=tuple(connect), scouting=False, **security)


class ZenohFeed:
    def __init__(self, state: FleetState, cfg: ZenohConfig, prefix: str = "daa", query_timeout_s: float = 2.0,
                 session: zenoh.Session | None = None):
        self.state = state
        self.prefix = prefix
        self.query_timeout_s = query_timeout_s
        self._own_session = session is None
        self.session = session if session is not None else open_session(cfg)
        self._sync_queue: queue.Queue = queue.Queue()
        self._pending: set[str] = set()  # vehicles queued for a snapshot and not yet asked
        self._pending_lock = threading.Lock()
        self._stop = threading.Event()
        self.errors = 0
        state.on_new_vehicle = self.request_sync
        self._worker = threading.Thread(target=self._sync_loop, name="monitor-snapshot", daemon=True)
        self._worker.start()
        # zenoh's receive thread files each sample in a channel on the Rust side, without Python's lock; a worker
        # parses and applies them. A burst of 500 track updates then never holds up the link (zenoh would drop
        # data samples it cannot deliver); a full channel pushes back on zenoh, where advisories block, not drop.
        self._subscriber = self.session.declare_subscriber(f"{prefix}/*/**", zenoh.handlers.FifoChannel(INBOX_LIMIT))
        self._applier = threading.Thread(target=self._apply_loop, name="monitor-apply", daemon=True)
        self._applier.start()
        self._alive = self.session.liveliness().declare_subscriber(f"{prefix}/*/alive", self._on_alive, history=True)
        self.last_sample_s: float | None = None  # time.monotonic() of the last sample or liveliness change
        self._linker = threading.Thread(target=self._link_loop, name="monitor-link", daemon=True)
        self._linker.start()

    def link_state(self) -> dict:
        """The session's reach, for the link light: "no_peer" when it is connected to no router and no peer (a
        client whose router is down, a peer nobody reached), "no_data" when connected but nothing came for
        LINK_NO_DATA_S, else "ok". routers and peers count the zenoh ids session.info reports
        (eclipse-zenoh 1.x SessionInfo.routers_zid / peers_zid)."""
        info = self.session.info
        routers, peers = len(list(info.routers_zid())), len(list(info.peers_zid()))
        age = None if self.last_sample_s is None else time.monotonic() - self.last_sample_s
        if routers + peers == 0:
            state, detail = "no_peer", "zenoh session connected to no router or peer"
        elif age is None or age > LINK_NO_DATA_S:
            state, detail = "no_data", "no sample " + ("yet" if age is None else f"for {age:.0f} s")
        else:
            state, detail = "ok", ""
        return {"state": state, "routers": routers, "peers": peers, "detail": detail,
                "last_sample_age_s": None if age is None else round(age, 1)}

    def _link_loop(self) -> None:
        while not self._stop.wait(LINK_PERIOD_S):
            try:
                self.state.set_zenoh_link(self.link_state())
            except Exception:  # noqa: BLE001  (the session closed under us)
                if self._stop.is_set():
                    return
                self.state.set_zenoh_link({"state": "down", "detail": "zenoh session closed"})

    def _apply_loop(self) -> None:
        try:
            for sample in self._subscriber:  # ends when the subscriber is undeclared
                try:
                    self._apply_sample(sample)
                except Exception:  # noqa: BLE001  (one bad sample must not stop the feed)
                    self.errors += 1
                    if self.errors == 1:
                        log.exception("monitor: applying a sample failed (further failures are only counted)")
        except Exception:  # noqa: BLE001  (the session closed under us)
            pass

    def _apply_sample(self, sample: zenoh.Sample) -> None:
        self.last_sample_s = time.monotonic()
        if sample.kind != zenoh.SampleKind.PUT:
            return
        parts = str(sample.key_expr).split("/")
        if len(parts) < 3 or parts[2] not in KINDS:
            return  # not a topic of the contract (e.g. a newer one): ignored, not an error
        kind = parts[2]
        try:
            vehicle = check_id(parts[1])
            per_intruder = kind in ("tracks", "advisories")
            if len(parts) != (4 if per_intruder else 3):
                raise Rejected("key")
            name = check_id(parts[3]) if per_intruder else ""
            raw = sample.payload.to_bytes()
            if kind == "traffic":
                dropped: dict = {}
                rows = clean_traffic(raw, vehicle, dropped)
                for reason, n in dropped.items():
                    self.state.reject(kind, reason, n)
                self.state.apply_traffic(vehicle, rows)
                return
            if len(raw) > MAX_SAMPLE_BYTES:
                raise Rejected("size")
            try:
                payload = json.loads(raw)
            except (ValueError, RecursionError):
                raise Rejected("json") from None
            payload = clean_sample(kind, payload, name if per_intruder else None)
        except Rejected as exc:
            self.state.reject(kind, exc.reason)
            return
        self.state.apply(vehicle, kind, name, payload)

    def _on_alive(self, sample: zenoh.Sample) -> None:
        self.last_sample_s = time.monotonic()
        parts = str(sample.key_expr).split("/")
        if len(parts) != 3:
            return
        try:
            vehicle = check_id(parts[1])
        except Rejected as exc:
            self.state.reject("alive", exc.reason)
            return
        if sample.kind == zenoh.SampleKind.PUT:
            self.state.set_alive(vehicle, True)
            self.request_sync(vehicle)
        else:
            self.state.set_alive(vehicle, False)

    def request_sync(self, vehicle: str) -> None:
        self.state.begin_sync(vehicle)
        with self._pending_lock:  # its first data sample and its liveliness token both ask: one query serves both
            if vehicle in self._pending:
                return
            self._pending.add(vehicle)
        self._sync_queue.put(vehicle)

    def _sync_loop(self) -> None:
        while not self._stop.is_set():
            try:
                vehicle = self._sync_queue.get(timeout=0.2)
            except queue.Empty:
                continue
            with self._pending_lock:  # a request from now on (a reconnection) asks again
                self._pending.discard(vehicle)
            snap = None
            try:
                for reply in self.session.get(f"{self.prefix}/{vehicle}/snapshot", timeout=self.query_timeout_s):
                    if reply.ok is not None:
                        snap = self._check_snapshot(reply.ok.payload.to_bytes())
            except Exception as exc:  # noqa: BLE001
                self.errors += 1
                log.debug("snapshot of %s failed: %s", vehicle, exc)
                if self._stop.is_set():
                    return
            # a rejected snapshot counts as none: the vehicle is synced from its live samples
            self.state.apply_snapshot(vehicle, snap)

    def _check_snapshot(self, raw: bytes) -> dict | None:
        dropped: dict = {}
        try:
            if len(raw) > MAX_SNAPSHOT_BYTES:
                raise Rejected("size")
            try:
                snap = json.loads(raw)
            except (ValueError, RecursionError):
                raise Rejected("json") from None
            snap = clean_snapshot(snap, dropped)
        except Rejected as exc:
            self.state.reject("snapshot", exc.reason)
            return None
        for reason, n in dropped.items():
            self.state.reject("snapshot", reason, n)
        return snap

    def close(self) -> None:
        self._stop.set()
        for entity in (self._subscriber, self._alive):
            try:
                entity.undeclare()
            except zenoh.ZError:
                pass
        self._worker.join(timeout=self.query_timeout_s + 1.0)
        self._applier.join(timeout=2.0)
        self._linker.join(timeout=LINK_PERIOD_S + 1.0)
        if self._own_session:
            self.session.close()


def wait_for(predicate, timeout_s: float, period_s: float = 0.02) -> bool:
    """Poll predicate until true or timeout (tests and tools)."""
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        if predicate():
            return True
        time.sleep(period_s)
    return bool(predicate())
