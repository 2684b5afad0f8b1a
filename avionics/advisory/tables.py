"""TCAS II v7.1 sensitivity-level thresholds, as data.

Sources: RTCA DO-185B; FAA "Introduction to TCAS II Version 7.1" (2011), Table 3 (SL by altitude band,
TA/RA tau, DMOD, ZTHR, ALIM) and the RA horizontal miss distance filter; the same numbers as NASA DAIDALUS
TCASTable. SL 2 issues TAs only; above FL420 the thresholds widen (last row).
"""

from __future__ import annotations

from dataclasses import dataclass

from avionics.core.units import FT, NM


@dataclass(frozen=True, slots=True)
class SensitivityLevel:
    sl: int
    ceiling_m: float  # the band holds altitudes <= this (SL 2: < 1000 ft AGL)
    agl_band: bool  # band bounds are above ground level (SL 2, 3); else pressure altitude
    ta_tau_s: float
    ta_dmod_m: float
    ta_zthr_m: float
    ra_tau_s: float | None  # None: no RA at this level
    ra_dmod_m: float | None
    ra_zthr_m: float | None
    alim_m: float | None
    ra_hmd_m: float | None  # RA horizontal miss distance filter


def _row(sl, ceiling_ft, agl, ta_tau, ta_dmod_nm, ta_zthr_ft, ra_tau, ra_dmod_nm, ra_zthr_ft, alim_ft, hmd_nm):
    opt = lambda v, k: None if v is None else v * k  # noqa: E731
    return SensitivityLevel(
        sl, ceiling_ft * FT, agl, ta_tau, ta_dmod_nm * NM, ta_zthr_ft * FT,
        ra_tau, opt(ra_dmod_nm, NM), opt(ra_zthr_ft, FT), opt(alim_ft, FT), opt(hmd_nm, NM),
    )


INF = float("inf")

# sl, band ceiling [ft], AGL band, TA tau [s], TA DMOD [nm], TA ZTHR [ft], RA tau [s], RA DMOD [nm],
# RA ZTHR [ft], ALIM [ft], RA HMD [nm]
TCAS_II_V71: tuple[SensitivityLevel, ...] = (
    _row(2, 1000, True, 20, 0.30, 850, None, None, None, None, None),
    _row(3, 2350, True, 25, 0.33, 850, 15, 0.20, 600, 300, 0.40),
    _row(4, 5000, False, 30, 0.48, 850, 20, 0.35, 600, 300, 0.57),
    _row(5, 10000, False, 40, 0.75, 850, 25, 0.55, 600, 350, 0.74),
    _row(6, 20000, False, 45, 1.00, 850, 30, 0.80, 600, 400, 0.82),
    _row(7, 42000, False, 48, 1.30, 850, 35, 1.10, 700, 600, 0.98),
    _row(7, INF, False, 48, 1.30, 1200, 35, 1.10, 800, 700, 0.98),  # above FL420
)


def select_level(agl_m: float | None, altitude_m: float, table=TCAS_II_V71) -> SensitivityLevel:
    """The row whose band holds ownship: AGL for the low bands (SL 2, 3), pressure altitude above.

    TCAS II uses the radar altimeter for SL 2/3; without AGL we fall through to the altitude bands, which
    is the conservative choice (larger thresholds) for a UAV flying low over high terrain only if its
    altitude is above the AGL bands; docs/advisories.md explains the choice.
    """
    for row in table:
        if row.agl_band:
            if agl_m is not None and (agl_m < row.ceiling_m if row.sl == 2 else agl_m <= row.ceiling_m):
                return row
        elif altitude_m <= row.ceiling_m:
            return row
    return table[-1]
