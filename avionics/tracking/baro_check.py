"""Ownship barometer cross-check: pressure altitude against GNSS altitude through the learned offset.

The offset b = h_pressure - h_geometric is learned from SCALED_PRESSURE (a first-order low-pass, rate-limited to
what the atmosphere can do). Each sample is checked before it may touch b, and a faulty pressure is withheld:

- implausible: outside the ISA range base/atmosphere.py inverts, or an offset beyond any real atmosphere's;
- stuck: the pressure has not moved since the GNSS altitude was within the noise of where it is now;
- jump: the sample's residual against b is beyond a gate of the GNSS and barometer noise plus the drift b can
  physically have had since it was last updated.

A fault holds until the pressure has been plausible, not stuck and self-consistent for altitude.baro_recovery_s
(hysteresis); the offset is then re-learned from those samples only. docs/altitude.md, "Barometer cross-check",
has the equations and the sources of every number.
"""

from __future__ import annotations

import logging
import math
from collections import Counter
from dataclasses import dataclass

from avionics.tracking.params import AltitudeConfig
from avionics.base.atmosphere import MAX_PRESSURE_ALTITUDE_M, MIN_PRESSURE_ALTITUDE_M

log = logging.getLogger("avionics.baro")

STUCK = "stuck"
JUMP = "jump"
IMPLAUSIBLE = "implausible"
TIME_EPSILON_S = 1e-6  # sample times are sums of periods: 5 s of 0.2-s samples may add up to 4.999999 s


@dataclass(slots=True)
class LearnedOffset:
    """An offset estimate and the sample that last updated it."""

    offset_m: float
    t_s: float  # time of its last sample
    geometric_m: float  # GNSS altitude at its last sample
    since_s: float  # since when its samples have been consistent


class BaroCrossCheck:
    """Decides per SCALED_PRESSURE sample whether it may update the offset; holds the offset and the fault."""

    def __init__(self, cfg: AltitudeConfig, gnss_altitude_sigma_m: float, counters: Counter):
        self.cfg = cfg
        self.counters = counters
        self.residual_sigma_m = math.hypot(gnss_altitude_sigma_m, cfg.baro_noise_sigma_m)
        # the GNSS altitude change the noise cannot explain: the difference of two fixes, k sigma
        self.stuck_gate_m = cfg.baro_gate_sigmas * math.sqrt(2.0) * gnss_altitude_sigma_m
        self.learned: LearnedOffset | None = None  # from accepted samples only; frozen during a fault
        self.candidate: LearnedOffset | None = None  # being re-learned during a fault
        self.fault: str | None = None  # STUCK | JUMP | IMPLAUSIBLE while the pressure is withheld
        self.fault_since_s: float | None = None
        self._moved: tuple[float, float] | None = None  # (pressure alt, GNSS alt) when the pressure last moved

    # -- the learned offset ----------------------------------------------------------------------------------
    def offset_at(self, t_s: float, timeout_s: float) -> float | None:
        """The offset to add to GNSS altitude, or None: in a fault, or no accepted sample within timeout_s."""
        if self.fault is not None or self.learned is None or t_s - self.learned.t_s > timeout_s:
            return None
        return self.learned.offset_m

    def confirmed(self) -> bool:
        """The learned offset has been consistent for baro_recovery_s: a reference to judge a recovery by."""
        return self.learned is not None and \
            self.learned.t_s - self.learned.since_s >= self.cfg.baro_recovery_s - TIME_EPSILON_S

    # -- one sample ------------------------------------------------------------------------------------------
    def update(self, t_s: float, pressure_alt_m: float, geometric_m: float, climb_rate_mps: float) -> bool:
        """Check one sample at t_s (GNSS altitude and climb rate from the ownship filter at t_s); True when it
        updated the learned offset."""
        offset = pressure_alt_m - geometric_m
        reason = self._fault_of(pressure_alt_m, geometric_m, offset, t_s, climb_rate_mps)
        if self.fault is None:
            if reason is not None:
                self._declare(t_s, reason, offset)
                return False
            if self.learned is None:
                self.learned = LearnedOffset(offset, t_s, geometric_m, t_s)
            else:
                self._follow(self.learned, t_s, offset, geometric_m)
            return True
        if reason is not None:  # still faulty: the re-learning starts again
            self.counters[f"baro.{reason}"] += 1
            self.fault, self.candidate = reason, None
            return False
        c = self.candidate
        if c is None or abs(offset - c.offset_m) > self._gate(c, t_s, geometric_m, climb_rate_mps):
            self.candidate = LearnedOffset(offset, t_s, geometric_m, t_s)
        else:
            self._follow(c, t_s, offset, geometric_m)
        if self.candidate.t_s - self.candidate.since_s < self.cfg.baro_recovery_s - TIME_EPSILON_S:
            return False
        log.info("t=%.2f ownship pressure plausible again after %.1f s (%s): offset re-learned %+.1f m", t_s,
                 t_s - self.fault_since_s, self.fault, self.candidate.offset_m)
        self.counters["baro.recovered"] += 1
        self.learned, self.candidate, self.fault, self.fault_since_s = self.candidate, None, None, None
        return True

    def _fault_of(self, pressure_alt_m: float, geometric_m: float, offset: float, t_s: float,
                  climb_rate_mps: float) -> str | None:
        cfg = self.cfg
        stuck = self._stuck(pressure_alt_m, geometric_m)  # kept up to date on every sample
        if not (MIN_PRESSURE_ALTITUDE_M <= pressure_alt_m <= MAX_PRESSURE_ALTITUDE_M
                and cfg.baro_offset_min_m <= offset <= cfg.baro_offset_max_m):
            return IMPLAUSIBLE
        if stuck:
            return STUCK
        # Against the learned offset: always when in use; during a fault only once it was confirmed, so that an
        # unconfirmed start-up offset (one sample can be the glitch) cannot keep a good pressure out for long.
        ref = self.learned
        if ref is not None and (self.fault is None or self.confirmed()) and \
                abs(offset - ref.offset_m) > self._gate(ref, t_s, geometric_m, climb_rate_mps):
            return JUMP
        return None

    def _stuck(self, pressure_alt_m: float, geometric_m: float) -> bool:
        """The pressure has stayed within baro_stuck_tolerance_m since it last moved, while the GNSS altitude has
        moved from where it was then by more than its noise allows (a live static port follows every metre:
        d h_pressure / d h_geometric = T_ISA / T, 0.8 to 1.2)."""
        if self._moved is None or abs(pressure_alt_m - self._moved[0]) > self.cfg.baro_stuck_tolerance_m:
            self._moved = (pressure_alt_m, geometric_m)
            return False
        return abs(geometric_m - self._moved[1]) > self.stuck_gate_m

    def _gate(self, ref: LearnedOffset, t_s: float, geometric_m: float, climb_rate_mps: float) -> float:
        """How far a good sample's offset can be from ref: k sigma of the GNSS and barometer noise, plus the drift
        the true offset can have had since ref's last sample and the lag of the low-pass behind that drift."""
        cfg = self.cfg
        tau = cfg.baro_offset_smoothing_s
        dt = max(t_s - ref.t_s, 0.0)
        return (cfg.baro_gate_sigmas * self.residual_sigma_m
                + cfg.baro_offset_drift_mps * (tau + dt)
                + cfg.baro_offset_drift_per_m * (abs(climb_rate_mps) * tau + abs(geometric_m - ref.geometric_m)))

    def _follow(self, est: LearnedOffset, t_s: float, offset: float, geometric_m: float) -> None:
        """First-order low-pass towards the sample, no faster than the atmosphere can move the offset."""
        cfg = self.cfg
        dt = max(t_s - est.t_s, 0.0)
        alpha = 1.0 - math.exp(-dt / cfg.baro_offset_smoothing_s)
        limit = cfg.baro_offset_drift_mps * dt + cfg.baro_offset_drift_per_m * abs(geometric_m - est.geometric_m)
        est.offset_m += max(-limit, min(limit, alpha * (offset - est.offset_m)))
        est.t_s, est.geometric_m = t_s, geometric_m

    def _declare(self, t_s: float, reason: str, offset: float) -> None:
        self.counters[f"baro.{reason}"] += 1
        self.fault, self.fault_since_s, self.candidate = reason, t_s, None
        learned = "none" if self.learned is None else f"{self.learned.offset_m:+.1f} m"
        log.warning("t=%.2f ownship pressure %s (offset %+.1f m, learned %s): not used, vertical logic on GNSS "
                    "altitude with the datum-mismatch margin", t_s, reason, offset, learned)
