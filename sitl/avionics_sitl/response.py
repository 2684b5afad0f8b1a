"""Closed loop: the simulated ownship flies the RAs it receives (DAA_ADVISORY) with the response model.

The horizontal path stays the scenario's; the vertical one gets an offset. After an RA arrives, the
autopilot waits the response delay, then accelerates at the response acceleration to the RA's target rate
(a preventive RA only stops motion toward the threat); strengthening and reversal use the strengthened
delay and acceleration. When every RA has ended, ownship returns to the scenario's vertical rate and keeps
the altitude it gained.
"""

from __future__ import annotations

import math
from dataclasses import replace

from avionics.advisory.tables import ResponseModel
from avionics.io.dialect import daa as mavlink2
from avionics_sitl.trajectory import KinematicState


class RaResponder:
    def __init__(self, response: ResponseModel):
        self.response = response
        self.offset_m = 0.0  # altitude gained over the scenario's path
        self.extra_rate_mps = 0.0  # vertical rate over the scenario's rate
        self._active: dict[int, object] = {}  # intruder id -> its latest DAA_ADVISORY while RA
        self._command = None  # (target rate or None for preventive, sense sign, accel, start time)
        self._key = None  # what makes a command a new manoeuvre
        self._last_t: float | None = None

    def receive(self, msg, now_s: float) -> None:
        """Take a DAA_ADVISORY from the DAA process."""
        if msg.level == mavlink2.DAA_ADVISORY_LEVEL_RA:
            self._active[msg.id] = msg
        else:
            self._active.pop(msg.id, None)
        if not self._active:
            self._command = None
            return
        latest = msg if msg.level == mavlink2.DAA_ADVISORY_LEVEL_RA else next(iter(self._active.values()))
        stronger = latest.strength == mavlink2.DAA_RA_STRENGTH_INCREASE or latest.flags & \
            mavlink2.DAA_ADVISORY_FLAGS_REVERSED
        delay = self.response.strengthen_delay_s if stronger else self.response.delay_s
        accel = self.response.strengthen_accel_mps2 if stronger else self.response.accel_mps2
        sign = 1.0 if latest.sense == mavlink2.DAA_RA_SENSE_CLIMB else -1.0
        target = None if math.isnan(latest.target_vertical_rate) else latest.target_vertical_rate
        # A target rate is the same manoeuvre against every threat (a composite RA sends 0 with opposite
        # senses); only a one-sided preventive limit depends on the sense.
        key = (target, 0.0 if target is not None else sign)
        if self._command is None or self._key != key:
            # a new or changed manoeuvre starts after the delay; the same RA repeated changes nothing
            self._command, self._key = (target, sign, accel, now_s + delay), key

    def fly(self, base: KinematicState) -> KinematicState:
        """Advance to base.t_s and return the ownship state with the response applied."""
        dt = 0.0 if self._last_t is None else max(base.t_s - self._last_t, 0.0)
        self._last_t = base.t_s
        rate = base.vel_up_mps + self.extra_rate_mps
        if self._command is None:
            wanted = base.vel_up_mps  # RA over: back to the scenario's rate, keep the altitude gained
            accel = self.response.accel_mps2
        else:
            target, sign, accel, start = self._command
            if base.t_s < start:
                wanted = rate
            elif target is None:  # preventive: no motion toward the threat
                wanted = max(rate, 0.0) if sign > 0 else min(rate, 0.0)
            else:
                wanted = target
        step = accel * dt
        new_rate = rate + max(-step, min(step, wanted - rate))
        self.offset_m += 0.5 * (rate + new_rate) * dt - base.vel_up_mps * dt
        self.extra_rate_mps = new_rate - base.vel_up_mps
        return replace(base, alt_msl_m=base.alt_msl_m + self.offset_m, vel_up_mps=new_rate)
