"""Closest point of approach and tau for many pairs at once (straight-line relative motion).

s = intruder - ownship horizontal position, v = relative velocity, sz/vz the vertical pair.
  t_cpa = max(0, -s.v / |v|^2)                  horizontal CPA time (0 when diverging or v = 0)
  hmd   = |s + v t_cpa|                         horizontal miss distance
  vmd   = sz + vz t_cpa                         vertical separation at horizontal CPA
  range tau    = -r / r_dot = -|s|^2 / (s.v)    when closing (s.v < 0), else inf
  modified tau = (DMOD^2 - r^2) / (s.v)         TCAS II (Muñoz et al. 2013, 'tau_mod'); 0 inside DMOD
  vertical tau = -sz / vz                       time to co-altitude when converging, else inf

Also (issue 4): the relative position at horizontal CPA, the 3D CPA (time, relative position, slant miss
distance; 3D CPA time = max(0, -(s.v + sz vz) / (|v|^2 + vz^2))), and the intervals during which a pair is
inside a disk |s + v t| <= R, a slab |sz + vz t| <= H, and both (the deterministic loss-of-separation window).
Degenerate cases: zero relative velocity -> CPA now; co-located -> range and taus 0; diverging -> CPA now.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from avionics.conflict.probability import as_c
from avionics.base import jit

kernels = jit.lazy(__name__, "avionics.conflict.kernels")  # the module, once jit.load() ran (jit.py)

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
    vertical_tau_s: np.ndarray  # = time to co-altitude (-sz/vz when converging, 0 at co-altitude, else inf)
    # Added for issue 4 (defaults keep any keyword construction of the fields above valid):
    s_xy_m: np.ndarray | None = None  # (N, 2) relative horizontal position
    v_xy_mps: np.ndarray | None = None  # (N, 2) relative horizontal velocity
    cpa_xy_m: np.ndarray | None = None  # (N, 2) relative horizontal position at the horizontal CPA
    t_cpa3d_s: np.ndarray | None = None  # 3D CPA time (>= 0)
    cpa3d_xyz_m: np.ndarray | None = None  # (N, 3) relative position at the 3D CPA
    miss3d_m: np.ndarray | None = None  # slant distance at the 3D CPA

    def mod_tau(self, dmod_m) -> np.ndarray:
        return modified_tau(self.range_m, self.s_dot_v, dmod_m)

    @property
    def time_to_coaltitude_s(self) -> np.ndarray:
        return self.vertical_tau_s

    def horizontal_interval(self, radius_m) -> tuple[np.ndarray, np.ndarray]:
        """(t_in, t_out) with |s + v t| <= R exactly for t_in <= t <= t_out (any sign; NaN when never)."""
        return disk_interval(self.s_xy_m, self.v_xy_mps, radius_m)

    def vertical_interval(self, half_height_m) -> tuple[np.ndarray, np.ndarray]:
        """(t_in, t_out) with |sz + vz t| <= H (+-inf for a level pair inside the slab; NaN when never)."""
        return slab_interval(self.sz_m, self.vz_mps, half_height_m)

    def conflict_interval(self, radius_m, half_height_m=None, lookahead_s=INF) -> tuple[np.ndarray, np.ndarray]:
        """Deterministic loss-of-separation window within [0, lookahead]: (t_in, t_out) of being inside the disk
        (and the slab, if half_height_m is given) at once; t_in is the time to loss of separation (0 when
        already inside). NaN, NaN when there is none in the window."""
        a, b = self.horizontal_interval(radius_m)
        if half_height_m is not None:
            c, d = self.vertical_interval(half_height_m)
            a, b = np.maximum(a, c), np.minimum(b, d)  # NaN (never) on either axis propagates
        a, b = np.maximum(a, 0.0), np.minimum(b, lookahead_s)
        none = ~(a <= b)
        return np.where(none, np.nan, a), np.where(none, np.nan, b)


def pair_geometry(s_xy, v_xy, sz, vz) -> PairGeometry:
    """The geometry of N pairs (the formulas in the module's docstring): the compiled kernel (conflict/kernels.py
    pair_geometry_pairs, one call) when the compiled kernels are ready (avionics.base.jit.ready), else the numpy reference
    `pair_geometry_reference`."""
    if not jit.ready():
        return pair_geometry_reference(s_xy, v_xy, sz, vz)
    s_xy, v_xy = np.atleast_2d(s_xy).astype(float), np.atleast_2d(v_xy).astype(float)
    sz, vz = np.atleast_1d(sz).astype(float), np.atleast_1d(vz).astype(float)
    n = max(s_xy.shape[0], v_xy.shape[0], sz.shape[0], vz.shape[0])
    # (broadcast only where needed: np.broadcast_to costs 4 us a call on the one-report path)
    s_xy = as_c(s_xy if s_xy.shape == (n, 2) else np.broadcast_to(s_xy, (n, 2)))
    v_xy = as_c(v_xy if v_xy.shape == (n, 2) else np.broadcast_to(v_xy, (n, 2)))
    sz = as_c(sz if sz.shape == (n,) else np.broadcast_to(sz, (n,)))
    vz = as_c(vz if vz.shape == (n,) else np.broadcast_to(vz, (n,)))
    g = kernels.pair_geometry_pairs(s_xy, v_xy, sz, vz)
    return PairGeometry(
        range_m=g[:, 0], s_dot_v=g[:, 1], closure_rate_mps=g[:, 2], t_cpa_s=g[:, 3], hmd_m=g[:, 4], sz_m=sz,
        vz_mps=vz, vmd_m=g[:, 5], range_tau_s=g[:, 6], vertical_tau_s=g[:, 7], s_xy_m=s_xy, v_xy_mps=v_xy,
        cpa_xy_m=g[:, 8:10], t_cpa3d_s=g[:, 10], cpa3d_xyz_m=g[:, 11:14], miss3d_m=g[:, 14])


def pair_geometry_reference(s_xy, v_xy, sz, vz) -> PairGeometry:
    """The numpy reference of `pair_geometry`."""
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
    v3 = v2 + vz * vz
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        t3 = np.where(v3 > 0.0, np.maximum(0.0, -(sv + sz * vz) / np.where(v3 > 0.0, v3, 1.0)), 0.0)
    cpa3 = np.column_stack([s_xy + v_xy * t3[:, None], sz + vz * t3])
    return PairGeometry(
        range_m=r, s_dot_v=sv, closure_rate_mps=closure, t_cpa_s=t_cpa,
        hmd_m=np.hypot(miss[:, 0], miss[:, 1]), sz_m=sz, vz_mps=vz, vmd_m=sz + vz * t_cpa,
        range_tau_s=range_tau, vertical_tau_s=vtau,
        s_xy_m=s_xy, v_xy_mps=v_xy, cpa_xy_m=miss, t_cpa3d_s=t3, cpa3d_xyz_m=cpa3,
        miss3d_m=np.linalg.norm(cpa3, axis=1),
    )


def hmd_sigma_m(g: PairGeometry, p_rel: np.ndarray) -> np.ndarray:
    """(N,) 1-sigma of each pair's horizontal miss distance, to first order, from the covariance of the relative
    state p_rel (N, 6, 6) on [x, y, z, vx, vy, vz]: the miss point s + t v moves across v by n.(ds + t dv), n the
    unit normal to v and t the time to CPA (an error along v moves the CPA's time, not the miss). With v = 0 the
    miss is the range: n = s/|s|."""
    s, v, t = g.s_xy_m, g.v_xy_mps, g.t_cpa_s
    speed, rng = np.linalg.norm(v, axis=1), np.linalg.norm(s, axis=1)
    n = np.where((speed > 0.0)[:, None], np.stack([-v[:, 1], v[:, 0]], axis=1) / np.maximum(speed, 1e-300)[:, None],
                 s / np.maximum(rng, 1e-300)[:, None])
    j = np.zeros((len(t), 6))
    j[:, 0:2], j[:, 3:5] = n, n * t[:, None]
    return np.sqrt(np.maximum(np.einsum("ni,nij,nj->n", j, p_rel, j), 0.0))


def modified_tau(range_m, s_dot_v, dmod_m) -> np.ndarray:
    """TCAS II modified tau: time until range would reach DMOD at the current closure; 0 inside DMOD."""
    range_m, s_dot_v = np.asarray(range_m, float), np.asarray(s_dot_v, float)
    dmod_m = np.asarray(dmod_m, float)
    if dmod_m.shape != range_m.shape:  # one DMOD for all (the usual call): broadcast by the ufuncs, same values
        dmod_m = np.broadcast_to(dmod_m, range_m.shape) if dmod_m.ndim else dmod_m
    inside = range_m <= dmod_m
    closing = s_dot_v < 0.0
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        tau = np.where(closing, (dmod_m**2 - range_m**2) / np.where(closing, s_dot_v, -1.0), INF)
    return np.where(inside, 0.0, tau)


def disk_interval(s_xy, v_xy, radius_m) -> tuple[np.ndarray, np.ndarray]:
    """Times (t_in, t_out), any sign, between which |s + v t| <= R; (-inf, inf) for v = 0 inside the disk,
    NaN when the line misses the disk. Roots of |v|^2 t^2 + 2 (s.v) t + |s|^2 - R^2 = 0 in the cancellation-free
    form q = -(b + sign(b) sqrt(b^2 - ac)), t = q/a and c/q."""
    s_xy, v_xy = np.atleast_2d(s_xy).astype(float), np.atleast_2d(v_xy).astype(float)
    r2 = np.broadcast_to(np.asarray(radius_m, float), s_xy.shape[:1]) ** 2
    a = np.einsum("ij,ij->i", v_xy, v_xy)
    b = np.einsum("ij,ij->i", s_xy, v_xy)
    c = np.einsum("ij,ij->i", s_xy, s_xy) - r2
    disc = b * b - a * c
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        q = -(b + np.copysign(np.sqrt(np.maximum(disc, 0.0)), b))
        t1 = q / np.where(a > 0.0, a, 1.0)
        t2 = np.where(q != 0.0, c / np.where(q != 0.0, q, 1.0), 0.0)
    t_in, t_out = np.minimum(t1, t2), np.maximum(t1, t2)
    still = a == 0.0
    t_in = np.where(still, np.where(c <= 0.0, -INF, np.nan), np.where(disc >= 0.0, t_in, np.nan))
    t_out = np.where(still, np.where(c <= 0.0, INF, np.nan), np.where(disc >= 0.0, t_out, np.nan))
    return t_in, t_out


def slab_interval(sz, vz, half_height_m) -> tuple[np.ndarray, np.ndarray]:
    """Times (t_in, t_out), any sign, between which |sz + vz t| <= H; (-inf, inf) when level inside, NaN when
    level outside."""
    sz, vz = np.atleast_1d(sz).astype(float), np.atleast_1d(vz).astype(float)
    h = np.broadcast_to(np.asarray(half_height_m, float), sz.shape)
    level = vz == 0.0
    with np.errstate(divide="ignore", invalid="ignore"):
        safe = np.where(level, 1.0, vz)
        t1, t2 = (-h - sz) / safe, (h - sz) / safe
    inside = np.abs(sz) <= h
    t_in = np.where(level, np.where(inside, -INF, np.nan), np.minimum(t1, t2))
    t_out = np.where(level, np.where(inside, INF, np.nan), np.maximum(t1, t2))
    return t_in, t_out
