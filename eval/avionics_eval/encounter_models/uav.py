"""Ownship trajectories of a multirotor UAV on its missions at 50-1,200 ft AGL (the band issue 28 asks for),
as Tracks at 1 Hz for pairing. Speeds, rates and the turn rate are the `multirotor` vehicle profile's
(avionics/advisory/vehicles/multirotor.toml: ArduCopter's waypoint-navigation defaults, AC_WPNav.cpp and .h), the
one source the RA logic and the guidance read too.

- hover: stationary at its altitude;
- transit: straight and level at the waypoint speed;
- survey: a lawnmower pattern, legs of SURVEY_LEG_S seconds joined by 180-degree turns;
- corridor: straight at the waypoint speed, stepping CORRIDOR_STEP_FT up or down every CORRIDOR_PERIOD_S
  seconds at the climb/descent rates (a linear inspection following the ground), inside the band.
Heading, altitude and the time into the pattern are uniform random per track."""

from __future__ import annotations

import numpy as np

from avionics.advisory.vehicle import load_vehicle
from avionics.base.units import FT
from avionics_eval.encounter_models.tracks import KT_TO_FTPS, Tracks

_VEHICLE = load_vehicle("multirotor")
SPEED_MPS = _VEHICLE.max_ground_speed_mps  # WPNAV_SPEED
CLIMB_MPS = _VEHICLE.climb_rate_mps  # WPNAV_SPEED_UP
DESCENT_MPS = _VEHICLE.descent_rate_mps  # WPNAV_SPEED_DN
TURN_RATE_DEG_S = _VEHICLE.turn_rate_deg_s  # WPNAV_ACCEL / WPNAV_SPEED
ALT_BAND_FT = (50.0, 1200.0)
SURVEY_LEG_S = 60    # mission geometry, not a vehicle limit: 600 m legs
CORRIDOR_STEP_FT = 100.0
CORRIDOR_PERIOD_S = 60
MISSIONS = ("hover", "transit", "survey", "corridor")


def mission_tracks(mission: str, n: int, duration_s: int, rng: np.random.Generator) -> Tracks:
    if mission not in MISSIONS:
        raise ValueError(f"unknown UAV mission {mission!r} (one of {', '.join(MISSIONS)})")
    points = duration_s + 1
    t = np.arange(points, dtype=float)
    heading0 = rng.uniform(0.0, 360.0, n)
    alt0 = rng.uniform(*ALT_BAND_FT, n)
    speed_kts = np.full((n, points), SPEED_MPS / FT / KT_TO_FTPS)
    turn_rate = TURN_RATE_DEG_S
    dpsi = np.zeros((n, points))
    dh_fpm = np.zeros((n, points))
    if mission == "hover":
        speed_kts[:] = 0.0
    elif mission == "survey":
        turn_s = 180.0 / turn_rate
        period = SURVEY_LEG_S + turn_s
        phase = (t[None, :] + rng.uniform(0, 2 * period, n)[:, None]) % (2 * period)
        # alternate right and left turns so the legs advance across the area
        in_turn = (phase % period) >= SURVEY_LEG_S
        direction = np.where(phase < period, 1.0, -1.0)
        dpsi = np.where(in_turn, direction * turn_rate, 0.0)
    elif mission == "corridor":
        phase = (t[None, :] + rng.uniform(0, CORRIDOR_PERIOD_S, n)[:, None]) // CORRIDOR_PERIOD_S
        up = rng.random((n, int(phase.max()) + 2)) < 0.5
        step_up = np.take_along_axis(up, phase.astype(int), axis=1)
        climb_s = CORRIDOR_STEP_FT * FT / CLIMB_MPS
        descent_s = CORRIDOR_STEP_FT * FT / DESCENT_MPS
        into = (t[None, :] + 0.0) % CORRIDOR_PERIOD_S
        dh_fpm = np.where(step_up & (into < climb_s), CLIMB_MPS / FT * 60,
                          np.where(~step_up & (into < descent_s), -DESCENT_MPS / FT * 60, 0.0))
    heading = heading0[:, None] + np.concatenate([np.zeros((n, 1)), np.cumsum(dpsi[:, :-1], axis=1)], axis=1)
    alt = alt0[:, None] + np.concatenate([np.zeros((n, 1)), np.cumsum(dh_fpm[:, :-1] / 60, axis=1)], axis=1)
    alt = np.clip(alt, *ALT_BAND_FT)
    step = speed_kts[:, :-1] * KT_TO_FTPS
    rad = np.radians(heading[:, :-1])
    zeros = np.zeros((n, 1))
    north = np.concatenate([zeros, np.cumsum(step * np.cos(rad), axis=1)], axis=1)
    east = np.concatenate([zeros, np.cumsum(step * np.sin(rad), axis=1)], axis=1)
    return Tracks(np.broadcast_to(t, (n, points)), north, east, alt, speed_kts, np.mod(heading, 360.0),
                  np.gradient(alt, axis=1) * 60 if points > 1 else dh_fpm)
