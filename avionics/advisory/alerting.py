"""Alerting shaped as NASA DAIDALUS shapes it: an alerter is an ordered list of alert levels, each a detector with
its thresholds (per sensitivity level) and its hysteresis; the alert is the most severe level whose detector fires.

The model (nasa/daidalus, Java, package gov.nasa.larcfm.ACCoRD):
  Detection3D      the detector interface: `violation(so, vo, si, vi)` (loss of the volume now) and
                   `conflict(so, vo, si, vi, B, T)` (loss within [B, T]) -> `Detector` here, over N pairs at once.
  AlertThresholds  one alert level: a detector and an alerting time (`getAlertingTime`) -> `AlertLevel`.
  Alerter          the levels 1..n, 0 meaning none; "it is assumed that for all alert level i >= 1:
                   detection(i+1) => detection(i)" (Alerter.java) -> `Alerter`.
  TCAS3D           TCAS II threat detection with a TCASTable row per sensitivity level (TCAS2D.horizontal_RA,
                   TCAS3D.vertical_RA, TCAS3D.cd2d_TCAS) -> `TCAS3D`, the logic of advisory/logic.py before issue 12.
  CDCylinder/CD3D  the cylinder: loss of separation is |s_xy| < D and |s_z| < H (CD3D.LoS), a conflict is such a
                   loss at some time in [B, T] of straight-line relative motion (CD3D.cd3d) -> `CD3D`.
                   Alerter.CD3D() is the cylinder of 5 nmi x 1000 ft with a 180 s lookahead: `cd3d_alerter()`.

TA and RA are the two levels of the `tcas2` alerter (numbers 1 and 2, AdvisoryLevel.TA and .RA, names "TA" and
"RA"), both TCAS3D with the columns of the profile's sensitivity-level table ([B71] "Introduction to TCAS II
Version 7.1", FAA 2011, Table 3; HMD: DO-185B): TA = (TA TAU, TA DMOD, TA ZTHR), RA = (RA TAU, RA DMOD, RA ZTHR,
HMD). The TA level lets an intruder without altitude pass the vertical test (TCAS shows non-altitude-reporting
traffic on range alone); the RA level needs its altitude and a vertical rate a threat may be declared against.

Hysteresis: a TA stays at least `min_duration_s` (TCAS II: 8 s, [B71] "Traffic advisories"; the advisory state
machine applies it, advisory/logic.py AdvisoryState); an RA whose tests no longer hold continues while the range
still closes (`TcasRaContinuation`; [B71]: "when the range of an intruder responsible for an RA begins to
increase, its conflict is resolved"; the v7.1 HMD filter may end it earlier).
"""

from __future__ import annotations

from dataclasses import dataclass, fields, replace

import numpy as np

from avionics.advisory.levels import AlertLevel, Continuation, Detector  # noqa: F401  (the alerter's types)
from avionics.advisory.tables import SensitivityLevel
from avionics.conflict.cpa import PairGeometry
from avionics.conflict.probability import as_c
from avionics.base import jit
from avionics.base.types import AdvisoryLevel
from avionics.base.units import FT, NM

kernels = jit.lazy(__name__, "avionics.conflict.kernels")  # the module, once jit.load() ran (jit.py)
wcv_kernels = jit.lazy(__name__, "avionics.advisory.kernels", "wcv_kernels")

NONE = int(AdvisoryLevel.NONE)


@dataclass(frozen=True, slots=True)
class Encounter:
    """What a detector sees of N pairs: the relative geometry (intruder - ownship, datum-matched altitudes) and
    what is known of each intruder."""

    geometry: PairGeometry
    has_altitude: np.ndarray  # (N,) bool: the intruder's altitude is known (else its sz, vz are placeholders)
    vertical_margin_m: np.ndarray | float = 0.0  # (N,) datum-mismatch widening: separation used is |sz| - margin
    threat_eligible: np.ndarray | bool = True  # (N,) an RA threat may be declared (the intruder's vertical rate)
    # (N, 4) ownship's + intruder's stated errors before z-scores (advisory/wcv_sum.py SumData.errors: horizontal
    # and vertical position, horizontal and vertical speed), read by the SUM detector; None: no uncertainty
    uncertainty: np.ndarray | None = None
    non_cooperative: np.ndarray | bool = False  # (N,) the intruder is seen only by the ownship's sensors

    def take(self, rows) -> "Encounter":
        """The encounter of the pairs `rows` (an int array)."""
        g = self.geometry
        geometry = replace(g, **{f.name: getattr(g, f.name)[rows] for f in fields(g) if getattr(g, f.name) is not None})
        pick = lambda a: a if np.ndim(a) == 0 else np.asarray(a)[rows]  # noqa: E731
        return Encounter(geometry, np.asarray(self.has_altitude)[rows], pick(self.vertical_margin_m),
                         pick(self.threat_eligible),
                         None if self.uncertainty is None else np.asarray(self.uncertainty)[rows],
                         pick(self.non_cooperative))

    def separation_z_m(self) -> np.ndarray:
        """The relative altitude with the margin taken off (never below 0): uncertainty never hides a threat."""
        sz = self.geometry.sz_m
        return np.sign(sz) * np.maximum(np.abs(sz) - self.vertical_margin_m, 0.0)


# --- TCAS3D -----------------------------------------------------------------------------------------------


@dataclass(frozen=True, slots=True)
class TcasThresholds:
    """One TCASTable row for one advisory type ([B71] Table 3): TAU (s), DMOD (m), ZTHR (m), HMD (m, RA only)."""

    tau_s: float
    dmod_m: float
    zthr_m: float
    hmd_m: float | None = None

    @property
    def alerting_time_s(self) -> float:
        return self.tau_s


def ta_thresholds(level: SensitivityLevel) -> TcasThresholds:
    """The TA columns of a sensitivity level ([B71] Table 3: TA TAU, TA DMOD, TA ZTHR)."""
    return TcasThresholds(level.ta_tau_s, level.ta_dmod_m, level.ta_zthr_m)


def ra_thresholds(level: SensitivityLevel) -> TcasThresholds | None:
    """The RA columns ([B71] Table 3: RA TAU, RA DMOD, RA ZTHR; HMD from DO-185B); None where the level has no RA
    (TCAS SL 2)."""
    if level.ra_tau_s is None:
        return None
    return TcasThresholds(level.ra_tau_s, level.ra_dmod_m, level.ra_zthr_m, level.ra_hmd_m)


def _horizontal_test(g: PairGeometry, dmod_m: float, tau_s: float) -> np.ndarray:
    """TCAS2D.horizontal_RA: inside DMOD (closing or not), or closing with modified tau <= TAU."""
    return (g.range_m <= dmod_m) | ((g.s_dot_v < 0.0) & (g.mod_tau(dmod_m) <= tau_s))


def _vertical_test(sz_m: np.ndarray, vz_mps: np.ndarray, zthr_m: float, tau_s: float) -> np.ndarray:
    """TCAS3D.vertical_RA: inside ZTHR, or converging with time to co-altitude (TCOA) <= TAU."""
    converging = sz_m * vz_mps < 0.0
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        t_coalt = np.where(converging, -sz_m / np.where(converging, vz_mps, 1.0), np.inf)
    return (np.abs(sz_m) <= zthr_m) | (converging & (t_coalt <= tau_s))


def _per_pair(a, n: int, dtype) -> np.ndarray:
    """An (N,) array or a scalar of the Encounter as an (N,) array the kernels take."""
    a = np.asarray(a, dtype)
    return as_c(a if a.shape == (n,) else np.full(n, a, dtype), dtype)


@dataclass(frozen=True, slots=True)
class TCAS3D:
    """TCAS II v7.1 threat detection (DO-185B; DAIDALUS TCAS3D after Muñoz, Narkawicz & Chamberlain 2013):

      horizontal: r <= DMOD, or closing (s.v < 0) with modified tau <= TAU          (TCAS2D.horizontal_RA)
      vertical:   |sz| <= ZTHR, or converging with time to co-altitude <= TAU      (TCAS3D.vertical_RA)
      HMD filter: horizontal miss distance at CPA <= HMD, where the thresholds have one and `hmd_filter`
                  (v7.1; inside the HMD circle when diverging, as TCAS3D.cd2d_TCAS's exit time >= 0)

    altitude_required False (the TA): an intruder without altitude passes the vertical test; True (the RA): it
    never fires, nor against an intruder that is not threat-eligible. A diverging pair outside DMOD is clear; inside
    DMOD it is not (a slowly diverging neighbour at the same altitude stays a threat, as in TCAS3D)."""

    altitude_required: bool = False
    hmd_filter: bool = True

    def conflict(self, encounter: Encounter, thresholds: TcasThresholds, time_s: float) -> np.ndarray:
        """The tests of every pair in one call of the compiled kernel (conflict/kernels.py tcas3d_conflict_pairs)
        when the compiled kernels are ready (avionics.base.jit.ready), else `conflict_reference`."""
        if not jit.ready():
            return self.conflict_reference(encounter, thresholds, time_s)
        g = encounter.geometry
        n = g.range_m.shape[0]
        hmd = thresholds.hmd_m if self.hmd_filter and thresholds.hmd_m is not None else np.nan
        return kernels.tcas3d_conflict_pairs(
            as_c(g.range_m), as_c(g.s_dot_v), as_c(g.hmd_m), as_c(g.sz_m), as_c(g.vz_mps),
            _per_pair(encounter.has_altitude, n, bool), _per_pair(encounter.vertical_margin_m, n, np.float64),
            _per_pair(encounter.threat_eligible, n, bool), float(thresholds.dmod_m), float(thresholds.zthr_m),
            float(time_s), float(hmd), self.altitude_required)

    def conflict_reference(self, encounter: Encounter, thresholds: TcasThresholds, time_s: float) -> np.ndarray:
        """The numpy reference of `conflict`."""
        g = encounter.geometry
        horizontal = _horizontal_test(g, thresholds.dmod_m, time_s)
        vertical = _vertical_test(encounter.separation_z_m(), g.vz_mps, thresholds.zthr_m, time_s)
        has_alt = encounter.has_altitude
        if self.altitude_required:
            out = has_alt & encounter.threat_eligible & horizontal & vertical
        else:
            out = horizontal & (~has_alt | vertical)
        if self.hmd_filter and thresholds.hmd_m is not None:
            out = out & (g.hmd_m <= thresholds.hmd_m)
        return np.asarray(out, bool)

    def violation(self, encounter: Encounter, thresholds: TcasThresholds) -> np.ndarray:
        """The tests with a zero time: inside DMOD and ZTHR (and the HMD filter)."""
        return self.conflict(encounter, thresholds, 0.0)


@dataclass(frozen=True, slots=True)
class TcasRaContinuation:
    """An RA threat whose RA tests no longer hold stays a threat while the range still closes, unless the HMD
    filter ends it ([B71]: the HMD filter can terminate an RA before ALIM is obtained). Without this an RA could
    end halfway, ownship go back to its old vertical rate, and fly into the threat it was steering clear of. The
    threat must still be one an RA may be issued against (altitude known, threat-eligible)."""

    hmd_filter: bool = True

    def __call__(self, encounter: Encounter, thresholds: TcasThresholds, had: np.ndarray) -> np.ndarray:
        g = encounter.geometry
        keep = had & (g.s_dot_v < 0.0)
        if self.hmd_filter and thresholds.hmd_m is not None:
            keep &= g.hmd_m <= thresholds.hmd_m
        return keep & encounter.has_altitude & encounter.threat_eligible


# --- CD3D ---------------------------------------------------------------------------------------------------


@dataclass(frozen=True, slots=True)
class CylinderThresholds:
    """DAIDALUS CD3DTable (D, H) and the AlertThresholds alerting time: a cylinder of radius d_m and half height
    h_m, a conflict being its loss within lookahead_s."""

    d_m: float
    h_m: float
    lookahead_s: float

    @property
    def alerting_time_s(self) -> float:
        return self.lookahead_s


@dataclass(frozen=True, slots=True)
class CD3D:
    """DAIDALUS CDCylinder / CD3D for N pairs, straight-line relative motion s(t) = s + v t, sz(t) = sz + vz t:

      violation (CD3D.LoS):  |s|^2 < D^2 and |sz| < H
      conflict (CD3D.cd3d):  some t in [0, T] with |s + v t| < D and |sz + vz t| < H

    The open intervals of each axis (the roots of |v|^2 t^2 + 2 s.v t + |s|^2 - D^2 and of |sz + vz t| = H;
    every t when the axis has no relative motion and is inside, none when outside) intersected with [0, T]: a
    conflict when max(t_in, 0) < min(t_out, T). The vertical separation has the datum margin taken off. An intruder
    without altitude passes the vertical test unless altitude_required (then no conflict)."""

    altitude_required: bool = False

    def violation(self, encounter: Encounter, thresholds: CylinderThresholds) -> np.ndarray:
        g = encounter.geometry
        horizontal = g.range_m**2 < thresholds.d_m**2
        vertical = np.abs(encounter.separation_z_m()) < thresholds.h_m
        return self._with_altitude(encounter, horizontal, vertical)

    def conflict(self, encounter: Encounter, thresholds: CylinderThresholds, time_s: float) -> np.ndarray:
        g = encounter.geometry
        h_in, h_out = _open_disk_interval(g.s_xy_m, g.v_xy_mps, thresholds.d_m)
        z_in, z_out = _open_slab_interval(encounter.separation_z_m(), g.vz_mps, thresholds.h_m)
        has_alt = np.asarray(encounter.has_altitude, bool)
        if not self.altitude_required:  # without altitude: every time passes the vertical test
            z_in, z_out = np.where(has_alt, z_in, -np.inf), np.where(has_alt, z_out, np.inf)
        t_in = np.maximum(np.maximum(h_in, z_in), 0.0)
        t_out = np.minimum(np.minimum(h_out, z_out), time_s)
        out = t_in < t_out  # NaN (never on an axis) compares False
        return out & has_alt if self.altitude_required else out

    def _with_altitude(self, encounter: Encounter, horizontal, vertical) -> np.ndarray:
        has_alt = np.asarray(encounter.has_altitude, bool)
        if self.altitude_required:
            return horizontal & vertical & has_alt
        return horizontal & (~has_alt | vertical)


def _open_disk_interval(s_xy, v_xy, d_m):
    """(t_in, t_out) with |s + v t| < D exactly for t_in < t < t_out; (-inf, inf) for v = 0 inside; NaN never."""
    a = np.einsum("ij,ij->i", v_xy, v_xy)
    b = np.einsum("ij,ij->i", s_xy, v_xy)
    c = np.einsum("ij,ij->i", s_xy, s_xy) - d_m**2
    disc = b * b - a * c
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        q = -(b + np.copysign(np.sqrt(np.maximum(disc, 0.0)), b))  # cancellation-free roots q/a and c/q
        t1 = q / np.where(a > 0.0, a, 1.0)
        t2 = np.where(q != 0.0, c / np.where(q != 0.0, q, 1.0), 0.0)
    moving = a > 0.0
    t_in = np.where(moving, np.where(disc > 0.0, np.minimum(t1, t2), np.nan), np.where(c < 0.0, -np.inf, np.nan))
    t_out = np.where(moving, np.where(disc > 0.0, np.maximum(t1, t2), np.nan), np.where(c < 0.0, np.inf, np.nan))
    return t_in, t_out


def _open_slab_interval(sz, vz, h_m):
    """(t_in, t_out) with |sz + vz t| < H exactly for t_in < t < t_out; (-inf, inf) level inside; NaN never."""
    level = vz == 0.0
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        safe = np.where(level, 1.0, vz)
        t1, t2 = (-h_m - sz) / safe, (h_m - sz) / safe
    inside = np.abs(sz) < h_m
    t_in = np.where(level, np.where(inside, -np.inf, np.nan), np.minimum(t1, t2))
    t_out = np.where(level, np.where(inside, np.inf, np.nan), np.maximum(t1, t2))
    return t_in, t_out


# --- levels and the alerter ---------------------------------------------------------------------------------


@dataclass(frozen=True)
class Alerter:
    """An ordered list of alert levels (numbers 1..n; 0 = no alert). `alert` returns per pair the number of the
    most severe level whose detector fires (DAIDALUS Alerter / DaidalusCore.alert_level)."""

    name: str
    levels: tuple[AlertLevel, ...]
    # DAIDALUS's per-intruder alerter (its aircraft's `alerter` index; issue 30 item 5): the levels that judge the
    # intruders seen only by the ownship's sensors (Encounter.non_cooperative), e.g. DO-365B's DWC_Non_Coop beside
    # the Phase I volume. Same level numbers, names and advisories as this alerter's (checked), other thresholds.
    non_cooperative: Alerter | None = None

    def __post_init__(self):
        if [lv.number for lv in self.levels] != list(range(1, len(self.levels) + 1)):
            raise ValueError(f"alerter {self.name}: the levels must be numbered 1..{len(self.levels)} in order")
        other = self.non_cooperative
        if other is not None and ([(lv.name, lv.advisory_level) for lv in other.levels]
                                  != [(lv.name, lv.advisory_level) for lv in self.levels]):
            raise ValueError(f"alerter {self.name}: its non-cooperative alerter {other.name} must have the same "
                             "levels (number, name, advisory), so that one advisory logic reads both")
        object.__setattr__(self, "_compiled", _CompiledWcv.of(self.levels))

    @property
    def most_severe(self) -> int:
        return len(self.levels)

    def level(self, number: int) -> AlertLevel:
        return self.levels[number - 1]

    def names(self) -> dict[int, str]:
        """Alert number -> name, with 0 -> "NONE"."""
        return {NONE: "NONE", **{lv.number: lv.name for lv in self.levels}}

    @property
    def own_levels(self) -> bool:
        """The alert levels are not the advisory levels (a DO-365 alerter's preventive, corrective, warning):
        advisories carry the alert level and its name beside TA/RA."""
        return any(lv.advisory_level != lv.number for lv in self.levels)

    def advisory_of(self, alert: int) -> int:
        """The advisory level (AdvisoryLevel number) an alert level raises; 0 for 0."""
        return NONE if alert == NONE else self.level(alert).advisory_level

    @property
    def highest_without_ra(self) -> int:
        """The most severe level that raises no RA (the cap while RAs are inhibited)."""
        return max((lv.number for lv in self.levels if lv.advisory_level < int(AdvisoryLevel.RA)), default=NONE)

    def alert(self, encounter: Encounter, level: SensitivityLevel, max_level: int | None = None,
              previous: np.ndarray | None = None) -> np.ndarray:
        """(N,) int: the most severe level (<= max_level: e.g. the RA inhibited at low altitude) whose detector
        fires at this sensitivity level; 0 where none does. previous (N,) int: each intruder's alert level so
        far, for the levels' early alerting times (DaidalusCore.raw_alert_level). A well-clear alerter runs as
        one compiled kernel call when the kernels are ready (advisory/kernels.py wcv_alert_pairs; this loop over
        the levels' numpy detectors is its reference)."""
        split = self._by_surveillance(encounter)
        if split is not None:
            out = np.empty(len(split[0]) + len(split[1]), int)
            for alerter, rows in zip((self, self.non_cooperative), split):
                if len(rows):
                    out[rows] = alerter.alert(encounter.take(rows), level, max_level,
                                              None if previous is None else previous[rows])
            return out
        if self._compiled is not None and jit.ready():
            return self._compiled.alert(encounter, max_level, previous)
        out = np.full(len(encounter.has_altitude), NONE, int)
        for lv in self.levels:
            if max_level is not None and lv.number > max_level:
                break
            fires = lv.fires(encounter, level, None if previous is None else previous == lv.number)
            if fires is not None:
                out = np.where(fires, lv.number, out)
        return out

    def _by_surveillance(self, encounter: Encounter) -> tuple[np.ndarray, np.ndarray] | None:
        """(cooperative rows, non-cooperative rows) where a non-cooperative alerter is set and some intruder is
        non-cooperative; None where this alerter judges every pair."""
        nc = encounter.non_cooperative
        if self.non_cooperative is None or nc is False or not np.any(nc):
            return None
        nc = np.broadcast_to(np.asarray(nc, bool), np.shape(encounter.has_altitude))
        return np.flatnonzero(~nc), np.flatnonzero(nc)

    def hold(self, encounter: Encounter, level: SensitivityLevel, previous: np.ndarray, candidates: np.ndarray,
             max_level: int | None = None) -> tuple[np.ndarray, np.ndarray]:
        """Apply the levels' continuations: a pair that had a level (`previous` (N,) int) and whose candidate is now
        below it keeps the level while its continuation holds. Returns (candidates, continued (N,) bool)."""
        split = self._by_surveillance(encounter)
        if split is not None:
            candidates, continued = np.array(candidates, copy=True), np.zeros(len(candidates), bool)
            for alerter, rows in zip((self, self.non_cooperative), split):
                if len(rows):
                    candidates[rows], continued[rows] = alerter.hold(encounter.take(rows), level, previous[rows],
                                                                     candidates[rows], max_level)
            return candidates, continued
        continued = np.zeros(len(candidates), bool)
        for lv in self.levels:
            if lv.continuation is None or (max_level is not None and lv.number > max_level):
                continue
            thresholds = lv.thresholds_at(level)
            if thresholds is None:
                continue
            keep = lv.continuation(encounter, thresholds, previous == lv.number) & (candidates < lv.number)
            candidates = np.where(keep, lv.number, candidates)
            continued |= keep
        return candidates, continued


class _CompiledWcv:
    """A well-clear alerter's levels as the compiled kernel takes them (advisory/kernels.py LEVEL_COLUMNS and
    SUM_COLUMNS), built once per Alerter: every level a WCV_TAUMOD (or every one a WCV_TAUMOD_SUM with the same
    z-scores and lookahead) with fixed thresholds and an alerting time; `of` returns None for any other alerter."""

    __slots__ = ("levels", "sum_params")

    def __init__(self, levels: np.ndarray, sum_params: np.ndarray):
        self.levels, self.sum_params = levels, sum_params

    @classmethod
    def of(cls, levels) -> "_CompiledWcv | None":
        from avionics.advisory.wcv import WCV_TAUMOD, WcvThresholds
        from avionics.advisory.wcv_sum import WCV_TAUMOD_SUM

        kinds = {type(lv.detector) for lv in levels}
        if not levels or not kinds <= {WCV_TAUMOD, WCV_TAUMOD_SUM} or len(kinds) > 1:
            return None
        if any(not isinstance(lv.thresholds, WcvThresholds) or lv.alerting_time_s is None for lv in levels):
            return None
        sums = {(lv.detector.z_scores, lv.detector.lookahead_s) for lv in levels
                if isinstance(lv.detector, WCV_TAUMOD_SUM)}
        if len(sums) > 1:
            return None
        rows = [(t.dthr_m, t.dthr_m**2, t.zthr_m, t.tthr_s, t.tcoa_s, lv.alerting_time_s,
                 np.nan if lv.early_alerting_time_s is None else lv.early_alerting_time_s,
                 float(lv.detector.altitude_required)) for lv in levels for t in (lv.thresholds,)]
        z, lookahead = sums.pop() if sums else (None, 0.0)
        sum_params = np.zeros(8) if z is None else np.array(
            [1.0, z.h_pos, z.h_vel_min, z.h_vel_max, z.h_vel_distance_m, z.v_pos, z.v_vel, lookahead])
        return cls(np.array(rows, np.float64), sum_params)

    def alert(self, encounter: Encounter, max_level: int | None, previous: np.ndarray | None) -> np.ndarray:
        g = encounter.geometry
        n = len(encounter.has_altitude)
        errors = encounter.uncertainty if self.sum_params[0] else None
        return wcv_kernels.wcv_alert_pairs(
            as_c(g.s_xy_m), as_c(g.v_xy_mps), as_c(g.sz_m), as_c(g.vz_mps), _per_pair(encounter.has_altitude, n, bool),
            _per_pair(encounter.vertical_margin_m, n, np.float64),
            np.zeros((n, 4)) if errors is None else as_c(errors),
            np.zeros(n, np.int64) if previous is None else as_c(previous, np.int64), self.levels, self.sum_params,
            len(self.levels) if max_level is None else int(max_level))


def tcas2_alerter(hmd_filter: bool = True, ta_min_duration_s: float = 8.0) -> Alerter:
    """The TCAS II alerter: level 1 "TA" and level 2 "RA" (AdvisoryLevel.TA, .RA), both TCAS3D with the columns
    of whatever sensitivity-level table the profile carries (tcas2, small-uas, do365, daidalus-tcas3d)."""
    ta = AlertLevel(int(AdvisoryLevel.TA), AdvisoryLevel.TA.name, TCAS3D(altitude_required=False, hmd_filter=False),
                    ta_thresholds, min_duration_s=ta_min_duration_s)
    ra = AlertLevel(int(AdvisoryLevel.RA), AdvisoryLevel.RA.name, TCAS3D(altitude_required=True, hmd_filter=hmd_filter),
                    ra_thresholds, continuation=TcasRaContinuation(hmd_filter))
    return Alerter("tcas2", (ta, ra))


def wcv_alerter(spec, name: str = "wcv", non_cooperative: Alerter | None = None) -> Alerter:
    """A DO-365 well-clear alerter: the levels of a profile's [alerter] table as advisory/tables.py read them
    (WcvAlerterSpec.levels: AlertLevels with WCV_TAUMOD detectors, advisory/wcv.py, or WCV_TAUMOD_SUM,
    advisory/wcv_sum.py, where the table has [alerter.sum]; the guidance bands read the same levels). Their
    hysteresis (M of N, persistence) is DAIDALUS's HysteresisData, advisory/persistence.py AlertingHysteresis.
    non_cooperative: the alerter of the intruders seen only by the ownship's sensors (Alerter.non_cooperative)."""
    return Alerter(name, tuple(spec.levels), non_cooperative)


CD3D_D_M, CD3D_H_M, CD3D_LOOKAHEAD_S = 5.0 * NM, 1000.0 * FT, 180.0  # DAIDALUS Alerter.CD3D()


def cd3d_alerter(d_m: float = CD3D_D_M, h_m: float = CD3D_H_M, lookahead_s: float = CD3D_LOOKAHEAD_S,
                 name: str = "CD3D") -> Alerter:
    """One level: the CD3D cylinder's loss within the lookahead, the same at every sensitivity level (DAIDALUS
    Alerter.CD3D(): CDCylinder(5 nmi, 1000 ft), alerting time 180 s)."""
    thresholds = CylinderThresholds(d_m, h_m, lookahead_s)
    return Alerter("cd3d", (AlertLevel(1, name, CD3D(), thresholds),))
