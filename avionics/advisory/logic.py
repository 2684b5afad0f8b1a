"""The advisory state of every intruder (TA hold, RA ending), held in arrays. The threat tests themselves
(TCAS II v7.1, DO-185B, DAIDALUS TCAS3D) are the `tcas2` alerter's levels in advisory/alerting.py (`TCAS3D`,
`TcasRaContinuation`); the core builds its alerter in avionics/compose.py (`build_alerter`).

One row per intruder (a key's row is reused after it is forgotten), so that a step moves every assessed
intruder's state in a few numpy operations instead of a Python object per intruder (issue 13, item 2).

A lost threat (`lost_hold`): an alerting intruder whose reports stopped for tracking.max_coast_s keeps its level on
its coasted track until that track says the encounter is over, and then ends as lost, never as clear.
"""

from __future__ import annotations

import math

import numpy as np

from avionics.base.types import AdvisoryLevel

NONE, TA = int(AdvisoryLevel.NONE), int(AdvisoryLevel.TA)


class AdvisoryStates:
    """Per intruder: the advisory level, when its current alert (TA or RA) began, its alert level (the
    alerter's number; the advisory level for tcas2) and whether its altitude was compared across datums.

    The transition (`next`), per intruder: a higher candidate is taken at once; a lower one only once the alert
    has lasted ta_min_s (a TA stays at least ta_min_s; an ended RA steps down to that TA), unless forced (stale
    data, no ownship)."""

    def __init__(self, capacity: int = 64):
        self._row: dict = {}
        self._free: list[int] = []
        self.level = np.zeros(capacity, np.int8)
        self.onset_s = np.full(capacity, math.nan)  # NaN: no alert
        self.alert = np.zeros(capacity, np.int16)
        self.mismatch = np.zeros(capacity, bool)

    def row(self, key) -> int | None:
        return self._row.get(key)

    def rows(self, keys) -> np.ndarray:
        """The rows of keys, allocating (level NONE, no alert) for the new ones."""
        row = self._row
        out = np.empty(len(keys), np.intp)
        for i, key in enumerate(keys):
            r = row.get(key)
            if r is None:
                r = row[key] = self._allocate()
            out[i] = r
        return out

    def _allocate(self) -> int:
        if self._free:
            r = self._free.pop()
        else:
            r = len(self._row)
            if r >= len(self.level):
                grow = len(self.level)
                self.level = np.concatenate([self.level, np.zeros(grow, np.int8)])
                self.onset_s = np.concatenate([self.onset_s, np.full(grow, math.nan)])
                self.alert = np.concatenate([self.alert, np.zeros(grow, np.int16)])
                self.mismatch = np.concatenate([self.mismatch, np.zeros(grow, bool)])
        self.level[r], self.onset_s[r], self.alert[r], self.mismatch[r] = NONE, math.nan, NONE, False
        return r

    def forget(self, key) -> None:
        r = self._row.pop(key, None)
        if r is not None:
            self._free.append(r)

    def level_of(self, key) -> AdvisoryLevel:
        r = self._row.get(key)
        return AdvisoryLevel.NONE if r is None else AdvisoryLevel(int(self.level[r]))

    def next(self, rows: np.ndarray, now_s: float, candidate: np.ndarray, ta_min_s: float,
             force: np.ndarray | bool = False) -> np.ndarray:
        """Move rows to the levels their candidates allow (module docstring); the (len(rows),) bool: changed."""
        previous = self.level[rows].astype(int)
        onset = self.onset_s[rows]
        candidate = np.asarray(candidate, int)
        held = ~((candidate >= previous) | force) & (now_s - onset < ta_min_s)  # NaN onset: False
        new = np.where(held, TA, candidate)
        self.onset_s[rows] = np.where(new == NONE, math.nan, np.where(previous == NONE, now_s, onset))
        self.level[rows] = new
        return new != previous

    def end(self, rows: np.ndarray) -> np.ndarray:
        """Every row to NONE at once (no ownship, shutdown, a failed step); the (len(rows),) bool: was alerting."""
        was = self.level[rows] != NONE
        self.level[rows] = NONE
        self.onset_s[rows] = math.nan
        self.alert[rows] = NONE
        return was


def lost_hold(previous_level: np.ndarray, stale: np.ndarray, closing: np.ndarray, range_m: np.ndarray,
              dmod_m: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The lost threats among the rows, and those of them whose alert is held: (held, lost), (N,) bools.

    Lost: an intruder alerting (TA or RA) whose track is stale (no report for tracking.max_coast_s). "Clear of
    conflict" is a statement about the geometry, which a lost track no longer gives, so its alert neither ends as
    clear nor changes level: it is held on the coasted track, whose state is the last one projected to now as
    NASA DAIDALUS projects a traffic state that is not current (docs/index.md, "Dealing with Asynchronous
    Inputs"), for as long as that track still calls for an alert by the test that ends one: closing, or within
    the held level's DMOD (TCAS II: an RA ends once the range increases, "Clear of Conflict" — FAA, Introduction
    to TCAS II v7.1; the horizontal test: range within DMOD, or closing within tau — DAIDALUS TCAS2D). Once the
    coasted track has passed its closest point of approach and left DMOD, the alert ends, as lost. The track's
    deletion (tracking.delete_after_s) ends it sooner (pipeline/daa_core.py)."""
    lost = np.asarray(stale, bool) & (np.asarray(previous_level) != NONE)
    held = lost & (np.asarray(closing, bool) | (np.asarray(range_m) <= np.asarray(dmod_m)))
    return held, lost
