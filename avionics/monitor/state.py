"""The monitor's picture of the fleet, built from zenoh samples and snapshots; the same for the page and the TUI.

Thread-safe: zenoh callbacks apply samples, the snapshot worker applies snapshots, the web and TUI threads read
views. Every change bumps `version`; a reader keeps a Cursor and asks for what changed since (delta), so the
page gets increments, not the whole picture, and advisories wake readers at once (`urgent`).

Advisory log without losses: a vehicle is *synced* once its snapshot has been applied. Until then (start-up,
or after its liveliness token went away and came back, e.g. a router restart) its advisory samples update the
current picture but are also buffered; the snapshot's change log fills the gap (deduplicated on
(intruder, time_s)), then the buffered samples newer than the snapshot are replayed through change detection.

Bounded: what the monitor keeps of an intruder (its track, advisory, change-detection baseline, tau/Pc history)
goes when it has not been heard for `forget_s` (monitor clock; its track leaves the display after `stale_s`),
and a vehicle keeps at most `max_intruders` (the least recently heard goes first); at most `max_vehicles`
vehicles (an offline one not heard for `vehicle_forget_s` goes, and makes room for a new one). Samples are
checked before they get here (schema.py, in feed.py).

Bands (DO-365 alerters, topic `bands`): the latest sample per vehicle is kept as it came; it is *stale* when no
newer one arrived for `bands_stale_s` (monitor clock): readers are told (`stale`, `age_s`) and keep showing it,
greyed, so that a lost link is visible rather than hidden. An onboard restart drops it.
"""

from __future__ import annotations

import math
import threading
import time
from collections import Counter, OrderedDict, deque
from dataclasses import dataclass, field

from avionics.contract.bands import BAND_KIND_NAMES
from avionics.contract.zenoh import SCHEMA_VERSION
from avionics.base.geodesy import WGS84_A, WGS84_E2
from avionics.base.units import FPM, FT, NM
from avionics.io.zenoh_bus import advisory_state

PROXIMATE_RANGE_M = 6 * NM  # TCAS II proximate traffic: within 6 NM ...
PROXIMATE_ALT_M = 1200 * FT  # ... and +-1200 ft
ARROW_RATE_MPS = 500 * FPM  # vertical-rate arrow from 500 fpm
KNOWN_SCHEMA = SCHEMA_VERSION  # a newer payload is shown, with a note (the contract this monitor was built with)



def enu_offset(lat0: float, lon0: float, lat: float, lon: float) -> tuple[float, float]:
    """East, north metres from (lat0, lon0) to (lat, lon): local radii of curvature, good to ~0.1 % at 100 km."""
    phi = math.radians(lat0)
    s = math.sin(phi)
    w = math.sqrt(1.0 - WGS84_E2 * s * s)
    r_n = WGS84_A / w
    r_m = WGS84_A * (1.0 - WGS84_E2) / (w * w * w)
    dlon = (lon - lon0 + 180.0) % 360.0 - 180.0
    return math.radians(dlon) * r_n * math.cos(phi), math.radians(lat - lat0) * r_m


def pick(payload: dict | None, *names):
    """The first of names present and not null in payload (fields may be absent in older schemas)."""
    if not payload:
        return None
    for name in names:
        value = payload.get(name)
        if value is not None:
            return value
    return None


def pc_of(payload: dict | None):
    return pick(payload, "pc_ta", "pc_max", "pc", "pc_now", "pc_within")


def imm_mode(track: dict | None) -> str | None:
    """IMM mode of a track: the most likely mode and its probability when the payload has them."""
    if not track:
        return None
    probs = track.get("mode_probabilities")
    if isinstance(probs, dict) and probs:
        name = max(probs, key=lambda k: probs[k] if probs[k] is not None else -1)
        p = probs[name]
        return f"{name.upper()} {p:.2f}" if isinstance(p, (int, float)) else name.upper()
    mode = pick(track, "most_likely_mode", "imm_mode")
    return str(mode).upper() if mode is not None else None


def hundreds_ft(rel_alt_m: float | None) -> int | None:
    return None if rel_alt_m is None else int(round(rel_alt_m / FT / 100.0))


def alt_tag(rel_alt_m: float | None) -> str:
    """TCAS relative-altitude tag: sign and two digits in hundreds of feet (+05, -12, 00)."""
    h = hundreds_ft(rel_alt_m)
    if h is None:
        return ""
    return "00" if h == 0 else f"{'+' if h > 0 else '-'}{abs(h):02d}"


def symbol_of(level: str, range_m: float | None, rel_alt_m: float | None) -> str:
    """TCAS symbol class: RA (red square), TA (amber circle), PROX (filled diamond), OTHER (hollow diamond)."""
    if level in ("RA", "TA"):
        return level
    if range_m is not None and range_m <= PROXIMATE_RANGE_M and (rel_alt_m is None or abs(rel_alt_m) <= PROXIMATE_ALT_M):
        return "PROX"
    return "OTHER"


def ownship_altitude(own: dict, datum: str | None) -> float | None:
    if datum == "pressure" and own.get("pressure_altitude_m") is not None:
        return own["pressure_altitude_m"]
    return own.get("alt_msl_m")


def derive_track(track: dict, own: dict | None, advisory: dict | None) -> dict:
    """What a display needs of one track, relative to ownship extrapolated to the track's time.

    tau and Pc of an alerting intruder come from its advisory (the track's when the advisory lacks them); of an
    intruder at NONE only from the track's own latest assessment, when that is not older than the advisory. A
    cleared (NONE) advisory is published once and never refreshed: its Pc (often 1.0, at the closest approach)
    is history, not the intruder's probability now."""
    level = track.get("advisory") or "NONE"
    source = track
    newer = advisory is not None and (advisory.get("time_s") or 0.0) >= (track.get("time_s") or 0.0) - 1e-9
    if newer:
        level, source = advisory.get("level") or level, advisory
    elif advisory is not None and advisory.get("level") == level:
        source = advisory
    alert = advisory if advisory is not None and advisory.get("level") == level else None
    if level == "NONE":
        source = None if newer and (advisory.get("time_s") or 0.0) > (track.get("time_s") or 0.0) + 1e-9 else track
    pc = pc_of(source)
    if pc is None and level != "NONE":
        pc = pc_of(track)
    east = north = rel_alt = None
    range_m = pick(track, "range_m")
    bearing = None
    if own and own.get("valid", True) and own.get("lat_deg") is not None and track.get("lat_deg") is not None:
        dt = (track.get("time_s") or 0.0) - (own.get("time_s") or 0.0)
        ve, vn, vu = own.get("velocity_enu_mps") or (0.0, 0.0, 0.0)
        e, n = enu_offset(own["lat_deg"], own["lon_deg"], track["lat_deg"], track["lon_deg"])
        east, north = e - ve * dt, n - vn * dt
        range_m = math.hypot(east, north)
        bearing = math.degrees(math.atan2(east, north)) % 360.0
        own_alt = ownship_altitude(own, track.get("altitude_datum"))
        if track.get("altitude_m") is not None and own_alt is not None:
            rel_alt = track["altitude_m"] - (own_alt + vu * dt)
    vrate = track.get("vertical_rate_mps")
    ra = advisory if advisory is not None and level == "RA" else None
    return {
        "id": track.get("intruder"),
        "callsign": track.get("callsign"),
        "sym": symbol_of(level, range_m, rel_alt),
        "level": level,
        "e": east, "n": north,
        "range_m": range_m,
        "bearing_deg": bearing,
        "rel_alt_m": rel_alt,
        "tag": alt_tag(rel_alt),
        "vs": None if vrate is None or abs(vrate) < ARROW_RATE_MPS else ("up" if vrate > 0 else "down"),
        "vrate_mps": vrate,
        "track_deg": track.get("track_deg"),
        "gs_mps": track.get("ground_speed_mps"),
        "alert_level": pick(alert, "alert_level"),
        "alert_name": pick(alert, "alert_name"),  # DO-365: PREVENTIVE, CORRECTIVE, WARNING (tcas2: TA, RA)
        "tau_s": pick(source, "mod_tau_s"),
        "range_tau_s": pick(source, "range_tau_s"),
        "pc": pc,
        "pc_ra": pick(source, "pc_ra"),
        "imm": imm_mode(track),
        "time_s": track.get("time_s"),
        "age_s": track.get("age_s"),
        "ra_sense": pick(ra, "ra_sense"),
        "ra_words": pick(ra, "ra_words"),
        "ra_strength": pick(ra, "ra_strength"),
        "target_vertical_rate_mps": pick(ra, "target_vertical_rate_mps"),
    }


def log_entry(vehicle: str, payload: dict, source: str, epoch: int) -> dict:
    """An advisory change as logged. A clear (NONE) carries no Pc: the one it was published with is the last
    alerting assessment's, not a probability of the cleared encounter."""
    level = payload.get("level")
    return {
        "vehicle": vehicle,
        "intruder": payload.get("intruder"),
        "callsign": payload.get("callsign"),
        "level": level,
        "alert_level": payload.get("alert_level"),
        "alert_name": payload.get("alert_name"),
        "reason": payload.get("reason"),
        "time_s": payload.get("time_s"),
        "range_m": payload.get("range_m"),
        "tau_s": payload.get("mod_tau_s"),
        "pc": None if level == "NONE" else pc_of(payload),
        "ra_sense": payload.get("ra_sense"),
        "ra_words": payload.get("ra_words"),
        "ra_strength": payload.get("ra_strength"),
        "target_vertical_rate_mps": payload.get("target_vertical_rate_mps"),
        "source": source,  # live | snapshot | replay
        "epoch": epoch,
        "received_wall_s": time.time(),
    }


@dataclass
class Cursor:
    """What a reader has seen: change version and advisory log sequence, and which vehicle."""

    vehicle: str | None = None
    version: int = -1
    log_seq: int = -1
    fleet_version: int = -1


@dataclass
class VehicleState:
    id: str
    online: bool | None = None  # liveliness: True/False; None until a token was seen or lost
    changed_online_wall_s: float | None = None
    ownship: dict | None = None
    status: dict | None = None
    tracks: dict = field(default_factory=dict)  # intruder -> {"raw", "view", "ver", "seen"}
    advisories: dict = field(default_factory=dict)  # intruder -> latest advisory payload
    baseline: dict = field(default_factory=dict)  # intruder -> (advisory_state, time_s) for change detection
    log: list = field(default_factory=list)
    logged: set = field(default_factory=set)  # (epoch, intruder, time_s)
    history: dict = field(default_factory=dict)  # intruder -> deque[(time_s, tau, pc, pc_ra, level)]
    removed: deque = field(default_factory=lambda: deque(maxlen=4096))  # (ver, intruder)
    synced: bool = False
    buffer: deque = field(default_factory=lambda: deque(maxlen=20000))  # advisories waiting for the snapshot
    snapshots: int = 0
    last_snapshot_wall_s: float | None = None
    epoch: int = 0  # bumps when the onboard clock (time_s) restarts: a new onboard process
    last_time_s: float | None = None
    own_ver: int = 0
    status_ver: int = 0
    last_sample_wall_s: float | None = None  # monitor clock of the last sample
    heard_s: float | None = None  # monitor clock of the last sample, liveliness change or snapshot
    heard: OrderedDict = field(default_factory=OrderedDict)  # intruder -> monitor clock, least recent first
    bands: dict | None = None  # the latest bands payload (DO-365 alerters)
    bands_ver: int = 0
    bands_seen: float | None = None  # monitor clock of its receipt
    bands_stale: bool = False  # set by expire() after bands_stale_s without a newer one


class FleetState:
    def __init__(self, stale_s: float = 5.0, log_size: int = 1000, history_points: int = 600, clock=time.monotonic,
                 forget_s: float = 120.0, max_intruders: int = 2000, max_vehicles: int = 256,
                 vehicle_forget_s: float = 3600.0, bands_stale_s: float = 3.0):
        """stale_s: a track not updated for this long leaves the picture; forget_s: an intruder not heard (track
        or advisory) for this long is forgotten (history, advisory, baseline); max_intruders per vehicle, least
        recently heard evicted first; max_vehicles, offline ones not heard for vehicle_forget_s dropped;
        bands_stale_s: a vehicle's bands without a newer sample for this long are shown as stale."""
        self.cond = threading.Condition()
        self.vehicles: dict[str, VehicleState] = {}
        self.version = 0
        self.fleet_version = 0
        # the monitor's own zenoh session (feed.py ZenohFeed.link_state): shown as the page's and the TUI's ZENOH
        # light, so that a session reaching nobody is not taken for a quiet sky
        self.zenoh_link: dict = {"state": "down", "detail": "no zenoh session yet"}
        self.urgent = 0
        self.log_seq = 0
        self.stale_s = stale_s
        self.log_size = log_size
        self.history_points = history_points
        self.clock = clock
        self.forget_s = max(forget_s, stale_s)
        self.max_intruders = max(1, max_intruders)
        self.max_vehicles = max(1, max_vehicles)
        self.vehicle_forget_s = vehicle_forget_s
        self.bands_stale_s = bands_stale_s
        self.stats: Counter = Counter()
        self.on_new_vehicle = None  # callback(vehicle_id) when a vehicle is first seen through data

    # -- writers -----------------------------------------------------------------------------------------------
    def _vehicle(self, vid: str) -> tuple[VehicleState | None, bool]:
        """The vehicle, created if new; (None, False) when max_vehicles are held and none can make room."""
        v = self.vehicles.get(vid)
        if v is None:
            if len(self.vehicles) >= self.max_vehicles and not self._evict_vehicle():
                self.stats["dropped.vehicle_cap"] += 1
                return None, False
            v = self.vehicles[vid] = VehicleState(vid)
            self.fleet_version += 1
            new = True
        else:
            new = False
        v.heard_s = self.clock()
        return v, new

    def _evict_vehicle(self) -> bool:
        """Make room for a new vehicle: drop the least recently heard one that is not online."""
        idle = [v for v in self.vehicles.values() if v.online is not True]
        if not idle:
            return False
        self._drop_vehicle(min(idle, key=lambda v: v.heard_s if v.heard_s is not None else -math.inf).id)
        self.stats["evicted.vehicles"] += 1
        return True

    def _drop_vehicle(self, vid: str) -> None:
        del self.vehicles[vid]
        self.fleet_version += 1
        self._bump()

    def _hear(self, v: VehicleState, name) -> None:
        """An intruder was heard of: most recently heard now; beyond max_intruders the least recent goes."""
        heard = v.heard
        if name in heard:
            heard.move_to_end(name)
        else:
            while len(heard) >= self.max_intruders:
                self._forget(v, next(iter(heard)))
                self.stats["evicted.intruders"] += 1
        heard[name] = self.clock()

    def _forget(self, v: VehicleState, name) -> None:
        v.heard.pop(name, None)
        v.history.pop(name, None)
        v.advisories.pop(name, None)
        v.baseline.pop(name, None)
        if name in v.tracks:
            del v.tracks[name]
            v.removed.append((self._bump(), name))

    def reject(self, kind: str, reason: str, n: int = 1) -> None:
        """Count a sample (or snapshot element) the schema check refused (feed.py)."""
        with self.cond:
            self.stats["rejected"] += n
            self.stats[f"rejected.{kind}"] += n
            self.stats[f"rejected.{kind}.{reason}"] += n

    def set_zenoh_link(self, link: dict) -> None:
        """The monitor's zenoh link (state "down", "no_peer", "no_data" or "ok", with routers, peers and the age of
        the last sample): readers are told when the state or the counts change (the fleet's version)."""
        with self.cond:
            keys = ("state", "routers", "peers", "detail")
            if tuple(link.get(k) for k in keys) != tuple(self.zenoh_link.get(k) for k in keys):
                self.fleet_version += 1
                self.cond.notify_all()
            self.zenoh_link = dict(link)

    def stats_copy(self) -> dict:
        with self.cond:
            return dict(self.stats)

    def _bump(self) -> int:
        self.version += 1
        return self.version

    def _clock_check(self, v: VehicleState, t) -> None:
        if not isinstance(t, (int, float)):
            return
        if v.last_time_s is not None and t < v.last_time_s - 5.0:  # the onboard process restarted
            v.epoch += 1
            v.baseline.clear()
            v.advisories.clear()
            v.history.clear()
            v.heard.clear()
            if v.bands is not None:
                v.bands = None
                v.bands_ver = self._bump()
            for name in list(v.tracks):
                del v.tracks[name]
                v.removed.append((self._bump(), name))
            v.last_time_s = t
        else:
            v.last_time_s = t if v.last_time_s is None else max(t, v.last_time_s)

    def apply(self, vid: str, kind: str, name: str, payload: dict) -> None:
        """One live sample: kind is ownship | status | tracks | advisories | bands; name the intruder for tracks and
        advisories."""
        new = False
        with self.cond:
            v, new = self._vehicle(vid)
            if v is None:
                return
            v.last_sample_wall_s = self.clock()
            self.stats[f"samples.{kind}"] += 1
            if isinstance(payload.get("schema"), int) and payload["schema"] > KNOWN_SCHEMA:
                self.stats["schema.newer"] += 1
            if kind in ("ownship", "status"):  # (same priority and FIFO as tracks; advisories may overtake)
                self._clock_check(v, payload.get("time_s"))
            if kind == "tracks":
                self._set_track(v, name, payload)
            elif kind == "advisories":
                self._set_advisory(v, name, payload)
                if v.synced:
                    self._detect(v, payload, "live")
                else:
                    v.buffer.append(payload)
                self.urgent += 1
            elif kind == "ownship":
                v.ownship = payload
                v.own_ver = self._bump()
            elif kind == "status":
                v.status = payload
                v.status_ver = self._bump()
                self.fleet_version += 1
            elif kind == "bands":
                self._set_bands(v, payload)
            else:
                return
            self.cond.notify_all()
        if new and self.on_new_vehicle is not None:
            self.on_new_vehicle(vid)

    def apply_traffic(self, vid: str, rows: list[dict]) -> None:
        """One traffic batch (feed.py, rows checked): each row as a per-track sample of its intruder."""
        with self.cond:
            v, new = self._vehicle(vid)
            if v is None:
                return
            v.last_sample_wall_s = self.clock()
            self.stats["samples.traffic"] += 1
            self.stats["samples.traffic.rows"] += len(rows)
            if any(isinstance(r.get("schema"), int) and r["schema"] > KNOWN_SCHEMA for r in rows[:1]):
                self.stats["schema.newer"] += 1
            for row in rows:
                self._set_track(v, row["intruder"], row)
            self.cond.notify_all()
        if new and self.on_new_vehicle is not None:
            self.on_new_vehicle(vid)

    def _set_track(self, v: VehicleState, name: str, payload: dict) -> None:
        self._hear(v, name)
        entry = v.tracks.get(name)
        if entry is not None and (entry["raw"].get("time_s") or 0.0) > (payload.get("time_s") or 0.0) + 1e-9:
            return  # older than what we have (a snapshot raced a live sample)
        view = derive_track(payload, v.ownship, v.advisories.get(name))
        v.tracks[name] = {"raw": payload, "view": view, "ver": self._bump(), "seen": self.clock()}
        self._history(v, name, view, payload.get("time_s"))

    def _set_bands(self, v: VehicleState, payload: dict) -> None:
        current = v.bands
        if current is not None:
            t, t0 = payload.get("time_s"), current.get("time_s")
            if isinstance(t, (int, float)) and isinstance(t0, (int, float)) and t0 - 5.0 <= t < t0 - 1e-9:
                return  # older than what we have (more than 5 s older: a restarted onboard clock, taken)
        v.bands = payload
        v.bands_seen = self.clock()
        v.bands_stale = False
        v.bands_ver = self._bump()

    def _set_advisory(self, v: VehicleState, name: str, payload: dict) -> None:
        self._hear(v, name)
        current = v.advisories.get(name)
        if current is not None and (current.get("time_s") or 0.0) > (payload.get("time_s") or 0.0) + 1e-9:
            return
        v.advisories[name] = payload
        entry = v.tracks.get(name)
        if entry is not None:
            entry["view"] = derive_track(entry["raw"], v.ownship, payload)
            entry["ver"] = self._bump()
            self._history(v, name, entry["view"], payload.get("time_s"))

    def _history(self, v: VehicleState, name: str, view: dict, t) -> None:
        if not isinstance(t, (int, float)):
            return
        h = v.history.get(name)
        if h is None:
            h = v.history[name] = deque(maxlen=self.history_points)
        if h and t <= h[-1][0] + 1e-9:
            if t < h[-1][0] - 5.0:
                h.clear()  # a new onboard clock
            else:
                return
        h.append((t, view["tau_s"], view["pc"], view["pc_ra"], view["level"]))

    def _detect(self, v: VehicleState, payload: dict, source: str) -> None:
        """Log payload if it changes its intruder's advisory state (what a pilot would hear change)."""
        name = payload.get("intruder")
        t = payload.get("time_s") or 0.0
        state = advisory_state(payload)
        base = v.baseline.get(name)
        if base is not None and t <= base[1] + 1e-9:
            return  # not newer than what the baseline already accounts for
        changed = base[0] != state if base is not None else payload.get("level") != "NONE"
        v.baseline[name] = (state, t)
        if changed:
            self._log(v, payload, source)

    def _log(self, v: VehicleState, payload: dict, source: str) -> bool:
        key = (v.epoch, payload.get("intruder"), payload.get("time_s"))
        if key in v.logged:
            return False
        v.logged.add(key)
        self.log_seq += 1
        entry = log_entry(v.id, payload, source, v.epoch)
        entry["seq"] = self.log_seq
        v.log.append(entry)
        if len(v.log) > self.log_size:
            old = v.log.pop(0)
            v.logged.discard((old["epoch"], old["intruder"], old["time_s"]))
        self.stats["log.entries"] += 1
        return True

    def begin_sync(self, vid: str) -> None:
        """The vehicle (re)appeared: buffer its advisories until its snapshot is applied."""
        with self.cond:
            v, _ = self._vehicle(vid)
            if v is None:
                return
            if v.synced:
                v.synced = False
                v.buffer.clear()

    def set_alive(self, vid: str, alive: bool) -> None:
        with self.cond:
            v, _ = self._vehicle(vid)
            if v is None:
                return
            if v.online != alive:
                v.online = alive
                v.changed_online_wall_s = time.time()
                self.fleet_version += 1
                self._bump()
                self.urgent += 1
            if not alive:
                v.synced = False
                v.buffer.clear()
            self.cond.notify_all()

    def apply_snapshot(self, vid: str, snap: dict | None) -> None:
        """Apply a snapshot reply (None: the vehicle has no snapshot queryable), then replay the buffer."""
        with self.cond:
            v, _ = self._vehicle(vid)
            if v is None:
                return
            if snap is not None:
                self.stats["snapshots"] += 1
                v.snapshots += 1
                v.last_snapshot_wall_s = time.time()
                self._clock_check(v, snap.get("time_s"))
                own = snap.get("ownship")
                if own is not None and (v.ownship is None or (own.get("time_s") or 0) >= (v.ownship.get("time_s") or 0)):
                    v.ownship = own
                    v.own_ver = self._bump()
                status = snap.get("status")
                if status is not None and (v.status is None or (status.get("time_s") or 0) >= (v.status.get("time_s") or 0)):
                    v.status = status
                    v.status_ver = self._bump()
                if snap.get("bands") is not None:  # not in the snapshot contract: used when a vehicle sends it
                    self._set_bands(v, snap["bands"])
                for adv in snap.get("advisories") or []:
                    self._set_advisory(v, adv.get("intruder"), adv)
                for track in snap.get("tracks") or []:
                    self._set_track(v, track.get("intruder"), track)
                # The snapshot's change log is authoritative for the time it covers.
                changes = sorted(snap.get("advisory_changes") or [], key=lambda p: p.get("time_s") or 0.0)
                added = False
                for change in changes:
                    added |= self._log(v, change, "snapshot")
                latest: dict = {}
                for p in changes + list(snap.get("advisories") or []):
                    name = p.get("intruder")
                    if name not in latest or (p.get("time_s") or 0) >= (latest[name].get("time_s") or 0):
                        latest[name] = p
                for name, p in latest.items():
                    self._hear(v, name)
                    base = v.baseline.get(name)
                    if base is None or (p.get("time_s") or 0) > base[1]:
                        v.baseline[name] = (advisory_state(p), p.get("time_s") or 0.0)
                if added:
                    v.log.sort(key=lambda e: (e["epoch"], e["time_s"] or 0.0))
            for payload in list(v.buffer):
                self._detect(v, payload, "live" if snap is None else "replay")
            v.buffer.clear()
            v.synced = True
            self.fleet_version += 1
            self._bump()
            self.urgent += 1
            self.cond.notify_all()

    def expire(self) -> int:
        """Drop tracks not updated for stale_s, forget intruders not heard for forget_s and offline vehicles not
        heard for vehicle_forget_s (monitor clock). Returns how many tracks left the picture."""
        now = self.clock()
        n = forgotten = 0
        with self.cond:
            for v in list(self.vehicles.values()):
                for name in [k for k, e in v.tracks.items() if now - e["seen"] > self.stale_s]:
                    del v.tracks[name]
                    v.removed.append((self._bump(), name))
                    n += 1
                cutoff = now - self.forget_s
                while v.heard:
                    name, t = next(iter(v.heard.items()))
                    if t >= cutoff:
                        break
                    self._forget(v, name)
                    forgotten += 1
                if v.bands is not None and not v.bands_stale and now - v.bands_seen > self.bands_stale_s:
                    v.bands_stale = True  # readers are told (a delta), the bands stay, greyed
                    v.bands_ver = self._bump()
                    self.cond.notify_all()
                if v.online is not True and v.heard_s is not None and now - v.heard_s > self.vehicle_forget_s:
                    self._drop_vehicle(v.id)
                    self.stats["expired.vehicles"] += 1
            if forgotten:
                self.stats["expired.intruders"] += forgotten
            if n or forgotten:
                self.cond.notify_all()
        return n

    def memory(self) -> dict:
        """What the picture holds (tests, /api/stats): vehicles, and per vehicle intruders by structure."""
        with self.cond:
            return {vid: {"heard": len(v.heard), "tracks": len(v.tracks), "advisories": len(v.advisories),
                          "baseline": len(v.baseline), "history": len(v.history), "log": len(v.log),
                          "buffer": len(v.buffer), "bands": int(v.bands is not None)}
                    for vid, v in self.vehicles.items()}

    # -- readers -----------------------------------------------------------------------------------------------
    def wait(self, cursor: Cursor, timeout_s: float) -> bool:
        with self.cond:
            return self.cond.wait_for(lambda: self.version > cursor.version or self.fleet_version > cursor.fleet_version,
                                      timeout_s)

    def fleet(self) -> list[dict]:
        with self.cond:
            return self._fleet()

    def _fleet(self) -> list[dict]:
        out = []
        for vid in sorted(self.vehicles):
            v = self.vehicles[vid]
            adv = (v.status or {}).get("advisories") or {}
            out.append({"id": vid, "online": v.online, "synced": v.synced, "tracks": len(v.tracks),
                        "ta": adv.get("TA", 0), "ra": adv.get("RA", 0),
                        "changed_online_wall_s": v.changed_online_wall_s})
        return out

    def default_vehicle(self) -> str | None:
        with self.cond:
            online = [k for k, v in sorted(self.vehicles.items()) if v.online]
            return online[0] if online else (min(self.vehicles) if self.vehicles else None)

    def _own_view(self, v: VehicleState) -> dict | None:
        own = v.ownship
        if own is None:
            return None
        return {k: own.get(k) for k in ("time_s", "valid", "lat_deg", "lon_deg", "alt_msl_m", "pressure_altitude_m",
                                         "track_deg", "ground_speed_mps", "vertical_rate_mps")}

    def _status_view(self, v: VehicleState) -> dict | None:
        s = v.status
        if s is None:
            return None
        return {k: s.get(k) for k in ("time_s", "version", "ownship_valid", "pressure_altitude_available",
                                       "sensitivity_level", "tracks", "advisories", "warnings", "schema")}

    def _bands_view(self, v: VehicleState) -> dict | None:
        b = v.bands
        if b is None:
            return None
        age = self.clock() - v.bands_seen
        out = {k: b.get(k) for k in ("time_s", "alerter", "ownship", *BAND_KIND_NAMES, "recovery", "intruders", "schema")}
        out.update(stale=v.bands_stale or age > self.bands_stale_s, age_s=age, stale_s=self.bands_stale_s)
        return out

    def bands(self, vid: str) -> dict | None:
        """The vehicle's latest bands with `stale` and `age_s` (seconds since receipt), or None."""
        with self.cond:
            v = self.vehicles.get(vid)
            return self._bands_view(v) if v else None

    def view(self, vid: str | None, cursor: Cursor | None = None) -> tuple[dict, Cursor]:
        """The selected vehicle's picture: everything (cursor None or another vehicle), or what changed since."""
        with self.cond:
            v = self.vehicles.get(vid) if vid is not None else None
            full = cursor is None or cursor.vehicle != vid
            if not full and v is not None and len(v.removed) == v.removed.maxlen and v.removed[0][0] > cursor.version:
                full = True  # more removals since the cursor than remembered: start the reader afresh
            since = -1 if full else cursor.version
            log_since = -1 if full else cursor.log_seq
            out: dict = {"type": "full" if full else "delta", "vehicle": vid, "version": self.version}
            if full or self.fleet_version > cursor.fleet_version:
                out["fleet"] = self._fleet()
                out["zenoh"] = dict(self.zenoh_link)
            if v is not None:
                out["online"] = v.online
                out["synced"] = v.synced
                tracks = [e["view"] for e in v.tracks.values() if e["ver"] > since]
                if tracks or full:
                    out["tracks"] = tracks
                if not full:
                    removed = [name for ver, name in v.removed if ver > since and name not in v.tracks]
                    if removed:
                        out["removed"] = removed
                if full or v.own_ver > since:
                    out["ownship"] = self._own_view(v)
                if full or v.status_ver > since:
                    out["status"] = self._status_view(v)
                if full or v.bands_ver > since:
                    out["bands"] = self._bands_view(v)
                log = [e for e in v.log if e["seq"] > log_since] if not full else v.log[-200:]
                if log or full:
                    out["log"] = log
                if full:
                    out["history"] = {name: list(h) for name, h in v.history.items()
                                      if name in v.tracks and v.tracks[name]["view"]["level"] in ("TA", "RA")}
            new_cursor = Cursor(vid, self.version, self.log_seq, self.fleet_version)
            return out, new_cursor

    def history(self, vid: str, intruder: str) -> list:
        with self.cond:
            v = self.vehicles.get(vid)
            return list(v.history.get(intruder, ())) if v else []

    def advisory_log(self, vid: str) -> list[dict]:
        with self.cond:
            v = self.vehicles.get(vid)
            return [dict(e) for e in v.log] if v else []

    def tracks(self, vid: str) -> list[dict]:
        with self.cond:
            v = self.vehicles.get(vid)
            return [dict(e["view"]) for e in v.tracks.values()] if v else []
