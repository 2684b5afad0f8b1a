"""Statistical encounter generator: one ownship and one intruder, reproducible from (set seed, index) alone.

The structure follows the public descriptions of the MIT Lincoln Laboratory encounter models (Kochenderfer et
al., "Uncorrelated Encounter Model of the National Airspace System", ATC-345, 2008; "Correlated Encounter Model
for Cooperative Aircraft in the National Airspace System", ATC-344, 2008; "Airspace Encounter Models for
Estimating Collision Risk", J. Guidance, Control, and Dynamics 33(2), 2010): an altitude layer, each aircraft's
speed, vertical rate, turn rate and acceleration, and the encounter placed by its geometry at the closest point
of approach (relative heading, HMD, VMD). The distributions are this project's (docs/evaluation.md states each
and why); the Lincoln models' Bayesian-network tables are not reproduced.

Construction: both aircraft's states at the CPA time are drawn, then the trajectories are integrated backwards
and forwards from the CPA with their manoeuvres, so the horizontal miss and the vertical miss at the CPA are
exactly the drawn ones. Manoeuvres that would bring the aircraft horizontally closer elsewhere are drawn again.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from avionics.base.units import FPM, FT, KT

DT_S = 0.1  # truth sampling step: NMAC and CPA are evaluated on this grid
T_CPA_S = 80.0  # time of CPA from the start: longer than DO-365's 75 s early alerting time plus track start-up
AFTER_CPA_S = 15.0  # flown past the CPA: an RA's effect and its end are seen
DURATION_S = T_CPA_S + AFTER_CPA_S

SOURCE = "ours"  # the records' name for this generator (`avionics evaluate --generator ours`)
MANOEUVRE_TRIES = 5  # manoeuvre draws per geometry, then the geometry is drawn again


@dataclass(frozen=True)
class Model:
    """The distributions (docs/evaluation.md, "The encounter model"); the defaults are the evaluation's model.
    Feet, knots, fpm and degrees as named."""

    # Altitude layers (ft above ground) of the MIT LL uncorrelated model (ATC-345); ground at 0 ft MSL here.
    layers_ft: tuple[tuple[float, float], ...] = ((500.0, 1200.0), (1200.0, 3000.0), (3000.0, 5000.0),
                                                  (5000.0, 12500.0))
    own_speed_kt: tuple[float, float] = (60.0, 250.0)  # 250 kt: the limit below 10,000 ft MSL (14 CFR 91.117)
    int_speed_kt: tuple[float, float] = (60.0, 250.0)
    hmd_max_ft: float = 4000.0  # HMD at CPA uniform in [0, this]: covers DO-365's 4000 ft well-clear DTHR
    vmd_max_ft: float = 1000.0  # VMD at CPA uniform in [-this, this]
    min_closure_mps: float = 10.0  # slower relative motion is redrawn: no encounter develops in T_CPA_S
    own_p_level: float = 0.5  # an aircraft flies level at the CPA with this probability ...
    int_p_level: float = 0.5
    vrate_fpm: tuple[float, float] = (500.0, 2000.0)  # ... else climbs or descends at a rate uniform in this
    p_turn: float = 0.25  # a turn (standard rate: 3 deg/s) of manoeuvre_s somewhere in the encounter
    turn_dps: tuple[float, float] = (1.0, 3.0)
    p_accel: float = 0.25  # a speed change
    accel_kt_s: tuple[float, float] = (0.5, 1.5)
    p_vchange: float = 0.25  # the vertical rate before some time differs (a level-off, a start of climb/descent)
    manoeuvre_s: tuple[float, float] = (10.0, 30.0)
    min_agl_ft: float = 200.0  # trajectories lower than this are redrawn
    speed_bounds_kt: tuple[float, float] = (40.0, 300.0)  # a speed change leaving these is redrawn


DEFAULT_MODEL = Model()


@dataclass(frozen=True, slots=True)
class Aircraft:
    """One aircraft's state at the CPA and its manoeuvre program (times from the encounter start)."""

    east_m: float
    north_m: float
    alt_m: float
    heading_rad: float
    speed_mps: float
    vrate_mps: float  # at the CPA
    turn_dps: float = 0.0  # turn rate during [turn_start_s, turn_end_s)
    turn_start_s: float = 0.0
    turn_end_s: float = 0.0
    accel_mps2: float = 0.0  # along track during [accel_start_s, accel_end_s)
    accel_start_s: float = 0.0
    accel_end_s: float = 0.0
    vrate_before_mps: float | None = None  # vertical rate before vchange_s (None: no change)
    vchange_s: float = 0.0

    def sample(self, t: np.ndarray) -> np.ndarray:
        """Truth on the grid t (which contains T_CPA_S): columns east, north, up, v_east, v_north, v_up."""
        k_cpa = round(T_CPA_S / DT_S)
        turn = np.where((t >= self.turn_start_s) & (t < self.turn_end_s), math.radians(self.turn_dps), 0.0)
        accel = np.where((t >= self.accel_start_s) & (t < self.accel_end_s), self.accel_mps2, 0.0)
        heading = self.heading_rad + _integral_from(turn, k_cpa)
        speed = self.speed_mps + _integral_from(accel, k_cpa)
        vup = np.full_like(t, self.vrate_mps)
        if self.vrate_before_mps is not None:
            vup[t < self.vchange_s] = self.vrate_before_mps
        ve, vn = speed * np.sin(heading), speed * np.cos(heading)
        return np.column_stack((self.east_m + _integral_from(ve, k_cpa), self.north_m + _integral_from(vn, k_cpa),
                                self.alt_m + _integral_from(vup, k_cpa), ve, vn, vup))


def grid() -> np.ndarray:
    """The truth's sample times: 0 to DURATION_S every DT_S."""
    return np.arange(round(DURATION_S / DT_S) + 1) * DT_S


def _integral_from(rate: np.ndarray, k0: int) -> np.ndarray:
    """Trapezoidal integral of rate over the DT_S grid, zero at index k0 (the CPA)."""
    cum = np.concatenate(([0.0], np.cumsum(0.5 * (rate[1:] + rate[:-1]) * DT_S)))
    return cum - cum[k0]


@dataclass(frozen=True, slots=True)
class Encounter:
    """What the evaluation needs: identity, the drawn geometry (kept in the record) and the two aircraft."""

    seed: int
    index: int
    layer: int  # 1-based, Model.layers_ft
    hmd_m: float
    vmd_m: float  # intruder above ownship at the CPA when positive
    rel_heading_deg: float
    own: Aircraft
    intruder: Aircraft

    def truth(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(t, ownship, intruder) sampled every DT_S (Aircraft.sample columns)."""
        t = grid()
        return t, self.own.sample(t), self.intruder.sample(t)

    def geometry(self) -> dict:
        """The drawn geometry as the record keeps it (evaluate.RECORD_SCHEMA); every encounter weighs 1."""
        own, intruder = self.own, self.intruder
        return {
            "source": SOURCE, "weight": 1.0, "layer": self.layer, "alt_ft": own.alt_m / FT,
            "hmd_drawn_ft": self.hmd_m / FT, "vmd_drawn_ft": self.vmd_m / FT, "rel_heading_deg": self.rel_heading_deg,
            "own_speed_kt": own.speed_mps / KT, "int_speed_kt": intruder.speed_mps / KT,
            "own_vrate_fpm": own.vrate_mps / FPM, "int_vrate_fpm": intruder.vrate_mps / FPM,
            "own_manoeuvres": _manoeuvre_count(own), "int_manoeuvres": _manoeuvre_count(intruder),
        }


def _manoeuvre_count(a: Aircraft) -> int:
    return int(a.turn_dps != 0.0) + int(a.accel_mps2 != 0.0) + int(a.vrate_before_mps is not None)


def _uniform_magnitude(rng, bounds) -> float:
    return float(rng.choice((-1.0, 1.0)) * rng.uniform(*bounds))


def _vrate(rng, m: Model, p_level: float) -> float:
    return 0.0 if rng.random() < p_level else _uniform_magnitude(rng, m.vrate_fpm) * FPM


def _window(rng, m: Model) -> tuple[float, float]:
    start = rng.uniform(0.0, DURATION_S - m.manoeuvre_s[0])
    return start, start + rng.uniform(*m.manoeuvre_s)


def _manoeuvres(rng, m: Model, base: Aircraft, p_level: float) -> Aircraft:
    """base with a random turn, speed change and vertical-rate change (each with its probability)."""
    fields = {}
    if rng.random() < m.p_turn:
        start, end = _window(rng, m)
        fields.update(turn_dps=_uniform_magnitude(rng, m.turn_dps), turn_start_s=start, turn_end_s=end)
    if rng.random() < m.p_accel:
        start, end = _window(rng, m)
        fields.update(accel_mps2=_uniform_magnitude(rng, m.accel_kt_s) * KT, accel_start_s=start, accel_end_s=end)
    if rng.random() < m.p_vchange:
        fields.update(vrate_before_mps=_vrate(rng, m, p_level), vchange_s=rng.uniform(0.0, T_CPA_S))
    return replace(base, **fields)


def _acceptable(m: Model, own: Aircraft, intruder: Aircraft, hmd_m: float, t: np.ndarray) -> bool:
    o, i = own.sample(t), intruder.sample(t)
    horizontal = np.hypot(i[:, 0] - o[:, 0], i[:, 1] - o[:, 1])
    low, high = m.speed_bounds_kt
    for x in (o, i):
        speed = np.hypot(x[:, 3], x[:, 4])
        if x[:, 2].min() < m.min_agl_ft * FT or speed.min() < low * KT or speed.max() > high * KT:
            return False
    return bool(horizontal.min() >= hmd_m - 0.5)  # nowhere closer than the drawn HMD (0.5 m: the grid)


def generate(seed: int, index: int, model: Model = DEFAULT_MODEL) -> Encounter:
    """Encounter `index` of set `seed`: its own generator, seeded by (seed, index), so any encounter can be made
    on any worker in any order. Draws are rejected (and made again from the same stream) until the encounter
    meets the conditions of _acceptable: the set is the model conditioned on them."""
    rng = np.random.default_rng([seed, index])
    t = grid()
    while True:
        found = _draw(rng, model, seed, index, t)
        if found is not None:
            return found


def _draw(rng, m: Model, seed: int, index: int, t: np.ndarray) -> Encounter | None:
    layer = int(rng.integers(len(m.layers_ft)))
    alt_m = rng.uniform(*m.layers_ft[layer]) * FT
    own_heading = rng.uniform(0.0, 2 * math.pi)
    rel_heading = rng.uniform(0.0, 2 * math.pi)
    own_speed = rng.uniform(*m.own_speed_kt) * KT
    int_speed = rng.uniform(*m.int_speed_kt) * KT
    int_heading = (own_heading + rel_heading) % (2 * math.pi)
    v_rel = int_speed * np.array([math.sin(int_heading), math.cos(int_heading)]) \
        - own_speed * np.array([math.sin(own_heading), math.cos(own_heading)])
    if np.hypot(*v_rel) < m.min_closure_mps:  # the relative velocity sets the HMD's direction: none here
        return None
    hmd_m = rng.uniform(0.0, m.hmd_max_ft) * FT
    vmd_m = rng.uniform(-m.vmd_max_ft, m.vmd_max_ft) * FT
    side = np.array([-v_rel[1], v_rel[0]]) / np.hypot(*v_rel) * rng.choice((-1.0, 1.0))
    own = Aircraft(0.0, 0.0, alt_m, own_heading, own_speed, _vrate(rng, m, m.own_p_level))
    intruder = Aircraft(float(hmd_m * side[0]), float(hmd_m * side[1]), alt_m + vmd_m, int_heading, int_speed,
                        _vrate(rng, m, m.int_p_level))
    for _ in range(MANOEUVRE_TRIES):
        own_m = _manoeuvres(rng, m, own, m.own_p_level)
        intruder_m = _manoeuvres(rng, m, intruder, m.int_p_level)
        if _acceptable(m, own_m, intruder_m, hmd_m, t):
            return Encounter(seed, index, layer + 1, float(hmd_m), float(vmd_m), math.degrees(rel_heading), own_m,
                             intruder_m)
    return None
