"""ICAO/ISA standard atmosphere: static pressure <-> pressure altitude (ICAO Doc 7488, 3rd edition, 1993).

Only the two lowest layers are implemented: the troposphere (0-11 km, lapse rate -6.5 K/km) and the isothermal
lower stratosphere (11-20 km, 216.65 K). Above 20 km Doc 7488 has a +1.0 K/km lapse rate, which this module
does not model, so its inversion is valid only up to 20 km (Doc 7488: 5.47489e3 Pa at 20 000 m): lower pressures
are rejected, not extrapolated. Altitudes are geopotential metres, which is what pressure altitude is.
"""

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
STRATOSPHERE_1_TOP_M = 20000.0  # top of the isothermal layer: the highest altitude this module inverts

MIN_VALID_HPA = P11_HPA * math.exp(-G0 * (STRATOSPHERE_1_TOP_M - TROPOPAUSE_M) / (R_AIR * T11_K))  # 54.7489 hPa
# Above this a reading is no aircraft's static pressure: ~-700 m, below the lowest land (Dead Sea, -430 m) even
# under the highest sea-level pressure recorded (1084.8 hPa, WMO); also the top of the usual MEMS barometers'
# rated range (e.g. Bosch BMP280/BMP388: 300-1100 hPa).
MAX_VALID_HPA = 1100.0
MAX_PRESSURE_ALTITUDE_M = STRATOSPHERE_1_TOP_M
MIN_PRESSURE_ALTITUDE_M = T0_K / LAPSE_K_PER_M * (1.0 - (MAX_VALID_HPA / P0_HPA) ** EXPONENT)  # -698.3 m


def pressure_altitude_m(pressure_hpa: float) -> float:
    """Pressure altitude of a static pressure in [MIN_VALID_HPA, MAX_VALID_HPA]; ValueError outside (and NaN)."""
    if not (MIN_VALID_HPA <= pressure_hpa <= MAX_VALID_HPA):  # also False for NaN
        raise ValueError(f"static pressure {pressure_hpa!r} hPa outside [{MIN_VALID_HPA:.4f}, {MAX_VALID_HPA}]")
    if pressure_hpa >= P11_HPA:
        return T0_K / LAPSE_K_PER_M * (1.0 - (pressure_hpa / P0_HPA) ** EXPONENT)
    return TROPOPAUSE_M - R_AIR * T11_K / G0 * math.log(pressure_hpa / P11_HPA)


def pressure_hpa_at(pressure_altitude: float) -> float:
    """Static pressure at a pressure altitude (inverse of pressure_altitude_m); ValueError above 20 km, where
    the isothermal layer would be extrapolated wrongly (and NaN)."""
    if not pressure_altitude <= MAX_PRESSURE_ALTITUDE_M:
        raise ValueError(f"pressure altitude {pressure_altitude!r} m above the {MAX_PRESSURE_ALTITUDE_M:.0f} m "
                         "this model covers")
    if pressure_altitude <= TROPOPAUSE_M:
        return P0_HPA * (1.0 - LAPSE_K_PER_M * pressure_altitude / T0_K) ** (1.0 / EXPONENT)
    return P11_HPA * math.exp(-G0 * (pressure_altitude - TROPOPAUSE_M) / (R_AIR * T11_K))
