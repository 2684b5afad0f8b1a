"""Periodic events on a caller-supplied clock (live or simulated)."""

from __future__ import annotations


class Every:
    """True once per period on a caller-supplied clock, without drift; a late call restarts the grid."""

    def __init__(self, period_s: float):
        self.period_s = period_s
        self.next_s: float | None = None

    def due(self, now_s: float) -> bool:
        if self.next_s is not None and now_s < self.next_s - 1e-9:
            return False
        late = self.next_s is None or now_s - self.next_s > self.period_s
        self.next_s = (now_s if late else self.next_s) + self.period_s
        return True
