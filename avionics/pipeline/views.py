"""What the shell reads of the advisory records (records.py) between steps and in a step's result: each quiet
intruder's advisory is built only when it is read; and the round in which the track views a port asked for are
built, a slice a step (ViewRound)."""

from __future__ import annotations

from collections import deque
from collections.abc import Callable, Sequence
from functools import partial

from avionics.base.types import Advisory, AdvisoryLevel, IntruderKey
from avionics.pipeline.records import AdvisoryRecords, advisory_of
from avionics.pipeline.schedule import slice_count


class Assessed(Sequence):
    """The advisories of a step's assessed intruders (`records.latest` entries), each built when read."""

    __slots__ = ("_entries",)

    def __init__(self, entries: list):
        self._entries = entries

    def __len__(self) -> int:
        return len(self._entries)

    def __getitem__(self, i):
        if isinstance(i, slice):
            return [advisory_of(e) for e in self._entries[i]]
        return advisory_of(self._entries[i])


def _no_advisory() -> None:
    return None


def advisory(records: AdvisoryRecords, key: IntruderKey) -> Advisory | None:
    """An intruder's latest advisory (built now if the step left it as arrays); None: never assessed."""
    entry = records.latest.get(key)
    return None if entry is None else advisory_of(entry)


def advisory_reader(records: AdvisoryRecords, key: IntruderKey):
    """(level, a callable returning the intruder's latest advisory as of now, built when called, and its
    ASSESSMENT_FIELDS): for the track views, whose publications read the level and those fields of every track
    and the whole advisory of a few."""
    entry = records.latest.get(key)
    if entry is None:
        return AdvisoryLevel.NONE, _no_advisory, None
    assessment = entry.assessment() if type(entry) is Advisory else entry[0].assessment(entry[1])
    return records.states.level_of(key), partial(advisory_of, entry), assessment


def datum_mismatch_keys(records: AdvisoryRecords) -> list[IntruderKey]:
    """The intruders whose latest assessment compared altitudes across datums."""
    states = records.states
    return [k for k in records.latest if states.mismatch[states.row(k)]]


class ViewRound:
    """The views of every track that a port asked for (DaaResult.tracks), built over the steps of at most
    `within_s` in slices of `slice_size` (advisory.assessment_slice), more when the round would otherwise not be
    done in time (schedule.slice_count): with 1000 tracks a 2 Hz publication no longer makes one step build them
    all while a fresh report waits behind it (issue 32 item 2). Each view is its track predicted to the step that
    built it (TrackView.time_s). The round's tracks are those of its start, in intruder-id order; one deleted
    before its slice is left out, one created during the round waits for the next. With no more tracks than a
    slice, or within_s 0, the round is one step, as a whole build was."""

    def __init__(self, slice_size: int):
        self.slice_size = slice_size
        self._left: deque = deque()  # the round's tracks not built yet
        self._size = 0
        self._start_s = 0.0
        self._deadline_s = 0.0
        self._views: list = []
        self.running = False

    def step(self, now_s: float, wanted: bool, within_s: float, keys: Callable[[], list], build) -> tuple | None:
        """One step: a round starts when views are wanted and none runs (keys(): every track, sorted; a demand
        during a round brings its deadline to now_s + within_s at the latest); build(keys) returns the views of a
        slice. Returns every view of the round when this step completes it, else None."""
        if wanted and not self.running:
            self._left = deque(keys())
            self._size, self._start_s, self._deadline_s = len(self._left), now_s, now_s + within_s
            self._views, self.running = [], True
        elif wanted:
            self._deadline_s = min(self._deadline_s, now_s + within_s)
        if not self.running:
            return None
        n = slice_count(self._size, len(self._left), now_s - self._start_s, self._deadline_s - self._start_s,
                        self.slice_size)
        self._views.extend(build([self._left.popleft() for _ in range(n)]))
        if self._left:
            return None
        views, self._views, self.running = tuple(self._views), [], False
        return views
