"""What every tracker keeps of an intruder besides its filter (identity, datum, report times), and the
lifecycle constants the CV and IMM trackers share. The pipeline and the payloads read tracks through these."""

from __future__ import annotations

from dataclasses import dataclass, field

from avionics.base.types import AltitudeDatum, IntruderKey, IntruderReport
from avionics.tracking.integrity import OK, IntegrityStatus

UNKNOWN_SPEED_SIGMA_MPS = 150.0  # prior on an unreported horizontal velocity: any aircraft we protect against
UNKNOWN_VRATE_SIGMA_MPS = 15.0
UNKNOWN_ALT_SIGMA_M = 1.0e4  # placeholder variance of an axis that has never been measured
REJECTS_BEFORE_RESTART = 3  # implausible reports in a row before the track is replaced by the new motion
DUPLICATE_WINDOW_S = 1e-6  # reports closer in time than this are the same report


@dataclass
class TrackRecord:
    key: IntruderKey
    datum: AltitudeDatum | None
    first_report_s: float
    last_report_s: float
    last_altitude_s: float | None
    n_updates: int = 1
    consecutive_rejects: int = 0
    callsign: str | None = None
    squawk: int | None = None
    emitter_type: int = 0
    simulated: bool = False
    last_received_s: float = 0.0
    meta: dict = field(default_factory=dict)
    integrity: IntegrityStatus = OK  # ADS-B integrity of the key (tracking/integrity.py), set at every report
    # the last report of the key: (east, north) offset from the track's posterior position at that report, and its
    # altitude; kept as an offset so that it follows the plane when the trackers' reframe carries the filters
    report_offset: tuple | None = None

    @property
    def last_reported_enu(self) -> tuple | None:
        """The key's last reported (east, north, altitude or None), in the current plane (metres)."""
        if self.report_offset is None:
            return None
        x = self.kf.x
        return float(x[0] + self.report_offset[0]), float(x[1] + self.report_offset[1]), self.report_offset[2]

    def altitude_valid(self, t_s: float, max_coast_s: float) -> bool:
        return self.last_altitude_s is not None and t_s - self.last_altitude_s <= max_coast_s

    def copy_identity(self, report: IntruderReport) -> None:
        """Keep the last valid callsign and squawk; emitter type, SIMULATED and receipt time as last reported."""
        self.callsign = report.callsign or self.callsign
        self.squawk = report.squawk if report.squawk is not None else self.squawk
        self.emitter_type = report.emitter_type
        self.simulated = report.simulated
        self.last_received_s = report.received_s
