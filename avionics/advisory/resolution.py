"""RA sense and strength like TCAS II v7.1: one vertical manoeuvre for ownship against every RA threat.

Projection (DO-185B standard response, FAA "Introduction to TCAS II v7.1", "Resolution Advisory
Selection": the logic models upward and downward RAs to CPA): after delay d ownship accelerates at a to the
target rate and holds it; each intruder keeps its vertical rate. Against threat k at its CPA time t_k:

    miss_k(RA)  = dz_own(t_k) - (sz_k + v_k t_k)          sz_k = intruder - ownship altitude now
    sep_k(RA)   = sigma_k * miss_k(RA)                     sigma_k = +1 passing above the threat, -1 below

The rules, in the order they apply (docs/advisories.md has the table with sources and worked examples):
1. Never worse than doing nothing, threat by threat: a first or weakened RA (or a composite) that leaves a
   threat less |miss_k| than its reference (the path ownship was on when the threat joined: its vertical rate
   before any RA, the RA being flown during one), or a strengthened or reversed RA that leaves a threat less
   than the RA being flown, is never issued; against several threats a miss may shrink to ALIM, never below.
   Nor does any climb or descend word point at a threat that level flight or the RA being flown clears by
   ALIM (v7.1 booklet, "Multiple threat encounters").
2. Sense: the sense that crosses no threat's altitude when it achieves ALIM; otherwise, against threats
   above and below, a composite RA (Don't Climb + Don't Descend: level) when it does better than either
   sense (one in progress is projected with the response delay it has left and kept until a sense RA does
   better: an RA never ends while it has threats); otherwise the sense with the larger least separation. Ties within TIE_M go to descend (DO-185B
   sense selection, as publicly described), or to climb where descend is inhibited. A threat within
   COALTITUDE_M of ownship's altitude is crossed by neither sense, so exact co-altitude is a tie, not noise.
3. Strength: the weakest that achieves ALIM of preventive (Don't Climb / Don't Descend, ownship already
   complies), Level Off (ownship moving toward the threat), corrective (1500 fpm). Strengthening goes one
   step: preventive or Level Off -> corrective -> increase (2500 fpm). A corrective or increase RA weakens
   to Level Off (v7.1: "Adjust Vertical Speed" became "Level Off") once that beats ALIM by WEAKEN_MARGIN.
4. Inhibits (advisory/inhibits.py): below the Descend inhibit only the corrective and increase descents go;
   Don't Climb and Level Off stay. Where no allowed RA helps, the weakest that keeps the separation is
   issued, or none (the threat stays a TA), and `reason` says why.
5. Reversal (CLIMB NOW / DESCEND NOW, strengthened response 2.5 s, 0.35 g): when the current sense cannot
   reach ALIM even increased, the other sense can, and CPA is more than MIN_REVERSAL_TIME_S away; once.
6. Floors (advisory/inhibits.py Floors): a commanded descent is projected levelled off in time to stop above
   the descend floor, is not issued when it could not fly until the next assessment and still stop there, and
   levels off at once when flown into that state; an INCREASE DESCENT that would reach its inhibit height
   before CPA is not issued, and one in progress levels off there and is projected so (booklet, "RA
   inhibits": a Descend RA in progress there becomes a Don't Climb).
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass, replace
from enum import Enum
from typing import Hashable

from avionics.advisory.inhibits import NO_FLOORS, NO_INHIBITS, Floors, Inhibits
from avionics.advisory.tables import AlertProfile
from avionics.base.units import FT

DWELL_S = 2.0  # least time between strength changes, so an RA does not flicker with noise
MIN_REVERSAL_TIME_S = 4.0  # no reversal this close to CPA: it could not take effect
TIE_M = 1.0  # senses whose projected separations differ by less than this are tied
COALTITUDE_M = 3.048  # 10 ft: a threat this close in altitude is crossed by neither sense
WEAKEN_MARGIN = 1.1  # an RA weakens only once the weaker strength beats ALIM by 10 %
NEVER_WORSE_TOLERANCE_M = 0.01  # rounding of the projections; far below any altitude source's resolution
LEVEL_MPS = 0.5  # ~100 fpm: ownship this slow vertically is level (a composite RA is then preventive)


class Sense(str, Enum):
    CLIMB = "climb"
    DESCEND = "descend"

    @property
    def sign(self) -> float:
        return 1.0 if self is Sense.CLIMB else -1.0

    @property
    def opposite(self) -> "Sense":
        return Sense.DESCEND if self is Sense.CLIMB else Sense.CLIMB


class Strength(str, Enum):
    PREVENTIVE = "preventive"  # vertical speed limit: do not move toward the threat
    LEVEL_OFF = "level_off"  # reduce the vertical rate toward the threat to 0
    CORRECTIVE = "corrective"  # climb/descend at the response rate
    INCREASE = "increase"  # at the strengthened rate


STRONGER = {Strength.PREVENTIVE: Strength.CORRECTIVE, Strength.LEVEL_OFF: Strength.CORRECTIVE,
            Strength.CORRECTIVE: Strength.INCREASE}


@dataclass(frozen=True, slots=True)
class Threat:
    """An RA threat's vertical picture: relative altitude now, intruder vertical rate, time to CPA."""

    sz_m: float  # intruder - ownship altitude, in a common datum
    vz_intruder_mps: float
    t_cpa_s: float
    key: Hashable = None  # the intruder (None: its place in the list), so that it keeps its reference

    def intruder_dz(self) -> float:
        """Intruder altitude at CPA relative to ownship's altitude now."""
        return self.sz_m + self.vz_intruder_mps * max(self.t_cpa_s, 0.0)


@dataclass(frozen=True, slots=True)
class Resolution:
    sense: Sense | None  # None: composite (each threat gets the sense away from it)
    strength: Strength
    target_rate_mps: float | None  # None for a one-sided preventive limit; 0 for Level Off and composite
    reversed: bool
    separation_m: float  # least projected separation at CPA over the threats, with this RA flown
    crossing: bool
    reason: str = ""  # the rule that limited the choice, when one did
    # each threat's projected separation at its CPA, in the sense this RA has against it (sense_against): the
    # one meaning of an advisory's ra_separation_m ((threat key, metres) in the threats' order)
    separations_m: tuple = ()

    @property
    def composite(self) -> bool:
        return self.sense is None

    def sense_against(self, threat: Threat) -> Sense:
        """The sense this RA has against one threat (a composite RA moves away from each)."""
        if self.sense is not None:
            return self.sense
        return Sense.CLIMB if threat.sz_m < 0.0 else Sense.DESCEND

    def separation_against(self, threat: Threat) -> float:
        """The projected separation from one threat (the least over the threats for an unknown one)."""
        return next((sep for key, sep in self.separations_m if key == threat.key), self.separation_m)

    def words(self) -> str:
        """TCAS-style phrase: CLIMB, DESCEND, DONT CLIMB, LEVEL OFF, INCREASE CLIMB, CLIMB NOW, ..."""
        s = self.sense
        if s is None:
            return "DONT CLIMB DONT DESCEND" if self.strength is Strength.PREVENTIVE else "LEVEL OFF"
        if self.strength is Strength.PREVENTIVE:
            return "DONT DESCEND" if s is Sense.CLIMB else "DONT CLIMB"
        if self.strength is Strength.LEVEL_OFF:
            return "LEVEL OFF"
        base = "CLIMB" if s is Sense.CLIMB else "DESCEND"
        if self.strength is Strength.INCREASE:
            return f"INCREASE {base if s is Sense.CLIMB else 'DESCENT'}"
        return f"{base} NOW" if self.reversed else base


def own_displacement(t: float, v0: float, target: float, accel: float, delay: float) -> float:
    """Ownship altitude change after t seconds: v0 for delay, then constant acceleration to target, then target."""
    if t <= delay:
        return v0 * t
    tr = t - delay
    ta = abs(target - v0) / accel if accel > 0 else 0.0
    direction = math.copysign(1.0, target - v0)
    if tr <= ta:
        return v0 * t + 0.5 * direction * accel * tr * tr
    return v0 * (delay + ta) + 0.5 * direction * accel * ta * ta + target * (tr - ta)


def own_rate(t: float, v0: float, target: float, accel: float, delay: float) -> float:
    """Ownship vertical rate after t seconds of the same response (the derivative of own_displacement)."""
    if t <= delay:
        return v0
    tr = t - delay
    if accel <= 0 or tr >= abs(target - v0) / accel:
        return target
    return v0 + math.copysign(accel, target - v0) * tr


@dataclass(frozen=True, slots=True)
class _Command:
    """An RA flown from ownship's present state: its altitude change and rate t seconds from now."""

    v0: float
    target: float
    accel: float
    delay: float

    def dz(self, t: float) -> float:
        return own_displacement(t, self.v0, self.target, self.accel, self.delay)

    def rate(self, t: float) -> float:
        return own_rate(t, self.v0, self.target, self.accel, self.delay)


@dataclass(frozen=True, slots=True)
class _Cut:
    """A path cut by a floor: `head` until the stop takes effect at t_cut (commanded at commanded_s, one response
    delay earlier), then `rest` (from the state at t_cut, toward the stop rate with no further delay)."""

    head: _Command
    commanded_s: float
    t_cut: float
    rest: _Command

    def dz(self, t: float) -> float:
        if t <= self.t_cut:
            return self.head.dz(t)
        return self.head.dz(self.t_cut) + self.rest.dz(t - self.t_cut)

    def rate(self, t: float) -> float:
        return self.head.rate(t) if t <= self.t_cut else self.rest.rate(t - self.t_cut)


def cut_at_floor(path: _Command, floor_dz: float, stop_rate: float, accel: float, delay: float,
                 horizon_s: float) -> _Command | _Cut:
    """The path with a stop toward stop_rate (0: level off; a descent rate: weaken to it) commanded at the latest
    time that, after the response delay and at the response acceleration, reaches stop_rate no lower than
    floor_dz (relative to ownship's altitude now); the path itself when it needs no stop within horizon_s.

    The margin of a stop commanded at t_c is m(t_c) = dz(t_c + d) - (v^2 - s^2) / (2 a) - floor_dz with v the rate
    at t_c + d (descending faster than s; else no drop). It rises while ownship climbs and falls once it
    descends, so {m >= 0} is an interval from 0 and its end is found by bisection; m(0) < 0 (too late already):
    the stop is commanded now."""

    def margin(tc: float) -> float:
        t = tc + delay
        v = path.rate(t)
        drop = (v * v - stop_rate * stop_rate) / (2.0 * accel) if v < stop_rate else 0.0
        return path.dz(t) - drop - floor_dz

    horizon_s = max(horizon_s, 0.0)
    if margin(horizon_s) >= 0.0:
        return path
    lo = 0.0
    if margin(0.0) >= 0.0:
        hi = horizon_s
        for _ in range(40):  # 60 s / 2^40: far below any clock's resolution
            mid = 0.5 * (lo + hi)
            lo, hi = (mid, hi) if margin(mid) >= 0.0 else (lo, mid)
    t_cut = lo + delay
    return _Cut(path, lo, t_cut, _Command(path.rate(t_cut), stop_rate, accel, 0.0))


@dataclass(frozen=True, slots=True)
class _Reference:
    """'Doing nothing' against one threat: the path ownship was on when the threat joined, from its altitude
    then. Before any RA that is keeping its vertical rate; during an RA it is the RA being flown, which ownship
    cannot leave faster than the response allows (a threat that joins is not owed the undoing of the manoeuvre
    an earlier threat needed: TCAS II resolves the threats it has)."""

    time_s: float
    altitude_m: float
    path: _Command | _Cut

    def displacement(self, now_s: float, altitude_m: float, t: float) -> float:
        return self.altitude_m + self.path.dz(now_s + t - self.time_s) - altitude_m


class ResolutionLogic:
    """One ownship manoeuvre for all RA threats, kept consistent across assessments.

    period_s: the longest time between two calls of resolve (the core re-assesses at least this often): a
    commanded descent is levelled off one period before its floor would be too close to stop above it."""

    def __init__(self, profile: AlertProfile, period_s: float = 1.0):
        self.profile = profile
        self.period_s = period_s
        self.current: Resolution | None = None
        self._changed_s = -math.inf
        self._command_s = -math.inf  # when the manoeuvre being flown was commanded
        self._command_delay_s = 0.0
        self._references: dict = {}  # threat key -> _Reference: its "doing nothing"
        self._floored = False  # this RA levelled off at a floor: it never descends again (no DESCEND/LEVEL OFF flicker)
        self._intervals: deque = deque(maxlen=4)  # between the last calls: the period actually seen
        self._last_s: float | None = None
        self.blocked = ""  # why the last resolve() gave no RA although there were threats
        # the picture of the assessment being resolved
        self._threats: list[Threat] = []
        self._v0 = 0.0
        self._alim = 0.0
        self._do_nothing: list[float] = []  # per threat, |miss| on its reference path
        self._floors: Floors = NO_FLOORS
        self._floor_dz = {"descend": -math.inf, "increase_descent": -math.inf}  # relative to ownship now

    # -- projection ------------------------------------------------------------------------------------------
    def _command(self, sense: Sense | None, strength: Strength, v0: float) -> tuple[float, float, float]:
        """(target rate, accel, delay) of an RA; preventive and level-off are targets too."""
        r = self.profile.response
        if sense is None or strength is Strength.LEVEL_OFF:
            return 0.0, r.accel_mps2, r.delay_s
        if strength is Strength.PREVENTIVE:  # keep the current rate, but never toward the threat
            return (max(v0, 0.0) if sense is Sense.CLIMB else min(v0, 0.0)), r.accel_mps2, r.delay_s
        strong = strength is Strength.INCREASE
        rate = sense.sign * r.rate(sense is Sense.CLIMB, strong)
        target = max(v0, rate) if sense is Sense.CLIMB else min(v0, rate)
        return target, (r.strengthen_accel_mps2 if strong else r.accel_mps2), \
            (r.strengthen_delay_s if strong else r.delay_s)

    def _commanded(self, sense: Sense | None, strength: Strength, reversal: bool = False,
                   delay_s: float | None = None) -> _Command:
        target, accel, delay = self._command(sense, strength, self._v0)
        if reversal:  # reversals use the strengthened response timing at the normal rate
            accel, delay = self.profile.response.strengthen_accel_mps2, self.profile.response.strengthen_delay_s
        return _Command(self._v0, target, accel, delay if delay_s is None else delay_s)

    def _descends(self, sense: Sense | None, strength: Strength) -> bool:
        """A commanded descent (DESCEND, INCREASE DESCENT, DESCEND NOW) where a floor is known."""
        return sense is Sense.DESCEND and strength in (Strength.CORRECTIVE, Strength.INCREASE) and \
            self._floors.ground_m is not None

    def _horizon(self) -> float:
        return max(max(th.t_cpa_s for th in self._threats), self._period())

    def _path(self, sense: Sense | None, strength: Strength, reversal: bool = False, delay_s: float | None = None):
        """Ownship's projected path with this RA flown: the response model, and for a commanded descent the
        LEVEL OFFs its floors force (_update): an INCREASE DESCENT's once it could no longer slow to the
        corrective rate above its inhibit height, any descent's as late as still stops ownship above the descend
        floor. A threat that joins an INCREASE DESCENT is owed no more than that path will give it."""
        path = self._commanded(sense, strength, reversal, delay_s)
        if not self._descends(sense, strength):
            return path
        r = self.profile.response
        if strength is Strength.INCREASE:
            cut = cut_at_floor(path, self._floor_dz["increase_descent"], -r.rate(climb=False), r.accel_mps2, r.delay_s,
                               self._horizon())
            if isinstance(cut, _Cut):
                path = _Cut(path, cut.commanded_s, cut.t_cut, _Command(path.rate(cut.t_cut), 0.0, r.accel_mps2, 0.0))
        return cut_at_floor(path, self._floor_dz["descend"], 0.0, r.accel_mps2, r.delay_s, self._horizon())

    def _descend_cut(self, sense: Sense, strength: Strength, reversal: bool = False,
                     delay_s: float | None = None) -> _Command | _Cut:
        """The descent with only the descend floor's LEVEL OFF: when it is due is the descend floor's question."""
        r = self.profile.response
        return cut_at_floor(self._commanded(sense, strength, reversal, delay_s), self._floor_dz["descend"], 0.0,
                            r.accel_mps2, r.delay_s, self._horizon())

    def _misses(self, sense: Sense | None, strength: Strength, reversal: bool = False,
                delay_s: float | None = None) -> list[float]:
        """miss_k = ownship - intruder altitude at each threat's CPA with this RA flown."""
        path = self._path(sense, strength, reversal, delay_s)
        return [path.dz(max(th.t_cpa_s, 0.0)) - th.intruder_dz() for th in self._threats]

    def _separations(self, sense: Sense | None, misses: list[float]) -> list[float]:
        """sep_k: each threat's projected separation in the sense the RA has against it (Resolution.sense_against)."""
        if sense is not None:
            return [sense.sign * m for m in misses]
        return [(1.0 if th.sz_m < 0.0 else -1.0) * m for th, m in zip(self._threats, misses)]

    def _separation(self, sense: Sense | None, misses: list[float]) -> float:
        return min(self._separations(sense, misses))

    def separation(self, threats: list[Threat], sense: Sense | None, strength: Strength, v0: float,
                   reversal: bool = False, delay_s: float | None = None) -> float:
        """Least projected separation at CPA with this RA flown; delay_s overrides the response delay
        (an RA already being answered has only the rest of its delay left)."""
        self._threats, self._v0 = threats, v0
        return self._separation(sense, self._misses(sense, strength, reversal, delay_s))

    def _helps(self, misses: list[float], references: list[float] | None = None) -> bool:
        """Rule 1, threat by threat: no RA leaves a threat less vertical miss than its reference (by default the
        path ownship was on when it joined the RA). Against several threats, where no manoeuvre may add to every
        miss, a miss may also shrink as far as ALIM, never below (TCAS II v7.1 booklet, "Multiple threat
        encounters": the RA provides the required separation from each threat)."""
        references = self._do_nothing if references is None else references
        several = len(misses) > 1
        return all(abs(m) >= (min(ref, self._alim) if several else ref) - NEVER_WORSE_TOLERANCE_M
                   for m, ref in zip(misses, references))

    def _points_at_cleared_threat(self, sense: Sense, misses_now: list[float] | None = None) -> bool:
        """Against several threats, a climb or descend never points toward a threat that level flight (the
        response model's level-off), or the RA being flown, leaves at least ALIM away on that side at its CPA
        (booklet, "Multiple threat encounters": the composite RA keeps ownship between threats)."""
        if len(self._threats) < 2:
            return False
        references = [self._misses(None, Strength.LEVEL_OFF)] + ([misses_now] if misses_now is not None else [])
        return any(-sense.sign * m > 0.0 and abs(m) >= self._alim for misses in references for m in misses)

    def _period(self) -> float:
        return max(self.period_s, max(self._intervals, default=0.0))

    def _floor_stop(self, sense: Sense, strength: Strength, reversal: bool = False, delay_s: float | None = None,
                    issuing: bool = False) -> str:
        """The floor ("descend", "increase_descent") that rules this RA out; "" when none does. A descent is ruled
        out when, flown until the next assessment, it would leave too little height to level off above the
        descend floor. An INCREASE DESCENT also when it would have to slow to the corrective rate (the increase
        descent inhibit) before the next assessment, or, being issued, at any time before CPA: its projection
        then stays what it flies."""
        if not self._descends(sense, strength):
            return ""
        path = self._descend_cut(sense, strength, reversal, delay_s)
        if isinstance(path, _Cut) and path.commanded_s < self._period():
            return "descend"
        if strength is Strength.INCREASE:
            r = self.profile.response
            cut = cut_at_floor(self._commanded(sense, strength, reversal, delay_s), self._floor_dz["increase_descent"],
                               -r.rate(climb=False), r.accel_mps2, r.delay_s, self._horizon())
            if isinstance(cut, _Cut) and (issuing or cut.commanded_s < self._period()):
                return "increase_descent"
        return ""

    def _floor_reason(self, floor: str, what: str) -> str:
        height = self._floors.descend_agl_m if floor == "descend" else self._floors.increase_descent_agl_m
        name = "descend" if floor == "descend" else "increase-descent"
        return f"{name} floor {height / FT:.0f} ft AGL: {what}"

    @staticmethod
    def _crossing(threats: list[Threat], sense: Sense | None) -> bool:
        """Does this sense take ownship through a threat's current altitude?"""
        return sense is not None and any(sense.sign * th.sz_m > COALTITUDE_M for th in threats)

    # -- what is allowed -------------------------------------------------------------------------------------
    def _allowed(self, sense: Sense, strength: Strength, inhibits: Inhibits) -> bool:
        if sense is Sense.CLIMB:
            return True
        if strength is Strength.CORRECTIVE:
            return not inhibits.descend
        if strength is Strength.INCREASE:
            return not (inhibits.descend or inhibits.increase_descent)
        return True  # Don't Climb and Level Off are not descents

    def _initial_strengths(self, sense: Sense, inhibits: Inhibits) -> list[Strength]:
        """A first RA is preventive (ownship complies), Level Off (it moves toward the threat) or corrective;
        TCAS II never opens with an increase RA."""
        first = Strength.PREVENTIVE if sense.sign * self._v0 >= 0.0 else Strength.LEVEL_OFF
        return [s for s in (first, Strength.CORRECTIVE) if self._allowed(sense, s, inhibits)]

    def _option(self, sense: Sense | None, strengths: list[Strength], alim: float, reason: str = ""):
        """(strength, separation, reason, capability): the weakest helpful strength achieving ALIM, else the
        strongest helpful one, and what the strongest usable strength achieves; None if none helps. A strength
        that its floor or a cleared threat rules out is not usable."""
        usable = []
        for strength in strengths:
            if strength is Strength.CORRECTIVE and (floor := self._floor_stop(sense, strength)):
                reason = reason or self._floor_reason(floor, "no descent toward it")
            elif strength is Strength.CORRECTIVE and self._points_at_cleared_threat(sense):
                reason = reason or "multi-threat: no manoeuvre toward a threat level flight clears"
            else:
                usable.append(strength)
        helpful = []
        for strength in usable:
            misses = self._misses(sense, strength)
            if self._helps(misses):
                helpful.append((strength, self._separation(sense, misses)))
        if not helpful:
            return None
        strength, sep = next(((s, sep) for s, sep in helpful if sep >= alim), helpful[-1])
        if len(helpful) < len(usable) and strength is helpful[-1][0] and sep < alim:
            reason = reason or "stronger RA would reduce the vertical miss"
        return strength, sep, reason, self._separation(sense, self._misses(sense, usable[-1]))

    # -- selection -------------------------------------------------------------------------------------------
    def resolve(self, now_s: float, threats: list[Threat], v0_mps: float, alim_m: float,
                inhibits: Inhibits = NO_INHIBITS, own_altitude_m: float = 0.0,
                floors: Floors = NO_FLOORS) -> Resolution | None:
        """The RA for ownship given every current RA threat. None when there is none, or when no allowed RA
        would leave more vertical miss than doing nothing (the threats then stay TAs): see `blocked`.
        floors: the heights no RA may take ownship below (advisory/inhibits.py Floors), own_altitude_m's frame."""
        self.blocked = ""
        if self._last_s is not None and now_s > self._last_s:
            self._intervals.append(now_s - self._last_s)
        self._last_s = now_s
        if not threats:
            self.current = None
            self._references.clear()
            self._floored = False
            return None
        threats = [th if th.key is not None else replace(th, key=i) for i, th in enumerate(threats)]
        self._threats, self._v0, self._alim, self._floors = threats, v0_mps, alim_m, floors
        self._floor_dz = {"descend": floors.descend_m - own_altitude_m,
                          "increase_descent": floors.increase_descent_m - own_altitude_m}
        references = self._references
        for key in [k for k in references if k not in {th.key for th in threats}]:
            del references[key]  # a threat that left; if it comes back, it joins anew
        joining = [th.key for th in threats if th.key not in references]
        if joining:  # doing nothing is the path ownship is on now: its vertical rate, or the RA being flown
            path = _Command(v0_mps, v0_mps, 1.0, 0.0) if self.current is None else \
                self._path(self.current.sense, self.current.strength,
                           delay_s=max(0.0, self._command_s + self._command_delay_s - now_s))
            for key in joining:
                references[key] = _Reference(now_s, own_altitude_m, path)
        self._do_nothing = [abs(references[th.key].displacement(now_s, own_altitude_m, max(th.t_cpa_s, 0.0))
                                - th.intruder_dz()) for th in threats]
        if self.current is None or self.current.composite:
            # A composite being flown is projected with only the rest of its response delay, and kept when no
            # sense RA does better: an RA in progress never ends while it still has threats.
            flying = None
            if self.current is not None:
                flying = self._composite(alim_m, delay_s=max(0.0, self._command_s + self._command_delay_s - now_s),
                                         judged=False)
            chosen = self._select(alim_m, inhibits, flying)
            if chosen is None:
                self.current = None
                return None
            if self.current is None or chosen.sense is not None:
                self._changed_s = self._command_s = now_s
                self._command_delay_s = self.profile.response.delay_s
            self.current = chosen
            return chosen
        self.current = self._update(now_s, alim_m, inhibits)
        return self.current

    def _resolution(self, sense, strength, reversed_=False, reason="", misses=None) -> Resolution:
        target, _, _ = self._command(sense, strength, self._v0)
        if sense is not None and strength is Strength.PREVENTIVE:
            target = None
        if misses is None:
            misses = self._misses(sense, strength, reversal=reversed_)
        seps = self._separations(sense, misses)
        return Resolution(sense, strength, target, reversed_, min(seps), self._crossing(self._threats, sense), reason,
                          tuple((th.key, sep) for th, sep in zip(self._threats, seps)))

    def _select(self, alim: float, inhibits: Inhibits, flying: Resolution | None = None) -> Resolution | None:
        """The RA to fly now; flying: the composite being flown, if one is (it competes as the composite does and
        is the fallback)."""
        options = {}
        for sense in (Sense.DESCEND, Sense.CLIMB):
            reason = "descend inhibited (low altitude): no corrective descent" if sense is Sense.DESCEND and inhibits.descend else ""
            option = self._option(sense, self._initial_strengths(sense, inhibits), alim, reason)
            if option is not None:
                options[sense] = option
        # Sense capability: what its strongest usable first RA achieves (TCAS models the corrective response).
        capability = {s: options[s][3] for s in options}

        def best(pool):
            top = max(capability[s] for s in pool)
            tied = [s for s in pool if capability[s] >= top - TIE_M]
            return Sense.DESCEND if Sense.DESCEND in tied and not inhibits.descend else tied[-1]

        non_crossing = [s for s in options if not self._crossing(self._threats, s) and options[s][1] >= alim]
        if non_crossing:
            sense = best(non_crossing)
            strength, _, reason, _ = options[sense]
            return self._resolution(sense, strength, reason=reason)
        composite = flying or self._composite(alim)
        if composite is not None and (composite.separation_m >= alim or not options or
                                      composite.separation_m > max(options[s][1] for s in options)):
            return composite
        if not options:
            self.blocked = "no allowed RA beats doing nothing: TA kept"
            return None
        sense = best(list(options))
        strength, _, reason, _ = options[sense]
        return self._resolution(sense, strength, reason=reason)

    def _composite(self, alim: float, delay_s: float | None = None, judged: bool = True) -> Resolution | None:
        """Threats above and below: Don't Climb against the upper, Don't Descend against the lower (level).
        delay_s: the response delay left (a composite being flown); judged: by rule 1 and on the threats' sides
        (not the one in progress: it stays until a sense RA does better, never dropped with threats left)."""
        above = any(th.sz_m > COALTITUDE_M for th in self._threats)
        below = any(th.sz_m < -COALTITUDE_M for th in self._threats)
        if judged and not (above and below):
            return None
        strength = Strength.PREVENTIVE if abs(self._v0) <= LEVEL_MPS else Strength.LEVEL_OFF
        misses = self._misses(None, strength, delay_s=delay_s)
        if judged and not self._helps(misses):
            return None
        return self._resolution(None, strength, reason="composite: threats above and below", misses=misses)

    def _strongest_flyable(self, sense: Sense, inhibits: Inhibits) -> Strength | None:
        """The strongest strength this sense could still be given: allowed by the inhibits, not ruled out by a
        floor, not a descent again after levelling off at one; None when only the RA being flown is left. A sense
        is judged by what it may fly: a DON'T CLIMB below the descend inhibit cannot become a DESCEND, so when
        the threat's descent overtakes it, reversing to a climb is the only help (TCAS II v7.1 booklet, "RA
        inhibits" and "Sense reversal"; Lincoln v2.1 encounter 1769, docs/advisories.md)."""
        for strength in (Strength.INCREASE, Strength.CORRECTIVE):
            if self._allowed(sense, strength, inhibits) and not (self._floored and sense is Sense.DESCEND) and \
                    not self._floor_stop(sense, strength):
                return strength
        return None

    def _update(self, now_s: float, alim: float, inhibits: Inhibits) -> Resolution:
        """Reverse, stop above a floor, turn composite, strengthen or weaken the RA being flown, or keep it (with
        its projections refreshed)."""
        current = self.current
        sense = current.sense
        r = self.profile.response
        delay_left = max(0.0, self._command_s + self._command_delay_s - now_s)
        misses_now = self._misses(sense, current.strength, delay_s=delay_left)
        now_sep = self._separation(sense, misses_now)
        # Doing nothing, for a strengthening or a reversal, is keeping the RA being flown, projected from ownship's
        # present state as TCAS II models every RA (v7.1 booklet, "Resolution Advisory Selection"). The path of the
        # RA's start may be one ownship has left: the descent a LEVEL OFF stopped, or a level-off that a DONT CLIMB
        # allows; judged against it, a strengthening the threat's manoeuvre needs was never issued.
        keep = [abs(m) for m in misses_now]
        dwell_over = now_s - self._changed_s >= DWELL_S
        t_min = min(th.t_cpa_s for th in self._threats)
        strongest = self._strongest_flyable(sense, inhibits)
        capable = now_sep if strongest is None else self._separation(sense, self._misses(sense, strongest))
        # Reversal: this sense cannot reach ALIM even at its strongest, the other sense can, or, where it cannot
        # either, leaves more (the sense "that provides the most vertical separation at CPA", as a first RA's).
        if (not current.reversed and t_min > MIN_REVERSAL_TIME_S and self._allowed(sense.opposite, Strength.CORRECTIVE, inhibits)
                and capable < alim):
            other = sense.opposite
            misses = self._misses(other, Strength.CORRECTIVE, reversal=True)
            reversed_sep = self._separation(other, misses)
            if (reversed_sep >= alim or reversed_sep > capable + TIE_M) and self._helps(misses, keep) and \
                    not self._floor_stop(other, Strength.CORRECTIVE, reversal=True) and \
                    not self._points_at_cleared_threat(other, misses_now):
                self._changed_s = self._command_s = now_s
                self._command_delay_s = r.strengthen_delay_s
                return self._resolution(other, Strength.CORRECTIVE, reversed_=True)
        # A floor: a commanded descent that, flown until the next assessment, could no longer stop above its
        # floor levels off now (booklet, "RA inhibits": a Descend RA in progress below the Descend inhibit becomes
        # a Don't Climb), whatever the dwell; so does an INCREASE DESCENT reaching its inhibit height (a level-off
        # is the one weakening every response model flies the same way).
        floor = self._floor_stop(sense, current.strength, delay_s=delay_left)
        if floor:
            self._floored = True
            self._changed_s = self._command_s = now_s
            self._command_delay_s = r.delay_s
            return self._resolution(sense, Strength.LEVEL_OFF, current.reversed,
                                    reason=self._floor_reason(floor, "levelled off above it"))
        # Several threats: where the RA being flown leaves a threat on its side short of ALIM and the composite
        # keeps ownship between them with more separation from each, the RA turns composite (booklet, "Multiple
        # threat encounters").
        if now_sep < alim and (composite := self._composite(alim)) is not None and \
                composite.separation_m > now_sep + TIE_M:
            self._changed_s = now_s
            if current.strength is not Strength.LEVEL_OFF:  # a new command (a LEVEL OFF is already being flown)
                self._command_s, self._command_delay_s = now_s, r.delay_s
            return composite
        if dwell_over and now_sep < alim:  # strengthen one step
            stronger = STRONGER.get(current.strength)
            if stronger is Strength.INCREASE and r.rate(sense is Sense.CLIMB, True) <= r.rate(sense is Sense.CLIMB):
                stronger = None  # no faster rate to ask for (a vehicle profile's single rate, advisory/vehicle.py)
            if stronger is not None and self._allowed(sense, stronger, inhibits) and \
                    not (self._floored and sense is Sense.DESCEND) and \
                    not self._floor_stop(sense, stronger, issuing=True) and not self._points_at_cleared_threat(sense, misses_now):
                misses = self._misses(sense, stronger)
                if self._helps(misses, keep) and self._separation(sense, misses) > now_sep:
                    self._changed_s = self._command_s = now_s
                    self._command_delay_s = self._command(sense, stronger, self._v0)[2]
                    return self._resolution(sense, stronger, current.reversed)
        if (dwell_over and current.strength in (Strength.CORRECTIVE, Strength.INCREASE)
                and sense.sign * self._v0 > 0.0):  # weaken to Level Off (v7.1)
            misses = self._misses(sense, Strength.LEVEL_OFF, delay_s=r.strengthen_delay_s)
            if self._separation(sense, misses) >= alim * WEAKEN_MARGIN and self._helps(misses):
                self._changed_s = now_s
                return self._resolution(sense, Strength.LEVEL_OFF, current.reversed, misses=misses)
        refreshed = self._resolution(sense, current.strength, misses=misses_now)
        return replace(current, separation_m=refreshed.separation_m, crossing=refreshed.crossing,
                       separations_m=refreshed.separations_m)
