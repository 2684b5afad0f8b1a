"""DAIDALUS-class manoeuvre guidance bands (issue 16, item 3): for the ownship's track, ground speed, vertical
speed and altitude, the intervals of values that lead to a loss of well clear (regions NEAR/MID/FAR), that are
conflict free (NONE), or that recover from an unavoidable loss (RECOVERY). A port of NASA DAIDALUS v2.0.4
(gov.nasa.larcfm.ACCoRD), vectorised with numpy; the classes and methods followed are named where they are used.

How DAIDALUS computes one kind of bands (DaidalusRealBands.compute), and so does BandsEngine.compute:

1. Aircraft per region (DaidalusCore.conflict_aircraft, DaidalusRealBands.peripheral_aircraft): for each
   conflict region painted by an alert level (here MID = level 2, NEAR = level 3), the intruders in conflict with
   that level's detector within its alerting time (the early alerting time when the intruder's current alert
   level is that level), with horizon = lookahead; plus the "peripheral" intruders not in conflict but that some
   manoeuvre of this kind brings into conflict within the alerting time, with horizon = alerting time.
2. None bands per region (compute_none_bands, DaidalusIntegerBands.kinematic_bands_combine): for each candidate
   value own + k step (k = -maxdown..maxup), the ownship flies the kinematic manoeuvre (turn at turn_rate,
   ground-speed or vertical-speed acceleration) for k time steps, then straight on. The candidate is red for an
   intruder when the manoeuvre itself passes through a loss (first LOS step, sampled every time step and on the
   line to the next sample: every larger k is red too), or the
   straight line after it has a conflict in [tsk, min(lookahead, horizon + tsk)]. A none interval joins
   consecutive green candidates (single points dropped); regions intersect over aircraft.
   Altitude bands (DaidalusAltBands) use level-out manoeuvres to each target altitude on a 100 ft grid.
3. Saturation and recovery (compute_region, compute_recovery_bands): when a region at least as severe as the
   corrective one (MID) is red everywhere, recovery bands are computed: the values that avoid the NMAC cylinder,
   then the largest cylinder (min_horizontal/vertical_recovery, shrunk by ca_factor when ca_bands) that can be
   kept after the earliest recovery time found by bisection (+ recovery_stability_time).
4. Colouring (color_values, ColorValue), then the hysteresis kept between calls (BandsHysteresis): M-of-N on
   every colour boundary (BandsMofN, MofN) and bands persistence of the conflict band the ownship is in.

Sensor uncertainty mitigation (a profile with [alerter.sum]): DAIDALUS's bands ask the alerter's detector, so
with WCV_TAUMOD_SUM every well-clear test of the bands is the SUM one: DaidalusIntegerBands.CD_future_traj copies
the ownship's TrafficState (its SUMData with it), moves it to the line after the manoeuvre and calls
det.conflictWithTrafficState(own, traffic, max(B, tsk), T), whose WCV_TAUMOD_SUM.conflictDetectionWithTrafficState
widens by both aircraft's SUMData at the range of that line (DaidalusCore.conflict_aircraft does the same for the
aircraft per region). Here `errors` (per intruder: ownship's + intruder's SumData.errors, the alerter's
Encounter.uncertainty) and the z-scores reach `_lines`, which uses advisory/wcv_sum.py's vectorised interval for
the WcvThresholds detectors; the recovery and NMAC cylinders (CDCylinder) have no SUM.

Internally the direction bands work in radians on a circle of 2 pi (DAIDALUS's internal units); the Bands result
is in degrees true for track_deg and SI for the other kinds.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Sequence

import numpy as np

from avionics.advisory.bands_kinematics import (
    Cylinder, almost_equals, almost_less, cylinder_lines, gs_accel, level_out_state,
    level_out_times, turn, vs_accel,
)
from avionics.advisory.persistence import MofN
from avionics.advisory.levels import AlertLevel
from avionics.advisory.wcv import WcvThresholds, conflict, wcv_interval
from avionics.advisory.wcv_sum import MIN_ERROR, SumZScores, relative_errors, wcv_uncertain_intervals
from avionics.contract.bands import BAND_KIND_NAMES
from avionics.base.almost import almost_equals as almost_equals_13, almost_less as almost_less_13
from avionics.base.units import FPM, FT, G0, KT, NM, ground_speed_mps, track_rad

KINDS = BAND_KIND_NAMES  # the outputs name them so (avionics/contract/bands.py)
TWO_PI = 2.0 * math.pi

# BandsRegion.orderOfRegion
_ORDER = {"UNKNOWN": -1, "NONE": 0, "FAR": 1, "MID": 2, "NEAR": 3, "RECOVERY": 4}
_NAME = {v: k for k, v in _ORDER.items()}
UNKNOWN, NONE, FAR, MID, NEAR, RECOVERY = -1, 0, 1, 2, 3, 4
# DAIDALUS conflict-region index: 0 NEAR, 1 MID, 2 FAR (BandsRegion.NUMBER_OF_CONFLICT_BANDS - order)
_REGION_OF_INDEX = (NEAR, MID, FAR)


# --- parameters -------------------------------------------------------------------------------------------------

@dataclass(frozen=True)
class BandsParams:
    """Band parameters, SI units; defaults are DAIDALUS's DO_365B_no_SUM.conf (DaidalusParameters names)."""

    lookahead_s: float = 180.0  # lookahead_time
    left_track_deg: float = 180.0  # left_hdir
    right_track_deg: float = 180.0  # right_hdir
    min_gs_mps: float = 10.0 * KT  # min_hs
    max_gs_mps: float = 700.0 * KT  # max_hs
    min_vs_mps: float = -6000.0 * FPM  # min_vs
    max_vs_mps: float = 6000.0 * FPM  # max_vs
    min_alt_m: float = 100.0 * FT  # min_alt
    max_alt_m: float = 50000.0 * FT  # max_alt
    step_track_deg: float = 1.0  # step_hdir
    step_gs_mps: float = 5.0 * KT  # step_hs
    step_vs_mps: float = 100.0 * FPM  # step_vs
    step_alt_m: float = 100.0 * FT  # step_alt
    turn_rate_deg_s: float = 3.0  # turn_rate (bank_angle = 0: the turn rate is used)
    horizontal_accel_mps2: float = 2.0  # horizontal_accel
    vertical_accel_mps2: float = 0.25 * G0  # vertical_accel (0.25 G)
    vertical_rate_mps: float = 500.0 * FPM  # vertical_rate (altitude bands' climb/descent rate)
    min_airspeed_mps: float = 10.0 * KT  # min_airspeed (direction manoeuvres fly at least this fast)
    recovery_track: bool = True  # recovery_hdir
    recovery_gs: bool = True  # recovery_hs
    recovery_vs: bool = True  # recovery_vs
    recovery_alt: bool = True  # recovery_alt
    min_horizontal_recovery_m: float = 0.66 * NM  # min_horizontal_recovery
    min_vertical_recovery_m: float = 450.0 * FT  # min_vertical_recovery
    recovery_stability_time_s: float = 3.0  # recovery_stability_time
    ca_bands: bool = True  # ca_bands
    ca_factor: float = 0.1  # ca_factor
    horizontal_nmac_m: float = 500.0 * FT  # horizontal_nmac
    vertical_nmac_m: float = 100.0 * FT  # vertical_nmac
    corrective_region: str = "MID"  # corrective_region
    hysteresis_time_s: float = 5.0  # hysteresis_time
    persistence_time_s: float = 4.0  # persistence_time
    bands_persistence: bool = True  # bands_persistence
    alerting_m: int = 2  # alerting_m
    alerting_n: int = 4  # alerting_n


# --- result -----------------------------------------------------------------------------------------------------

@dataclass(frozen=True)
class BandInterval:
    lower: float
    upper: float
    region: str  # "NONE", "FAR", "MID", "NEAR", "RECOVERY"


@dataclass(frozen=True)
class Bands:
    """Bands at time_s. Each kind: intervals in increasing order covering the kind's whole range (empty where the
    ownship's current value lies outside the range: DAIDALUS computes none)."""

    time_s: float
    track_deg: tuple[BandInterval, ...]
    ground_speed_mps: tuple[BandInterval, ...]
    vertical_rate_mps: tuple[BandInterval, ...]
    altitude_m: tuple[BandInterval, ...]
    recovery: dict = field(default_factory=dict)  # kind -> bool: recovery bands were computed
    ownship_pos: tuple = ()  # the ownship state the bands are for: ENU position (m) ...
    ownship_vel: tuple = ()  # ... and velocity (m/s)
    intruders: tuple = ()  # (intruder id, alert level[, its name]) of every intruder the bands took in
    traffic: tuple = ()  # ... and each one's (ENU position (m), velocity (m/s)), in the same order

    def intervals(self, kind: str) -> tuple[BandInterval, ...]:
        if kind not in KINDS:
            raise ValueError(f"unknown kind {kind!r}; one of {KINDS}")
        return getattr(self, kind)

    def region_at(self, kind: str, value: float) -> str:
        """The region of a value (track in degrees, modulo 360). At a shared end the more severe region wins
        unless one side is a resolution (NONE/RECOVERY) region, which then wins (DAIDALUS BandsRange.index_of);
        "UNKNOWN" outside the range or when there are no bands."""
        ivs = self.intervals(kind)
        if not ivs:
            return "UNKNOWN"
        if kind == "track_deg":
            value = value % 360.0
        hits = [iv for iv in ivs if iv.lower - 1e-9 <= value <= iv.upper + 1e-9]
        if kind == "track_deg" and (value < 1e-9 or value > 360.0 - 1e-9):
            hits = [ivs[0], ivs[-1]]
        if not hits:
            return "UNKNOWN"
        for iv in hits:
            if iv.region in ("NONE", "RECOVERY"):
                return iv.region
        return max(hits, key=lambda iv: _ORDER[iv.region]).region


# --- colour values, M of N, persistence (ColorValue, BandsMofN, MofN, BandsRange, BandsHysteresis) ---------------

class _CV:
    """ColorValue: a point with the colour (region order) to its left and to its right."""

    __slots__ = ("val", "left", "right")

    def __init__(self, left: int, val: float, right: int):
        self.left, self.val, self.right = left, val, right

    def __repr__(self):
        return f"<{_NAME[self.left]},{self.val:.6g},{_NAME[self.right]}>"


def _eq(a, b) -> bool:
    return bool(almost_equals(a, b))


def _insert(lcv: list[_CV], lb: float, ub: float, color: int) -> None:
    """ColorValue.insert: paint (lb, ub) with color where the current colour is weaker (UNKNOWN never)."""
    if not lcv or lb > ub or _eq(lb, ub) or ub < lcv[0].val or _eq(ub, lcv[0].val) or lb > lcv[-1].val \
            or _eq(lb, lcv[-1].val):
        return
    lb, ub = max(lb, lcv[0].val), min(ub, lcv[-1].val)
    pl, pr = 0, len(lcv) - 1
    while pl + 1 < pr:
        mid = (pl + pr) // 2
        if lb < lcv[mid].val and not _eq(lb, lcv[mid].val):
            pr = mid
        elif lb > lcv[mid].val and not _eq(lb, lcv[mid].val):
            pl = mid
        else:
            pl, pr = mid, mid + 1
    i = pl
    if i < len(lcv) - 1 and not _eq(lcv[i].val, lb) and lcv[i].right != UNKNOWN and lcv[i].right < color:
        ext = lcv[i].right
        lcv.insert(i + 1, _CV(ext, lb, ext))
        i += 1
    while i < len(lcv) - 1 and (lcv[i + 1].val < ub or _eq(lcv[i + 1].val, ub)):
        if lcv[i].right != UNKNOWN and lcv[i].right < color:
            lcv[i].right = color
            lcv[i + 1].left = color
        i += 1
    if i < len(lcv) - 1 and not _eq(lcv[i].val, ub) and lcv[i].right != UNKNOWN and lcv[i].right < color:
        ext = lcv[i].right
        lcv[i].right = color
        lcv.insert(i + 1, _CV(color, ub, ext))
    if lcv[0].left != UNKNOWN:
        lcv[0].left = lcv[-1].left
    if lcv[-1].right != UNKNOWN:
        lcv[-1].right = lcv[0].right


def _insert_with_mod(lcv, lb, ub, mod, color):
    if lb < ub:
        _insert(lcv, lb, ub, color)
    elif mod > 0:
        _insert(lcv, 0.0, ub, color)
        _insert(lcv, lb, mod, color)


def _is_resolution(c: int) -> bool:
    return c == NONE or c == RECOVERY


def _conflict_order(c: int) -> int:
    """BandsRegion.orderOfConflictRegion: NONE/RECOVERY 0, FAR 1, MID 2, NEAR 3, UNKNOWN -1."""
    return 0 if _is_resolution(c) else c


def _region_of(lcv: list[_CV], val: float) -> int:
    """ColorValue.region_of."""
    i = 0
    while i < len(lcv) and lcv[i].val < val and not _eq(lcv[i].val, val):
        i += 1
    if i < len(lcv):
        p = lcv[i]
        if _eq(p.val, val):
            if _is_resolution(p.right) or p.left == UNKNOWN:
                return p.right
            if _is_resolution(p.left) or p.right == UNKNOWN or _conflict_order(p.left) < _conflict_order(p.right):
                return p.left
            return p.right
        return p.left
    return UNKNOWN


class _BandsMofN:
    __slots__ = ("val", "left", "right")

    def __init__(self, val: float, left: MofN, right: MofN):
        self.val, self.left, self.right = val, left, right


def _ranges_from_cvs(lcv: list[_CV], recovery: bool) -> list[tuple[float, float, int]]:
    """BandsRange.makeRangesFromColorValues: NONE becomes RECOVERY when recovery bands were computed."""
    def res(c):
        return (RECOVERY if recovery else NONE) if _is_resolution(c) else c
    ranges, nxt = [], 0
    for i in range(1, len(lcv)):
        cl, cr = res(lcv[i].left), res(lcv[i].right)
        if cl != cr or i == len(lcv) - 1:
            ranges.append((lcv[nxt].val, lcv[i].val, cl))
            nxt = i
    return ranges


def _index_of(ranges, val: float, mod: float) -> int:
    """BandsRange.index_of."""
    if mod > 0:
        val = val % mod
    last = len(ranges) - 1
    for i, (lo, up, reg) in enumerate(ranges):
        inside = (lo < val or _eq(lo, val)) and (val < up or _eq(val, up))
        wrap = i == last and _eq(((up - val) % mod) if mod > 0 else up - val, 0.0)
        if inside or wrap:
            if _is_resolution(reg):
                return i
            if _eq(val, lo):
                prev = i - 1 if i > 0 else (last if mod > 0 else -1)
                if prev > 0 and reg != UNKNOWN:
                    pr = ranges[prev][2]
                    return i if pr == UNKNOWN or _conflict_order(reg) <= _conflict_order(pr) else prev
                return prev
            if val < up and not _eq(val, up):
                return i
            nxt = i + 1 if i < last else (0 if mod > 0 else -1)
            if nxt > 0 and reg != UNKNOWN:
                nr = ranges[nxt][2]
                return i if nr == UNKNOWN or _conflict_order(reg) <= _conflict_order(nr) else nxt
            return nxt
    return -1


class _Hysteresis:
    """BandsHysteresis, the parts that change the bands: M of N on colour values and bands persistence."""

    def __init__(self, mod: float, p: BandsParams):
        self.mod = mod
        self.p = p
        self.reset()
        self.last_time = math.nan

    def reset(self):
        self.mofn: list[_BandsMofN] = []
        self.last_time = math.nan
        self.conflict_region = UNKNOWN
        self.cr_low = math.nan
        self.cr_up = math.nan
        self.time_of_cr = math.nan

    def reset_if_current_time(self, t: float):
        """BandsHysteresis.resetIfCurrentTime."""
        if math.isnan(self.last_time) or t <= self.last_time or t - self.last_time > self.p.hysteresis_time_s:
            self.reset()
        self.last_time = t

    def m_of_n(self, lcv: list[_CV]):
        """BandsHysteresis.m_of_n: filter the left/right colour of every boundary (old and new) M of N."""
        m, n = self.p.alerting_m, self.p.alerting_n
        if not (self.p.hysteresis_time_s > 0 and 0 < m <= n):
            return
        if not self.mofn:
            self.mofn = [_BandsMofN(cv.val, MofN(m, n, cv.left), MofN(m, n, cv.right)) for cv in lcv]
        i = j = 0
        while i < len(self.mofn) and j < len(lcv):
            bm, cv = self.mofn[i], lcv[j]
            if _eq(bm.val, cv.val):
                cv.left = bm.left.apply(cv.left)
                cv.right = bm.right.apply(cv.right)
                i += 1
                j += 1
            elif bm.val < cv.val:
                lcv.insert(j, _CV(cv.left, bm.val, cv.left))
            else:
                q = bm.left
                self.mofn.insert(i, _BandsMofN(cv.val, q.copy(), q.copy()))
        i = 1
        while i < len(self.mofn) - 1:
            if self.mofn[i].left.same_as(self.mofn[i].right):
                del self.mofn[i]
            else:
                i += 1

    def _conflict_region_persistence(self, ranges, idx):
        if 0 <= idx < len(ranges) and ranges[idx][2] > NONE and ranges[idx][2] != RECOVERY:
            lo, up, reg = ranges[idx]
            self.conflict_region = reg
            if self.mod == 0 or 0 < idx < len(ranges) - 1:
                self.cr_low, self.cr_up = lo, up
            elif idx == 0:
                self.cr_up = up
                self.cr_low = ranges[-1][0] if ranges[0][2] == ranges[-1][2] else lo
            else:
                self.cr_low = lo
                self.cr_up = ranges[0][1] if ranges[0][2] == reg else up
        else:
            self.time_of_cr = math.nan
            self.conflict_region = UNKNOWN
            self.cr_low = self.cr_up = math.nan

    def persistence(self, lcv: list[_CV], recovery: bool, val: float):
        """BandsHysteresis.bandsPersistence: keep the conflict band the ownship was in for persistence_time."""
        p = self.p
        if p.hysteresis_time_s > 0 and p.persistence_time_s > 0 and p.bands_persistence:
            if math.isfinite(self.cr_low) and math.isfinite(self.cr_up):
                current = _region_of(lcv, val)
                is_conflict = self.conflict_region in (FAR, MID, NEAR)
                if current != UNKNOWN and is_conflict:
                    if (not math.isnan(self.time_of_cr) and current < self.conflict_region
                            and self.last_time >= self.time_of_cr
                            and self.last_time - self.time_of_cr < p.persistence_time_s):
                        _insert_with_mod(lcv, self.cr_low, self.cr_up, self.mod, self.conflict_region)
                    elif current in (FAR, MID, NEAR) and current > self.conflict_region:
                        self.time_of_cr = self.last_time
            else:
                self.time_of_cr = self.last_time
        ranges = _ranges_from_cvs(lcv, recovery)
        idx = _index_of(ranges, val, self.mod)
        if not math.isnan(self.time_of_cr):
            self._conflict_region_persistence(ranges, idx)
        return ranges


# --- candidate manoeuvres of one kind ----------------------------------------------------------------------------

Detector = WcvThresholds | Cylinder


class _Candidates:
    """All candidate manoeuvres of one kind against all intruders, with the per-detector loss data cached.

    Subclasses set n (intruders) and n_segments (segments between consecutive candidates), and implement
    green(det, B, T, rec, idx) -> (candidates, len(idx)) bool and any_red(det, T) -> (n,) bool."""

    lookahead: float
    sum_data: tuple | None = None  # (SumZScores, (n, 4) errors per intruder): the SUM detector (module docstring)

    def _sum_of(self, sel):
        """The SUM data of the intruders `sel` (a slice or an index array), or None."""
        if self.sum_data is None:
            return None
        z, errors = self.sum_data
        return z, errors[sel]

    def green_segments(self, idx: np.ndarray, det: Detector, B: float, T: np.ndarray,
                       rec: Cylinder | None) -> np.ndarray:
        """DaidalusRealBands.compute_none_bands for aircraft idx (horizons T): the none set as a boolean per
        segment between consecutive candidates (a none interval covers a segment when both ends are green)."""
        seg = np.ones(self.n_segments, bool)
        if len(idx) == 0:
            return seg
        idx = np.asarray(idx)
        T = np.asarray(T, float)
        normal = B <= T
        if normal.any():
            g = self.green(det, B, T[normal], rec, idx[normal])
            seg &= (g[:-1] & g[1:]).all(axis=1)
        if (~normal).any() and rec is not None:
            # B > T (recovery time beyond the aircraft's horizon): only the recovery cylinder, over [0, T]
            g = self.green(rec, 0.0, T[~normal], None, idx[~normal])
            seg &= (g[:-1] & g[1:]).all(axis=1)
        return seg


def _lines(det, s, v, lookahead, sum_data=None):
    """For a detector (a WcvThresholds or the recovery Cylinder): (t_in, t_out) of the loss over [0, lookahead]
    on the straight lines (s, v) (inf, -inf where there is no conflict: LossData.conflict). sum_data: (z-scores,
    (n, 4) errors of the lines' intruders, the last axis of s before the coordinates) for WCV_TAUMOD_SUM, whose
    velocity z-score is weighed at each line's range at time 0 (the state DAIDALUS hands the detector); pairs
    whose relative errors are all zero keep WCV_TAUMOD (conflictDetectionWithTrafficState)."""
    if isinstance(det, Cylinder):
        return cylinder_lines(s, v, det, lookahead)
    tin, tout = wcv_interval(s[..., :2], v[..., :2], s[..., 2], v[..., 2], det, 0.0, lookahead)
    if sum_data is not None:
        z, errors = sum_data
        rel = relative_errors(np.broadcast_to(errors, s.shape[:-1] + (4,)), np.hypot(s[..., 0], s[..., 1]), z)
        uncertain = (rel != 0.0).any(axis=-1)
        if uncertain.any():
            e = np.maximum(rel, MIN_ERROR)
            # DAIDALUS's sign convention (ownship - intruder): the worst case is even, kept as the alerter has it
            uin, uout = wcv_uncertain_intervals(0.0, lookahead, -s[..., :2], -v[..., :2], -s[..., 2], -v[..., 2],
                                                e[..., 0], e[..., 1], e[..., 2], e[..., 3], det)
            tin, tout = np.where(uncertain, uin, tin), np.where(uncertain, uout, tout)
    ok = conflict(tin, tout)
    return np.where(ok, tin, np.inf), np.where(ok, tout, -np.inf)


def _violation_at(det, s_t, v_t, t, sum_data=None):
    """Detection3D.violationAtWithTrafficState(own, traffic, t) of DAIDALUS v2.0.4 for the lines through the
    samples (s_t, v_t) at times t: not the instantaneous test but conflictWithTrafficState(t, t), i.e. a loss
    over [t, t + 1] (LossData.conflict, Util.almost_less) that begins at t (Util.almost_equals(time_in, t)). A
    sample exactly on a threshold and leaving it is no loss: a vertical separation equal to ZTHR to 1e-12 m,
    diverging, is clear (the loss lasts ~1e-14 s, almost equal to none)."""
    tin, tout = _lines(det, s_t, v_t, 1.0, sum_data)  # time from the sample
    return conflict(tin, tout) & almost_equals_13(t + tin, t)


class _Kinematic(_Candidates):
    """DaidalusIntegerBands kinematic bands: candidate j (-maxl..maxr) is the manoeuvre of |j| time steps to
    the left/down (j < 0) or right/up (j > 0), then straight on.

    The first-LOS search (kinematic_first_los_step) samples the continuing manoeuvre every time step (1/3 s for
    turns, 1.286 s for ground speed, 0.207 s for vertical speed) and asks, as DAIDALUS v2.0.4's LOS_at_coast
    does, for a conflict on the straight line through the sample within [tsk, tsk + tstep]
    (conflictWithTrafficState): a short pass between two samples is not missed, and a sample that only touches
    a threshold (a loss interval almost equal to none, Util.almost_less) is no loss."""

    def __init__(self, traj, tstep, maxl, maxr, p0, v0, si, vi, lookahead):
        self.lookahead = lookahead
        self.tstep, self.maxl, self.maxr = tstep, maxl, maxr
        kl, kr = np.arange(maxl + 1), np.arange(maxr + 1)
        pl, vl = traj(p0, v0, kl * tstep, False)
        pr, vr = traj(p0, v0, kr * tstep, True)
        self.k = np.concatenate([kl[::-1][:-1], kr])
        self.t = self.k * tstep
        pos = np.concatenate([pl[::-1][:-1], pr])
        vel = np.concatenate([vl[::-1][:-1], vr])
        self.center = maxl
        sat = pos - self.t[:, None] * vel  # DaidalusIntegerBands.CD_future_traj: the line after the manoeuvre
        self.s = si[None, :, :] - sat[:, None, :]  # (J, N, 3): intruder minus ownship at time 0 of that line
        self.v = vi[None, :, :] - vel[:, None, :]
        self.s_t = self.s + self.v * self.t[:, None, None]  # at the manoeuvre time tsk (LOS_at)
        self.n = si.shape[0]
        self.n_segments = len(self.k) - 1
        self._cache: dict = {}

    def _loss(self, det: Detector, idx):
        """(t_in, t_out) of loss over [0, lookahead] on the line after each manoeuvre, and LOS at the manoeuvre
        time (LOS_at), for the intruders idx: (J, n) each, cached per detector and intruder set."""
        idx = np.asarray(idx, int)
        key = (det, idx.tobytes())
        if key not in self._cache:
            L = self.lookahead
            sel = slice(None) if len(idx) == self.n and (idx == np.arange(self.n)).all() else idx
            s, v = self.s[:, sel], self.v[:, sel]
            tin, tout = _lines(det, s, v, L, self._sum_of(sel))
            # LOS_at_coast(k) (DaidalusIntegerBands.kinematic_first_los_step): a conflict on the line through the
            # sample within [tsk, tsk + tstep] (conflictWithTrafficState: Util.almost_less of the clipped
            # interval), none at or past the lookahead
            t = self.t[:, None]
            los = conflict(np.maximum(tin, t), np.minimum(tout, t + self.tstep)) & (t < L)
            self._cache[key] = (tin, tout, los)
        return self._cache[key]

    def conflict_after(self, det: Detector, B: float, T: np.ndarray, idx) -> np.ndarray:
        """CD_future_traj(det, B, T + tsk, tsk) per candidate and aircraft: (J, n) bool."""
        tin, tout, _ = self._loss(det, idx)
        t = self.t[:, None]
        hi = np.minimum(self.lookahead, T[None, :] + t)
        return conflict(np.maximum(tin, np.maximum(B, t)), np.minimum(tout, hi))

    def green(self, det, B, T, rec, idx) -> np.ndarray:
        """kinematic_bands: green per candidate (J, n): before the first LOS step of its side, and no conflict
        after the manoeuvre (no_CD_future_traj)."""
        _, _, los = self._loss(det, idx)
        k = self.k[:, None]
        kmax = np.where(np.arange(len(self.k)) < self.center, self.maxl, self.maxr)[:, None]
        first_n = np.minimum(math.floor(self.lookahead / self.tstep), kmax)
        los_c = los & (k >= math.ceil(B / self.tstep)) & (k <= first_n)
        red = self.conflict_after(det, B, T, idx)
        if rec is not None:
            rin, rout, los_r = self._loss(rec, idx)
            los_c = los_c | (los_r & (k <= np.minimum(math.floor(B / self.tstep), kmax)))
            t = self.t[:, None]
            red |= conflict(np.maximum(rin, t), np.minimum(rout, min(self.lookahead, B)))
        c = self.center
        blocked = np.empty_like(los_c)
        blocked[:c + 1] = np.logical_or.accumulate(los_c[c::-1], axis=0)[::-1]
        blocked[c:] = np.logical_or.accumulate(los_c[c:], axis=0)
        return ~blocked & ~red

    def any_red(self, det: Detector, T: float) -> np.ndarray:
        """any_red / kinematic_red_band_exist with B = 0: some manoeuvre leads to a conflict. (n,) bool."""
        idx = np.arange(self.n)
        return self.conflict_after(det, 0.0, np.full(self.n, T), idx).any(axis=0)


class _Altitude(_Candidates):
    """DaidalusAltBands: candidate k is a level-out to min_alt + k step (k = 0..maxup), time step 1 s."""

    def __init__(self, p, p0, v0, si, vi, min_val, max_val, lookahead):
        self.lookahead = lookahead
        step = p.step_alt_m
        self.maxup = int(math.floor((max_val - min_val) / step)) + 1
        self.targets = min_val + np.arange(self.maxup + 1) * step
        tstep = 1.0
        level_out = level_out_times(float(p0[2]), float(v0[2]), p.vertical_rate_mps, self.targets,
                                    p.vertical_accel_mps2)  # once: the trajectory below reads it too
        t1, t2, t3, _, _ = level_out
        tsqj3 = t3 + tstep
        self.t1, self.t2, self.t3 = t1, t2, tsqj3
        # LOS sample times: i = 0..floor(t1) and ceil(t2)..floor(t3 + 1) (conflict_free_traj_step)
        n1 = np.clip(np.floor(t1), -1, lookahead).astype(int) + 1  # number of phase-1 samples
        a3 = np.ceil(np.clip(t2, 0, lookahead + 1)).astype(int)
        b3 = np.floor(np.clip(tsqj3, -1, lookahead + 1)).astype(int)
        n3 = np.maximum(b3 - a3 + 1, 0)
        q = int(max(1, (n1 + n3).max()))
        qi = np.arange(q)[None, :]
        times = np.where(qi < n1[:, None], qi, a3[:, None] + (qi - n1[:, None]))
        self.los_mask = qi < (n1 + n3)[:, None]
        self.los_t = times.astype(float)
        self.tsk1 = np.maximum(t1, 0.0)
        self.tsk3 = np.maximum(tsqj3, 0.0)
        allt = np.concatenate([self.los_t, self.tsk1[:, None], self.tsk3[:, None]], axis=1)
        pos, vel, _ = level_out_state(p0, v0, allt, p.vertical_rate_mps, self.targets, p.vertical_accel_mps2,
                                      tstep, level_out)
        sat = pos - allt[..., None] * vel
        self.s = si[None, None] - sat[:, :, None]  # (M, Q+2, N, 3)
        self.v = vi[None, None] - vel[:, :, None]
        self.s_t = self.s + self.v * allt[:, :, None, None]
        self.q = q
        self.n = si.shape[0]
        self.n_segments = self.maxup
        self._cache: dict = {}

    def _loss(self, det, idx):
        """Loss data for intruders idx: (t_in, t_out) (M, 2, n) on the lines after phase 1 and after the level-out,
        and LOS (M, Q, n) at the sample times; cached per detector and intruder set."""
        idx = np.asarray(idx, int)
        key = (det, idx.tobytes())
        if key not in self._cache:
            L, q = self.lookahead, self.q
            sel = slice(None) if len(idx) == self.n and (idx == np.arange(self.n)).all() else idx
            s, v = self.s[:, q:, sel], self.v[:, q:, sel]
            s_t, v_t = self.s_t[:, :q, sel], self.v[:, :q, sel]
            tin, tout = _lines(det, s, v, L, self._sum_of(sel))
            # DaidalusAltBands.conflict_free_traj_step's LOS_at: violationAtWithTrafficState at each sample time
            los = _violation_at(det, s_t, v_t, self.los_t[..., None], self._sum_of(sel))
            los &= (self.los_mask & (self.los_t < L))[..., None]
            self._cache[key] = (tin, tout, los)
        return self._cache[key]

    def _red(self, det, B, T, idx, rec):
        L = self.lookahead
        tin, tout, los = self._loss(det, idx)
        red = (los & (self.los_t >= B)[..., None]).any(axis=1)
        t1, t2 = self.tsk1[:, None], self.t2[:, None]
        hi2 = np.minimum(L, np.minimum(T[None, :] + t1, t2))
        cd2 = conflict(np.maximum(tin[:, 0], np.maximum(B, t1)), np.minimum(tout[:, 0], hi2)) & (t2 >= B)
        t3 = self.tsk3[:, None]
        cd4 = conflict(np.maximum(tin[:, 1], np.maximum(B, t3)), np.minimum(tout[:, 1], np.minimum(L, T + t3)))
        red |= cd2 | cd4
        if rec is not None:
            rin, rout, rlos = self._loss(rec, idx)
            red |= (rlos & (self.los_t <= B)[..., None]).any(axis=1)
            red |= conflict(np.maximum(rin[:, 0], t1), np.minimum(rout[:, 0], np.minimum(L, np.minimum(B, t2)))) \
                & (t2 >= 0)
            red |= conflict(np.maximum(rin[:, 1], t3), np.minimum(rout[:, 1], min(L, B)))
        return red

    def green(self, det, B, T, rec, idx):
        return ~self._red(det, B, np.asarray(T, float), idx, rec)

    def any_red(self, det, T: float) -> np.ndarray:
        return self._red(det, 0.0, np.full(self.n, T), np.arange(self.n), None).any(axis=0)


# --- the engine ---------------------------------------------------------------------------------------------------

@dataclass(frozen=True)
class _Kind:
    name: str
    mod: float
    min_val: float
    max_val: float
    step: float
    recovery: bool


def _regions(levels: Sequence[AlertLevel]) -> list[AlertLevel | None]:
    """The level of `levels` that paints each region index (0 NEAR, 1 MID, 2 FAR), None where none does."""
    out: list[AlertLevel | None] = []
    for reg in _REGION_OF_INDEX:
        lv = [lv for lv in levels if _ORDER[lv.region] == reg]
        out.append(lv[0] if lv else None)
    return out


class BandsEngine:
    """DAIDALUS bands for one ownship, with the state DAIDALUS's bands keep between calls (BandsHysteresis per
    kind, and when each intruder was first seen, for the early alerting time)."""

    def __init__(self, params: BandsParams, levels: Sequence[AlertLevel], sum_z: SumZScores | None = None,
                 non_cooperative_levels: Sequence[AlertLevel] | None = None, kinds: Sequence[str] | None = None):
        """kinds: the kinds computed (None: all four, as DAIDALUS); the others come out empty, as a kind whose
        present value is outside its range (each kind is computed on its own: the ones kept are unchanged).
        non_cooperative_levels: the levels of the alerter of the intruders seen only by the ownship's sensors
        (DAIDALUS's per-intruder alerter: DO-365B's DWC_Non_Coop; advisory/alerting.py Alerter.non_cooperative),
        whose conflicts the bands take with those levels' volumes and times, as DAIDALUS's bands take each
        aircraft's with its own alerter (DaidalusCore.conflict_aircraft). Same SUM as `levels` (tables.py checks a
        profile's non-cooperative alerter at load)."""
        self.params = params
        self.sum_z = sum_z  # the alerter's [alerter.sum]: its detectors are WCV_TAUMOD_SUM, so are the bands' tests
        # the alerter's own levels (advisory/levels.py, a profile's [[alerter.levels]]): each level's thresholds
        # (WcvThresholds), the region it paints, its alerting and early alerting times, as DAIDALUS's bands read
        # the alerter's AlertThresholds
        self.levels = tuple(levels)
        p = params
        if kinds is not None and not set(kinds) <= set(KINDS):
            raise ValueError(f"unknown band kind(s) {sorted(set(kinds) - set(KINDS))}; known: {', '.join(KINDS)}")
        self._kinds = tuple(k for k in (
            _Kind("track_deg", TWO_PI, 0.0, TWO_PI, math.radians(p.step_track_deg), p.recovery_track),
            _Kind("ground_speed_mps", 0.0, p.min_gs_mps, p.max_gs_mps, p.step_gs_mps, p.recovery_gs),
            _Kind("vertical_rate_mps", 0.0, p.min_vs_mps, p.max_vs_mps, p.step_vs_mps, p.recovery_vs),
            _Kind("altitude_m", 0.0, p.min_alt_m, p.max_alt_m, p.step_alt_m, p.recovery_alt),
        ) if kinds is None or k.name in kinds)
        # regions painted (DaidalusCore.bands4region_): index 0 NEAR, 1 MID, 2 FAR -> the level that paints it,
        # per alerter (the cooperative one first)
        self._level_for_region = _regions(self.levels)
        self._non_cooperative = None if non_cooperative_levels is None else _regions(non_cooperative_levels)
        self._corrective = 3 - _ORDER[p.corrective_region]
        # this call's alerters: (the intruders' indices, that alerter's level per region); one, unless some
        # intruder is non-cooperative (compute)
        self._alerters: list[tuple[np.ndarray, list]] = []
        self.reset()

    def reset(self) -> None:
        self._hyst = {k.name: _Hysteresis(k.mod, self.params) for k in self._kinds}
        self._first_seen: dict = {}
        self._last_time = math.nan
        # kind -> (recovery time s, horizontal m, vertical m, n factor) of the last call (RecoveryInformation)
        self.recovery_information: dict = {}
        self.recovery_info = None

    # -- conflict aircraft ----------------------------------------------------------------------------------------

    def _conflict_aircraft(self, time_s, so, vo, si, vi, ids, alert_levels, sum_data=None):
        """DaidalusCore.conflict_aircraft: per region index, the intruders in conflict within the (early)
        alerting time, and the detection interval of each level."""
        p = self.params
        if not math.isnan(self._last_time) and (time_s <= self._last_time
                                                or time_s - self._last_time > p.hysteresis_time_s):
            self._first_seen = {}
        self._last_time = time_s
        early_ok = np.array([self._first_seen.setdefault(i, time_s) < time_s for i in ids], bool)
        s, v = si - so, vi - vo
        levels = np.asarray(alert_levels)
        out, det_data = [], []
        for r in range(len(_REGION_OF_INDEX)):
            painted = self._painting(r)
            if not painted:
                out.append(np.zeros(0, int))
                det_data.append(None)
                continue
            conflicting, before_at = [], np.zeros(len(ids), bool)
            for g, lv in painted:  # each intruder with its own alerter's level for the region
                rows = None if sum_data is None else (sum_data[0], sum_data[1][g])
                tin, tout = _lines(lv.thresholds, s[g], v[g], p.lookahead_s, rows)
                is_conf = conflict(tin, tout)
                at = np.where(early_ok[g] & (levels[g] == lv.number), lv.early_alerting_time_s, lv.alerting_time_s)
                # ConflictData.conflictBefore: time_in == 0 or Util.almost_less(time_in, t) (PRECISION13)
                conflicting.append(g[is_conf & ((tin == 0) | almost_less_13(tin, at))])
                t_at = min(p.lookahead_s, lv.alerting_time_s)
                before_at[g] = is_conf & ((tin == 0) | almost_less_13(tin, t_at))
            out.append(np.sort(np.concatenate(conflicting)))
            det_data.append(before_at)
        return out, det_data

    def _painting(self, r: int) -> list[tuple[np.ndarray, AlertLevel]]:
        """(intruders, their alerter's level) for region index r, for each alerter of this call that paints it."""
        return [(g, regions[r]) for g, regions in self._alerters if regions[r] is not None]

    def _green(self, cand: _Candidates, r: int, idx, B: float, T, rec) -> np.ndarray:
        """green_segments against the aircraft idx (horizons T), each tested with its own alerter's detector for
        region index r (DaidalusRealBands.compute_none_bands over aircraft of several alerters: a segment is
        none when it is none against every one)."""
        if len(self._alerters) == 1:
            return cand.green_segments(idx, self._alerters[0][1][r].thresholds, B, T, rec)
        idx, T = np.asarray(idx, int), np.asarray(T, float)
        seg = np.ones(cand.n_segments, bool)
        for g, lv in self._painting(r):
            mine = np.isin(idx, g)
            if mine.any():
                seg &= cand.green_segments(idx[mine], lv.thresholds, B, T[mine], rec)
        return seg

    # -- one kind ---------------------------------------------------------------------------------------------------

    def _candidates(self, kind: _Kind, val, so, vo, si, vi, sum_data=None):
        cand = self._candidates_of(kind, val, so, vo, si, vi)
        cand.sum_data = sum_data
        return cand

    def _candidates_of(self, kind: _Kind, val, so, vo, si, vi):
        p = self.params
        L = p.lookahead_s
        if kind.name == "altitude_m":
            return _Altitude(p, so, vo, si, vi, kind.min_val, kind.max_val, L)
        if kind.mod > 0:
            min_rel, max_rel = math.radians(p.left_track_deg), math.radians(p.right_track_deg)
            circular = abs((min_rel + max_rel) - TWO_PI) < 0.25 * kind.step
            if circular:
                min_rel = max_rel = math.pi
        else:
            min_rel, max_rel = val - kind.min_val, kind.max_val - val
        maxl = math.ceil(min_rel / kind.step)
        maxr = math.ceil(max_rel / kind.step)
        if kind.mod > 0:  # DaidalusRealBands.maxdown/maxup: at most half the circle
            if maxl * kind.step > kind.mod / 2 and not _eq(maxl * kind.step, kind.mod / 2):
                maxl -= 1
            if maxr * kind.step > kind.mod / 2 and not _eq(maxr * kind.step, kind.mod / 2):
                maxr -= 1
        if kind.name == "track_deg":
            # DaidalusDirBands: the turn flies at least max(step_hs, min_airspeed), at turn_rate
            gs = ground_speed_mps(vo[0], vo[1])
            gso = max(p.step_gs_mps, p.min_airspeed_mps, gs)
            if gs > 0:
                vt = np.array([vo[0] * gso / gs, vo[1] * gso / gs, vo[2]])
            else:
                vt = np.array([0.0, gso, vo[2]])
            omega = math.radians(p.turn_rate_deg_s)
            return _Kinematic(lambda a, b, t, r: turn(a, b, t, omega, r), kind.step / omega, maxl, maxr,
                              so, vt, si, vi, L)
        if kind.name == "ground_speed_mps":
            acc = p.horizontal_accel_mps2
            return _Kinematic(lambda a, b, t, r: gs_accel(a, b, t, acc if r else -acc), kind.step / acc,
                              maxl, maxr, so, vo, si, vi, L)
        acc = p.vertical_accel_mps2
        return _Kinematic(lambda a, b, t, r: vs_accel(a, b, t, acc if r else -acc), kind.step / acc,
                          maxl, maxr, so, vo, si, vi, L)

    def _recovery_bands(self, cand: _Candidates, idx, T):
        """DaidalusRealBands.compute_recovery_bands: (none segments, found). recovery_info: (time, horizontal,
        vertical distance, n factor) when found; (-inf, -inf, -inf, n factor) when not (its recovery_time_ ...
        start at NEGATIVE_INFINITY: DAIDALUS's RecoveryInformation of a saturated recovery, e.g. an NMAC that no
        value avoids)."""
        p = self.params
        L = p.lookahead_s
        self.recovery_info = (-math.inf, -math.inf, -math.inf, 0)
        nmac = Cylinder(p.horizontal_nmac_m, p.vertical_nmac_m)
        none = cand.green_segments(idx, nmac, 0.0, T, None)
        if not none.any():
            return none, False
        cyl = Cylinder(p.min_horizontal_recovery_m, p.min_vertical_recovery_m)
        factor = 1.0 - p.ca_factor
        nfactor = 0
        while cyl.d_m > p.horizontal_nmac_m or cyl.h_m > p.vertical_nmac_m:
            none = cand.green_segments(idx, cyl, 0.0, T, None)
            solid = not none.any()
            if solid and not p.ca_bands:
                return none, False
            if not solid:
                red_t, green_t = 0.0, L + 1.0
                pivot = green_t - 1.0
                while green_t - red_t > 0.5:
                    none = self._green(cand, self._corrective, idx, pivot, T, cyl)
                    if not none.any():
                        red_t = pivot
                    else:
                        green_t = pivot
                    pivot = (red_t + green_t) / 2.0
                rec_time = min(L, green_t + p.recovery_stability_time_s) if green_t <= L else red_t
                none = self._green(cand, self._corrective, idx, rec_time, T, cyl)
                if none.any():
                    self.recovery_info = (rec_time, cyl.d_m, cyl.h_m, nfactor)
                    return none, True
                if not p.ca_bands:
                    return none, False
            nfactor += 1
            self.recovery_info = (-math.inf, -math.inf, -math.inf, nfactor)
            cyl = Cylinder(max(p.horizontal_nmac_m, cyl.d_m * factor), max(p.vertical_nmac_m, cyl.h_m * factor))
        return none, False

    def _kind_bands(self, kind: _Kind, time_s, so, vo, si, vi, conf_idx, conf_at, sum_data=None):
        p = self.params
        L = p.lookahead_s
        if kind.name == "track_deg":
            val = track_rad(vo[0], vo[1])
        elif kind.name == "ground_speed_mps":
            val = ground_speed_mps(vo[0], vo[1])
        elif kind.name == "vertical_rate_mps":
            val = float(vo[2])
        else:
            val = float(so[2])
        if kind.mod == 0 and not (kind.min_val <= val <= kind.max_val and kind.min_val != kind.max_val):
            return (), False  # DaidalusRealBands.set_input: no bands
        cand = self._candidates(kind, val, so, vo, si, vi, sum_data)
        self.recovery_information[kind.name] = None
        # aircraft per region: conflict (horizon lookahead) + peripheral (horizon alerting time)
        acs: list[tuple[np.ndarray, np.ndarray] | None] = []
        for r in range(len(_REGION_OF_INDEX)):
            painted = self._painting(r)
            if not painted:
                acs.append(None)
                continue
            idx, T = [conf_idx[r]], [np.full(len(conf_idx[r]), L)]
            for g, lv in painted:
                at = min(L, lv.alerting_time_s)
                candidates = np.zeros(cand.n, bool)
                candidates[g] = ~conf_at[r][g]
                if candidates.any():
                    periph = np.flatnonzero(candidates & cand.any_red(lv.thresholds, at))
                    idx.append(periph)
                    T.append(np.full(len(periph), at))
            acs.append((np.concatenate(idx).astype(int), np.concatenate(T)))
        none_sets: list[np.ndarray | None] = [None, None, None]
        recovery = False
        saturated = False
        r = 0
        while r < 3 and not saturated:
            if acs[r] is not None:
                idx, T = acs[r]
                none_sets[r] = self._green(cand, r, idx, 0.0, T, None)
                if kind.recovery and not none_sets[r].any() and r <= self._corrective:
                    cidx, cT = acs[self._corrective]
                    none_sets[self._corrective], _ = self._recovery_bands(cand, cidx, cT)
                    self.recovery_information[kind.name] = self.recovery_info
                    recovery = True
                saturated = recovery or not none_sets[r].any()
            r += 1
        last = self._corrective if recovery else r - 1
        color = np.zeros(cand.n_segments, int)
        for r in range(last + 1):
            if acs[r] is None:
                continue
            reg = _REGION_OF_INDEX[r]
            color = np.where(~none_sets[r] & (color < reg), reg, color)
            if not none_sets[r].any():
                break
        if recovery:
            color = np.where(none_sets[self._corrective], RECOVERY, color)
        lcv = self._color_values(kind, cand, val, color)
        h = self._hyst[kind.name]
        h.reset_if_current_time(time_s)
        h.m_of_n(lcv)
        ranges = h.persistence(lcv, recovery, val)
        scale = math.degrees(1.0) if kind.mod > 0 else 1.0
        return tuple(BandInterval(float(lo) * scale, float(up) * scale, _NAME[reg]) for lo, up, reg in ranges), \
            recovery

    def _color_values(self, kind: _Kind, cand, val, color) -> list[_CV]:
        """ColorValue list of the painted segments (color_values): boundaries where the colour changes."""
        if isinstance(cand, _Altitude):
            lo = kind.min_val + np.arange(cand.n_segments) * kind.step
        else:
            lo = val + (np.arange(cand.n_segments) - cand.center) * kind.step
        hi = lo + kind.step
        if kind.mod == 0:
            lo, hi = np.maximum(lo, kind.min_val), np.minimum(hi, kind.max_val)
            keep = almost_less(lo, hi)
            a, b, c = lo[keep], hi[keep], color[keep]
        else:  # on the circle: a segment across 2 pi in two, then in order (as sorting the (a, b, colour) rows)
            a0 = np.remainder(lo, TWO_PI)  # Python's float %: fmod, sign-corrected
            b0 = a0 + (hi - lo)
            split = b0 > TWO_PI + 1e-12
            a = np.concatenate([a0, np.zeros(int(split.sum()))])
            b = np.concatenate([np.where(split, TWO_PI, np.minimum(b0, TWO_PI)), b0[split] - TWO_PI])
            c = np.concatenate([color, color[split]])
            order = np.lexsort((c, b, a))
            a, b, c = a[order], b[order], c[order]
        # the painted pieces: runs of one colour whose segments abut (to 1e-9), empty segments (1e-12) left out
        full = ~(b - a <= 1e-12)
        a, b, c = a[full], b[full], c[full]
        joins = np.zeros(len(a), bool)
        joins[1:] = (c[1:] == c[:-1]) & (np.abs(b[:-1] - a[1:]) < 1e-9)
        starts = np.flatnonzero(~joins)
        ends = np.append(starts[1:] - 1, len(a) - 1)
        pieces = list(zip(a[starts].tolist(), b[ends].tolist(), c[starts].tolist()))
        if kind.mod == 0:
            lcv = [_CV(UNKNOWN, kind.min_val, pieces[0][2])]
            lcv += [_CV(pieces[i - 1][2], pieces[i][0], pieces[i][2]) for i in range(1, len(pieces))]
            lcv.append(_CV(pieces[-1][2], kind.max_val, UNKNOWN))
        else:
            lcv = [_CV(pieces[-1][2], 0.0, pieces[0][2])]
            lcv += [_CV(pieces[i - 1][2], pieces[i][0], pieces[i][2]) for i in range(1, len(pieces))]
            lcv.append(_CV(pieces[-1][2], TWO_PI, pieces[0][2]))
        return lcv

    # -- public ---------------------------------------------------------------------------------------------------

    def compute(self, time_s: float, own_pos, own_vel, intr_pos, intr_vel, intruder_ids: Sequence,
                alert_levels, errors=None, non_cooperative=None) -> Bands:
        """Bands at time_s. Positions (3,) / (N, 3) and velocities in local ENU (m, m/s); intruder_ids name the
        intruders across calls; alert_levels (N,) are their current DAIDALUS alert levels (0..3), used for the
        early alerting time of the level painting each region (DaidalusCore.conflict_aircraft). errors: (N, 4)
        ownship's + each intruder's errors before z-scores (the alerter's Encounter.uncertainty), used with the
        engine's sum_z (None, or no sum_z: the plain WCV_TAUMOD). non_cooperative: (N,) bool, the intruders seen
        only by the ownship's sensors, taken with the non-cooperative levels (None: none is)."""
        so, vo = np.asarray(own_pos, float).reshape(3), np.asarray(own_vel, float).reshape(3)
        si = np.asarray(intr_pos, float).reshape(-1, 3)
        vi = np.asarray(intr_vel, float).reshape(-1, 3)
        ids = list(intruder_ids)
        levels = np.asarray(alert_levels, int).reshape(-1)
        if not (len(ids) == si.shape[0] == vi.shape[0] == levels.shape[0]):
            raise ValueError("intr_pos, intr_vel, intruder_ids and alert_levels must have the same length")
        sum_data = None
        if errors is not None and self.sum_z is not None:
            errors = np.asarray(errors, float).reshape(-1, 4)
            if errors.shape[0] != si.shape[0]:
                raise ValueError("errors must have one row per intruder")
            sum_data = (self.sum_z, errors)
        sensed = np.zeros(len(ids), bool) if non_cooperative is None else np.asarray(non_cooperative, bool).reshape(-1)
        if sensed.shape != (len(ids),):
            raise ValueError("non_cooperative must have one flag per intruder")
        if self._non_cooperative is not None and sensed.any():
            self._alerters = [(np.flatnonzero(~sensed), self._level_for_region),
                              (np.flatnonzero(sensed), self._non_cooperative)]
        else:
            self._alerters = [(np.arange(len(ids)), self._level_for_region)]
        conf_idx, conf_at = self._conflict_aircraft(float(time_s), so, vo, si, vi, ids, levels, sum_data)
        out, rec = dict.fromkeys(KINDS, ()), {}
        for kind in self._kinds:
            out[kind.name], rec[kind.name] = self._kind_bands(kind, float(time_s), so, vo, si, vi, conf_idx,
                                                              conf_at, sum_data)
        return Bands(time_s=float(time_s), recovery=rec, ownship_pos=tuple(map(float, so)),
                     ownship_vel=tuple(map(float, vo)), intruders=tuple(zip(map(str, ids), map(int, levels))),
                     traffic=tuple((tuple(map(float, p)), tuple(map(float, v))) for p, v in zip(si, vi)), **out)
