"""Closest point of approach and tau for many pairs at once (straight-line relative motion).

s = intruder - ownship horizontal position, v = relative velocity, sz/vz the vertical pair.
  t_cpa = max(0, -s.v / |v|^2)                  horizontal CPA time (0 when diverging or v = 0)
  hmd   = |s + v t_cpa|                         horizontal miss distance
  vmd   = sz + vz t_cpa                         vertical separation at horizontal CPA
  range tau    = -r / r_dot = -|s|^2 / (s.v)    when closing (s.v < 0), else inf
  modified tau = (DMOD^2 - r^2) / (s.v)         TCAS II (Muñoz et al. 2013, 'tau_mod'); 0 inside DMOD
  vertical tau = -sz / vz                       time to co-altitude when converging, else inf
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

INF = np.inf


@dataclass(frozen=True, slots=True)
class PairGeometry:
    """Relative geometry of N pairs; every field is an (N,) array."""

    range_m: np.ndarray
    s_dot_v: np.ndarray  # m^2/s; < 0 when the horizontal range is closing
    closure_rate_mps: np.ndarray  # -dr/dt
    t_cpa_s: np.ndarray
    hmd_m: np.ndarray
    sz_m: np.ndarray
    vz_mps: np.ndarray
    vmd_m: np.ndarray
    range_tau_s: np.ndarray
    vertical_tau_s: np.ndarray

    def mod_tau(self, dmod_m) -> np.ndarray:
        return modified_tau(self.range_m, self.s_dot_v, dmod_m)


def pair_geometry(s_xy, v_xy, sz, vz) -> PairGeometry:
    s_xy, v_xy = np.atleast_2d(s_xy).astype(float), np.atleast_2d(v_xy).astype(float)
    sz, vz = np.atleast_1d(sz).astype(float), np.atleast_1d(vz).astype(float)
    r = np.hypot(s_xy[:, 0], s_xy[:, 1])
    sv = np.einsum("ij,ij->i", s_xy, v_xy)
    v2 = np.einsum("ij,ij->i", v_xy, v_xy)
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        t_cpa = np.where(v2 > 0.0, np.maximum(0.0, -sv / np.where(v2 > 0.0, v2, 1.0)), 0.0)
        closure = np.where(r > 0.0, -sv / np.where(r > 0.0, r, 1.0), 0.0)
        range_tau = np.where(closure > 0.0, r / np.where(closure > 0.0, closure, 1.0), INF)
        range_tau = np.where(r == 0.0, 0.0, range_tau)
        converging = sz * vz < 0.0
        vtau = np.where(converging, -sz / np.where(converging, vz, 1.0), INF)
        vtau = np.where(sz == 0.0, 0.0, vtau)
    miss = s_xy + v_xy * t_cpa[:, None]
    return PairGeometry(
        range_m=r, s_dot_v=sv, closure_rate_mps=closure, t_cpa_s=t_cpa,
        hmd_m=np.hypot(miss[:, 0], miss[:, 1]), sz_m=sz, vz_mps=vz, vmd_m=sz + vz * t_cpa,
        range_tau_s=range_tau, vertical_tau_s=vtau,
    )


def modified_tau(range_m, s_dot_v, dmod_m) -> np.ndarray:
    """TCAS II modified tau: time until range would reach DMOD at the current closure; 0 inside DMOD."""
    range_m, s_dot_v = np.asarray(range_m, float), np.asarray(s_dot_v, float)
    dmod_m = np.broadcast_to(np.asarray(dmod_m, float), range_m.shape)
    inside = range_m <= dmod_m
    closing = s_dot_v < 0.0
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        tau = np.where(closing, (dmod_m**2 - range_m**2) / np.where(closing, s_dot_v, -1.0), INF)
    return np.where(inside, 0.0, tau)
