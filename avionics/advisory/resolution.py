"""RA sense and strength like TCAS II v7.1: one vertical manoeuvre for ownship against every RA threat.

Projection (DO-185B standard response, FAA "Introduction to TCAS II v7.1", "Resolution Advisory
Selection": the logic models upward and downward RAs to CPA): after delay d ownship accelerates at a to the
target rate and holds it; each intruder keeps its vertical rate. Against threat k at its CPA time t_k:

    miss_k(RA)  = dz_own(t_k) - (sz_k + v_k t_k)          sz_k = intruder - ownship altitude now
    sep_k(RA)   = sigma_k * miss_k(RA)                     sigma_k = +1 passing above the threat, -1 below

The rules, in the order they apply (docs/advisories.md has the table with sources and worked examples):
1. Never worse than doing nothing: a first or weakened RA whose least |miss_k| over the threats is smaller
   than that of the path ownship was on when the RA began (at the first RA: keeping the current vertical
   rate), or a strengthened or reversed RA whose least |miss_k| is smaller than that of the RA being flown
   (projected from ownship's present state), is never issued.
2. Sense: the sense that crosses no threat's altitude when it achieves ALIM; otherwise, against threats
   above and below, a composite RA (Don't Climb + Don't Descend: level) when it does better than either
   sense; otherwise the sense with the larger least separation. Ties within TIE_M go to descend (DO-185B
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
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from enum import Enum

from avionics.advisory.inhibits import NO_INHIBITS, Inhibits
from avionics.advisory.tables import AlertProfile

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

    @property
    def composite(self) -> bool:
        return self.sense is None

    def sense_against(self, threat: Threat) -> Sense:
        """The sense this RA has against one threat (a composite RA moves away from each)."""
        if self.sense is not None:
            return self.sense
        return Sense.CLIMB if threat.sz_m < 0.0 else Sense.DESCEND

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


@dataclass(frozen=True, slots=True)
class _Reference:
    """The path ownship was on when the RA began: 'doing nothing'."""

    time_s: float
    altitude_m: float
    rate_mps: float

    def displacement(self, now_s: float, altitude_m: float, t: float) -> float:
        return self.altitude_m + self.rate_mps * (now_s + t - self.time_s) - altitude_m


class ResolutionLogic:
    """One ownship manoeuvre for all RA threats, kept consistent across assessments."""

    def __init__(self, profile: AlertProfile):
        self.profile = profile
        self.current: Resolution | None = None
        self._changed_s = -math.inf
        self._command_s = -math.inf  # when the manoeuvre being flown was commanded
        self._command_delay_s = 0.0
        self._reference: _Reference | None = None
        self.blocked = ""  # why the last resolve() gave no RA although there were threats
        # the picture of the assessment being resolved
        self._threats: list[Threat] = []
        self._v0 = 0.0
        self._do_nothing_m = 0.0

    # -- projection ------------------------------------------------------------------------------------------
    def _command(self, sense: Sense | None, strength: Strength, v0: float) -> tuple[float, float, float]:
        """(target rate, accel, delay) of an RA; preventive and level-off are targets too."""
        r = self.profile.response
        if sense is None or strength is Strength.LEVEL_OFF:
            return 0.0, r.accel_mps2, r.delay_s
        if strength is Strength.PREVENTIVE:  # keep the current rate, but never toward the threat
            return (max(v0, 0.0) if sense is Sense.CLIMB else min(v0, 0.0)), r.accel_mps2, r.delay_s
        strong = strength is Strength.INCREASE
        rate = sense.sign * (r.strengthen_rate_mps if strong else r.rate_mps)
        target = max(v0, rate) if sense is Sense.CLIMB else min(v0, rate)
        return target, (r.strengthen_accel_mps2 if strong else r.accel_mps2), \
            (r.strengthen_delay_s if strong else r.delay_s)

    def _misses(self, sense: Sense | None, strength: Strength, reversal: bool = False,
                delay_s: float | None = None) -> list[float]:
        """miss_k = ownship - intruder altitude at each threat's CPA with this RA flown."""
        target, accel, delay = self._command(sense, strength, self._v0)
        if reversal:  # reversals use the strengthened response timing at the normal rate
            accel, delay = self.profile.response.strengthen_accel_mps2, self.profile.response.strengthen_delay_s
        if delay_s is not None:
            delay = delay_s
        return [own_displacement(max(th.t_cpa_s, 0.0), self._v0, target, accel, delay) - th.intruder_dz()
                for th in self._threats]

    def _separation(self, sense: Sense | None, misses: list[float]) -> float:
        if sense is not None:
            return min(sense.sign * m for m in misses)
        return min((1.0 if th.sz_m < 0.0 else -1.0) * m for th, m in zip(self._threats, misses))

    def separation(self, threats: list[Threat], sense: Sense | None, strength: Strength, v0: float,
                   reversal: bool = False, delay_s: float | None = None) -> float:
        """Least projected separation at CPA with this RA flown; delay_s overrides the response delay
        (an RA already being answered has only the rest of its delay left)."""
        self._threats, self._v0 = threats, v0
        return self._separation(sense, self._misses(sense, strength, reversal, delay_s))

    def _helps(self, misses: list[float], do_nothing_m: float | None = None) -> bool:
        """Rule 1: no RA leaves less vertical miss than doing nothing (by default the path of the RA's start)."""
        reference = self._do_nothing_m if do_nothing_m is None else do_nothing_m
        return min(abs(m) for m in misses) >= reference - NEVER_WORSE_TOLERANCE_M

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
        """The weakest helpful strength achieving ALIM, else the strongest helpful one; None if none helps."""
        helpful = []
        for strength in strengths:
            misses = self._misses(sense, strength)
            if self._helps(misses):
                helpful.append((strength, self._separation(sense, misses)))
        if not helpful:
            return None
        strength, sep = next(((s, sep) for s, sep in helpful if sep >= alim), helpful[-1])
        if len(helpful) < len(strengths) and strength is helpful[-1][0] and sep < alim:
            reason = reason or "stronger RA would reduce the vertical miss"
        return strength, sep, reason

    # -- selection -------------------------------------------------------------------------------------------
    def resolve(self, now_s: float, threats: list[Threat], v0_mps: float, alim_m: float,
                inhibits: Inhibits = NO_INHIBITS, own_altitude_m: float = 0.0) -> Resolution | None:
        """The RA for ownship given every current RA threat. None when there is none, or when no allowed RA
        would leave more vertical miss than doing nothing (the threats then stay TAs): see `blocked`."""
        self.blocked = ""
        if not threats:
            self.current, self._reference = None, None
            return None
        if self._reference is None:
            self._reference = _Reference(now_s, own_altitude_m, v0_mps)
        self._threats, self._v0 = threats, v0_mps
        ref = self._reference
        self._do_nothing_m = min(abs(ref.displacement(now_s, own_altitude_m, max(th.t_cpa_s, 0.0)) - th.intruder_dz())
                                 for th in threats)
        if self.current is None or self.current.composite:
            chosen = self._select(alim_m, inhibits)
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

    def _resolution(self, sense, strength, reversed_=False, reason="") -> Resolution:
        target, _, _ = self._command(sense, strength, self._v0)
        if sense is not None and strength is Strength.PREVENTIVE:
            target = None
        misses = self._misses(sense, strength, reversal=reversed_)
        return Resolution(sense, strength, target, reversed_, self._separation(sense, misses),
                          self._crossing(self._threats, sense), reason)

    def _select(self, alim: float, inhibits: Inhibits) -> Resolution | None:
        options = {}
        for sense in (Sense.DESCEND, Sense.CLIMB):
            reason = "descend inhibited (low altitude): no corrective descent" if sense is Sense.DESCEND and inhibits.descend else ""
            option = self._option(sense, self._initial_strengths(sense, inhibits), alim, reason)
            if option is not None:
                options[sense] = option
        # Sense capability: what its strongest allowed first RA achieves (TCAS models the corrective response).
        capability = {s: self._separation(s, self._misses(s, self._initial_strengths(s, inhibits)[-1]))
                      for s in options}

        def best(pool):
            top = max(capability[s] for s in pool)
            tied = [s for s in pool if capability[s] >= top - TIE_M]
            return Sense.DESCEND if Sense.DESCEND in tied and not inhibits.descend else tied[-1]

        non_crossing = [s for s in options if not self._crossing(self._threats, s) and options[s][1] >= alim]
        if non_crossing:
            sense = best(non_crossing)
            strength, _, reason = options[sense]
            return self._resolution(sense, strength, reason=reason)
        composite = self._composite(alim)
        if composite is not None and (composite.separation_m >= alim or not options or
                                      composite.separation_m > max(options[s][1] for s in options)):
            return composite
        if not options:
            self.blocked = "no allowed RA beats doing nothing: TA kept"
            return None
        sense = best(list(options))
        strength, _, reason = options[sense]
        return self._resolution(sense, strength, reason=reason)

    def _composite(self, alim: float) -> Resolution | None:
        """Threats above and below: Don't Climb against the upper, Don't Descend against the lower (level)."""
        above = any(th.sz_m > COALTITUDE_M for th in self._threats)
        below = any(th.sz_m < -COALTITUDE_M for th in self._threats)
        if not (above and below):
            return None
        strength = Strength.PREVENTIVE if abs(self._v0) <= LEVEL_MPS else Strength.LEVEL_OFF
        if not self._helps(self._misses(None, strength)):
            return None
        return self._resolution(None, strength, reason="composite: threats above and below")

    def _update(self, now_s: float, alim: float, inhibits: Inhibits) -> Resolution:
        """Strengthen, weaken or reverse the RA being flown, or keep it (with its projections refreshed)."""
        current = self.current
        sense = current.sense
        delay_left = max(0.0, self._command_s + self._command_delay_s - now_s)
        misses_now = self._misses(sense, current.strength, delay_s=delay_left)
        now_sep = self._separation(sense, misses_now)
        # Doing nothing, for a strengthening or a reversal, is keeping the RA being flown, projected from ownship's
        # present state as TCAS II models every RA (v7.1 booklet, "Resolution Advisory Selection"). The path of the
        # RA's start may be one ownship has left: the descent a LEVEL OFF stopped, or a level-off that a DONT CLIMB
        # allows; judged against it, a strengthening the threat's manoeuvre needs was never issued.
        keep_m = min(abs(m) for m in misses_now)
        dwell_over = now_s - self._changed_s >= DWELL_S
        t_min = min(th.t_cpa_s for th in self._threats)
        strongest = Strength.INCREASE if self._allowed(sense, Strength.INCREASE, inhibits) else Strength.CORRECTIVE
        # Reversal: this sense cannot reach ALIM even at its strongest, the other sense can.
        if (not current.reversed and t_min > MIN_REVERSAL_TIME_S and self._allowed(sense.opposite, Strength.CORRECTIVE, inhibits)
                and self._separation(sense, self._misses(sense, strongest)) < alim):
            other = sense.opposite
            misses = self._misses(other, Strength.CORRECTIVE, reversal=True)
            if self._separation(other, misses) >= alim and self._helps(misses, keep_m):
                self._changed_s = self._command_s = now_s
                self._command_delay_s = self.profile.response.strengthen_delay_s
                return self._resolution(other, Strength.CORRECTIVE, reversed_=True)
        if dwell_over and now_sep < alim:  # strengthen one step
            stronger = STRONGER.get(current.strength)
            if stronger is not None and self._allowed(sense, stronger, inhibits):
                misses = self._misses(sense, stronger)
                if self._helps(misses, keep_m) and self._separation(sense, misses) > now_sep:
                    self._changed_s = self._command_s = now_s
                    self._command_delay_s = self._command(sense, stronger, self._v0)[2]
                    return self._resolution(sense, stronger, current.reversed)
        if (dwell_over and current.strength in (Strength.CORRECTIVE, Strength.INCREASE)
                and sense.sign * self._v0 > 0.0):  # weaken to Level Off (v7.1)
            misses = self._misses(sense, Strength.LEVEL_OFF, delay_s=self.profile.response.strengthen_delay_s)
            if self._separation(sense, misses) >= alim * WEAKEN_MARGIN and self._helps(misses):
                self._changed_s = now_s
                return replace(self._resolution(sense, Strength.LEVEL_OFF, current.reversed),
                               separation_m=self._separation(sense, misses))
        return replace(current, separation_m=now_sep, crossing=self._crossing(self._threats, sense))
