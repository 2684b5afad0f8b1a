"""RA sense and strength like TCAS II: one vertical manoeuvre for ownship against every RA threat.

Projection (DO-185B standard response): after delay d ownship accelerates at a to the target rate and
holds it; the intruder keeps its vertical rate. For each sense the vertical separation at each threat's
CPA time t is
    climb:   sep = dz_own(t) - (sz + v_i t)        descend: sep = (sz + v_i t) - dz_own(t)
with sz = intruder - ownship altitude now. The sense achieving ALIM without crossing the intruder's
altitude is preferred; otherwise the sense with the larger least separation. The strength is the weakest
that achieves ALIM: preventive (keep the current rate: "don't descend"/"don't climb"), level off, corrective
(climb/descend at the response rate), increase (the strengthened rate). As the geometry evolves an RA is
strengthened, weakened or reversed (reversal uses the strengthened response: 2.5 s, 0.35 g in TCAS II).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from enum import Enum

from avionics.advisory.tables import AlertProfile

DWELL_S = 2.0  # least time between strength changes, so an RA does not flicker with noise
MIN_REVERSAL_TIME_S = 4.0  # no reversal this close to CPA: it could not take effect
TIE_M = 1.0  # senses whose projected separations differ by less than this are tied
WEAKEN_MARGIN = 1.1  # an RA weakens only once the weaker strength beats ALIM by 10 %


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
    LEVEL_OFF = "level_off"
    CORRECTIVE = "corrective"  # climb/descend at the response rate
    INCREASE = "increase"  # at the strengthened rate


ORDER = [Strength.PREVENTIVE, Strength.LEVEL_OFF, Strength.CORRECTIVE, Strength.INCREASE]


@dataclass(frozen=True, slots=True)
class Threat:
    """An RA threat's vertical picture: relative altitude now, intruder vertical rate, time to CPA."""

    sz_m: float  # intruder - ownship altitude, in a common datum
    vz_intruder_mps: float
    t_cpa_s: float


@dataclass(frozen=True, slots=True)
class Resolution:
    sense: Sense
    strength: Strength
    target_rate_mps: float | None  # None for preventive: a limit (>= 0 climb sense, <= 0 descend), no target
    reversed: bool
    separation_m: float  # least projected separation at CPA over the threats, with this RA flown
    crossing: bool

    def words(self) -> str:
        """TCAS-style phrase: CLIMB, DESCEND, DONT CLIMB, LEVEL OFF, INCREASE CLIMB, CLIMB NOW, ..."""
        s = self.sense
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


class ResolutionLogic:
    """One ownship manoeuvre for all RA threats, kept consistent across assessments."""

    def __init__(self, profile: AlertProfile):
        self.profile = profile
        self.current: Resolution | None = None
        self._changed_s = -math.inf
        self._command_s = -math.inf  # when the manoeuvre being flown was commanded
        self._command_delay_s = 0.0

    # -- projection ------------------------------------------------------------------------------------------
    def _target(self, sense: Sense, strength: Strength, v0: float) -> tuple[float, float, float]:
        """(target rate, accel, delay) of a strength; preventive and level-off are targets too."""
        r = self.profile.response
        if strength is Strength.PREVENTIVE:  # keep the current rate, but never toward the threat
            target = max(v0, 0.0) if sense is Sense.CLIMB else min(v0, 0.0)
            return target, r.accel_mps2, r.delay_s
        if strength is Strength.LEVEL_OFF:
            return 0.0, r.accel_mps2, r.delay_s
        if strength is Strength.CORRECTIVE:
            rate = sense.sign * r.rate_mps
            target = max(v0, rate) if sense is Sense.CLIMB else min(v0, rate)
            return target, r.accel_mps2, r.delay_s
        rate = sense.sign * r.strengthen_rate_mps
        target = max(v0, rate) if sense is Sense.CLIMB else min(v0, rate)
        return target, r.strengthen_accel_mps2, r.strengthen_delay_s

    def separation(self, threats: list[Threat], sense: Sense, strength: Strength, v0: float,
                   reversal: bool = False, delay_s: float | None = None) -> float:
        """Least projected separation at CPA with this RA flown; delay_s overrides the response delay
        (an RA already being answered has only the rest of its delay left)."""
        target, accel, delay = self._target(sense, strength, v0)
        if reversal:  # reversals use the strengthened response timing at the normal rate
            r = self.profile.response
            accel, delay = r.strengthen_accel_mps2, r.strengthen_delay_s
        if delay_s is not None:
            delay = delay_s
        seps = []
        for th in threats:
            t = max(th.t_cpa_s, 0.0)
            intruder = th.sz_m + th.vz_intruder_mps * t
            own = own_displacement(t, v0, target, accel, delay)
            seps.append(sense.sign * (own - intruder))
        return min(seps)

    # -- selection -------------------------------------------------------------------------------------------
    def _allowed(self, sense: Sense, strength: Strength, agl_m: float | None) -> bool:
        if agl_m is None or sense is Sense.CLIMB:
            return True
        if strength in (Strength.CORRECTIVE, Strength.INCREASE) and agl_m < self.profile.descend_inhibit_below_agl_m:
            return False
        return not (strength is Strength.INCREASE and agl_m < self.profile.increase_descent_inhibit_below_agl_m)

    def _weakest(self, threats, sense: Sense, v0: float, alim: float, agl_m, at_most: Strength,
                 current: Strength | None = None, delay_left_s: float | None = None) -> Strength:
        """The weakest strength up to at_most that achieves ALIM; the strongest of those if none does.
        With a current strength, weaker ones must beat ALIM by WEAKEN_MARGIN (no flicker at the boundary),
        the current and weaker ones keep what is left of the current delay, stronger ones get the
        strengthened response."""
        allowed = [s for s in ORDER[:ORDER.index(at_most) + 1] if self._allowed(sense, s, agl_m)]
        if sense.sign * v0 >= 0:
            allowed = [s for s in allowed if s is not Strength.LEVEL_OFF]  # nothing to level off from
        else:  # moving toward the threat: keeping the rate is no RA, changing it is corrective
            allowed = [s for s in allowed if s is not Strength.PREVENTIVE]
        for strength in allowed:
            needed, delay = alim, None
            if current is not None:
                rank, current_rank = ORDER.index(strength), ORDER.index(current)
                needed = alim * WEAKEN_MARGIN if rank < current_rank else alim
                delay = delay_left_s if rank <= current_rank else self.profile.response.strengthen_delay_s
            if self.separation(threats, sense, strength, v0, delay_s=delay) >= needed:
                return strength
        return allowed[-1] if allowed else Strength.PREVENTIVE

    @staticmethod
    def _crossing(threats: list[Threat], sense: Sense) -> bool:
        """Does this sense take ownship through an intruder's current altitude?"""
        return any(sense.sign * th.sz_m > 0 for th in threats)

    def _resolution(self, threats, sense, strength, v0, reversed_=False) -> Resolution:
        target, _, _ = self._target(sense, strength, v0)
        return Resolution(sense, strength, None if strength is Strength.PREVENTIVE else target, reversed_,
                          self.separation(threats, sense, strength, v0, reversal=reversed_),
                          self._crossing(threats, sense))

    def resolve(self, now_s: float, threats: list[Threat], v0_mps: float, agl_m: float | None,
                alim_m: float) -> Resolution | None:
        """The RA for ownship given every current RA threat (None when there is none)."""
        if not threats:
            self.current = None
            return None
        if self.current is None:
            self.current = self._select(threats, v0_mps, agl_m, alim_m)
            self._changed_s = self._command_s = now_s
            self._command_delay_s = self.profile.response.delay_s
            return self.current
        current = self.current
        sense = current.sense
        delay_left = max(0.0, self._command_s + self._command_delay_s - now_s)
        strength = self._weakest(threats, sense, v0_mps, alim_m, agl_m, Strength.INCREASE, current.strength,
                                 delay_left)
        # Reversal: this sense cannot reach ALIM even strengthened, the other sense can.
        best_here = self.separation(threats, sense, Strength.INCREASE, v0_mps)
        other = sense.opposite
        t_min = min(th.t_cpa_s for th in threats)
        if (best_here < alim_m and not current.reversed and t_min > MIN_REVERSAL_TIME_S
                and self._allowed(other, Strength.CORRECTIVE, agl_m)):
            reverse_sep = self.separation(threats, other, Strength.CORRECTIVE, v0_mps, reversal=True)
            if reverse_sep >= alim_m:
                self.current = self._resolution(threats, other, Strength.CORRECTIVE, v0_mps, reversed_=True)
                self._changed_s = self._command_s = now_s
                self._command_delay_s = self.profile.response.strengthen_delay_s
                return self.current
        if strength is not current.strength and now_s - self._changed_s >= DWELL_S:
            if ORDER.index(strength) > ORDER.index(current.strength):  # strengthening: a new manoeuvre
                self._command_s, self._command_delay_s = now_s, self.profile.response.strengthen_delay_s
            self.current = self._resolution(threats, sense, strength, v0_mps, current.reversed)
            self._changed_s = now_s
        else:
            self.current = self._resolution(threats, sense, current.strength, v0_mps, current.reversed)
        return self.current

    def _select(self, threats, v0, agl_m, alim) -> Resolution:
        senses = [s for s in (Sense.CLIMB, Sense.DESCEND) if self._allowed(s, Strength.CORRECTIVE, agl_m)]
        best = {s: self.separation(threats, s, Strength.CORRECTIVE, v0) for s in senses}
        non_crossing = [s for s in senses if not self._crossing(threats, s) and best[s] >= alim]
        pool = non_crossing or senses
        top = max(best[s] for s in pool)
        sense = next(s for s in pool if best[s] >= top - TIE_M)  # near-ties go to climb, away from the ground
        # A first RA is at most corrective (TCAS II never opens with an increase RA).
        strength = self._weakest(threats, sense, v0, alim, agl_m, Strength.CORRECTIVE)
        return self._resolution(threats, sense, strength, v0)
