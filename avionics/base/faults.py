"""Faults of the stages around the core (decoding, publication, display outputs): counted `fault.<stage>`,
logged at ERROR with the traceback the first time a stage raises an exception type; the rest goes on."""

from __future__ import annotations

import logging
from collections import Counter

log = logging.getLogger("avionics.faults")


class FaultLog:
    def __init__(self, counters: Counter):
        self.counters = counters
        self._traced: set[tuple[str, str]] = set()

    def __call__(self, stage: str, exc: Exception) -> None:
        self.counters[f"fault.{stage}"] += 1
        kind = (stage, type(exc).__name__)
        if kind not in self._traced:
            self._traced.add(kind)
            log.error("%s failed (%s: %s): skipped, the rest goes on", stage, type(exc).__name__, exc, exc_info=exc)
