"""Ownship state: the latest GLOBAL_POSITION_INT fix propagated at constant velocity (with its uncertainty, a CV
Kalman prediction from the fix), plus the pressure-altitude offset.

Ownship pressure altitude at any instant = filtered geometric altitude + a smoothed (pressure - geometric)
offset learned from SCALED_PRESSURE, so both datums are available whenever a recent pressure exists. Each
pressure sample is cross-checked against GNSS altitude first (tracking/baro_check.py): while the pressure is
faulty, ownship pressure altitude is None and the vertical logic compares with GNSS altitude instead.
"""

from __future__ import annotations

from collections import Counter
from dataclasses import dataclass

import numpy as np

from avionics.tracking.params import AltitudeConfig, InputConfig
from avionics.base.types import OwnshipFix, OwnshipPressure
from avionics.tracking.baro_check import BaroCrossCheck
from avionics.tracking.kalman_cv import CvKalman, Measurement

GNSS_POSITION_SIGMA_M = 2.0
GNSS_ALTITUDE_SIGMA_M = 4.0
GNSS_VELOCITY_SIGMA_MPS = 0.3
OWNSHIP_ACCEL_SIGMA_MPS2 = 3.0


@dataclass(frozen=True, slots=True)
class OwnshipState:
    t_s: float
    x: np.ndarray  # [east, north, alt_msl (geometric), v_east, v_north, v_up]
    pressure_altitude_m: float | None  # None: no recent SCALED_PRESSURE, or the pressure is faulty
    height_above_home_m: float
    p: np.ndarray  # covariance of x


class OwnshipFilter:
    def __init__(self, altitude: AltitudeConfig, inputs: InputConfig, counters: Counter | None = None):
        self.altitude_cfg = altitude
        self.input_cfg = inputs
        self.counters = counters if counters is not None else Counter()  # baro.<fault> and baro.recovered
        self.kf: CvKalman | None = None
        self.last_fix: OwnshipFix | None = None
        self.baro = BaroCrossCheck(altitude, GNSS_ALTITUDE_SIGMA_M, self.counters)
        # the last state_at's (time, state): the loop's stages ask for the same instant several times a step;
        # everything that changes the filter (a fix, a pressure, a new frame) forgets it
        self._state_memo: tuple[float, OwnshipState | None] | None = None

    def update_fix(self, fix: OwnshipFix, east: float, north: float) -> bool:
        vn, ve, vd = fix.velocity_ned_mps
        z = Measurement(
            (0, 1, 2, 3, 4, 5),
            np.array([east, north, fix.alt_msl_m, ve, vn, -vd]),
            np.array([GNSS_POSITION_SIGMA_M] * 2 + [GNSS_ALTITUDE_SIGMA_M] + [GNSS_VELOCITY_SIGMA_MPS] * 3),
        )
        if self.kf is not None and fix.time_s < self.kf.t_s:
            return False  # out of order: counted by the caller (two fixes read together share a time: both used)
        # The fix is the autopilot's navigation solution (ArduPilot EKF3, PX4 EKF2), already filtered: it is taken
        # as it is, with the GNSS-class uncertainty above, and propagated at constant velocity to each assessment.
        # Filtering it again lagged it by metres in turns whenever its position and velocity disagreed.
        self._state_memo = None
        self.kf = CvKalman(fix.time_s, z.value, np.diag(z.sigma**2), OWNSHIP_ACCEL_SIGMA_MPS2, OWNSHIP_ACCEL_SIGMA_MPS2)
        self.last_fix = fix
        return True

    def update_pressure(self, pressure: OwnshipPressure) -> bool:
        """False before the first fix (the offset needs a geometric altitude to refer to). A faulty sample is
        taken (True) but kept out of the offset, and counted by the cross-check."""
        if self.kf is None:
            return False
        x = self.kf.predict_to(pressure.time_s)[0]
        self._state_memo = None
        self.baro.update(pressure.time_s, pressure.pressure_altitude_m, float(x[2]), float(x[5]))
        return True

    @property
    def pressure_fault(self) -> str | None:
        """stuck | jump | implausible while ownship pressure is withheld as faulty (baro_check.py), else None."""
        return self.baro.fault

    def reframe(self, change) -> None:
        """The tangent plane moved (avionics/base/frame.py): carry the filter's state into it."""
        self._state_memo = None
        if self.kf is not None:
            x, p, _ = change.carry(self.kf.x[None], self.kf.p[None], vectors=(3,))
            self.kf.x, self.kf.p = x[0], p[0]

    def state_at(self, t_s: float) -> OwnshipState | None:
        """Ownship at t_s, or None without a fix in the last ownship_timeout_s."""
        if self._state_memo is not None and self._state_memo[0] == t_s:
            return self._state_memo[1]
        state = self._state_at(t_s)
        self._state_memo = (t_s, state)
        return state

    def _state_at(self, t_s: float) -> OwnshipState | None:
        if self.kf is None or self.last_fix is None or t_s - self.kf.t_s > self.input_cfg.ownship_timeout_s:
            return None
        x, p = self.kf.predict_to(t_s)
        offset = self.baro.offset_at(t_s, self.input_cfg.pressure_timeout_s)
        pressure_alt = None if offset is None else float(x[2] + offset)
        hah = self.last_fix.height_above_home_m + (x[2] - self.last_fix.alt_msl_m)
        return OwnshipState(t_s, x, pressure_alt, hah, p)
