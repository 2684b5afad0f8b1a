"""Band kinds and regions: the guidance bands of a DO-365 alerter (advisory/bands.py computes them) as every output
names them: the zenoh `bands` topic's fields, DAA_BANDS `kind` and `region`, the monitor's page and terminal view."""

from __future__ import annotations

from dataclasses import dataclass

from avionics.base.units import FPM, FT, KT


@dataclass(frozen=True, slots=True)
class BandKind:
    name: str  # the field of advisory/bands.py Bands and of the zenoh bands payload
    unit: str  # SI, as the payload carries it
    limit: tuple[float, float]  # where its intervals may lie (a receiver's check; track split at north)
    mavlink: str  # DAA_BANDS_KIND entry (avionics/io/dialect/daa.xml)
    label: str  # a display's short name
    display_unit: str  # what a display shows it in
    per_display_unit: float  # SI units per display unit


BAND_KINDS = (
    BandKind("track_deg", "deg", (0.0, 360.0), "DAA_BANDS_KIND_TRACK", "TRK", "°", 1.0),
    BandKind("ground_speed_mps", "m/s", (0.0, 10_000.0), "DAA_BANDS_KIND_GROUND_SPEED", "GS", "kt", KT),
    BandKind("vertical_rate_mps", "m/s", (-10_000.0, 10_000.0), "DAA_BANDS_KIND_VERTICAL_SPEED", "V/S", "fpm", FPM),
    BandKind("altitude_m", "m", (-2_000.0, 100_000.0), "DAA_BANDS_KIND_ALTITUDE", "ALT", "ft", FT),
)
BAND_KIND_NAMES = tuple(k.name for k in BAND_KINDS)

# DAIDALUS BandsRegion, least to most severe but RECOVERY (a conflict-free value does not exist: the soonest way out);
# a newer region is shown as UNKNOWN. Each -> its DAA_BANDS_REGION entry.
BAND_REGIONS = {"NONE": "DAA_BANDS_REGION_NONE", "FAR": "DAA_BANDS_REGION_FAR", "MID": "DAA_BANDS_REGION_MID",
                "NEAR": "DAA_BANDS_REGION_NEAR", "RECOVERY": "DAA_BANDS_REGION_RECOVERY"}
BAND_REGION_UNKNOWN = "DAA_BANDS_REGION_UNKNOWN"
