"""Monte Carlo oracle for SUM from the tracks (issue 29): does "no conflict at this level" under DAIDALUS's sensor
uncertainty mitigation hold for the states the tracks' own covariances say are possible?

    python -m avionics_eval.reports.sum_oracle [--seeds 3] [--draws 2000] [--profile daidalus-do365b-sum]
                                               [--plot docs/img/sum_oracle.png]

Encounters (`oracle_encounters`: head-on and crossing passes near DTHR laterally and near ZTHR vertically, level
and climbing) are flown by `sitl replay` with the simulator's default ADS-B impairments (NACp 9, NACv 2, 25 ft
altitude, latency, dropouts) through the real MAVLink path, IMM tracker and core, with advisory.sum_from_tracks
on. Once a second, for every tracked intruder and every alert level, the level's detector (WCV_TAUMOD_SUM with
the track's and the ownship filter's covariances as DAIDALUS's inputs, exactly as the core forms them:
base/uncertainty.py errors_from_covariance) is asked for a conflict within the level's alerting time. Where it
says none, `draws` true relative states are drawn from N(estimate, P_intruder + P_ownship) (the same 1-sigma
covariances SUM was given; the two filters are independent) and the fraction of draws in conflict with the
plain WCV_TAUMOD volume of the level within its alerting time is counted.

The level the z-scores imply (`implied_level`, docs/advisories.md "What SUM bounds"): SUM clear means no state in
DAIDALUS's uncertainty set U (relative horizontal position within s_err, vertical within sz_err, horizontal
velocity within v_err, vertical speed within vz_err of the estimate, each the z-score times the sum of both
aircraft's 1-sigma errors) is in conflict. A draw in conflict lies beyond U towards the conflict set; where that
set is on one side of a hyperplane with normal n, the probability is at most 1 - Phi(h_U(n) / sigma(n)), with
h_U(n) = sum_k z_k e_k |n_k| and sigma(n) <= sum_k e_k |n_k| (Cauchy-Schwarz on the relative covariance, whatever
its position-velocity correlations; the ellipse's semi-major axis bounds the sigma in every horizontal direction;
sqrt(a^2 + b^2) <= a + b for the two aircraft): at most 1 - Phi(z_min), z_min the smallest z-score of an axis the
conflict depends on. With DO_365B_SUM.conf's scores (position 1.5, vertical 0.75, horizontal velocity 1.0 at range
0 to 0.5 from 5 nmi, vertical speed 1.5) and every axis counted, z_min(r) = min(0.75, z_hvel(r)): 22.7 % up to
2.5 nmi, rising to 30.9 % at 5 nmi and beyond (r = max(range - s_err, 0), as DAIDALUS weighs it). A single axis
alone gives 6.7 % (1.5 sigma), 22.7 % (0.75), 15.9-30.9 % (1.0-0.5) and 6.7 %. The containment bound
P(outside U) is no bound worth stating (a 2-D disk of 0.5 sigma holds 12 % of a Gaussian). The check per
assessment allows a binomial excess (`allowance`: the count's upper quantile at 1e-6 / assessments).

JSON: per level the assessments where SUM was clear, their draws in conflict (the aggregate fraction), the worst
assessment's fraction against its implied level, and how many exceeded their allowance; the same counts for the
plain detector (no SUM) on its own clear assessments, which is what SUM is for.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy import stats

from avionics.advisory.alerting import Encounter, wcv_alerter
from avionics.advisory.tables import load_profile
from avionics.advisory.wcv import WCV_TAUMOD
from avionics.advisory.wcv_sum import SumZScores, relative_errors
from avionics.conflict.cpa import pair_geometry
from avionics.base.geodesy import LocalTangentPlane
from avionics.base.types import AltitudeDatum
from avionics.base.uncertainty import errors_from_covariance
from avionics.base.units import FPM, FT, KT, NM

REFERENCE = (47.4, 8.5)
OWNSHIP_ICAO = 0xC0FFEE
FAMILY_P = 1e-6  # the family-wise probability of a false failure across all assessments of a run


@dataclass(frozen=True)
class Geometry:
    """One oracle encounter: the intruder's course relative to the ownship's (deg), its lateral offset at the
    meeting point (m, to the east of the ownship's course), its altitude above the ownship's (ft), its vertical
    rate (fpm) and the meeting time (s)."""

    course_deg: float
    offset_m: float
    dz_ft: float
    vz_fpm: float = 0.0
    t_meet_s: float = 70.0
    duration_s: float = 90.0

    @property
    def name(self) -> str:
        return f"c{self.course_deg:g}_off{self.offset_m:g}_dz{self.dz_ft:g}_vz{self.vz_fpm:g}"


def oracle_encounters() -> list[Geometry]:
    """Passes near the volume's edges: head-on and 90 deg crossings 1150-1350 m abeam (DTHR 1222 m), co-altitude
    and 400-500 ft apart (ZTHR 450 ft), level and with the intruder climbing at 500 fpm toward the ownship."""
    out = []
    for course in (180.0, 90.0):
        for off in (1150.0, 1250.0, 1350.0):
            out.append(Geometry(course, off, 0.0))
        for dz in (400.0, 500.0):
            out.append(Geometry(course, 0.0, dz))
        out.append(Geometry(course, 0.0, -1000.0, 500.0))
    return out


def scenario_of(geo: Geometry):
    """The encounter as a sitl Scenario on the tangent plane at REFERENCE: ownship northbound at 110 kt, 3000 ft;
    the intruder at 130 kt reaching its meeting point (offset abeam, dz above) at t_meet_s."""
    from avionics_sitl.aircraft import AircraftSpec
    from avionics_sitl.scenario import Scenario

    plane = LocalTangentPlane(*REFERENCE)
    own_v, intr_v, alt = 110 * KT, 130 * KT, 3000 * FT
    meet = np.array([geo.offset_m, own_v * geo.t_meet_s])
    hdg = math.radians(geo.course_deg)
    start = meet - intr_v * geo.t_meet_s * np.array([math.sin(hdg), math.cos(hdg)])
    alt_i = alt + geo.dz_ft * FT - geo.vz_fpm * FPM * geo.t_meet_s

    def spec(name, icao, east, north, alt_m, heading, speed, vz=0.0):
        lat, lon = plane.to_geodetic(east, north)
        return AircraftSpec(name=name, icao_address=icao, lat_deg=float(lat), lon_deg=float(lon), alt_msl_m=alt_m,
                            heading_deg=heading % 360.0, speed_mps=speed, vertical_rate_mps=vz)

    own = spec("ownship", OWNSHIP_ICAO, 0.0, 0.0, alt, 0.0, own_v)
    intr = spec("intruder", 0xA20001, float(start[0]), float(start[1]), alt_i, geo.course_deg, intr_v,
                geo.vz_fpm * FPM)
    return Scenario(geo.name, "SUM oracle encounter", own, (intr,), geo.duration_s, ground_elevation_m=0.0,
                    origin=REFERENCE)


@dataclass(frozen=True)
class Assessment:
    """One intruder at one second: the relative state estimate (intruder - ownship: E, N, U, vE, vN, vU, the
    vertical in the intruder's datum as the core forms it), its covariance P_intruder + P_ownship, and the four
    error sums SUM is given (errors_from_covariance of each, added)."""

    time_s: float
    mean: np.ndarray
    cov: np.ndarray
    errors: np.ndarray


class _Observer:
    """An output port of the replay that, once a second, reads the core's tracks and ownship predicted to the
    step's time (DaaCore.predict_tracks, ownship_state: the states and covariances its assessment used)."""

    def __init__(self, core):
        self.core, self.rows, self._next = core, [], 0.0

    def wants(self, now_s):
        from avionics.ports import NOTHING
        return NOTHING

    def publish(self, result) -> None:
        t = result.time_s
        if t + 1e-9 < self._next:
            return
        self._next = math.floor(t + 1e-9) + 1.0
        own = self.core.ownship_state()
        keys = list(self.core.tracker.tracks)
        if own is None or not keys:
            return
        keys, xs, ps = self.core.predict_tracks(keys, t)
        own_e = errors_from_covariance(own.p)
        for key, x, p in zip(keys, xs, ps):
            track = self.core.tracker.tracks[key]
            if not track.altitude_valid(t, self.core.config.tracking.max_coast_s):
                continue
            own_alt = own.pressure_altitude_m if (track.datum is AltitudeDatum.PRESSURE and
                                                  own.pressure_altitude_m is not None) else float(own.x[2])
            mean = np.asarray(x, float) - np.asarray(own.x, float)
            mean[2] = float(x[2]) - own_alt
            self.rows.append(Assessment(float(t), mean, np.asarray(p, float) + np.asarray(own.p, float),
                                        errors_from_covariance(p) + own_e))

    def close(self) -> None:
        pass


def assessments(geo: Geometry, profile: str, seed: int) -> list[Assessment]:
    """Fly one encounter with the default ADS-B impairments; the per-second assessments of its intruder."""
    from avionics.config import load_config
    from avionics.pipeline.daa_core import DaaCore
    from avionics_sitl.impairments import DEFAULT
    from avionics_sitl.replay import replay

    config = load_config(None, [f"advisory.profile={profile}", "advisory.sum_from_tracks=true",
                                "advisory.guidance_bands=false", "zenoh.enabled=false"])
    core = DaaCore(config)
    observer = _Observer(core)
    replay(scenario_of(geo), config, DEFAULT, seed=seed, ports=[observer], core=core)
    return observer.rows


def _encounter(mean: np.ndarray, errors: np.ndarray | None) -> Encounter:
    mean = np.atleast_2d(mean)
    g = pair_geometry(mean[:, 0:2], mean[:, 3:5], mean[:, 2], mean[:, 5])
    n = len(mean)
    return Encounter(g, np.ones(n, bool), 0.0, True, None if errors is None else np.atleast_2d(errors))


def implied_level(z: SumZScores, range_m: float, s_err_m: float) -> float:
    """1 - Phi(z_min): the bound on the fraction of draws in conflict where SUM is clear (module docstring), with
    every axis counted: z_min = min(h_pos, v_pos, z_hvel(max(range - s_err, 0)), v_vel)."""
    z_min = min(z.h_pos, z.v_pos, z.weighted_h_vel(max(range_m - s_err_m, 0.0)), z.v_vel)
    return float(stats.norm.sf(z_min))


def allowance(n: int, p: float, tests: int) -> int:
    """The most draws in conflict out of n that a fraction p allows, at family-wise 1e-6 over `tests` checks."""
    return int(stats.binom.isf(FAMILY_P / max(tests, 1), n, p))


def oracle(rows: list[Assessment], profile: str, draws: int, rng: np.random.Generator) -> dict:
    """Per level: the SUM-clear assessments, the draws in conflict, and the worst fraction against its bound; the
    same for the plain detector's clear assessments."""
    spec = load_profile(profile).alerter
    z = spec.sum
    if z is None:
        raise ValueError(f"profile {profile!r} has no [alerter.sum]: nothing to check")
    levels = wcv_alerter(spec).levels
    plain = WCV_TAUMOD()
    out = {}
    for lv in levels:
        thr, at = lv.thresholds, lv.alerting_time_s
        per = {"sum": [], "plain": []}
        for a in rows:
            nominal = _encounter(a.mean, a.errors)
            rng_m = float(np.hypot(a.mean[0], a.mean[1]))
            s_err = float(relative_errors(a.errors[None], np.array([rng_m]), z)[0, 0])
            sample = None
            for which, det in (("sum", lv.detector), ("plain", plain)):
                if bool(det.conflict(nominal, thr, at)[0]):
                    continue
                if sample is None:
                    sample = rng.multivariate_normal(a.mean, a.cov, size=draws, method="cholesky")
                k = int(plain.conflict(_encounter(sample, None), thr, at).sum())
                per[which].append((a.time_s, k, implied_level(z, rng_m, s_err), rng_m))
        out[lv.name] = {which: summary(v, draws) for which, v in per.items()}
    return out


def summary(checks: list[tuple], draws: int) -> dict:
    """Aggregate fraction, worst assessment, and the assessments over their binomial allowance."""
    if not checks:
        return {"assessments": 0}
    ks = np.array([c[1] for c in checks])
    bounds = np.array([c[2] for c in checks])
    allowed = np.array([allowance(draws, p, len(checks)) for p in bounds])
    worst = int(np.argmax(ks / draws - bounds))
    return {
        "assessments": len(checks), "draws_each": draws,
        "in_conflict_fraction": float(ks.sum() / (draws * len(checks))),
        "assessments_with_any_conflict": int((ks > 0).sum()),
        "worst": {"time_s": checks[worst][0], "range_m": round(checks[worst][3], 1),
                  "fraction": float(ks[worst] / draws), "implied_level": float(bounds[worst])},
        "max_fraction": float(ks.max() / draws),
        "over_allowance": int((ks > allowed).sum()),
        "fractions": [float(k / draws) for k in ks],
        "ranges_m": [round(c[3], 1) for c in checks],
    }


def plot(result: dict, path: Path) -> Path:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from avionics_eval.reports import save_figure

    fig, axes = plt.subplots(1, len(result["levels"]), figsize=(12, 3.8), sharey=True)
    z = load_profile(result["profile"]).alerter.sum
    r = np.linspace(0, 8 * NM, 200)
    for ax, (name, res) in zip(np.atleast_1d(axes), result["levels"].items()):
        for which, colour, label in (("plain", "tab:red", "no SUM"), ("sum", "tab:blue", "SUM")):
            d = res[which]
            if d.get("assessments"):
                ax.scatter(np.array(d["ranges_m"]) / NM, d["fractions"], s=6, c=colour, alpha=0.5,
                           label=f"{label} clear ({d['assessments']})")
        ax.plot(r / NM, [implied_level(z, x, 0.0) for x in r], "k--", lw=1, label="implied level 1-Phi(z_min)")
        ax.set_title(name)
        ax.set_xlabel("range (nmi)")
        ax.set_xlim(0, 8)
    np.atleast_1d(axes)[0].set_ylabel("fraction of draws in conflict")
    np.atleast_1d(axes)[0].legend(fontsize=7, loc="upper right")
    fig.suptitle("Where the detector says no conflict: draws from the tracks' covariances in conflict", fontsize=10)
    return save_figure(fig, path)


def run(seeds: int, draws: int, profile: str, geometries=None, seed0: int = 1) -> dict:
    rows: list[Assessment] = []
    geos = oracle_encounters() if geometries is None else geometries
    for geo in geos:
        for seed in range(seed0, seed0 + seeds):
            rows.extend(assessments(geo, profile, seed))
    levels = oracle(rows, profile, draws, np.random.default_rng(seed0))
    return {"profile": profile, "noise": "default", "encounters": [g.name for g in geos], "seeds": seeds,
            "assessments": len(rows), "levels": levels}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=3)
    ap.add_argument("--draws", type=int, default=2000)
    ap.add_argument("--profile", default="daidalus-do365b-sum")
    ap.add_argument("--plot", type=Path, help="write the figure here (e.g. docs/img/sum_oracle.png)")
    ap.add_argument("--full", action="store_true", help="keep every assessment's fraction and range in the JSON")
    args = ap.parse_args(argv)
    result = run(args.seeds, args.draws, args.profile)
    if args.plot:
        result["plot"] = str(plot(result, args.plot))
    if not args.full:
        for res in result["levels"].values():
            for d in res.values():
                d.pop("fractions", None)
                d.pop("ranges_m", None)
    json.dump(result, sys.stdout, indent=2)
    print()
    return 0


if __name__ == "__main__":
    sys.exit(main())
