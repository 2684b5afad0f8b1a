"""ICAO/ISA standard atmosphere: static pressure <-> pressure altitude (ICAO Doc 7488)."""

from __future__ import annotations

import math

P0_HPA = 1013.25
T0_K = 288.15
LAPSE_K_PER_M = 0.0065
R_AIR = 287.05287
G0 = 9.80665
TROPOPAUSE_M = 11000.0
T11_K = T0_K - LAPSE_K_PER_M * TROPOPAUSE_M  # 216.65 K
EXPONENT = R_AIR * LAPSE_K_PER_M / G0  # 0.190263
P11_HPA = P0_HPA * (T11_K / T0_K) ** (1.0 / EXPONENT)  # 226.32 hPa

MIN_VALID_HPA = 1.0  # ~31 km; below this a static port reading is not an aircraft's
MAX_VALID_HPA = 1100.0  # ~ -700 m; above this the sensor is wrong


def pressure_altitude_m(pressure_hpa: float) -> float:
    """Pressure altitude of a static pressure in the ISA troposphere and lower stratosphere."""
    if not (MIN_VALID_HPA <= pressure_hpa <= MAX_VALID_HPA):  # also False for NaN
        raise ValueError(f"static pressure {pressure_hpa!r} hPa outside [{MIN_VALID_HPA}, {MAX_VALID_HPA}]")
    if pressure_hpa >= P11_HPA:
        return T0_K / LAPSE_K_PER_M * (1.0 - (pressure_hpa / P0_HPA) ** EXPONENT)
    return TROPOPAUSE_M - R_AIR * T11_K / G0 * math.log(pressure_hpa / P11_HPA)


def pressure_hpa_at(pressure_altitude: float) -> float:
    """Static pressure at a pressure altitude (inverse of pressure_altitude_m)."""
    if pressure_altitude <= TROPOPAUSE_M:
        return P0_HPA * (1.0 - LAPSE_K_PER_M * pressure_altitude / T0_K) ** (1.0 / EXPONENT)
    return P11_HPA * math.exp(-G0 * (pressure_altitude - TROPOPAUSE_M) / (R_AIR * T11_K))
