"""An active-surveillance track's altitude and vertical rate from quantised altitude replies, as TCAS II reads them.

Why: a Mode C reply gives the 100 ft level the intruder is in, not its altitude. Taken as a white 8.8 m error
(the quantum's q / sqrt(12)) by a Kalman filter, a few level steps of a young track read as a fast climb: on NASA's
`scenario_6` (an intruder 280 m below, climbing at 2.4 m/s) the sensor track's vertical rate read 10.2 m/s at its
first confirmed second, its vertical tau 26 s instead of 105, and the TA came 7.5-8.5 s before TCAS3D's
(docs/tracking.md). Neither does a quantum behave like white noise: the error is the altitude's place inside its
level, the same from one reply to the next while the aircraft stays in it.

What TCAS II does (the CAS logic's 100 ft vertical tracker, RTCA DO-185B Vol. II; the parameter values below are
those of the TCAS II Version 7 logic as the public simulator ledieuke/tcas_simulator transcribes them,
simulation/tcasConstant.py): the rate comes from the *times of level transitions*, a level of q crossed every
t_bin seconds being a rate of q / t_bin, and the altitude from the level and the time since the last transition.
A track is in one of five states:
- new: no transition yet. Rate 0; it is bounded by +-q / (time since the first reply).
- guess: one transition (or a jump of several levels). Rate GUESRATE in its direction; with no second transition
  within TGOLEV, level. TCAS decays the guess by ZDDECAY = 0.9 a reply without a second transition; here it is held,
  capped by what the replies allow (no second transition for s seconds: at most q / s), which put NASA's
  scenario_6 TA within 3 s of TCAS3D where the decay left it 4.5 s late (docs/tracking.md, measured).
- trend: a second transition the same way. t_bin is the time spent in the level just left (at least TBINMIN once
  the track is TINITZD old), then averaged over the last levels (up to MAXBINS, within MAXZDTIME): each expected
  transition moves t_bin by (levels crossed / levels averaged) of the difference (EARLYLATE off schedule restarts
  the average). A transition that is late by more than LATESLACK puts the altitude at the level's edge and slows
  the rate; by more than LATELEVEL, level.
- level: no transition when one was due. Rate 0.
- oscillating: a transition against the previous one (an aircraft sitting on a boundary): rate 0. A reversal
  sooner than ZRJIT of t_bin into a trend is a reply jittering across the boundary and is ignored.
Left out: TCAS's reply credibility test (association's gate on the vertical prediction does that job here), its
alpha-beta smoothing of rates above a level a second, and its 25 ft tracker (a Mode S 25 ft reply's error is 2.2 m,
which the Kalman filter handles: such tracks keep it).

For the pipeline's covariance, the rate is taken as uniform between the tracker's bounds (its zd inner and outer
limits: the rates consistent with the transition times seen, each known to within the reply interval), and the
altitude as uniform within its level (q^2 / 12), widened by the rate's uncertainty when predicted.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from avionics.base.units import FPM, FT
from avionics.tracking.record import UNKNOWN_VRATE_SIGMA_MPS

# TCAS II Version 7 CAS logic, vertical tracking (DO-185B; values as transcribed in tcas_simulator's tcasConstant.py)
GUESRATE_MPS = 480.0 * FPM  # the rate assumed after a single transition
ZDLIKELY_MPS = 3000.0 * FPM  # the fastest likely rate: a guess's outer bound once the track is TINITZD old
TGOLEV_S = 20.5  # a guess with no second transition for this long is level
TINITZD_S = 5.5  # a track younger than this may cross its first levels in less than TBINMIN
TBINMIN_S = 2.0
LATESLACK_S = 0.5  # a trend's transition overdue by more than this: at the level's edge, slowing
LATELEVEL_S = 4.5  # ... by more than this: level
EARLYLATE_S = 1.5  # a trend's transition this far off schedule restarts t_bin's average
MAXBINS = 8  # levels averaged into t_bin at most ...
MAXZDTIME_S = 17.0  # ... and over this long at most
ZRJIT = 0.24  # a reversal this early into a level (as a fraction of t_bin) is jitter across the boundary
DELZDT_S = 4.0  # a trend predicted out of its level corrects its rate over at least this long

# Quanta of altitude replies: Mode C's 100 ft (and Mode S's 25 ft, left to the Kalman filter: see above)
MODE_C_QUANTUM_M = 100.0 * FT


def mode_c_quantum(altitude_sigma_m: float | None) -> float | None:
    """The 100 ft quantum whose uniform error a reported altitude's declared sigma is (q / sqrt(12) to 1 %, as
    DEGAS and the simulator declare a Mode C altitude: sitl/avionics_sitl/sensors.py), else None."""
    if altitude_sigma_m is None:
        return None
    q = altitude_sigma_m * math.sqrt(12.0)
    return MODE_C_QUANTUM_M if abs(q - MODE_C_QUANTUM_M) <= 0.01 * MODE_C_QUANTUM_M else None


@dataclass
class QuantisedAltitudeTrack:
    """The altitude and vertical rate of one intruder from its quantised altitude replies (module doc)."""

    q: float
    t_start: float
    t_last: float  # time of the last reply
    level: float  # the level (reported altitude) the track is in
    t_tran: float  # time of the reply that showed the last transition (t_start before any)
    direc: int = 0  # direction of the last transition: +1 up, -1 down
    state: str = "new"
    t_bin: float = math.inf  # a trend's seconds per level
    bins: int = 1  # levels averaged into t_bin
    z: float = 0.0  # altitude at t_last
    zd: float = 0.0  # vertical rate
    zd_lo: float = -math.inf  # the rates consistent with the transitions seen
    zd_hi: float = math.inf

    @classmethod
    def start(cls, t_s: float, altitude_m: float, quantum_m: float) -> QuantisedAltitudeTrack:
        return cls(quantum_m, t_s, t_s, altitude_m, t_s, z=altitude_m)

    # -- one reply ---------------------------------------------------------------------------------------------
    def update(self, t_s: float, altitude_m: float) -> None:
        dt = t_s - self.t_last
        if dt <= 0.0:
            return
        d = altitude_m - self.level
        n = int(round(abs(d) / self.q))
        if n == 0:
            self._no_transition(t_s, dt)
        else:
            self._transition(t_s, dt, altitude_m, n, 1 if d > 0 else -1)
        self.t_last = t_s

    def _no_transition(self, t: float, dt: float) -> None:
        since = t - self.t_tran
        if self.state == "new":
            self.zd_hi = self.q / (t - self.t_start)
            self.zd_lo = -self.zd_hi
        elif self.state == "guess":
            if since > TGOLEV_S:
                self._level(t)
            else:
                zp = self.z + self.zd * dt
                self.zd = self.direc * min(GUESRATE_MPS, self.q / since)
                self.z = self._in_level(zp)
                self.zd_lo, self.zd_hi = _ordered(0.0, self.direc * self.q / since)
        elif self.state == "trend":
            late = since - self.t_bin
            if late > LATELEVEL_S:
                self._level(t)
            elif late > LATESLACK_S:  # overdue: at the level's edge, the rate slowing to 0 at LATELEVEL
                self.zd = self.direc * self.q / (since + dt) * (LATELEVEL_S + dt / 2 - late) / (LATELEVEL_S + dt / 2)
                self.z = self.level + self.direc * self.q / 2.0
                self.zd_lo, self.zd_hi = _ordered(0.0, self.direc * self.q / since)
            else:
                zp = self.z + self.zd * dt
                self.z = self._in_level(zp)
                self.zd += (self.z - zp) / max(since, DELZDT_S)  # predicted out of the level: slower than thought
        else:  # level, oscillating
            self.zd_lo, self.zd_hi = _ordered(0.0, self.direc * self.q / since)

    def _transition(self, t: float, dt: float, altitude_m: float, n: int, s: int) -> None:
        since = t - self.t_tran
        t_prev = since / n  # seconds per level since the last transition
        if self.state in ("new", "level") or (n > 1 and self.state != "trend"):
            self._guess(t, dt, altitude_m, s, n)
        elif self.state in ("guess", "oscillating"):
            if s == self.direc:
                self._trend(t, dt, altitude_m, s, n, since, t_prev)
            else:
                self._oscillating(altitude_m, s)
        elif s != self.direc:  # a trend reversed
            if t_prev / self.t_bin <= ZRJIT:
                return  # jitter across the boundary just crossed: the reply is not taken
            self._oscillating(altitude_m, s)
        else:
            self._expected(t, dt, altitude_m, s, n, since, t_prev)
        self.level, self.t_tran, self.direc = altitude_m, t, s

    # -- the states --------------------------------------------------------------------------------------------
    def _guess(self, t, dt, altitude_m, s, n) -> None:
        young = t - self.t_start < TINITZD_S
        self.zd = s * GUESRATE_MPS
        self.z = altitude_m - s * self.q / 2.0 + self.zd * dt / 2.0  # crossed within the last interval
        outer = (n + 1) * s * self.q / (t - self.t_start) if young else s * ZDLIKELY_MPS
        self.zd_lo, self.zd_hi = _ordered(0.0, outer)
        self.state = "guess"

    def _trend(self, t, dt, altitude_m, s, n, since, t_prev) -> None:
        self.t_bin = t_prev if t - self.t_start < TINITZD_S else max(t_prev, TBINMIN_S)
        self.bins = 1
        self.zd = s * self.q / self.t_bin
        self.z = altitude_m - s * self.q / 2.0 + self.zd * dt / 2.0 if self.t_bin > dt else altitude_m
        # each transition is known to within a reply interval: since +- dt
        self.zd_lo, self.zd_hi = _ordered(n * s * self.q / (since + dt), n * s * self.q / max(since - dt, dt))
        self.state = "trend"

    def _expected(self, t, dt, altitude_m, s, n, since, t_prev) -> None:
        if abs(since - self.t_bin * n) > EARLYLATE_S:
            self.bins = n
        elif t_prev >= MAXZDTIME_S / 2.0:
            self.bins = 1
        else:
            self.bins = min(self.bins + n, MAXBINS, int(MAXZDTIME_S / t_prev))
        self.t_bin += (n / max(self.bins, n)) * (t_prev - self.t_bin)
        self.zd = s * self.q / self.t_bin
        self.level = altitude_m
        self.z = self._in_level(self.z + self.zd * dt)
        span = self.bins * self.t_bin  # the averaged levels' time, known to within a reply interval
        self.zd_lo, self.zd_hi = _ordered(self.zd * span / (span + dt), self.zd * span / max(span - dt, dt))
        self.state = "trend"

    def _oscillating(self, altitude_m, s) -> None:
        self.z = altitude_m - s * self.q / 3.0
        self.zd = 0.0
        self.zd_lo = self.zd_hi = 0.0
        self.state = "oscillating"

    def _level(self, t) -> None:
        self.z, self.zd = self.level, 0.0
        self.zd_lo, self.zd_hi = _ordered(0.0, self.direc * self.q / (t - self.t_tran))
        self.state = "level"

    def _in_level(self, z: float) -> float:
        return min(max(z, self.level - self.q / 2.0), self.level + self.q / 2.0)

    # -- outputs -----------------------------------------------------------------------------------------------
    def rate_variance(self) -> float:
        """The rate's variance about zd, the rate uniform between its bounds (the prior before a bound exists)."""
        if not (math.isfinite(self.zd_lo) and math.isfinite(self.zd_hi)):
            return UNKNOWN_VRATE_SIGMA_MPS**2
        mid = 0.5 * (self.zd_lo + self.zd_hi)
        return (self.zd_hi - self.zd_lo) ** 2 / 12.0 + (mid - self.zd) ** 2

    def predicted(self, t_s: float) -> tuple[float, float, float, float]:
        """(altitude, vertical rate, their variances) at t_s: straight on at the rate; the altitude uniform within
        its level at the last reply, widened by the rate's variance over the time since."""
        dt = t_s - self.t_last
        var_zd = self.rate_variance()
        return self.z + self.zd * dt, self.zd, self.q**2 / 12.0 + var_zd * dt * dt, var_zd

    def into(self, x: np.ndarray, p: np.ndarray, t_s: float) -> tuple[np.ndarray, np.ndarray]:
        """A published state (x (6,), p (6, 6): [e, n, alt, ve, vn, vu]) with its altitude and vertical rate taken
        from this track at t_s, uncorrelated with the rest and with each other."""
        x, p = np.array(x, float), np.array(p, float)
        z, zd, var_z, var_zd = self.predicted(t_s)
        x[2], x[5] = z, zd
        p[[2, 5], :] = 0.0
        p[:, [2, 5]] = 0.0
        p[2, 2], p[5, 5] = var_z, var_zd
        return x, p


def _ordered(a: float, b: float) -> tuple[float, float]:
    return (a, b) if a <= b else (b, a)
