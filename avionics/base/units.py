"""Unit conversions at the edges. Inside the core everything is SI (m, s, rad, m/s). Also the one place that turns
an east/north velocity into ground speed and track angle."""

import math

import numpy as np

FT = 0.3048  # m per foot
NM = 1852.0  # m per nautical mile
KT = NM / 3600.0  # m/s per knot
FPM = FT / 60.0  # m/s per foot per minute
G0 = 9.80665  # m/s^2, standard gravity

INT32_MAX = 2**31 - 1
UINT16_MAX = 2**16 - 1
INT16_MAX = 2**15 - 1
UINT8_MAX = 2**8 - 1


def ground_speed_mps(east_mps, north_mps):
    """Horizontal speed of an east/north velocity: floats with math (the per-sample payloads), numpy arrays
    element-wise (the traffic batch); the two agree to the last bit or two (math.hypot is correctly rounded)."""
    if isinstance(east_mps, np.ndarray):
        return np.hypot(east_mps, north_mps)
    return math.hypot(east_mps, north_mps)


def track_deg(east_mps, north_mps):
    """Course over ground of an east/north velocity, degrees clockwise from north in [0, 360); a velocity of 0
    gives 0. Floats with math, numpy arrays element-wise, as ground_speed_mps."""
    if isinstance(east_mps, np.ndarray):
        return np.degrees(np.arctan2(east_mps, north_mps)) % 360.0
    return math.degrees(math.atan2(east_mps, north_mps)) % 360.0


def track_rad(east_mps, north_mps) -> float:
    """track_deg in radians, [0, 2 pi) (the bands' track kind, advisory/bands.py)."""
    return math.atan2(east_mps, north_mps) % (2.0 * math.pi)
