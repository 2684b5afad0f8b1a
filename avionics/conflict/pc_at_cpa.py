"""Probability that a pair's miss at the predicted CPA falls inside a protected volume (for alert gating).

The relative state r = intruder - ownship ~ N(m, P) with P = P_intruder + P_ownship (independent filters,
Baek & Bang eq 23) is propagated in straight lines to the horizontal CPA time t of the mean, with a relative
white-acceleration noise over t: the pipeline passes the conflict stage's prediction noise
(conflict.accel_sigma_h_mps2 / accel_sigma_v_mps2), the one used by every conflict probability:

    m(t) = m_pos + t m_vel,   P_pos(t) = P_pp + t (P_pv + P_vp) + t^2 P_vv + Q_pos(t)

and Pc = P(|x_h(t)| <= R) * P(|z(t)| <= H), the disk computed exactly (conflict.probability.pc_exact) and
the vertical slab in closed form; horizontal and vertical are independent in every tracker here.
"""

from __future__ import annotations

import numpy as np

from avionics.conflict.probability import as_c, pc_exact_reference, vertical_probability
from avionics.base import jit

kernels = jit.lazy(__name__, "avionics.conflict.kernels")  # the module, once jit.load() ran (jit.py)

# A CPA further ahead than this is no conflict any alerter here acts on (TCAS II alerts at most 48 s ahead, DO-365
# 75 s): the propagation stops there. Without a bound a pair closing at 1e-131 m/s (two hovering aircraft, a
# rounding residue) puts its CPA 1e134 s ahead, t^4 overflows and the pair failed as "not finite".
MAX_PROPAGATION_S = 3600.0


def pc_at_cpa(rel_x: np.ndarray, rel_p: np.ndarray, t_s: np.ndarray, volumes, accel_sigma_h_mps2: float,
              accel_sigma_v_mps2: float, has_altitude: np.ndarray) -> np.ndarray:
    """As `pc_at_cpa_reference` (the arguments and the result are described there), in one call of the compiled
    kernel (conflict/kernels.py pc_at_cpa_pairs: propagation, disk and slab of every volume) when the compiled
    kernels are ready (avionics.base.jit.ready), else the numpy reference."""
    if not jit.ready():
        return pc_at_cpa_reference(rel_x, rel_p, t_s, volumes, accel_sigma_h_mps2, accel_sigma_v_mps2, has_altitude)
    t = as_c(np.asarray(t_s, float).reshape(-1))
    n = t.shape[0]
    radii = np.array([r for r, _ in volumes], float)
    half = np.array([np.nan if h is None else h for _, h in volumes], float)
    has_alt = np.asarray(has_altitude, bool)
    has_alt = as_c(has_alt if has_alt.shape == (n,) else np.full(n, has_alt), bool)
    return kernels.pc_at_cpa_pairs(as_c(np.reshape(rel_x, (n, 6))), as_c(np.reshape(rel_p, (n, 6, 6))), t, radii, half,
                                   has_alt, float(accel_sigma_h_mps2), float(accel_sigma_v_mps2), MAX_PROPAGATION_S)


def pc_at_cpa_reference(rel_x: np.ndarray, rel_p: np.ndarray, t_s: np.ndarray, volumes, accel_sigma_h_mps2: float,
                        accel_sigma_v_mps2: float, has_altitude: np.ndarray) -> np.ndarray:
    """The numpy reference. rel_x (N, 6) [e, n, z, ve, vn, vz], rel_p (N, 6, 6), t_s (N,) >= 0; volumes: V pairs
    (radius m, half height m or None). Returns (V, N) probabilities, every volume's disks in one exact call (the
    per-call cost dominates for the few pairs of a single report). Without altitude (has_altitude False) or
    without a half height the vertical factor is 1."""
    t = np.minimum(np.asarray(t_s, float), MAX_PROPAGATION_S)
    n = t.shape[0]
    mean = rel_x[:, 0:3] + t[:, None] * rel_x[:, 3:6]
    pp, pv, vv = rel_p[:, 0:3, 0:3], rel_p[:, 0:3, 3:6], rel_p[:, 3:6, 3:6]
    cov = pp + t[:, None, None] * (pv + np.swapaxes(pv, 1, 2)) + (t * t)[:, None, None] * vv
    q = (t**4 / 4.0)[:, None] * np.array([accel_sigma_h_mps2**2] * 2 + [accel_sigma_v_mps2**2])
    cov = cov + q[:, :, None] * np.eye(3)[None]
    radii = np.repeat(np.array([r for r, _ in volumes], float), n)
    v = len(volumes)
    out = pc_exact_reference(np.tile(mean[:, 0:2], (v, 1)), np.tile(cov[:, 0:2, 0:2], (v, 1, 1)),
                             radii).reshape(v, n)
    for k, (_, half_height_m) in enumerate(volumes):
        if half_height_m is not None:
            out[k] *= np.where(has_altitude, vertical_probability(mean[:, 2], cov[:, 2, 2], half_height_m), 1.0)
    return out
