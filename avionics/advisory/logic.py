"""TCAS II v7.1 threat detection (TA and RA tests) for many pairs, and the per-intruder advisory state.

Tests, as in DO-185B and NASA DAIDALUS TCAS3D (Muñoz, Narkawicz & Chamberlain 2013; DAIDALUS
`TCAS2D.horizontal_RA`, `TCAS3D.vertical_RA`, `TCAS3D.cd2d_TCAS`):
  horizontal: r <= DMOD (closing or not), or closing (s.v < 0) with modified tau <= TAU
  vertical:   |sz| <= ZTHR, or converging (sz vz < 0) with time to co-altitude <= TCOA (= TAU)
  RA only:    horizontal miss distance at CPA <= HMD (v7.1 HMD filter; inside the HMD circle when
              diverging, as cd2d_TCAS's exit time >= 0); intruder altitude known; a threat may be declared
              (|intruder vertical rate| <= the profile's limit: 10,000 fpm in TCAS II v7.0/7.1); SL has an RA
An intruder without valid altitude passes the TA vertical test (TCAS shows non-altitude-reporting traffic
on range alone) and never gets an RA. A diverging pair outside DMOD is clear of conflict; inside DMOD it
is not (a slowly diverging neighbour at the same altitude stays a threat, as in TCAS3D).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from avionics.advisory.tables import SensitivityLevel
from avionics.conflict.cpa import PairGeometry
from avionics.core.types import AdvisoryLevel


def _horizontal_test(g: PairGeometry, dmod_m: float, tau_s: float) -> np.ndarray:
    return (g.range_m <= dmod_m) | ((g.s_dot_v < 0.0) & (g.mod_tau(dmod_m) <= tau_s))


def _vertical_test(sz_m: np.ndarray, vz_mps: np.ndarray, zthr_m: float, tau_s: float) -> np.ndarray:
    converging = sz_m * vz_mps < 0.0
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        t_coalt = np.where(converging, -sz_m / np.where(converging, vz_mps, 1.0), np.inf)
    return (np.abs(sz_m) <= zthr_m) | (converging & (t_coalt <= tau_s))


def detect(g: PairGeometry, level: SensitivityLevel, has_altitude: np.ndarray, vertical_margin_m: np.ndarray,
           ra_enabled: bool = True, hmd_filter: bool = True, threat_eligible: np.ndarray | bool = True) -> np.ndarray:
    """Candidate advisory level (N,) of int: NONE, TA or RA from the geometry alone.

    vertical_margin_m widens the vertical tests where the relative altitude crosses datums: the
    separation used is |sz| - margin (never below 0), so uncertainty never hides a threat.
    threat_eligible (N,) is False where no RA threat may be declared (the intruder's vertical rate).
    """
    sz = np.sign(g.sz_m) * np.maximum(np.abs(g.sz_m) - vertical_margin_m, 0.0)
    ta = _horizontal_test(g, level.ta_dmod_m, level.ta_tau_s)
    ta &= ~has_altitude | _vertical_test(sz, g.vz_mps, level.ta_zthr_m, level.ta_tau_s)
    out = np.where(ta, int(AdvisoryLevel.TA), int(AdvisoryLevel.NONE))
    if ra_enabled and level.ra_tau_s is not None:
        ra = has_altitude & threat_eligible
        ra &= _horizontal_test(g, level.ra_dmod_m, level.ra_tau_s)
        ra &= _vertical_test(sz, g.vz_mps, level.ra_zthr_m, level.ra_tau_s)
        if hmd_filter:
            ra &= g.hmd_m <= level.ra_hmd_m
        out = np.where(ra, int(AdvisoryLevel.RA), out)
    return out


def ra_continues(g: PairGeometry, level: SensitivityLevel, was_ra: np.ndarray, hmd_filter: bool = True) -> np.ndarray:
    """Which current RA threats stay threats although the RA tests no longer hold: while the range still
    closes ("when the range of an intruder responsible for an RA begins to increase, its conflict is
    resolved": clear of conflict, FAA TCAS II descriptions), unless the HMD filter ends it (v7.1 booklet: the
    HMD filter can terminate an RA before ALIM is obtained). Without this an RA could end halfway, ownship
    go back to its old vertical rate, and fly into the threat it was steering clear of."""
    keep = was_ra & (g.s_dot_v < 0.0)
    if hmd_filter and level.ra_hmd_m is not None:
        keep &= g.hmd_m <= level.ra_hmd_m
    return keep


@dataclass
class AdvisoryState:
    """One intruder's advisory over time: upgrades at once, a TA (or an RA ending) holds for ta_min_s."""

    level: AdvisoryLevel = AdvisoryLevel.NONE
    alert_onset_s: float | None = None  # when the current alert (TA or RA) began

    def next(self, now_s: float, candidate: AdvisoryLevel, ta_min_s: float, force: bool = False) -> bool:
        """Move to the level the candidate allows; force (stale data, no ownship) skips the TA hold.
        Returns True when the level changed."""
        previous = self.level
        if candidate >= self.level or force:
            new = candidate
        elif self.alert_onset_s is not None and now_s - self.alert_onset_s < ta_min_s:
            new = AdvisoryLevel.TA  # a TA stays at least ta_min_s; an ended RA steps down to that TA
        else:
            new = candidate
        if new is not AdvisoryLevel.NONE and previous is AdvisoryLevel.NONE:
            self.alert_onset_s = now_s
        if new is AdvisoryLevel.NONE:
            self.alert_onset_s = None
        self.level = new
        return new is not previous
