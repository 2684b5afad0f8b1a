"""TCAS II low-altitude RA inhibits, each with a hysteresis band (FAA, Introduction to TCAS II v7.1, "RA
inhibits"; the +-100 ft bands as FAA AC 20-151 states them, e.g. "1000 ft +-100 ft"):

    all RAs (SL 2, TA only)   below 1000 ft AGL
    Descend (corrective)      below 1100 ft AGL   a preventive Don't Climb and a Level Off stay allowed
    Increase Descent          below 1450 ft AGL

An inhibit engages when ownship descends below its height - h and releases when it climbs above height + h,
so an RA does not flicker while flying along the boundary. Without AGL (no home, no configured ground) no
inhibit can apply (docs/advisories.md).
"""

from __future__ import annotations

from dataclasses import dataclass

from avionics.advisory.tables import AlertProfile


class HysteresisInhibit:
    """One inhibit: True below height - h, False above height + h, unchanged in between."""

    def __init__(self, height_m: float, hysteresis_m: float):
        self.height_m = height_m
        self.hysteresis_m = hysteresis_m
        self.active: bool | None = None  # None until the first AGL

    def update(self, agl_m: float | None) -> bool:
        if agl_m is None:
            self.active = None
            return False
        if self.active is None:
            self.active = agl_m < self.height_m
        elif agl_m < self.height_m - self.hysteresis_m:
            self.active = True
        elif agl_m > self.height_m + self.hysteresis_m:
            self.active = False
        return self.active


@dataclass(frozen=True, slots=True)
class Inhibits:
    """Which RAs the height above ground forbids now."""

    ra: bool = False
    descend: bool = False
    increase_descent: bool = False


NO_INHIBITS = Inhibits()


class LowAltitudeInhibits:
    def __init__(self, profile: AlertProfile):
        h = profile.inhibit_hysteresis_m
        self._ra = HysteresisInhibit(profile.ra_inhibit_below_agl_m, h)
        self._descend = HysteresisInhibit(profile.descend_inhibit_below_agl_m, h)
        self._increase_descent = HysteresisInhibit(profile.increase_descent_inhibit_below_agl_m, h)

    def update(self, agl_m: float | None) -> Inhibits:
        return Inhibits(self._ra.update(agl_m), self._descend.update(agl_m), self._increase_descent.update(agl_m))
