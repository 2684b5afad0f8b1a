"""When each intruder is assessed (docs/architecture.md, "Latency"). Intruders updated in a step are assessed in
that step (report-to-advisory latency is one step); every intruder is re-assessed at advisory.assessment_hz so
that coasting tracks and timeouts are seen too. That re-assessment pass is spread over the steps after each tick
in slices (advisory.assessment_slice), so that a fresh report never waits behind a whole pass."""

from __future__ import annotations

import math
from collections import Counter, deque
from operator import attrgetter

from avionics.base.types import IntruderKey

KEY_ORDER = attrgetter("address", "source")  # IntruderKey's own order, as one C-built tuple per key
TIME_EPSILON_S = 1e-6  # steps on a 0.1 s grid must not miss a tick to floating-point rounding


def slice_count(size: int, left: int, elapsed_s: float, spread_s: float, slice_size: int) -> int:
    """How many of a round of `size` items (`left` not done yet, `elapsed_s` into it) to do in this step: a slice
    (slice_size), or more when the round would otherwise not be done by the share of spread_s gone by (all when
    spread_s is up, or is 0). The re-assessment pass and the track views' round (views.py) are paced by it."""
    share = min(1.0, elapsed_s / spread_s) if spread_s > 0 else 1.0
    due = math.ceil(size * share - TIME_EPSILON_S)
    return min(max(due - (size - left), min(slice_size, left)), left)


class AssessmentSchedule:
    def __init__(self, advisory_params, counters: Counter):
        self.period_s = 1.0 / advisory_params.assessment_hz
        self.slice_size = advisory_params.assessment_slice
        self.counters = counters
        self.last_tick_s = -math.inf  # the last assessment tick (assessment_hz): a re-assessment pass starts
        self._pass: deque[IntruderKey] = deque()  # the pass's intruders not re-assessed yet (`due`)
        self._pass_size = 0

    def tick(self, now_s: float) -> bool:
        """Whether now_s is an assessment tick (it then is the last one)."""
        if now_s - self.last_tick_s >= self.period_s - TIME_EPSILON_S:
            self.last_tick_s = now_s
            return True
        return False

    def due(self, now_s: float, tick: bool, tracks) -> set[IntruderKey]:
        """The intruders to re-assess in this step (issue 13, item 3). Every assessment tick starts a pass over
        every track (tracks: the tracker's, after the tick's deletions); the pass is spread over the steps in
        slices of at most advisory.assessment_slice intruders, more when that would not finish it within half a
        period (so a step never makes a fresh report wait behind a whole pass, and every intruder is still
        re-assessed at assessment_hz). Intruders still left at the next tick are re-assessed in that step
        (counted: `assessment.pass_overrun`). A step on the tick with no more tracks than the slice re-assesses
        them all, as a full pass."""
        take: set[IntruderKey] = set()
        if tick:
            if self._pass:
                self.counters["assessment.pass_overrun"] += 1
                take.update(self._pass)
            self._pass = deque(sorted(tracks, key=KEY_ORDER))
            self._pass_size = len(self._pass)
        if not self._pass:
            return take
        n = slice_count(self._pass_size, len(self._pass), now_s - self.last_tick_s, 0.5 * self.period_s,
                        self.slice_size)
        take.update(self._pass.popleft() for _ in range(n))
        return take

    def recent(self, now_s: float, since_s: float) -> bool:
        """Whether an assessment at since_s is within the last period of now_s."""
        return now_s - since_s <= self.period_s - TIME_EPSILON_S
