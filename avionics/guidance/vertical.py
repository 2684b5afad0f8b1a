"""The vertical manoeuvre of the active RAs, as a vertical rate the vehicle can fly above the floor.

A TCAS-like RA is one manoeuvre shared by every threat (advisory/resolution.py): a corrective RA's target rate is
flown at the vehicle profile's rate (advisory/vehicle.py: the logic already asks for no more than the vehicle's
climb or descent rate; clamped here too); a composite RA's target is level. A preventive RA is a limit, not a
target ("DON'T DESCEND": no rate below 0): the present rate is kept when it complies (the stage then commands
nothing and the mission flies on), and clamped to the limit when it does not (level off).

The floor and ceiling bound the rate, not just the altitude: a descent is limited to the rate from which the
vehicle still stops above the floor, planned at half its vertical acceleration (a margin for the setpoint and
response lags), so the commanded path levels off at the floor instead of crossing it; the same below a ceiling.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from avionics.base.types import Advisory

LEVEL_MPS = 0.05  # below this a target rate is "level"
PLAN_ACCEL_FRACTION = 0.5  # of the vehicle's vertical acceleration, for the stopping distance to the floor


@dataclass(frozen=True, slots=True)
class VerticalManoeuvre:
    target_mps: float  # up positive
    complies: bool  # a preventive RA the present rate already satisfies: nothing needs commanding
    reason: str  # "ra" | "preventive" | "composite" | "floor" | "ceiling" | "floor_unknown"

    @property
    def name(self) -> str:
        return "climb" if self.target_mps > LEVEL_MPS else "descend" if self.target_mps < -LEVEL_MPS else "level"


def vertical_manoeuvre(ras: list[Advisory], present_up_mps: float, height_above_home_m: float | None,
                       climb_rate_mps: float, descent_rate_mps: float, vertical_accel_mps2: float,
                       floor_m: float, ceiling_m: float = 0.0) -> VerticalManoeuvre | None:
    """The manoeuvre of the RAs (level RA advisories; None when there is none)."""
    if not ras:
        return None
    targets = [a.target_vertical_rate_mps for a in ras if a.target_vertical_rate_mps is not None]
    if any(a.ra_composite for a in ras):
        target, reason, complies = 0.0, "composite", False
    elif targets:
        target, reason, complies = max(targets, key=abs), "ra", False
    else:  # preventive only: no motion toward the threats
        senses = {a.ra_sense for a in ras}
        low = 0.0 if "climb" in senses else -math.inf
        high = 0.0 if "descend" in senses else math.inf
        target = min(max(present_up_mps, low), high)
        reason, complies = "preventive", low <= present_up_mps <= high
    target = min(max(target, -descent_rate_mps), climb_rate_mps)
    plan_accel = PLAN_ACCEL_FRACTION * vertical_accel_mps2
    if target < 0:
        if height_above_home_m is None:
            target, reason, complies = 0.0, "floor_unknown", False
        else:
            limit = math.sqrt(2 * plan_accel * max(height_above_home_m - floor_m, 0.0))
            if -target > limit:
                target, reason, complies = -limit, "floor", False
    elif target > 0 and ceiling_m > 0 and height_above_home_m is not None:
        limit = math.sqrt(2 * plan_accel * max(ceiling_m - height_above_home_m, 0.0))
        if target > limit:
            target, reason, complies = limit, "ceiling", False
    return VerticalManoeuvre(target, complies, reason)
