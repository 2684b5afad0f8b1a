"""Unit conversions at the edges. Inside the core everything is SI (m, s, rad, m/s)."""

FT = 0.3048  # m per foot
NM = 1852.0  # m per nautical mile
KT = NM / 3600.0  # m/s per knot
FPM = FT / 60.0  # m/s per foot per minute
G0 = 9.80665  # m/s^2, standard gravity

INT32_MAX = 2**31 - 1
UINT16_MAX = 2**16 - 1
INT16_MAX = 2**15 - 1
UINT8_MAX = 2**8 - 1
