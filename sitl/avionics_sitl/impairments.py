"""ADS-B-like impairments of a truth state: noise, quantisation, latency and dropouts, reproducible by seed.

The simulator calls `impair(state)` once per report it would broadcast; `None` means the report is lost.
The returned state keeps `t_s` as its time of applicability; the simulator delivers it `latency_s` later.
Errors are drawn independently per report (white) unless a correlation time is set: white errors are harsher
on a tracker than real GNSS errors (correlated over minutes) and so the conservative choice for testing one;
with position_correlation_s / velocity_correlation_s the horizontal errors are first-order Gauss-Markov
processes of that time constant, as the DAA MOPS' ADS-B model has them (DO365_ADSB). docs/scenarios.md explains
the DEFAULT numbers, docs/evaluation.md DO365_ADSB's. One instance per aircraft (with_seed): a correlated
error's state is the instance's.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np

from avionics.base.geodesy import WGS84_A, WGS84_E2
from avionics.base.units import FPM, FT, KT
from avionics_sitl.trajectory import KinematicState

# A circular 2-D Gaussian with per-axis sigma holds 95 % of its mass within RAYLEIGH_95 * sigma: this is
# how a 95 % accuracy bound (NACp, NACv in RTCA DO-260B) becomes a per-axis sigma.
RAYLEIGH_95 = math.sqrt(-2.0 * math.log(0.05))  # 2.4477
NACP_9_EPU_M = 30.0  # NACp 9: estimated position uncertainty < 30 m (95 %)
NACV_2_HORIZONTAL_MPS = 3.0  # NACv 2: horizontal velocity error < 3 m/s (95 %)


@dataclass(frozen=True, slots=True)
class ImpairedState:
    state: KinematicState  # what is reported, valid at state.t_s
    latency_s: float  # delay from state.t_s until the report reaches the receiver


def _meters_to_degrees(lat_deg: float, d_north_m: float, d_east_m: float) -> tuple[float, float]:
    """Small offsets on the WGS-84 ellipsoid: meridian and prime-vertical radii of curvature."""
    s2 = math.sin(math.radians(lat_deg)) ** 2
    w = math.sqrt(1.0 - WGS84_E2 * s2)
    r_meridian = WGS84_A * (1.0 - WGS84_E2) / w**3
    r_normal = WGS84_A / w
    return (
        math.degrees(d_north_m / r_meridian),
        math.degrees(d_east_m / (r_normal * math.cos(math.radians(lat_deg)))),
    )


def _quantise(value: float, quantum: float) -> float:
    return round(value / quantum) * quantum if quantum > 0.0 else value


@dataclass(frozen=True)
class AdsbImpairments:
    """Per-report impairments. Sigmas are per axis (east and north each get position_sigma_m)."""

    position_sigma_m: float = 0.0
    velocity_sigma_mps: float = 0.0
    altitude_sigma_m: float = 0.0
    vertical_rate_sigma_mps: float = 0.0
    latency_s: float = 0.0  # mean
    latency_jitter_s: float = 0.0  # latency is uniform in latency_s +- latency_jitter_s
    dropout_probability: float = 0.0
    altitude_quantum_m: float = 0.0  # 0: not quantised
    vertical_rate_quantum_mps: float = 0.0
    velocity_quantum_mps: float = 0.0  # per east/north component
    position_correlation_s: float = 0.0  # 0: white; else the Gauss-Markov time constant of the horizontal error
    velocity_correlation_s: float = 0.0
    rng: np.random.Generator = field(default_factory=lambda: np.random.default_rng(0), compare=False)
    # (time, error) of the last report per correlated quantity; not copied by replace(): with_seed starts afresh
    _markov: dict = field(default_factory=dict, init=False, compare=False, repr=False)

    def __post_init__(self) -> None:
        for name in ("position_sigma_m", "velocity_sigma_mps", "altitude_sigma_m", "vertical_rate_sigma_mps",
                     "latency_s", "latency_jitter_s", "altitude_quantum_m", "vertical_rate_quantum_mps",
                     "velocity_quantum_mps", "position_correlation_s", "velocity_correlation_s"):
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value >= 0.0):
                raise ValueError(f"{name} must be a finite number >= 0, got {value!r}")
        if self.latency_jitter_s > self.latency_s:
            raise ValueError("latency_jitter_s must not exceed latency_s (latency would go negative)")
        if not 0.0 <= self.dropout_probability < 1.0:
            raise ValueError(f"dropout_probability must be in [0, 1), got {self.dropout_probability!r}")
        if not isinstance(self.rng, np.random.Generator):
            raise ValueError("rng must be a numpy.random.Generator")

    def with_seed(self, seed) -> "AdsbImpairments":
        """The same impairment levels with a fresh generator: use one per aircraft and run, e.g.
        seed=(run_seed, icao_address), so that adding an aircraft does not change the others' noise."""
        return replace(self, rng=np.random.default_rng(seed))

    def _error(self, name: str, t_s: float, sigma: float, tau_s: float) -> np.ndarray:
        """Two per-axis errors of standard deviation sigma: white (tau_s 0), or a first-order Gauss-Markov
        process, e(t) = phi e(t0) + sigma sqrt(1 - phi^2) n, phi = exp(-(t - t0) / tau_s), stationary from its
        first draw e = sigma n (the exact discretisation at any report interval; n standard normal)."""
        n = self.rng.normal(0.0, 1.0, 2)
        last = self._markov.get(name) if tau_s > 0.0 else None
        if last is None:
            error = sigma * n
        else:
            phi = math.exp(-max(0.0, t_s - last[0]) / tau_s)
            error = phi * last[1] + sigma * math.sqrt(1.0 - phi * phi) * n
        if tau_s > 0.0:
            self._markov[name] = (t_s, error)
        return error

    def impair(self, state: KinematicState) -> ImpairedState | None:
        """The report an ADS-B transmitter would produce for this truth state, or None if it is lost."""
        rng = self.rng
        if self.dropout_probability > 0.0 and rng.random() < self.dropout_probability:
            return None
        lat, lon = state.lat_deg, state.lon_deg
        if self.position_sigma_m > 0.0:
            d_north, d_east = self._error("position", state.t_s, self.position_sigma_m, self.position_correlation_s)
            d_lat, d_lon = _meters_to_degrees(lat, d_north, d_east)
            lat, lon = lat + d_lat, lon + d_lon
        ve, vn = state.vel_east_mps, state.vel_north_mps
        if self.velocity_sigma_mps > 0.0:
            n_e, n_n = self._error("velocity", state.t_s, self.velocity_sigma_mps, self.velocity_correlation_s)
            ve, vn = ve + n_e, vn + n_n
        alt = state.alt_msl_m
        if self.altitude_sigma_m > 0.0:
            alt += rng.normal(0.0, self.altitude_sigma_m)
        vu = state.vel_up_mps
        if self.vertical_rate_sigma_mps > 0.0:
            vu += rng.normal(0.0, self.vertical_rate_sigma_mps)
        latency = self.latency_s
        if self.latency_jitter_s > 0.0:
            latency += rng.uniform(-self.latency_jitter_s, self.latency_jitter_s)
        reported = KinematicState(
            t_s=state.t_s,
            lat_deg=float(lat),
            lon_deg=float((lon + 180.0) % 360.0 - 180.0) if not -180.0 <= lon <= 180.0 else float(lon),
            alt_msl_m=float(_quantise(alt, self.altitude_quantum_m)),
            vel_east_mps=float(_quantise(ve, self.velocity_quantum_mps)),
            vel_north_mps=float(_quantise(vn, self.velocity_quantum_mps)),
            vel_up_mps=float(_quantise(vu, self.vertical_rate_quantum_mps)),
        )
        return ImpairedState(reported, float(latency))


# Exact truth, delivered instantly, never lost.
NONE = AdsbImpairments()

# A typical 1090ES/UAT transponder-grade source (docs/scenarios.md, "Impairments"):
# NACp 9 (EPU < 30 m) and NACv 2 (< 3 m/s) as 95 % bounds -> per-axis sigmas 12.3 m and 1.2 m/s;
# pressure altitude in 25 ft steps and vertical rate in 64 fpm steps (the LSBs of the airborne position and
# velocity messages), velocity components in 1 kt steps (subsonic LSB);
# 0.2-0.5 s from time of applicability to receipt; 5 % of reports lost.
DEFAULT = AdsbImpairments(
    position_sigma_m=NACP_9_EPU_M / RAYLEIGH_95,
    velocity_sigma_mps=NACV_2_HORIZONTAL_MPS / RAYLEIGH_95,
    altitude_sigma_m=0.0,  # the encoder's output is what is sent: its error is the 25 ft step
    vertical_rate_sigma_mps=0.5,  # ~100 fpm: a filtered baro rate (a choice; NACv's vertical bound is looser)
    latency_s=0.35,
    latency_jitter_s=0.15,
    dropout_probability=0.05,
    altitude_quantum_m=25 * FT,
    vertical_rate_quantum_mps=64 * FPM,
    velocity_quantum_mps=1 * KT,
)

# The ADS-B model of the DAA MOPS, RTCA DO-365 Appendix Q, as MIT Lincoln Laboratory's DEGAS simulation codes it
# (surveillance library, SC228_AdsbModel.m, "Values from DAA MOPS DO-365 Appendix Q"): north and east position
# errors of 75.6 m sigma and north and east rate errors of 1.22 m/s sigma, each a Gauss-Markov process of 300 s
# correlation time, no bias; altitude exact but in 25 ft steps; a report received in a second with probability
# 1 - 0.05^(1/3) (at least one in any 3 s with 95 %, its figure within 10 nmi; beyond, 1 - 0.05^(1/7), not
# modelled: alerts are raised inside 10 nmi). No latency and no vertical-rate error are given there: none here.
DO365_ADSB = AdsbImpairments(
    position_sigma_m=75.6,
    position_correlation_s=300.0,
    velocity_sigma_mps=1.22,
    velocity_correlation_s=300.0,
    altitude_quantum_m=25 * FT,
    dropout_probability=0.05 ** (1 / 3),
)

PRESETS: dict[str, AdsbImpairments] = {"none": NONE, "default": DEFAULT, "do365-adsb": DO365_ADSB}
