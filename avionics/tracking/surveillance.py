"""Every surveillance source as one tracker: ADS-B's tracks and the range/bearing sensors' tracks (issue 30).

The pipeline reads one Tracker (interface.py); this is it. Inside:
- the ADS-B tracker (imm_tracker.py or tracker.py, as compose.py builds it), keyed by address;
- one SensorTracker per sensor kind (sensor_tracker.py: radar, active surveillance), fed each SensorScan with the
  ownship's position and heading at the scan's time. A confirmed sensor track is an intruder of its own, keyed
  `sensor-<track id>` (AddressSource.SENSOR: it has no address), with a TrackRecord like an ADS-B track's: its
  altitude datum is geometric for the radar (its elevation is measured from the ownship's GNSS position) and
  pressure for active surveillance (the Mode C/S reply's altitude).

**One aircraft, one track.** A confirmed sensor track and an ADS-B track are one aircraft when an active
surveillance reply carries the ADS-B track's address, or when their positions pass the association gate
(fusion.pair_tracks: GNN on [east, north, altitude], chi2_3 at the [tracking] gate probability, at most once a
second per sensor kind). The pair is published under the ADS-B key; the sensor track leaves the published set (the
pipeline forgets its key, `prune`), and the ADS-B key's state is the fused one (fusion.fuse, covariance
intersection: the local filters' cross-covariance is unknown, docs/tracking.md "Fusion"), in which a degraded
ADS-B (the integrity monitor) weighs less. A pair whose ADS-B track ends, or whose sensor track is deleted, comes
apart: the remaining track goes on alone (a sensor track that outlives its ADS-B partner is published again).
"""

from __future__ import annotations

import math
from collections import Counter
from collections.abc import Iterator, Mapping

import numpy as np

from avionics.base.types import AddressSource, AltitudeDatum, IntruderKey, SensorScan
from avionics.tracking import fusion
from avionics.tracking.interface import Tracker
from avionics.tracking.record import TrackRecord
from avionics.tracking.sensor_tracker import SensorTracker

DATUM = {"radar": AltitudeDatum.GEOMETRIC, "active": AltitudeDatum.PRESSURE}
PAIRING_PERIOD_S = 1.0  # how often a sensor kind's confirmed tracks are paired with the ADS-B tracks
# A kind's tracker is built once its scan period is known (compose.motion_models scales the per-step noise to it):
# from the first two scans' times, within these bounds (DAA_SENSOR_MEASUREMENT has no rate field).
SCAN_PERIOD_BOUNDS_S = (0.02, 5.0)


class _Tracks(Mapping):
    """The published tracks: ADS-B's and the unpaired confirmed sensor tracks', read-only."""

    def __init__(self, owner: SurveillanceTracker):
        self._owner = owner

    def __getitem__(self, key: IntruderKey) -> TrackRecord:
        if key.source is AddressSource.SENSOR:
            return self._owner.sensor_records[key]
        return self._owner.adsb.tracks[key]

    def __contains__(self, key) -> bool:
        return key in self._owner.sensor_records or key in self._owner.adsb.tracks

    def __iter__(self) -> Iterator[IntruderKey]:
        yield from self._owner.adsb.tracks
        yield from self._owner.sensor_records

    def __len__(self) -> int:
        return len(self._owner.adsb.tracks) + len(self._owner.sensor_records)


class SurveillanceTracker:
    """A Tracker (interface.py) over the ADS-B tracker and the sensors' trackers. adsb: the ADS-B tracker;
    motion_models: (measurement period s, horizontal mode names) -> (horizontal, vertical) IMM mode filters for a
    sensor's tracks (compose.motion_models, called once a kind's first two scans give its period); tracking:
    [tracking]."""

    def __init__(self, adsb: Tracker, motion_models, tracking, counters: Counter):
        self.adsb = adsb
        self.motion_models = motion_models
        self.config = tracking
        self.counters = counters
        self.sensors: dict[str, SensorTracker] = {}  # by kind
        self.sensor_records: dict[IntruderKey, TrackRecord] = {}  # the published (confirmed, unpaired) ones
        self._where: dict[IntruderKey, tuple[str, int]] = {}  # sensor key -> (kind, track id), published or paired
        self.paired: dict[IntruderKey, IntruderKey] = {}  # ADS-B key -> its partner's sensor key
        self._partner: dict[IntruderKey, IntruderKey] = {}  # sensor key -> ADS-B key
        self._gone: list[IntruderKey] = []  # sensor keys that left the published set since the last prune
        self._next_pairing_s: dict[str, float] = {}
        self._held: dict[str, list] = {}  # kind -> its first scans (scan, own_enu, heading) until its period is known
        self._view = _Tracks(self)

    @property
    def tracks(self) -> Mapping[IntruderKey, TrackRecord]:
        # ADS-B alone (no sensor ever seen): its own dict, no view in between
        return self._view if self._where else self.adsb.tracks

    # -- ADS-B (the identity resolver reads the ADS-B tracker's error model through these) -----------------------
    def ingest_many(self, reports, easts, norths):
        return self.adsb.ingest_many(reports, easts, norths)

    def position_sigma_m(self, report) -> float:
        return self.adsb.position_sigma_m(report)

    def velocity_sigma_mps(self, report) -> float:
        return self.adsb.velocity_sigma_mps(report)

    # -- sensors -----------------------------------------------------------------------------------------------
    def scan(self, scan: SensorScan, own_enu, own_heading_rad: float, own_velocity=None) -> set[IntruderKey]:
        """Apply one sensor scan (the ownship's [east, north, altitude], heading and [v_east, v_north, v_up] at its
        time, the altitude in the datum of the sensor's kind; without the velocity, range rates are unused); the
        keys it updated (a paired sensor track: its ADS-B partner's). A kind's first scans are held until one at a
        later time gives the period its tracker is built for."""
        kind = scan.measurements[0].mount.kind
        tracker = self.sensors.get(kind)
        if tracker is None:
            held = self._held.setdefault(kind, [])
            period_s = scan.time_s - held[0][0].time_s if held else 0.0
            if period_s <= 1e-6 and len(held) < 63:
                held.append((scan, own_enu, own_heading_rad, own_velocity))
                return set()
            tracker = self.sensors[kind] = self._tracker(kind, period_s)
        dirty = set().union(*(self._apply(tracker, *h) for h in self._held.pop(kind, [])))
        return dirty | self._apply(tracker, scan, own_enu, own_heading_rad, own_velocity)

    def _tracker(self, kind: str, period_s: float) -> SensorTracker:
        """A kind's tracker, its motion noise for scans period_s apart (within SCAN_PERIOD_BOUNDS_S); a radar's
        with [tracking]'s radar modes and switching (docs/tracking.md, "Turns seen by a radar")."""
        t = self.config
        modes, switch = t.modes_for(kind)
        return SensorTracker(
            *self.motion_models(min(max(period_s, SCAN_PERIOD_BOUNDS_S[0]), SCAN_PERIOD_BOUNDS_S[1]), modes),
            switch_probability=switch,
            turn_exit_probability=t.imm_turn_exit_probability, gate_probability=t.gate_probability,
            delete_after_s=t.delete_after_s, initial_accel_sigma_mps2=t.imm_initial_accel_sigma_mps2,
            range_track_bearing_sigma_deg=t.range_track_bearing_sigma_deg,
            range_rate_correlation_s=t.range_rate_correlation_s, counters=self.counters)

    def _apply(self, tracker: SensorTracker, scan: SensorScan, own_enu, own_heading_rad: float,
               own_velocity=None) -> set[IntruderKey]:
        kind = scan.measurements[0].mount.kind
        before = set(tracker.tracks)
        ids = tracker.scan(scan.time_s, list(scan.measurements), np.asarray(own_enu, float), own_heading_rad,
                           own_velocity)
        for track_id in before - set(tracker.tracks):  # deleted by the scan's review
            self._lost(kind, track_id)
        dirty: set[IntruderKey] = set()
        for track_id in {i for i in ids if i is not None}:
            trk = tracker.tracks.get(track_id)
            if trk is None or not trk.confirmed:
                continue
            key = IntruderKey(track_id, AddressSource.SENSOR)
            record = self.sensor_records.get(key)
            if key not in self._where:
                self._where[key] = (kind, track_id)
                record = self.sensor_records[key] = TrackRecord(key, DATUM[kind], scan.time_s, scan.time_s,
                                                                scan.time_s)
            if record is not None:
                record.last_report_s = record.last_altitude_s = record.last_received_s = trk.t_s
                record.n_updates = trk.n_updates
                dirty.add(key)
            else:
                dirty.add(self._partner[key])
        if scan.time_s >= self._next_pairing_s.get(kind, -math.inf):
            self._next_pairing_s[kind] = scan.time_s + PAIRING_PERIOD_S
            dirty |= self._pair(kind, scan.time_s)
        return {k for k in dirty if k in self.tracks}

    def _pair(self, kind: str, t_s: float) -> set[IntruderKey]:
        """Pair this kind's published sensor tracks with unpaired ADS-B tracks: by a reply's address, else by the
        gate (GNN). The ADS-B keys that now carry a partner."""
        tracker = self.sensors[kind]
        free = [k for k in self.sensor_records if self._where[k][0] == kind]
        adsb = [k for k in self.adsb.tracks if k not in self.paired]
        if not free or not adsb:
            return set()
        pairs = []
        by_address = {k.address: k for k in adsb}
        for key in list(free):
            address = tracker.tracks[self._where[key][1]].address
            if address is not None and address in by_address:
                pairs.append((by_address.pop(address), key))
                free.remove(key)
        adsb = list(by_address.values())
        if free and adsb:
            ax, ap = self.adsb.predict(adsb, t_s)
            sx, sp = tracker.predict([self._where[k][1] for k in free], t_s, consider_bias=True)
            pairs += [(adsb[i], free[j]) for i, j in fusion.pair_tracks(ax, ap, sx, sp, self.config.gate_probability)]
        for adsb_key, sensor_key in pairs:
            self.paired[adsb_key] = sensor_key
            self._partner[sensor_key] = adsb_key
            del self.sensor_records[sensor_key]
            self._gone.append(sensor_key)
            self.counters["sensor.paired_with_adsb"] += 1
        return {a for a, _ in pairs}

    def _lost(self, kind: str, track_id: int) -> None:
        """A sensor track was deleted: unpublish it, or part it from its ADS-B partner."""
        key = IntruderKey(track_id, AddressSource.SENSOR)
        if self._where.pop(key, None) is None:
            return  # never confirmed
        if self.sensor_records.pop(key, None) is not None:
            self._gone.append(key)
        adsb_key = self._partner.pop(key, None)
        if adsb_key is not None:
            del self.paired[adsb_key]

    # -- the Tracker protocol ------------------------------------------------------------------------------------
    def predict(self, keys: list[IntruderKey], t_s: float) -> tuple[np.ndarray, np.ndarray]:
        if not self._where:
            return self.adsb.predict(keys, t_s)
        xs, ps = np.empty((len(keys), 6)), np.empty((len(keys), 6, 6))
        sensor = [i for i, k in enumerate(keys) if k.source is AddressSource.SENSOR]
        adsb = [i for i, k in enumerate(keys) if k.source is not AddressSource.SENSOR]
        if adsb:
            xs[adsb], ps[adsb] = self.adsb.predict([keys[i] for i in adsb], t_s)
            fused = [i for i in adsb if keys[i] in self.paired]
            if fused:
                sx, sp = self._predict_sensor([self.paired[keys[i]] for i in fused], t_s, consider_bias=True)
                degraded = [self.adsb.tracks[keys[i]].integrity.degraded for i in fused]
                xs[fused], ps[fused], _, _ = fusion.fuse(xs[fused], ps[fused], sx, sp, degraded, cross="ci",
                                                         gate_probability=self.config.gate_probability)
        if sensor:
            xs[sensor], ps[sensor] = self._predict_sensor([keys[i] for i in sensor], t_s)
        return xs, ps

    def _predict_sensor(self, keys: list[IntruderKey], t_s: float, consider_bias: bool = False):
        xs, ps = np.empty((len(keys), 6)), np.empty((len(keys), 6, 6))
        for tracker, rows, track_ids in self._by_sensor(keys):
            xs[rows], ps[rows] = tracker.predict(track_ids, t_s, consider_bias)
        return xs, ps

    def _by_sensor(self, keys: list[IntruderKey]):
        """(sensor tracker, rows of keys, their track ids) for each sensor kind with a track among keys (sensor keys
        only)."""
        for kind, tracker in self.sensors.items():
            rows = [i for i, k in enumerate(keys) if k.source is AddressSource.SENSOR and self._where[k][0] == kind]
            if rows:
                yield tracker, rows, [self._where[keys[i]][1] for i in rows]

    def ranging(self, keys: list[IntruderKey], t_s: float) -> np.ndarray:
        """(N, 3) the range track [r, r_dot, r_ddot] at t_s of each key's sensor track (active surveillance,
        range_tracker.py); NaN rows for the others (ADS-B, fused with a sensor or not, and radar tracks)."""
        out = np.full((len(keys), 3), np.nan)
        for tracker, rows, track_ids in self._by_sensor(keys):
            out[rows] = tracker.ranging(track_ids, t_s)
        return out

    def prune(self, now_s: float) -> list[IntruderKey]:
        """ADS-B's silent tracks, the sensor tracks silent for delete_after_s (a sensor that stopped sending scans
        deletes none in its own review), and the sensor keys that left the published set (paired or deleted)."""
        gone = self.adsb.prune(now_s)
        for adsb_key in [k for k in self.paired if k not in self.adsb.tracks]:  # the ADS-B partner is gone
            sensor_key = self.paired.pop(adsb_key)
            del self._partner[sensor_key]
            kind, track_id = self._where[sensor_key]
            trk = self.sensors[kind].tracks[track_id]
            self.sensor_records[sensor_key] = TrackRecord(sensor_key, DATUM[kind], trk.t_s, trk.t_s, trk.t_s,
                                                          trk.n_updates)
        for kind, tracker in self.sensors.items():
            for trk in [t for t in tracker.tracks.values() if now_s - t.t_s > self.config.delete_after_s]:
                tracker.delete(trk, "sensor.track_deleted")
                self._lost(kind, trk.track_id)
        gone += self._gone
        self._gone = []
        return gone

    def reframe(self, change) -> None:
        self.adsb.reframe(change)
        for tracker in self.sensors.values():
            tracker.reframe(change)

    def mode_infos(self, keys: list[IntruderKey], t_s: float | None = None) -> list[dict | None]:
        adsb = [k for k in keys if k.source is not AddressSource.SENSOR]
        infos = iter(self.adsb.mode_infos(adsb, t_s) if adsb else [])
        return [None if k.source is AddressSource.SENSOR else next(infos) for k in keys]

    def drop(self, key: IntruderKey) -> None:
        if key.source is not AddressSource.SENSOR:
            partner = self.paired.pop(key, None)
            if partner is not None:
                self._drop_sensor(partner)
            self.adsb.drop(key)
        elif key in self._where:
            self._drop_sensor(key)

    def _drop_sensor(self, key: IntruderKey) -> None:
        kind, track_id = self._where[key]
        tracker = self.sensors[kind]
        tracker.delete(tracker.tracks[track_id], "sensor.track_dropped")
        adsb_key = self._partner.pop(key, None)
        if adsb_key is not None:
            self.paired.pop(adsb_key, None)
        self._where.pop(key)
        self.sensor_records.pop(key, None)
