"""What the shell reads of the advisory records (records.py) between steps and in a step's result: each quiet
intruder's advisory is built only when it is read."""

from __future__ import annotations

from collections.abc import Sequence
from functools import partial

from avionics.base.types import Advisory, AdvisoryLevel, IntruderKey
from avionics.pipeline.records import AdvisoryRecords, advisory_of


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
