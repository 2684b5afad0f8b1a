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

import math
from dataclasses import dataclass

from avionics.advisory.tables import AlertProfile
from avionics.base.units import FT


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


@dataclass(frozen=True, slots=True)
class Floors:
    """The heights above ground below which an RA must never take ownship, for the whole RA (not only at its
    onset): a commanded descent (DESCEND, INCREASE DESCENT, DESCEND NOW) is levelled off in time to stop above
    `descend_agl_m`, and an INCREASE DESCENT is weakened to DESCEND in time to be at the corrective rate by
    `increase_descent_agl_m` (advisory/resolution.py projects both with the response model). They are the
    inhibit heights where the inhibits engage (height - hysteresis), never below the ground: TCAS II changes a
    Descend RA in progress to a Don't Climb when the aircraft descends through the Descend inhibit height (FAA,
    Introduction to TCAS II v7.1, "RA inhibits"); a UAV, whose floor is the nearest obstacle, is stopped above it.
    `ground_m`: the ground's altitude in the frame of the ownship altitude the RA logic is given; None (AGL
    unknown): no floor applies, as no inhibit can."""

    ground_m: float | None = None
    descend_agl_m: float = 0.0
    increase_descent_agl_m: float = 0.0

    @property
    def descend_m(self) -> float:
        return -math.inf if self.ground_m is None else self.ground_m + self.descend_agl_m

    @property
    def increase_descent_m(self) -> float:
        return -math.inf if self.ground_m is None else self.ground_m + self.increase_descent_agl_m


NO_FLOORS = Floors()


# the built-in profiles that give RAs at any height (ra_inhibit_below_agl_ft = 0): what a drone should run
UAS_ADVICE = "use --set advisory.profile=small-uas (or f3442, do365)"
RA_INHIBIT_WARN_S = 60.0  # flying this long with RAs inhibited is named once (issue 26: "for a minute")
FLYING_AGL_M = 10.0  # below this the vehicle is taken to be on the ground (GNSS height error; a landed vehicle)


def profile_banner(profile: AlertProfile, ra_enabled: bool = True, agl_source: str = "height above home") -> str:
    """What the profile means at a drone's height, for the start-up line: "profile tcas2: RAs inhibited below
    1000 ft AGL (305 m), ..."."""
    head = f"profile {profile.name}"
    if not ra_enabled:
        return f"{head}: RAs off (advisory.ra_enabled = false), TAs only"
    ra_ft, descend_ft = profile.ra_inhibit_below_agl_m / FT, profile.descend_inhibit_below_agl_m / FT
    descend = f"; descend RAs inhibited below {descend_ft:.0f} ft AGL" if descend_ft > 0 else ""
    if ra_ft <= 0:
        return f"{head}: RAs at any height{descend} (AGL: {agl_source})"
    return (f"{head}: RAs inhibited below {ra_ft:.0f} ft AGL ({profile.ra_inhibit_below_agl_m:.0f} m), TAs only "
            f"there{descend} (AGL: {agl_source}); for a UAV flying below that, {UAS_ADVICE}")


class RaInhibitWatch:
    """Names a profile that leaves a flying drone without RAs: the ownship above FLYING_AGL_M and below the profile's
    RA-inhibit height (engage height, no hysteresis: a warning, not the inhibit) for RA_INHIBIT_WARN_S.
    update(now_s, agl_m) -> the warning's message while that lasts, else None."""

    def __init__(self, profile: AlertProfile, ra_enabled: bool = True):
        self.profile = profile
        self.height_m = profile.ra_inhibit_below_agl_m if ra_enabled else 0.0
        self.since_s: float | None = None

    def update(self, now_s: float, agl_m: float | None) -> str | None:
        if agl_m is None or not FLYING_AGL_M <= agl_m < self.height_m:
            self.since_s = None
            return None
        if self.since_s is None:
            self.since_s = now_s
        if now_s - self.since_s < RA_INHIBIT_WARN_S:
            return None
        return (f"flying {agl_m:.0f} m AGL for {now_s - self.since_s:.0f} s, below profile {self.profile.name}'s RA "
                f"inhibit height {self.height_m / FT:.0f} ft AGL: no RA is possible, TAs only; for a UAV "
                f"{UAS_ADVICE}")


class LowAltitudeInhibits:
    def __init__(self, profile: AlertProfile):
        h = profile.inhibit_hysteresis_m
        self._ra = HysteresisInhibit(profile.ra_inhibit_below_agl_m, h)
        self._descend = HysteresisInhibit(profile.descend_inhibit_below_agl_m, h)
        self._increase_descent = HysteresisInhibit(profile.increase_descent_inhibit_below_agl_m, h)

    def update(self, agl_m: float | None) -> Inhibits:
        return Inhibits(self._ra.update(agl_m), self._descend.update(agl_m), self._increase_descent.update(agl_m))

    def floors(self, altitude_m: float, agl_m: float | None) -> Floors:
        """The floors for ownship at altitude_m (any frame), agl_m above the ground (None: unknown)."""
        if agl_m is None:
            return NO_FLOORS
        engage = lambda inhibit: max(inhibit.height_m - inhibit.hysteresis_m, 0.0)  # noqa: E731
        return Floors(altitude_m - agl_m, engage(self._descend), engage(self._increase_descent))
