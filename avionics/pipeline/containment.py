"""Fault containment (docs/architecture.md, "Failure states"): the stages are vectorised over intruders, so one
intruder's bad numbers (a NaN state, a covariance that is not positive definite) can make a whole call raise.

Each stage call (track update, prediction, conflict probabilities, advisory logic) is guarded (`contained`):
when it raises, it is run again for each intruder alone; an intruder that still raises (or whose predicted state
or geometry is not finite) fails (`fail`): counted `fault.<stage>`, logged once with its traceback, its track
dropped, and its advisory ends in the failed state (level NONE, reason `fault`), announced like any change. The
others go on. An exception outside these boundaries fails the step (`fault.step`): every active advisory ends
with reason `fault` and the next step starts again. The ownship filter and the guidance bands have boundaries of
their own (counted `fault.ownship`, `fault.bands`).
"""

from __future__ import annotations

import logging
from collections import Counter
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from avionics.base.types import Advisory, AdvisoryLevel, IntruderKey
from avionics.pipeline.records import AdvisoryRecords, advisory_of, blank_advisory, with_level

FAULT = "fault"  # the reason of an advisory whose intruder failed in a stage (docs/zenoh.md, Advisory reasons)

log = logging.getLogger("avionics.pipeline")


@dataclass
class Fault:
    """An intruder (or the whole step) that failed in a stage: no advisory can be computed for it."""

    stage: str  # "track", "predict", "conflict", "advisory", "resolution"; "step" for the whole step
    since_s: float
    last_s: float
    error: str  # "LinAlgError: matrix is not positive definite"
    count: int = 1


class Containment:
    """The failed intruders and the failed step, and the boundaries that put them there."""

    def __init__(self, counters: Counter, records: AdvisoryRecords, drop: Callable[[IntruderKey], None]):
        """drop(key): forget a failed intruder in every stage, its track included (its next report starts a new
        one)."""
        self.counters = counters
        self.records = records
        self.drop = drop
        self.faults: dict[IntruderKey, Fault] = {}  # intruders in the failed state (track dropped)
        self.step_fault: Fault | None = None  # the last step failed outside the per-intruder boundaries
        self.pending: list[Advisory] = []  # failed-state advisories found outside step(), announced by the next
        self._traced: set[tuple[str, str]] = set()  # (stage, exception type) already logged with a traceback
        self._ownship_faulted = False  # the ownship filter failed and no fix has gone in since

    def _first(self, stage: str, exc: Exception) -> bool:
        """Whether this stage raises this exception type for the first time (its traceback is logged once)."""
        first = (stage, type(exc).__name__) not in self._traced
        self._traced.add((stage, type(exc).__name__))
        return first

    def contained(self, stage: str, now_s: float, keys: list[IntruderKey], changes: list[Advisory], run,
                  combine=None):
        """run(idx) for the rows idx (an int array) of keys, vectorised. When it raises, each intruder is run
        alone; those that raise alone fail. Returns (rows that went through, result for those rows): the
        results of the lone runs joined by combine, or (without combine) one more vectorised run over them."""
        rows = np.arange(len(keys))
        try:
            return rows, run(rows)
        except Exception as exc:  # noqa: BLE001
            self.batch_failed(stage, exc)
        went, parts = [], []
        for i in rows:
            try:
                parts.append(run(np.array([i])))
            except Exception as exc:  # noqa: BLE001
                self.fail(now_s, keys[i], stage, exc, changes)
            else:
                went.append(i)
        ok = np.array(went, int)
        if not len(ok):
            return ok, None
        return ok, (combine(parts) if combine is not None else run(ok))

    def batch_failed(self, stage: str, exc: Exception) -> None:
        """A vectorised stage call raised: it is retried per intruder (counted; traceback logged once)."""
        self.counters[f"fault.{stage}.batch"] += 1
        if self._first(stage + ".batch", exc):  # then counted only
            log.warning("%s stage raised for a batch of intruders (%s: %s): retried per intruder", stage,
                        type(exc).__name__, exc, exc_info=exc)

    def fail(self, now_s: float, key: IntruderKey, stage: str, exc: Exception, changes: list[Advisory],
             failed: set | None = None) -> None:
        """Intruder key failed in stage: counted, logged once (with the traceback the first time this stage
        raised this exception type), track dropped, advisory to the failed state (announced once per fault)."""
        self.counters[f"fault.{stage}"] += 1
        if failed is not None:
            failed.add(key)
        fault = self.faults.get(key)
        error = f"{type(exc).__name__}: {exc}"
        if fault is None:
            entry = self.records.latest.get(key)
            level = self.records.level
            advisory = (with_level(advisory_of(entry), now_s, AdvisoryLevel.NONE, FAULT) if entry is not None
                        else blank_advisory(key, now_s, FAULT, level.sl if level else 0))
            changes.append(advisory)
            self.faults[key] = Fault(stage, now_s, now_s, error)
            log.error("t=%.2f intruder %s failed in the %s stage (%s): no advisory for it; the others go on",
                      now_s, key, stage, error, exc_info=exc if self._first(stage, exc) else None)
        else:
            fault.stage, fault.last_s, fault.error, fault.count = stage, now_s, error, fault.count + 1
        self.drop(key)

    def recovered(self, now_s: float, keys: list[IntruderKey]) -> None:
        """Intruders that failed before and whose new tracks were assessed (keys): they are back."""
        for key in [k for k in keys if k in self.faults and k in self.records.latest]:
            fault = self.faults.pop(key)
            self.counters["fault.recovered"] += 1
            log.warning("t=%.2f intruder %s assessed again after its %s fault", now_s, key, fault.stage)

    def expire(self, now_s: float, tracks, horizon_s: float) -> None:
        """A failed intruder not heard of again (no track in tracks) for horizon_s (tracking.delete_after_s) is
        gone."""
        for key in [k for k, f in self.faults.items() if k not in tracks and now_s - f.last_s > horizon_s]:
            del self.faults[key]

    def step_failed(self, now_s: float, exc: Exception, end_all: Callable[[], object]) -> None:
        """Outside the per-intruder boundaries: end_all() ends every active advisory with reason fault; DAA
        unavailable until a whole assessment goes through again (`step_works`)."""
        self.counters["fault.step"] += 1
        if self.step_fault is None:
            self.step_fault = Fault("step", now_s, now_s, f"{type(exc).__name__}: {exc}")
            log.error("t=%.2f the DAA step failed (%s: %s): every advisory ends (reason fault)", now_s,
                      type(exc).__name__, exc, exc_info=exc if self._first("step", exc) else None)
        else:
            self.step_fault.last_s, self.step_fault.count = now_s, self.step_fault.count + 1
        try:
            end_all()
        except Exception:  # noqa: BLE001
            log.exception("ending the advisories after a failed step failed too")

    def step_works(self, now_s: float) -> None:
        """An assessment tick went through: a failed step is over."""
        if self.step_fault is not None:
            log.warning("t=%.2f the DAA step works again after %d failed step(s)", now_s, self.step_fault.count)
            self.step_fault = None

    def ownship_failed(self, now_s: float, exc: Exception) -> None:
        """The ownship filter raised (the intake restarts it): counted, logged once until a fix goes in again."""
        self.counters["fault.ownship"] += 1
        if self._ownship_faulted:
            return
        self._ownship_faulted = True
        log.error("t=%.2f the ownship filter failed (%s: %s): restarted, ownship unknown until the next fix", now_s,
                  type(exc).__name__, exc, exc_info=exc if self._first("ownship", exc) else None)

    def ownship_works(self) -> None:
        """A fix went into the ownship filter."""
        self._ownship_faulted = False

    def bands_failed(self, now_s: float, exc: Exception) -> None:
        """The guidance bands raised: counted and logged; they never stop the advisories."""
        self.counters["fault.bands"] += 1
        log.error("t=%.2f the guidance bands failed (%s: %s); the advisories go on", now_s,
                  type(exc).__name__, exc, exc_info=exc if self._first("bands", exc) else None)
