"""The ownship's range/bearing sensors, simulated: DO-365 Appendix Q's radar and active surveillance as MIT Lincoln
Laboratory's DEGAS codes them (code/block_libraries, surveillance library: SC228_RadarModel.m and
SC228_ActiveSurveillanceModel.m, "Values from DAA MOPS DO-365 Appendix Q"), one place for the simulator and the
evaluation. A `SimulatedSensor` scans the truth at its rate and returns avionics.tracking.measurement
PolarMeasurement objects (what the process's intake takes), with the true aircraft behind each for scoring.

Radar (SC228_RadarModel.m, dt_s 0.1): range sigma 21.34 m, bias uniform in +-15.24 m; range rate sigma 3.0 m/s,
bias +-2.4 m/s; azimuth and elevation sigma 1.0 deg, bias +-0.5 deg; white errors (tau 0); field of regard
+-110 deg azimuth, +-15 deg elevation; no detection inside RCPR_Range_ft 4000 ft (RCPR_Mode true). Biases are drawn
once per run, uniform in +-bias (prepareProperties: bias_stddev (2 rand - 1)). The declared covariance is
random^2 + bias^2 (reported_errorCovRAE).

Active surveillance (SC228_ActiveSurveillanceModel.m, dt_s 1, intruder_mode 1 = Mode C): range sigma 15.24 m as a
Gauss-Markov process of 1 s correlation, range bias 250 ft (Mode S: 125 ft), declared sigma sqrt(15.24^2 + 38.1^2);
bearing sigma from the table over elevation (breakpoints -9999, -15, -10, 10, 20, 9999 deg; sigma 15, 15, 15, 9,
15, 15 deg; errors clipped at bearing_Max 45, 45, 45, 27, 45, 45 deg), 1 s correlation; altitude exact in 100 ft
steps (Mode S: 25 ft); no range rate; detection probability per 0.1 s 1 - 0.10^(1/10) (Mode S 0.05), so a 1 s
scan detects with 0.90 (0.95); maximum range 20.6 NM ahead, 14.3 NM to the side, 8.0 NM behind (Mode S 15.6 NM
all round), at most sns_max_range 20 NM; elevation -15 .. +20 deg; 1 Hz when tau < 60 s, else every 5 s
(tauThreshold_sec, updateRate_sec 0.2).

What the DEGAS classes leave open and how it is filled here (docs/tracking.md, "Range/bearing sensors"): the
bearing table's interpolation lives in the Simulink model, not the class: linear here (Simulink's 1-D lookup
default), so 9 deg holds at +10 deg elevation and 12 deg at level; which azimuths are "front", "side" and "rear"
(here |az| <= 45 deg, >= 135 deg, between); the radar class models neither missed detections nor false returns
nor a maximum range: their defaults here are DEGAS's (none), set detection_probability, false_returns_per_scan and
max_range_m to exercise them. The altitude's declared sigma is the 100 ft quantisation's q / sqrt(12) (DEGAS
declares 1 ft^2).

`noise none` (exact()): every error, bias, limit, miss and false return off and the field of regard all round;
the declared sigmas are then small floors (1 m, 1 mrad) so that the tracker's converted measurement is the exact
position. The range rate's floor is 1.5 m/s, not a small one: a .daa file states each aircraft's velocity at its
rows and the replay interpolates the positions between them (sitl's trajectories), so the "exact" range rate (from
the stated velocities) and the derivative of the exact positions differ by up to about 1 m/s in a turn; declared
tighter, it pulls the track's velocity off its positions (measured: at 0.1 m/s the radar-exact replay of NASA's
turning scenarios lost first levels).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np

from avionics.base.units import FT, NM
from avionics.tracking.measurement import PolarMeasurement, SensorMount

DEG = math.pi / 180.0
EXACT_RANGE_SIGMA_M, EXACT_ANGLE_SIGMA_RAD, EXACT_RATE_SIGMA_MPS = 1.0, 1e-3, 1.5


@dataclass(frozen=True)
class SensorErrors:
    """One sensor type's error model (module docstring for the values and their sources)."""

    kind: str  # "radar" | "active"
    rate_hz: float
    range_sigma_m: float
    range_bias_m: float  # radar: half-width of the uniform bias; active: the bias itself
    range_bias_declared_m: float
    range_tau_s: float
    bearing_breakpoints_deg: tuple = (-9999.0, 9999.0)  # elevation breakpoints of the bearing sigma table
    bearing_sigma_deg: tuple = (1.0, 1.0)
    bearing_max_deg: tuple = (math.inf, math.inf)
    azimuth_bias_deg: float = 0.0
    angle_tau_s: float = 0.0
    elevation_sigma_deg: float | None = None  # None: no elevation (active surveillance reports altitude)
    elevation_bias_deg: float = 0.0
    range_rate_sigma_mps: float | None = None
    range_rate_bias_mps: float = 0.0
    altitude_quantum_m: float = 0.0
    detection_probability: float = 1.0
    false_returns_per_scan: float = 0.0
    half_azimuth_deg: float = 180.0
    elevation_min_deg: float = -90.0
    elevation_max_deg: float = 90.0
    min_range_m: float = 0.0
    max_range_m: float = math.inf
    directional_range_m: tuple | None = None  # (front, side, rear) maximum ranges
    far_period_s: float | None = None  # active surveillance: every far_period_s while tau >= near_tau_s
    near_tau_s: float = 60.0
    exact: bool = False

    def __post_init__(self) -> None:
        if not 0.0 < self.detection_probability <= 1.0 or self.false_returns_per_scan < 0.0:
            raise ValueError("detection_probability must be in (0, 1] and false_returns_per_scan >= 0")

    def mount(self, sensor_id: str, boresight_deg: float = 0.0) -> SensorMount:
        far = self.max_range_m if self.directional_range_m is None else max(self.directional_range_m)
        return SensorMount(sensor_id, self.kind, boresight_deg, self.half_azimuth_deg, self.elevation_min_deg,
                           self.elevation_max_deg, self.min_range_m, far, self.rate_hz)

    def bearing_sigma_rad(self, elevation_rad) -> np.ndarray:
        return DEG * np.interp(np.degrees(elevation_rad), self.bearing_breakpoints_deg, self.bearing_sigma_deg)

    def period_s(self, tau_s: float) -> float:
        """The scan period: active surveillance slows to far_period_s while the intruder is far in tau."""
        if self.far_period_s is not None and not tau_s < self.near_tau_s:
            return self.far_period_s
        return 1.0 / self.rate_hz

    def exact_model(self) -> "SensorErrors":
        """The same sensor measuring exactly and seeing all round (`--noise none`, conformance runs)."""
        return replace(self, range_sigma_m=0.0, range_bias_m=0.0, range_bias_declared_m=0.0, bearing_sigma_deg=(0.0, 0.0),
                       bearing_breakpoints_deg=(-9999.0, 9999.0), bearing_max_deg=(math.inf, math.inf),
                       azimuth_bias_deg=0.0, elevation_sigma_deg=None if self.elevation_sigma_deg is None else 0.0,
                       elevation_bias_deg=0.0, range_rate_sigma_mps=None if self.range_rate_sigma_mps is None else 0.0,
                       range_rate_bias_mps=0.0, altitude_quantum_m=0.0, detection_probability=1.0,
                       false_returns_per_scan=0.0, half_azimuth_deg=180.0, elevation_min_deg=-90.0,
                       elevation_max_deg=90.0, min_range_m=0.0, max_range_m=math.inf, directional_range_m=None,
                       far_period_s=None, exact=True)


RADAR = SensorErrors(
    kind="radar", rate_hz=10.0, range_sigma_m=21.34, range_bias_m=15.24, range_bias_declared_m=15.24, range_tau_s=0.0,
    bearing_sigma_deg=(1.0, 1.0), azimuth_bias_deg=0.5, elevation_sigma_deg=1.0, elevation_bias_deg=0.5,
    range_rate_sigma_mps=3.0, range_rate_bias_mps=2.4, half_azimuth_deg=110.0, elevation_min_deg=-15.0,
    elevation_max_deg=15.0, min_range_m=4000 * FT)

ACTIVE_MODE_C = SensorErrors(
    kind="active", rate_hz=1.0, range_sigma_m=15.24, range_bias_m=250 * FT, range_bias_declared_m=38.1, range_tau_s=1.0,
    bearing_breakpoints_deg=(-9999.0, -15.0, -10.0, 10.0, 20.0, 9999.0),
    bearing_sigma_deg=(15.0, 15.0, 15.0, 9.0, 15.0, 15.0), bearing_max_deg=(45.0, 45.0, 45.0, 27.0, 45.0, 45.0),
    angle_tau_s=1.0, altitude_quantum_m=100 * FT, detection_probability=1.0 - 0.10,  # (1 - 0.10^(1/10)) per 0.1 s over a 1 s scan
    elevation_min_deg=-15.0, elevation_max_deg=20.0, max_range_m=20 * NM,
    directional_range_m=(20.6 * NM, 14.3 * NM, 8.0 * NM), far_period_s=5.0)

MODELS = {"radar": RADAR, "active": ACTIVE_MODE_C}


@dataclass
class SimulatedSensor:
    """One sensor on the ownship, one run: biases drawn at construction (DEGAS prepareProperties), correlated
    errors kept per target. scan() measures the targets in view at one time."""

    errors: SensorErrors
    sensor_id: str = "radar0"
    boresight_deg: float = 0.0
    seed: object = 0
    _gm: dict = field(default_factory=dict, init=False, repr=False)

    def __post_init__(self) -> None:
        self.rng = np.random.default_rng(self.seed)
        e = self.errors
        uniform = lambda half: float(half * (2.0 * self.rng.random() - 1.0))  # noqa: E731  DEGAS: b (2 rand - 1)
        self.range_bias_m = e.range_bias_m if e.kind == "active" else uniform(e.range_bias_m)
        self.range_rate_bias_mps = uniform(e.range_rate_bias_mps)
        self.azimuth_bias_rad = uniform(e.azimuth_bias_deg) * DEG
        self.elevation_bias_rad = uniform(e.elevation_bias_deg) * DEG
        self.mount = e.mount(self.sensor_id, self.boresight_deg)

    def _noise(self, name: str, target, t_s: float, sigma, tau_s: float) -> np.ndarray:
        """Errors of the targets (K,) with sigma (K,): white, or first-order Gauss-Markov with tau_s per target."""
        sigma = np.broadcast_to(np.asarray(sigma, float), (len(target),))
        n = self.rng.normal(0.0, 1.0, len(target))
        if tau_s <= 0.0:
            return sigma * n
        out = np.empty(len(target))
        for k, tid in enumerate(target):
            last = self._gm.get((name, tid))
            if last is None:
                out[k] = sigma[k] * n[k]
            else:
                phi = math.exp(-max(0.0, t_s - last[0]) / tau_s)
                out[k] = phi * last[1] + sigma[k] * math.sqrt(1.0 - phi * phi) * n[k]
            self._gm[(name, tid)] = (t_s, out[k])
        return out

    def in_view(self, own: np.ndarray, heading_rad: float, targets: np.ndarray) -> np.ndarray:
        """(K,) whether each target [e, n, alt, ...] is inside the field of regard and range limits."""
        rel = np.asarray(targets, float)[:, :3] - np.asarray(own, float)[:3]
        rng_m = np.linalg.norm(rel, axis=1)
        az = np.arctan2(rel[:, 0], rel[:, 1]) - heading_rad
        el = np.arcsin(np.clip(rel[:, 2] / np.maximum(rng_m, 1e-9), -1.0, 1.0))
        ok = self.mount.sees(rng_m, az, el)
        d = self.errors.directional_range_m
        if d is not None:
            off = np.abs(np.degrees(np.angle(np.exp(1j * az))))
            limit = np.where(off <= 45.0, d[0], np.where(off >= 135.0, d[2], d[1]))
            ok &= rng_m <= limit
        return ok

    def scan(self, t_s: float, own: np.ndarray, heading_rad: float, targets: np.ndarray, target_ids=None):
        """Measure at t_s. own [e, n, alt, ve, vn, vu] and heading (clockwise from north) of the ownship; targets
        (K, 6) the same for the aircraft around. Returns (measurements, truth): truth[i] the id of the target
        behind measurement i (None for a false return)."""
        e = self.errors
        targets = np.atleast_2d(np.asarray(targets, float)).reshape(-1, 6)
        ids = list(range(len(targets))) if target_ids is None else list(target_ids)
        own = np.asarray(own, float)
        seen = self.in_view(own, heading_rad, targets)
        detected = seen & (self.rng.random(len(targets)) < e.detection_probability)
        idx = np.flatnonzero(detected)
        tids = [ids[i] for i in idx]
        rel = targets[idx, :3] - own[:3]
        vrel = targets[idx, 3:6] - own[3:6]
        rng_m = np.linalg.norm(rel, axis=1)
        az = np.arctan2(rel[:, 0], rel[:, 1]) - heading_rad
        el = np.arcsin(np.clip(rel[:, 2] / np.maximum(rng_m, 1e-9), -1.0, 1.0))
        rdot = (rel * vrel).sum(axis=1) / np.maximum(rng_m, 1e-9)
        s_b = e.bearing_sigma_rad(el)
        if e.exact:
            m_r, m_az, m_el, m_rr = rng_m, az, el, rdot
        else:
            m_r = rng_m + self.range_bias_m + self._noise("range", tids, t_s, e.range_sigma_m, e.range_tau_s)
            b_err = self._noise("bearing", tids, t_s, s_b, e.angle_tau_s)
            cap = DEG * np.interp(np.degrees(el), e.bearing_breakpoints_deg, e.bearing_max_deg)
            m_az = az + self.azimuth_bias_rad + np.clip(b_err, -cap, cap)
            m_el = el + self.elevation_bias_rad + self._noise("elevation", tids, t_s, (e.elevation_sigma_deg or 0.0) * DEG,
                                                              e.angle_tau_s)
            m_rr = rdot + self.range_rate_bias_mps + self._noise("rdot", tids, t_s, e.range_rate_sigma_mps or 0.0, 0.0)
        alt = targets[idx, 2]
        if e.altitude_quantum_m > 0.0:
            alt = np.round(alt / e.altitude_quantum_m) * e.altitude_quantum_m
        out = [self._measurement(t_s, m_r[k], m_az[k], m_el[k], m_rr[k], alt[k], s_b[k]) for k in range(len(idx))]
        truth: list = list(tids)
        n_false = self.rng.poisson(e.false_returns_per_scan) if e.false_returns_per_scan > 0 else 0
        for _ in range(n_false):  # uniform in the field of regard out to the maximum range (or 20 NM)
            far = min(self.mount.max_range_m, 20 * NM)
            r = float(self.rng.uniform(self.mount.min_range_m, far))
            a = math.radians(self.boresight_deg + self.rng.uniform(-e.half_azimuth_deg, e.half_azimuth_deg))
            el_f = math.radians(self.rng.uniform(e.elevation_min_deg, e.elevation_max_deg))
            alt_f = own[2] + r * math.sin(el_f)
            if e.altitude_quantum_m > 0.0:
                alt_f = round(alt_f / e.altitude_quantum_m) * e.altitude_quantum_m
            out.append(self._measurement(t_s, r, a, el_f, float(self.rng.normal(0.0, 50.0)), alt_f,
                                         float(e.bearing_sigma_rad(el_f))))
            truth.append(None)
        return out, truth

    def _measurement(self, t_s, r, az, el, rdot, alt, s_b) -> PolarMeasurement:
        e = self.errors
        wrap = float(np.angle(np.exp(1j * az)))
        if e.exact:
            s_r, s_a, s_e, s_rr, s_alt = (EXACT_RANGE_SIGMA_M, EXACT_ANGLE_SIGMA_RAD, EXACT_ANGLE_SIGMA_RAD,
                                          EXACT_RATE_SIGMA_MPS, EXACT_RANGE_SIGMA_M)
        else:
            s_r = math.hypot(e.range_sigma_m, e.range_bias_declared_m)
            s_a = math.hypot(float(s_b), e.azimuth_bias_deg * DEG)
            s_e = math.hypot(e.elevation_sigma_deg or 0.0, e.elevation_bias_deg) * DEG
            s_rr = math.hypot(e.range_rate_sigma_mps or 0.0, e.range_rate_bias_mps)
            s_alt = e.altitude_quantum_m / math.sqrt(12.0) if e.altitude_quantum_m > 0 else EXACT_RANGE_SIGMA_M
        common = dict(mount=self.mount, time_s=float(t_s), range_m=max(float(r), 1.0), azimuth_rad=wrap,
                      range_sigma_m=s_r, azimuth_sigma_rad=s_a)
        if e.elevation_sigma_deg is not None:
            common.update(elevation_rad=float(el), elevation_sigma_rad=s_e)
        else:
            common.update(altitude_m=float(alt), altitude_sigma_m=s_alt)
        if e.range_rate_sigma_mps is not None:
            common.update(range_rate_mps=float(rdot), range_rate_sigma_mps=s_rr)
        return PolarMeasurement(**common)
