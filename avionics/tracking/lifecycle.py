"""The track lifecycle every intruder tracker shares (Stone Soup's Initiator/Deleter around a filter): one
implementation, the filters plug in below it.

- **Ordering:** a report not newer than its key's track (within DUPLICATE_WINDOW_S) is counted report.duplicate,
  an older one report.out_of_order, and dropped; each key's reports are applied in arrival order.
- **Integrity:** the integrity monitor (integrity.py) sees every report of a key before the filter's gate; a report
  that repeats a stale position is applied without its position.
- **Initiation** from the first report of a key (track.initiated); a report in another altitude datum restarts the
  vertical state (track.datum_change).
- **Record keeping** of an accepted report: report times, update count, identity (record.TrackRecord).
- **Deletion** after delete_after_s without an accepted report (track.deleted); competing tracks (kept out of
  `tracks` by a filter that tracks a rejected motion apart) after max_coast_s; `drop(key)` forgets a key's tracks.

A filter subclass provides `_init_filters` (its state from the first reports), `_update_round` (its gated update of
existing tracks; it calls `_datum_changes` and `_accepted`), `_positions`, `_reset_vertical`, `_release`, and the
outputs (`predict`, `reframe`, `mode_infos`). `vectorised` filters get a batch as rounds of distinct keys (one
vectorised cycle per round); the others one report per round, which is the same thing one report at a time.
"""

from __future__ import annotations

import math
from collections import Counter

import numpy as np

from avionics.base.types import AddressSource, IntruderKey, IntruderReport
from avionics.tracking.integrity import IntegrityMonitor
from avionics.tracking.record import DUPLICATE_WINDOW_S, TrackRecord


class TrackLifecycle:
    vectorised = False
    track_type: type = TrackRecord

    def __init__(self, params, counters: Counter | None = None, capacity: int = 16):
        self.config = params
        self.counters = counters if counters is not None else Counter()
        self.tracks: dict[IntruderKey, TrackRecord] = {}
        self.competitors: dict[IntruderKey, TrackRecord] = {}
        self.integrity = IntegrityMonitor(params.velocity_sigma_mps, capacity)  # per key, sees every report

    # -- filter hooks ------------------------------------------------------------------------------------
    def _init_filters(self, reps: list[IntruderReport], easts, norths) -> list[dict]:
        """Start a filter per report; returns the filter fields of each report's track record."""
        raise NotImplementedError

    def _update_round(self, upd: list[int], reports, easts, norths, stale: np.ndarray, out: np.ndarray) -> None:
        """Apply reports upd (distinct keys, each with a track, in order) to their tracks; out[i]: it updated or
        restarted a published track."""
        raise NotImplementedError

    def _positions(self, tracks: list[TrackRecord]) -> np.ndarray:
        """(K, 2) posterior east, north of the tracks, in the current plane."""
        raise NotImplementedError

    def _reset_vertical(self, track: TrackRecord) -> None:
        raise NotImplementedError

    def _release(self, track: TrackRecord) -> None:
        """A track's filter storage is no longer used."""

    # -- shared parts ------------------------------------------------------------------------------------
    def position_sigma_m(self, report: IntruderReport) -> float:
        """The report's own horizontal accuracy (a receiver's NACp) or the address source's configured default."""
        if report.position_sigma_m is not None:
            return report.position_sigma_m
        cfg = self.config
        return cfg.position_sigma_uat_m if report.key.source is AddressSource.UAT else cfg.position_sigma_1090es_m

    def velocity_sigma_mps(self, report: IntruderReport) -> float:
        """The report's own velocity accuracy (a receiver's NACv) or the configured default."""
        return self.config.velocity_sigma_mps if report.velocity_sigma_mps is None else report.velocity_sigma_mps

    def ingest(self, report: IntruderReport, east: float, north: float) -> bool:
        """Apply one report; True when it updated or started a track, False when it was counted and dropped."""
        return bool(self.ingest_many([report], [east], [north])[0])

    def ingest_many(self, reports: list[IntruderReport], easts, norths) -> np.ndarray:
        """Apply a batch of reports (any order, any keys). Returns, per report, whether it updated or started a
        published track. Each key's reports are applied in arrival order, one round per report of a key, so
        that a batch gives what one report at a time gives (an older report after a newer one is out of order)."""
        easts = np.asarray(easts, float)
        norths = np.asarray(norths, float)
        out = np.zeros(len(reports), bool)
        if not self.vectorised:
            rounds = [[i] for i in range(len(reports))]
        else:
            rounds: list[list[int]] = []
            seen: Counter = Counter()
            for i in range(len(reports)):
                r = seen[reports[i].key]
                seen[reports[i].key] += 1
                if r == len(rounds):
                    rounds.append([])
                rounds[r].append(i)
        for idx in rounds:
            self._ingest_round(idx, reports, easts, norths, out)
        return out

    def _ingest_round(self, idx: list[int], reports, easts, norths, out: np.ndarray) -> None:
        new, upd = [], []
        for i in idx:
            rep = reports[i]
            track = self.tracks.get(rep.key)
            if track is None:
                new.append(i)
                continue
            dt = rep.time_s - track.last_report_s
            if abs(dt) <= DUPLICATE_WINDOW_S:
                self.counters["report.duplicate"] += 1
                continue
            if dt < 0:
                self.counters["report.out_of_order"] += 1
                continue
            upd.append(i)
        stale = self._observe(new + upd, reports, easts, norths)
        if new:
            self._start([reports[i] for i in new], easts[new], norths[new], self.tracks)
            out[new] = True
        if upd:
            self._update_round(upd, reports, easts, norths, stale[len(new):], out)
        seen = new + upd
        if not seen:
            return
        tracks = [self.tracks[reports[i].key] for i in seen]  # the key's published track (maybe restarted)
        x = self._positions(tracks)
        for k, (i, track) in enumerate(zip(seen, tracks)):
            track.integrity = self.integrity.status(track.key)
            track.report_offset = (float(easts[i] - x[k, 0]), float(norths[i] - x[k, 1]), reports[i].altitude_m)

    def _observe(self, idx: list[int], reports, easts, norths) -> np.ndarray:
        """The integrity monitor sees every report of a key before the gate (a step or a frozen position shows
        first as gate misses); returns which reports repeat a stale position."""
        if not idx:
            return np.zeros(0, bool)
        reps = [reports[i] for i in idx]
        sigma = [self.position_sigma_m(r) for r in reps]
        vel = [r.velocity_en_mps or (math.nan, math.nan) for r in reps]
        # where each key's previous report is in today's plane: its track's posterior (carried by reframe) + offset
        previous = np.full((len(reps), 2), np.nan)
        known = [b for b, r in enumerate(reps) if r.key in self.tracks and self.tracks[r.key].report_offset]
        if known:
            tracks = [self.tracks[reps[b].key] for b in known]
            previous[known] = self._positions(tracks) + np.array([t.report_offset[:2] for t in tracks])
        return self.integrity.observe([r.key for r in reps], [r.time_s for r in reps], [r.received_s for r in reps],
                                      easts[idx], norths[idx], vel, sigma, previous)

    def _start(self, reps: list[IntruderReport], easts, norths, into: dict) -> list[TrackRecord]:
        """Initiation: a new track per report in `into` (the published tracks or the competitors), replacing the
        key's previous one there."""
        fields = self._init_filters(reps, easts, norths)
        out = []
        for rep, kw in zip(reps, fields):
            track = self.track_type(rep.key, rep.altitude_datum, rep.time_s, rep.time_s,
                                    rep.time_s if rep.altitude_m is not None else None, **kw)
            track.copy_identity(rep)
            old = into.get(rep.key)
            if old is not None:
                self._release(old)
            into[rep.key] = track
            out.append(track)
        if into is self.tracks:
            self.counters["track.initiated"] += len(reps)
        return out

    def _datum_changes(self, tracks: list[TrackRecord], reps: list[IntruderReport]) -> None:
        for rep, track in zip(reps, tracks):
            if rep.altitude_m is not None and rep.altitude_datum is not track.datum:
                # The sender switched altitude source: the old vertical state is in another datum.
                self.counters["track.datum_change"] += 1
                self._reset_vertical(track)
                track.datum = rep.altitude_datum

    @staticmethod
    def _accepted(track: TrackRecord, rep: IntruderReport) -> None:
        """Record keeping of a report the filter merged."""
        track.consecutive_rejects = 0
        track.last_report_s = rep.time_s
        track.n_updates += 1
        if rep.altitude_m is not None:
            track.last_altitude_s = rep.time_s
        track.copy_identity(rep)

    def prune(self, now_s: float) -> list[IntruderKey]:
        """Delete tracks silent for longer than delete_after_s (competitors: max_coast_s)."""
        dead = [k for k, t in self.tracks.items() if now_s - t.last_report_s > self.config.delete_after_s]
        for key in dead:
            self._release(self.tracks.pop(key))
            self.integrity.forget(key)
            self.counters["track.deleted"] += 1
            comp = self.competitors.pop(key, None)
            if comp is not None:
                self._release(comp)
        for key in [k for k, t in self.competitors.items() if now_s - t.last_report_s > self.config.max_coast_s]:
            self._release(self.competitors.pop(key))
        for key in self.integrity.check_silence(now_s):  # position loss while the track lives
            if key in self.tracks:
                self.tracks[key].integrity = self.integrity.status(key)
        return dead

    def drop(self, key: IntruderKey) -> None:
        """Forget the key's track and competitor (its next report starts a new track); not counted as a deletion,
        and the key's integrity history is kept."""
        for store in (self.tracks, self.competitors):
            track = store.pop(key, None)
            if track is not None:
                self._release(track)
