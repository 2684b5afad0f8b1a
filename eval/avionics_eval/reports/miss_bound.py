"""How well any estimator can know a miss distance from a sensor's measurements: the Cramér-Rao lower bound over
a straight stretch of relative flight, horizontally from ranges and bearings, vertically from elevations or
reported altitudes.

Why: TCAS's HMD filter lets an RA through unless the miss is resolved outside the HMD threshold
(pipeline/assessment.py Assessor._resolvable: the miss two sigmas low). Whether a sensor can resolve a miss at the
moment the RA is due is a property of the sensor and the geometry, not of our tracks; this bound says it, from
nothing we wrote but the Fisher information.

Model: the relative horizontal position p(t) = p0 + v (t - t_at), theta = (p0, v) in 4 dimensions, measured at
the sensor's rate over the `window` seconds up to t_at by a range r = |p| (sigma_r) and a bearing atan2(e, n)
(sigma_b), white and unbiased. The Fisher information is sum_k J_k^T R^-1 J_k with J_k the Jacobian of
(r, bearing) in theta (Kay, "Fundamentals of Statistical Signal Processing: Estimation Theory", 1993, ch. 3,
Gaussian data); the miss d(theta) = |p0 x v| / |v| has var(d_hat) >= grad d^T I^-1 grad d for any unbiased
estimator (Kay ch. 3, a function of a vector parameter). A radar's range rates are left out: for a radar the
horizontal figure is the bound without them, above the true one. Vertically, z(t) = z0 + z_dot (t - t_at)
measured with sigma_z (the radar: the ground range times the elevation sigma; active surveillance: the reported
altitude's), the vertical miss z0 + z_dot t_cpa: the same bound, which for this linear model is the weighted
least-squares covariance (A^T W A)^-1. The white errors alone: a sensor's bias and a model that must allow for
manoeuvres only widen it, so the bound is the best any tracker could do.

    python -m avionics_eval.reports.miss_bound FILE --at T [--window S] [--sensor active|radar]
"""

from __future__ import annotations

import argparse
import json
import math

import numpy as np


def straight_fit(times_s, rel_en) -> tuple[np.ndarray, np.ndarray]:
    """(p0 at the last time, v): the least-squares straight line through relative positions rel_en (K, 2)."""
    t = np.asarray(times_s, float) - float(times_s[-1])
    a = np.stack([np.ones_like(t), t], axis=1)
    coef, *_ = np.linalg.lstsq(a, np.asarray(rel_en, float), rcond=None)
    return coef[0], coef[1]


def miss_m(theta) -> float:
    """The horizontal miss distance of straight relative flight theta = (east, north, v_east, v_north)."""
    e, n, ve, vn = theta
    return abs(e * vn - n * ve) / math.hypot(ve, vn)


def fisher(theta, offsets_s, sigma_r_m: float, sigma_b_rad: float | None) -> np.ndarray:
    """The 4 x 4 Fisher information of theta from a range (and a bearing, unless sigma_b_rad is None) at each
    offset (s, relative to theta's time)."""
    e0, n0, ve, vn = theta
    info = np.zeros((4, 4))
    for t in offsets_s:
        e, n = e0 + ve * t, n0 + vn * t
        r2 = e * e + n * n
        r = math.sqrt(r2)
        j_r = np.array([e / r, n / r, e / r * t, n / r * t])  # d|p| / d theta
        info += np.outer(j_r, j_r) / sigma_r_m**2
        if sigma_b_rad is not None:
            j_b = np.array([n / r2, -e / r2, n / r2 * t, -e / r2 * t])  # d atan2(e, n) / d theta
            info += np.outer(j_b, j_b) / sigma_b_rad**2
    return info


def miss_sigma_bound(theta, offsets_s, sigma_r_m: float, sigma_b_rad: float | None) -> float:
    """The Cramér-Rao bound on the miss's standard deviation (m). Ranges alone cannot see the geometry turned
    about the ownship (the information is singular along that rotation), which leaves the miss unchanged: the
    pseudo-inverse gives the bound of a function blind to that direction."""
    theta = np.asarray(theta, float)
    step = 1e-3
    grad = np.array([(miss_m(theta + h) - miss_m(theta - h)) / (2 * step) for h in np.eye(4) * step])
    return float(math.sqrt(grad @ np.linalg.pinv(fisher(theta, offsets_s, sigma_r_m, sigma_b_rad), rcond=1e-9,
                                                   hermitian=True) @ grad))


def vertical_miss_sigma_bound(offsets_s, sigma_z_m, t_cpa_s: float) -> float:
    """The bound on the vertical miss z0 + z_dot t_cpa's standard deviation (m) from heights z0 + z_dot t (t:
    offsets_s) measured with sigma_z_m each."""
    a = np.stack([np.ones(len(offsets_s)), np.asarray(offsets_s, float)], axis=1)
    info = (a / np.asarray(sigma_z_m, float)[:, None] ** 2).T @ a
    g = np.array([1.0, t_cpa_s])
    return float(math.sqrt(g @ np.linalg.solve(info, g)))


def report(case_file: str, at_s: float, window_s: float, sensor: str) -> dict:
    from avionics_eval.reports.noncoop import CONFORMANCE
    from avionics_sitl.encounters import load_scenario
    from avionics_sitl.sensors import MODELS

    own, intruders = load_scenario(str(CONFORMANCE / case_file)).trajectories()
    errors = MODELS[sensor]
    times = np.arange(at_s - window_s, at_s + 1e-9, 1.0 / errors.rate_hz)
    rel = np.array([np.subtract(intruders[0].enu_at(t), own.enu_at(t)) for t in times])
    p0, v = straight_fit(times, rel[:, :2])
    residual = float(np.abs(rel[:, :2] - (p0 + np.outer(times - at_s, v))).max())
    ground = np.hypot(rel[:, 0], rel[:, 1])
    elevation = math.atan2(rel[-1, 2], float(ground[-1]))
    sigma_b = float(errors.bearing_sigma_rad(elevation))
    theta, offsets = np.concatenate([p0, v]), times - at_s
    t_cpa = max(-float(p0 @ v) / float(v @ v), 0.0)
    z_dot = float(np.polyfit(offsets, rel[:, 2], 1)[0])
    if errors.elevation_sigma_deg is not None:  # a radar: the height from the elevation
        sigma_z = ground * math.radians(errors.elevation_sigma_deg)
    else:  # active surveillance: the reported altitude, in its quantum
        sigma_z = np.full(len(times), errors.altitude_quantum_m / math.sqrt(12.0))
    return {"file": case_file, "at_s": at_s, "window_s": window_s, "sensor": sensor,
            "range_m": round(float(np.hypot(*p0)), 1), "straight_line_residual_m": round(residual, 1),
            "t_cpa_s": round(t_cpa, 1), "miss_m": round(miss_m(theta), 1),
            "vertical_miss_m": round(float(rel[-1, 2]) + z_dot * t_cpa, 1),
            "range_sigma_m": errors.range_sigma_m, "bearing_sigma_deg": round(math.degrees(sigma_b), 2),
            "miss_sigma_bound_m": round(miss_sigma_bound(theta, offsets, errors.range_sigma_m, sigma_b), 1),
            "miss_sigma_bound_ranges_only_m": round(miss_sigma_bound(theta, offsets, errors.range_sigma_m, None), 1),
            "vertical_miss_sigma_bound_m": round(vertical_miss_sigma_bound(offsets, sigma_z, t_cpa), 1)}


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="python -m avionics_eval.reports.miss_bound",
                                     description=__doc__.split("\n")[0])
    parser.add_argument("file", help="a file of ../shared/conformance/daidalus (its first intruder)")
    parser.add_argument("--at", type=float, required=True, help="the time of the decision, s")
    parser.add_argument("--window", type=float, default=30.0, help="seconds of straight flight measured before it")
    parser.add_argument("--sensor", choices=("active", "radar"), default="active")
    args = parser.parse_args(argv)
    print(json.dumps(report(args.file, args.at, args.window, args.sensor), indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
