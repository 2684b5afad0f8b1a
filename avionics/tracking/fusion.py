"""One aircraft seen by ADS-B and by a range/bearing sensor: one track, fused as Dai et al. 2017 fuse ADS-B and TCAS.

**Which tracks are one aircraft.** A sensor track (sensor_tracker.py) and an ADS-B track (imm_tracker.py) are
paired by gate and global nearest neighbour (association.py) on their positions [east, north, altitude] at a
common time, d^2 against chi2_3(gate_probability) with S = P_adsb + P_sensor.

**The fused state** (Dai Sec. 2.3, "optimal information fusion criterion", after Deng 2005 Chap. 6): L unbiased
local estimates x_i with the joint error covariance P (blocks P_ij) give the matrix-weighted linear minimum
variance estimate

    [A_1 ... A_L] = (e^T P^-1 e)^-1 e^T P^-1,   x_0 = sum A_i x_i,   P_0 = (e^T P^-1 e)^-1,   e = [I ... I]^T

(Dai eqs 41-42 with L = 2). Dai write P_12 = cov(x_TCAS, x_ADS-B) without saying how they obtain it; the local
filters' errors are correlated through the common process noise only (the measurement noises are independent),
and for IMM filters that correlation has no closed form. Two ways are offered: `cross="independent"` (P_12 = 0:
eqs 41-42 as they reduce without it; optimistic when the process noise dominates) and `cross="ci"`, covariance
intersection (Julier & Uhlmann 1997: P_0^-1 = w P_1^-1 + (1 - w) P_2^-1, w minimising trace P_0), consistent
for any unknown correlation.

**An ADS-B failure lowers ADS-B's weight** (Dai Sec. 3.7: "adjust fusion weight"): the integrity monitor's
degraded modes (integrity.py: position_loss, step, ramp, oscillation, inconsistent) widen the ADS-B track's
position covariance by the detected fault size (IntegrityMonitor.widen, at least the NIC 7 containment radius),
so A_ADS-B falls and the fused track falls back to the sensor's accuracy. A pair whose position difference fails
the association's gate (`consistent`) has a suspect, named by the monitor: a degraded ADS-B, else the sensor
(whose track then is off beyond its own covariance: active surveillance's 9-15 degree bearing has heavy tails);
the suspect's covariance grows by the disagreement d d^T. The monitor tests ADS-B against itself (position
against velocity), so a fault it has not yet seen is below its detection threshold (about 5.7 sigma of its
window's covariance, docs/tracking.md "Integrity monitor"): ADS-B keeps its weight until then.

**Variable sampling period** (Dai Sec. 2.3, Table 1): the local filters sample their measurements every 1 s
while the intruder is far, and, when it is near, faster as the position accuracy (NACp) worsens: 0.8 s at NACp
9 and 5, 0.6 s at NACp 6 to 8, 1 s at NACp 10, 11 and 0 to 4. Dai do not define "near"; here it is DEGAS's
active-surveillance threshold, tau below 60 s (SC228_ActiveSurveillanceModel.m tauThreshold_sec).
"""

from __future__ import annotations

import math

import numpy as np

from avionics.base.chi2 import chi2_quantile
from avionics.tracking.association import gnn, normalised_distances
from avionics.tracking.imm import spd_inverse

CROSS = ("independent", "ci")
# DO-260B NACp: 95 % horizontal accuracy bounds (EPU, m), NACp 1 .. 11 (Dai Table 1)
NACP_EPU_M = np.array([18520.0, 7408.0, 3704.0, 1852.0, 926.0, 555.6, 185.2, 92.6, 30.0, 10.0, 3.0])
DAI_PERIOD_S = np.array([1.0, 1.0, 1.0, 1.0, 1.0, 0.8, 0.6, 0.6, 0.6, 0.8, 1.0, 1.0])  # NACp 0 .. 11, Table 1
NEAR_TAU_S = 60.0  # DEGAS SC228_ActiveSurveillanceModel tauThreshold_sec: the intruder is near
RAYLEIGH_95 = math.sqrt(-2.0 * math.log(0.05))  # a per-axis sigma to a 95 % radial bound (circular Gaussian)


def optimal_fusion(xs: np.ndarray, p: np.ndarray):
    """Dai eqs 41-42 for a batch: xs (B, L, n) local estimates, p (B, L n, L n) their joint error covariance.
    Returns x_0 (B, n), P_0 (B, n, n) and the weights A (B, L, n, n)."""
    b, big_l, n = xs.shape
    e = np.tile(np.eye(n), (big_l, 1))  # (L n, n)
    et_pinv = e.T @ np.linalg.inv(p)  # (B, n, L n); batched LAPACK (spd_inverse's unrolled form suits d <= 6)
    p0 = np.linalg.inv(et_pinv @ e)
    a = p0 @ et_pinv  # (B, n, L n) = [A_1 ... A_L]
    x0 = (a @ xs.reshape(b, big_l * n, 1))[..., 0]
    return x0, 0.5 * (p0 + np.swapaxes(p0, 1, 2)), np.stack([a[:, :, i * n:(i + 1) * n] for i in range(big_l)], 1)


def fuse_pair(x1, p1, x2, p2, p12=None):
    """Two local estimates by eqs 41-42: x (B, n), p (B, n, n), cross-covariance p12 (None: zero)."""
    b, n = x1.shape
    joint = np.zeros((b, 2 * n, 2 * n))
    joint[:, :n, :n], joint[:, n:, n:] = p1, p2
    if p12 is not None:
        joint[:, :n, n:], joint[:, n:, :n] = p12, np.swapaxes(p12, 1, 2)
    return optimal_fusion(np.stack([x1, x2], axis=1), joint)


def covariance_intersection(x1, p1, x2, p2, iterations: int = 30):
    """Covariance intersection (Julier & Uhlmann 1997) for a batch: P^-1 = w P1^-1 + (1 - w) P2^-1,
    x = P (w P1^-1 x1 + (1 - w) P2^-1 x2), w in [0, 1] minimising trace P (golden-section search).
    Returns x (B, n), P (B, n, n), w (B,)."""
    i1, _ = spd_inverse(p1)
    i2, _ = spd_inverse(p2)

    def trace(w):
        return np.trace(spd_inverse(w[:, None, None] * i1 + (1 - w)[:, None, None] * i2)[0], axis1=1, axis2=2)

    lo, hi = np.zeros(len(x1)), np.ones(len(x1))
    g = (math.sqrt(5) - 1) / 2
    for _ in range(iterations):
        a, c = hi - g * (hi - lo), lo + g * (hi - lo)
        left = trace(a) < trace(c)
        hi, lo = np.where(left, c, hi), np.where(left, lo, a)
    w = np.clip(0.5 * (lo + hi), 1e-6, 1 - 1e-6)
    info = w[:, None, None] * i1 + (1 - w)[:, None, None] * i2
    p, _ = spd_inverse(info)
    x = (p @ ((w[:, None, None] * i1) @ x1[..., None] + ((1 - w)[:, None, None] * i2) @ x2[..., None]))[..., 0]
    return x, 0.5 * (p + np.swapaxes(p, 1, 2)), w


def pair_tracks(adsb_x, adsb_p, sensor_x, sensor_p, gate_probability: float = 0.9999) -> list[tuple[int, int]]:
    """Which ADS-B track (rows) and sensor track (columns) are one aircraft: GNN on [e, n, alt] at one time."""
    d2 = normalised_distances(adsb_x[:, :3], adsb_p[:, :3, :3], sensor_x[:, :3], sensor_p[:, :3, :3])
    return gnn(d2, chi2_quantile(gate_probability, 3))


def consistent(adsb_x, adsb_p, sensor_x, sensor_p, gate_probability: float = 0.9999) -> np.ndarray:
    """(B,) whether each pair's positions agree within the association gate (a failing ADS-B disagrees)."""
    r = (adsb_x - sensor_x)[:, :3]
    s_inv, _ = spd_inverse((adsb_p + sensor_p)[:, :3, :3])
    return np.einsum("bi,bij,bj->b", r, s_inv, r) <= chi2_quantile(gate_probability, 3)


def fuse(adsb_x, adsb_p, sensor_x, sensor_p, adsb_degraded=None, cross: str = "independent",
         gate_probability: float = 0.9999):
    """The fused [e, n, alt, ve, vn, vu] state and covariance of paired tracks (B,) at one time. adsb_p: the ADS-B
    track's covariance as its tracker predicts it (ImmTracker.predict: widened by the integrity monitor's fault
    size when degraded); adsb_degraded (B,): the integrity monitor's verdict (None: all healthy). A pair failing
    `consistent` has one suspect, the one the integrity monitor names: a degraded ADS-B, else the sensor (its
    track is off beyond its own covariance: a bearing outlier, a bias); the suspect's position covariance grows by
    the disagreement d d^T, so its weight along d falls. Returns x (B, 6), P (B, 6, 6), the ADS-B weight (B,)
    (the mean diagonal of A_ADS-B's horizontal position block) and the consistency (B,)."""
    if cross not in CROSS:
        raise ValueError(f"cross must be one of {CROSS}, got {cross!r}")
    degraded = np.zeros(len(adsb_x), bool) if adsb_degraded is None else np.asarray(adsb_degraded, bool)
    ok = consistent(adsb_x, adsb_p, sensor_x, sensor_p, gate_probability)
    if not ok.all():
        d = (adsb_x - sensor_x)[:, :3]
        outer = np.where(ok[:, None, None], 0.0, d[:, :, None] * d[:, None, :])
        adsb_p, sensor_p = adsb_p.copy(), sensor_p.copy()
        adsb_p[:, :3, :3] += np.where(degraded[:, None, None], outer, 0.0)
        sensor_p[:, :3, :3] += np.where(degraded[:, None, None], 0.0, outer)
    if cross == "ci":
        x, p, w = covariance_intersection(adsb_x, adsb_p, sensor_x, sensor_p)
    else:
        x, p, a = fuse_pair(adsb_x, adsb_p, sensor_x, sensor_p)
        w = np.trace(a[:, 0, :2, :2], axis1=1, axis2=2) / 2.0  # the horizontal position weight
    return x, p, w, ok


def nacp(position_sigma_m) -> np.ndarray:
    """The NACp category (0 .. 11) whose EPU bound a per-axis position sigma meets (95 % radial)."""
    epu = RAYLEIGH_95 * np.asarray(position_sigma_m, float)
    return np.searchsorted(-NACP_EPU_M, -epu, side="left")


def sampling_period(position_sigma_m, tau_s) -> np.ndarray:
    """Dai Table 1's variable sampling period: by the NACp of the estimated position sigma while the intruder is
    near (tau < NEAR_TAU_S, closing), 1 s while it is far."""
    period = DAI_PERIOD_S[nacp(position_sigma_m)]
    near = np.asarray(tau_s, float) < NEAR_TAU_S
    return np.where(near, period, 1.0)
