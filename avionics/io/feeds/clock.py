"""A receiver's clock -> our loop clock.

A receiver stamps its messages on its own clock (SBS: the "date/time message generated" fields, in the station's
local time; readsb: `now` - `seen_pos`, POSIX seconds; Beast: a 12 MHz counter that wraps at 2^48). We receive
each message after an unknown, varying delay d >= 0. For every message the observed offset

    o = received (our clock) - receiver time = c + d          (c: the clocks' offset, constant over minutes)

so the least o over a recent window is c plus the smallest delay seen: a lower envelope. Mapping a receiver time
by it, t = receiver time + min o, gives each message its time of applicability on our clock without the network
and buffering delay, never later than its receipt (min o <= o). A message without a receiver time gets its receipt
time. Receiver clock steps (a day rollover in local time, NTP stepping, a counter reset) show as an o more than
`step_s` above the envelope, or below it: the window restarts from that sample (counted as a step), so a step
costs no more than the few seconds until the envelope has its floor again.

When the envelope drops (a message came through faster than any before, as when the first ones waited behind a
busy reader), the drop is applied at SLEW_RATE of the receiver's time, not at once: a step back would place the
next messages before ones the receiver sent earlier, and one aircraft's positions out of order (a valid position
rejected as not newer). The mapped time is kept no later than the message's receipt, so the catch-up stays causal.
"""

from __future__ import annotations

import math
from collections import deque

# An offset this far above the envelope is a step of the receiver clock, not a delay: 3 s is
# input.max_report_age_s, beyond which a message is rejected as stale anyway (a receiver buffers for well under
# a second: readsb's network output flushes every 0.1 s by default, --net-ro-interval).
STEP_S = 3.0
# The envelope's drops are applied at this fraction of the receiver's elapsed time (mapped times still advance at
# 1 - SLEW_RATE of it): a 0.5 s drop is taken up over 1 s of the receiver's messages.
SLEW_RATE = 0.5


class ReceiverClock:
    """align(receiver_s, received_s) -> time on our clock. receiver_s: the receiver's time in seconds (any epoch;
    None: unknown); received_s: when we read it, on our loop clock. wrap_s: the period of a wrapping counter
    (Beast: 2**48 / 12e6 s), unwrapped here so that the caller may pass the raw counter / 12e6."""

    def __init__(self, window_s: float = 60.0, wrap_s: float | None = None, step_s: float = STEP_S):
        self.window_s, self.wrap_s, self.step_s = window_s, wrap_s, step_s
        self._floor: deque[tuple[float, float]] = deque()  # (received_s, offset): increasing offsets (min at 0)
        self._last_raw: float | None = None
        self._wraps = 0
        self._applied: float | None = None  # the offset applied last (the envelope, or slewing down to it)
        self._applied_at: float = 0.0  # the unwrapped receiver time it was applied at
        self.steps = 0  # receiver clock steps seen (the window restarted)

    @property
    def offset_s(self) -> float | None:
        """The current envelope: our clock - the receiver's, least delay included (None before a sample)."""
        return self._floor[0][1] if self._floor else None

    def _unwrap(self, raw: float) -> float:
        if self.wrap_s is None:
            return raw
        if self._last_raw is not None and raw < self._last_raw - self.wrap_s / 2:
            self._wraps += 1  # the counter wrapped
        elif self._last_raw is not None and raw > self._last_raw + self.wrap_s / 2:
            self._wraps -= 1  # a message from before the last wrap, read after it
        self._last_raw = raw
        return raw + self._wraps * self.wrap_s

    def align(self, receiver_s: float | None, received_s: float) -> float:
        if receiver_s is None or not math.isfinite(receiver_s):
            return received_s
        receiver_s = self._unwrap(receiver_s)
        offset = received_s - receiver_s
        floor = self._floor
        while floor and received_s - floor[0][0] > self.window_s:  # out of the window
            floor.popleft()
        if floor and not -self.step_s <= offset - floor[0][1] <= self.step_s:
            floor.clear()
            self.steps += 1
            self._applied = None
        while floor and floor[-1][1] >= offset:  # monotonic deque: the window's minimum is floor[0]
            floor.pop()
        floor.append((received_s, offset))
        envelope = floor[0][1]
        if self._applied is None or envelope >= self._applied:
            applied = envelope
        else:  # slewing down to a lower envelope (module docstring)
            applied = max(envelope, self._applied - SLEW_RATE * max(0.0, receiver_s - self._applied_at))
        if receiver_s >= self._applied_at or self._applied is None:
            self._applied, self._applied_at = applied, receiver_s
        return min(receiver_s + applied, received_s)  # the receiver time, unwrapped, on our clock
