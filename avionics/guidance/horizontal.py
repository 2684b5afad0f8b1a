"""The horizontal manoeuvre of a DO-365 alerter's conflicts: a track picked from the guidance bands (advisory/bands.py).

The resolution is DAIDALUS's (v2, gov.nasa.larcfm.ACCoRD; Daidalus.horizontalDirectionResolution(dir) ->
DaidalusRealBands.resolution -> BandsHysteresis.bandsHysteresis, the raw resolutions): when the ownship's present
track lies in a band at least as severe as the corrective region (is_up_from_corrective_region: MID or NEAR
with corrective_region MID), walk the bands left and right across the contiguous bands that are so severe; the
left resolution is the upper end of the first band below the corrective region met on the left (NONE, FAR or
RECOVERY), the right one the lower end of the first met on the right; -inf / +inf when the walk goes all the way
round (no resolution on that side), None (DAIDALUS: NaN) when the present track needs none. The preferred side is
the nearer one, right on a tie (BandsHysteresis.preferredDirectionHysteresis: actual_dir = mod_up <= mod_down).
In RECOVERY (the bands saturated: advisory/bands.py step 3) the same walk finds the recovery band.

Three departures from DAIDALUS, all ours:
- the target is the resolution plus guidance.track_margin_deg further in the turn's direction, as NASA ICAROUS flies
  DAIDALUS's preferred track resolution 5 deg past its edge (TrafficMonitor::MonitorTraffic, nasa/icarous): the
  band edge itself is where the loss of well clear begins; the margin is capped at half the resolution band, so
  the target stays inside it;
- the side chosen persists through the manoeuvre (a vehicle half-way through a right turn does not reverse because
  the left edge came nearer), unless it has no resolution any more: DAIDALUS keeps its preferred direction for
  persistence_time the same way (preferredDirectionHysteresis), we keep it until the conflict is over;
- a resolution is flown only where it leaves no intruder a smaller horizontal miss than the track flown now, each
  intruder on its present turn (seen between two bands: `turn_rates`) and the vehicle straight (the other side is
  tried, else none: `closest_horizontal_m`); a resolution that moves during the manoeuvre is followed under the
  same test, else the track flown is kept. DAIDALUS's bands project every aircraft straight, and its recovery
  resolution (saturated bands) only keeps the collision-avoidance cylinder, which the vertical separation may
  already keep: it can turn toward the intruder, and against a rotorcraft turning at 3 deg/s the resolution of
  the side kept moved round with it, second by second, into its arc (issue 27's property: the manoeuvre never
  leaves a smaller miss than flying the mission on).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

# An intruder's turn, seen between two bands: the miss a resolution leaves is predicted on its arc (closest_horizontal_m)
TURN_SAMPLE_S = 0.5
TURN_MIN_SPEED_MPS = 5.0  # slower, a track's direction is noise
TURN_MAX_GAP_S = 2.5  # bands come once a second: older ones say nothing of the turn now
# the MIT LL uncorrelated encounter models' turn-rate bins end at 8 deg/s (their `# boundaries`, \dot \psi, in
# eval/avionics_eval/encounter_models/models); past 12 deg/s an apparent turn is the track's noise
MAX_TURN_RATE_RPS = math.radians(12.0)

# BandsRegion.orderOfConflictRegion: NONE and RECOVERY both 0 (resolutions), FAR 1, MID 2, NEAR 3
_CONFLICT_ORDER = {"NONE": 0, "RECOVERY": 0, "FAR": 1, "MID": 2, "NEAR": 3}
ALMOST_DEG = 1e-6


@dataclass(frozen=True, slots=True)
class TrackResolution:
    """The two raw resolutions of DAIDALUS (degrees true, 0..360; -inf / +inf: none on that side) and the
    bands they lie in (the band's other end, for the margin; its region: NONE, FAR or RECOVERY)."""

    left_deg: float
    right_deg: float
    left_band: tuple[float, float, str] | None  # (lower, upper, region) of the left resolution's band
    right_band: tuple[float, float, str] | None
    track_deg: float  # the present track they are for

    @property
    def preferred_right(self) -> bool:
        """BandsHysteresis.preferredDirectionHysteresis without hysteresis: the nearer side (mod_up <= mod_down),
        right on a tie; the side that has one when only one has."""
        if math.isinf(self.left_deg) or math.isinf(self.right_deg):
            return not math.isinf(self.right_deg)
        return (self.right_deg - self.track_deg) % 360.0 <= (self.track_deg - self.left_deg) % 360.0 + ALMOST_DEG


def _severe(region: str, corrective: str) -> bool:
    """is_up_from_corrective_region: a conflict band at least as severe as the corrective region."""
    return region in ("FAR", "MID", "NEAR") and _CONFLICT_ORDER[region] >= _CONFLICT_ORDER[corrective]


def _index_of(intervals, track_deg: float) -> int:
    """The band of the present track (advisory/bands.py Bands.region_at's rule: at a shared end the resolution
    side wins, else the more severe), -1 when none holds it."""
    hits = [i for i, iv in enumerate(intervals) if iv.lower - ALMOST_DEG <= track_deg <= iv.upper + ALMOST_DEG]
    if not hits:
        return -1
    for i in hits:
        if intervals[i].region in ("NONE", "RECOVERY"):
            return i
    return max(hits, key=lambda i: _CONFLICT_ORDER.get(intervals[i].region, -1))


def track_resolution(intervals, track_deg: float, corrective: str = "MID") -> TrackResolution | None:
    """DAIDALUS's raw track resolutions (BandsHysteresis.bandsHysteresis) for the present track over the track
    bands (advisory/bands.py Bands.track_deg: increasing intervals covering 0..360); None when the present track
    is not in a band at least as severe as the corrective region (no resolution needed)."""
    track_deg %= 360.0
    idx = _index_of(intervals, track_deg)
    if idx < 0 or not _severe(intervals[idx].region, corrective):
        return None
    n = len(intervals)

    def walk(step: int):
        """The first band below the corrective region met turning that way; None when a severe band reaches
        more than half a turn that way (to_the_left fails: DAIDALUS leaves that side at infinity) or the walk
        goes all the way round."""
        i = idx
        for _ in range(n):
            iv = intervals[i]
            far = (track_deg - iv.lower) % 360.0 if step < 0 else (iv.upper - track_deg) % 360.0
            if 180.0 - ALMOST_DEG <= far < 360.0 - ALMOST_DEG:
                return None
            i = (i + step) % n
            if i == idx:
                return None
            if not _severe(intervals[i].region, corrective):
                return intervals[i]
        return None

    left, right = walk(-1), walk(+1)
    # the bands wrap at 0/360: a left band that ends at 360 ends where 0 is (DAIDALUS: raw_low = 0)
    left_deg = -math.inf if left is None else left.upper % 360.0
    right_deg = math.inf if right is None else right.lower % 360.0
    return TrackResolution(left_deg, right_deg, None if left is None else (left.lower, left.upper, left.region),
                           None if right is None else (right.lower, right.upper, right.region), track_deg)


def turn_to(from_deg: float, to_deg: float) -> float:
    """The signed turn from one track to another, right positive, in (-180, 180]."""
    d = (to_deg - from_deg) % 360.0
    return d - 360.0 if d > 180.0 else d


@dataclass(frozen=True, slots=True)
class HorizontalManoeuvre:
    target_track_deg: float  # degrees true: where the vehicle is turned to (the resolution plus the margin)
    right: bool  # the side of the turn
    reason: str  # "corrective" | "warning" | "recovery" (the resolution lies in a RECOVERY band)
    complies = False  # (as vertical.py's) a resolution is only found where the present track needs one
    target_mps = 0.0  # vertical: hold altitude

    @property
    def name(self) -> str:
        return "turn_right" if self.right else "turn_left"


def horizontal_manoeuvre(intervals, track_deg: float, alert_name: str, margin_deg: float,
                         side: bool | None = None, corrective: str = "MID") -> HorizontalManoeuvre | None:
    """The track to fly for the present track bands, the side kept when given (True: right) unless it has no
    resolution; None when the present track needs no resolution, or neither side has one."""
    res = track_resolution(intervals, track_deg, corrective)
    if res is None:
        return None
    has_left, has_right = not math.isinf(res.left_deg), not math.isinf(res.right_deg)
    if not (has_left or has_right):
        return None
    if side is None or not (has_right if side else has_left):
        side = res.preferred_right
    value, band = (res.right_deg, res.right_band) if side else (res.left_deg, res.left_band)
    lower, upper, region = band
    margin = min(margin_deg, 0.5 * (upper - lower))
    target = (value + margin if side else value - margin) % 360.0
    return HorizontalManoeuvre(target, side, "recovery" if region == "RECOVERY" else alert_name.lower())


def closest_horizontal_m(own_en, velocity_en, traffic, lookahead_s: float, turn_rates=None) -> float:
    """The least horizontal distance (m) to any intruder within [0, lookahead_s], ownship straight at velocity_en
    (east, north; m/s) from own_en, every intruder from its (ENU position, velocity) of Bands.traffic, straight,
    or turning at its rate of turn_rates (rad/s, clockwise positive; None, 0 or none given: straight) at constant
    speed, sampled every TURN_SAMPLE_S; inf without traffic."""
    closest = math.inf
    for k, (pos, vel) in enumerate(traffic):
        sx, sy = pos[0] - own_en[0], pos[1] - own_en[1]
        omega = turn_rates[k] if turn_rates is not None and k < len(turn_rates) else 0.0
        if omega:
            t = np.arange(0.0, lookahead_s + TURN_SAMPLE_S, TURN_SAMPLE_S)
            speed, psi0 = math.hypot(vel[0], vel[1]), math.atan2(vel[0], vel[1])
            psi = psi0 + omega * t  # track, clockwise from north: east = speed sin psi, north = speed cos psi
            ex = sx + speed / omega * (math.cos(psi0) - np.cos(psi)) - velocity_en[0] * t
            ny = sy + speed / omega * (np.sin(psi) - math.sin(psi0)) - velocity_en[1] * t
            closest = min(closest, float(np.hypot(ex, ny).min()))
            continue
        vx, vy = vel[0] - velocity_en[0], vel[1] - velocity_en[1]
        v2 = vx * vx + vy * vy
        t = 0.0 if v2 <= 0.0 else min(max(-(sx * vx + sy * vy) / v2, 0.0), lookahead_s)
        closest = min(closest, math.hypot(sx + vx * t, sy + vy * t))
    return closest


def turn_rates(previous, bands) -> list[float]:
    """Each intruder of bands' rate of turn (rad/s, clockwise positive) from its velocity in the previous bands
    (advisory/bands.py Bands, a second apart): 0 for one not in them, slower than TURN_MIN_SPEED_MPS, or when they
    are more than TURN_MAX_GAP_S old; at most MAX_TURN_RATE_RPS either way."""
    dt = bands.time_s - previous.time_s if previous is not None else math.inf
    if not 0.0 < dt <= TURN_MAX_GAP_S:
        return [0.0] * len(bands.traffic)
    before = {ident[0]: vel for ident, (_, vel) in zip(previous.intruders, previous.traffic)}
    rates = []
    for ident, (_, vel) in zip(bands.intruders, bands.traffic):
        old = before.get(ident[0])
        if old is None or math.hypot(*old[:2]) < TURN_MIN_SPEED_MPS or math.hypot(*vel[:2]) < TURN_MIN_SPEED_MPS:
            rates.append(0.0)
            continue
        turned = (math.atan2(vel[0], vel[1]) - math.atan2(old[0], old[1]) + math.pi) % (2.0 * math.pi) - math.pi
        rates.append(max(-MAX_TURN_RATE_RPS, min(MAX_TURN_RATE_RPS, turned / dt)))
    return rates
