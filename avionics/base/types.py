"""Values that flow between the stages. All SI: metres, seconds, m/s; positions in WGS-84 degrees at the
edges and local ENU metres inside. Altitudes always say which datum they are in."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from enum import Enum, IntEnum
from functools import partial

from avionics.base.uncertainty import SumData


class AltitudeDatum(str, Enum):
    """Which kind of altitude a number is. Two altitudes are only differenced within one datum."""

    PRESSURE = "pressure"  # barometric pressure altitude, standard 1013.25 hPa reference
    GEOMETRIC = "geometric"  # GNSS height above mean sea level


class AddressSource(str, Enum):
    """The link an address came from: a 1090ES and a UAT address are different aircraft until shown otherwise."""

    ES1090 = "1090es"
    UAT = "uat"
    SENSOR = "sensor"  # no address: a range/bearing sensor's track (tracking/surveillance.py), keyed by its track id


@dataclass(frozen=True, slots=True, order=True)
class IntruderKey:
    """Identity of an intruder: (address, address source). Never the address alone."""

    address: int
    source: AddressSource
    # hashed once: a key is looked up in several dicts per intruder per assessment (the generated hash built a
    # tuple and called Enum.__hash__ every time)
    _hash: int = field(init=False, repr=False, compare=False, default=0)

    def __post_init__(self) -> None:
        object.__setattr__(self, "_hash", hash((self.address, self.source)))

    def __hash__(self) -> int:
        return self._hash

    def __str__(self) -> str:
        return f"{self.source.value}-{self.address:06X}"

    @classmethod
    def parse(cls, text: str) -> "IntruderKey":
        source, _, address = text.partition("-")
        return cls(int(address, 16), AddressSource(source))


@dataclass(frozen=True, slots=True)
class IntruderReport:
    """One validated ADSB_VEHICLE report. Optional fields are None when the sender flagged them invalid
    or sent a sentinel; nothing downstream sees a sentinel or NaN."""

    key: IntruderKey
    time_s: float  # time of applicability: receipt time back-dated by tslc
    received_s: float
    lat_deg: float
    lon_deg: float
    altitude_m: float | None
    altitude_datum: AltitudeDatum | None
    velocity_en_mps: tuple[float, float] | None  # (east, north)
    vertical_rate_mps: float | None  # positive up
    callsign: str | None = None
    squawk: int | None = None
    emitter_type: int = 0
    simulated: bool = False
    # The source's own accuracy where it says it (a receiver's NACp/NIC, NACv): 1-sigma per horizontal axis.
    # None: the tracker's configured default for the address source (ADSB_VEHICLE carries no NACp).
    position_sigma_m: float | None = None
    velocity_sigma_mps: float | None = None
    path: str = "mavlink"  # the traffic source that delivered it: "mavlink", "sbs:HOST:PORT", "beast:...", ...
    # The surveillance's stated uncertainties (DAIDALUS SUMData, base/uncertainty.py) for a SUM detector; None: none
    # stated (ADSB_VEHICLE has no field for them; a replayed .daa file's *_std columns are attached by the replay).
    uncertainty: SumData | None = None


@dataclass(frozen=True, slots=True)
class OwnshipFix:
    """A validated GLOBAL_POSITION_INT: geometric (GNSS, MSL) position and NED velocity."""

    time_s: float
    lat_deg: float
    lon_deg: float
    alt_msl_m: float
    height_above_home_m: float
    velocity_ned_mps: tuple[float, float, float]
    uncertainty: SumData | None = None  # ownship's stated uncertainties (as IntruderReport.uncertainty)
    heading_deg: float | None = None  # the nose's true heading (GLOBAL_POSITION_INT hdg); None: not known


@dataclass(frozen=True, slots=True)
class OwnshipPressure:
    """Ownship pressure altitude from SCALED_PRESSURE through the ISA standard atmosphere."""

    time_s: float
    pressure_altitude_m: float


@dataclass(frozen=True, slots=True)
class AutopilotHeartbeat:
    """Our autopilot's HEARTBEAT: the flight mode in force (the guidance stage's confirmation, avionics/guidance)."""

    time_s: float
    component: int
    custom_mode: int
    base_mode: int
    autopilot: int = 3  # MAV_AUTOPILOT: 3 ArduPilot, 12 PX4
    mav_type: int = 0  # MAV_TYPE: 1 fixed wing (ArduPlane's contract), 2 quadrotor, ...; 0 generic


@dataclass(frozen=True, slots=True)
class CommandAck:
    """Our autopilot's COMMAND_ACK addressed to us (or to everyone): the answer to a command we sent."""

    time_s: float
    command: int
    result: int


@dataclass(frozen=True, slots=True)
class MissionCount:
    """Our autopilot's MISSION_COUNT to us: the number of mission items (the answer to MISSION_REQUEST_LIST)."""

    time_s: float
    count: int


@dataclass(frozen=True, slots=True)
class MissionItem:
    """Our autopilot's MISSION_ITEM_INT to us: one mission item (command and frame as sent, position in degrees)."""

    time_s: float
    seq: int
    command: int
    frame: int
    lat_deg: float
    lon_deg: float


@dataclass(frozen=True, slots=True)
class MissionCurrent:
    """Our autopilot's MISSION_CURRENT: the item it flies to, and how many the mission has (0: not said)."""

    time_s: float
    seq: int
    total: int = 0


@dataclass(frozen=True, slots=True)
class SensorScan:
    """One scan of one range/bearing sensor (radar, active surveillance): its detections at one time of
    measurement, tracking/measurement.py PolarMeasurement objects (decoded by io/sensor_input.py)."""

    time_s: float
    sensor: str  # the sensor's instance (its mount's sensor_id)
    measurements: tuple


Input = (IntruderReport | OwnshipFix | OwnshipPressure | SensorScan | AutopilotHeartbeat | CommandAck | MissionCount
         | MissionItem | MissionCurrent)
# for the guidance stage, not the DAA core
AUTOPILOT_INPUTS = (AutopilotHeartbeat, CommandAck, MissionCount, MissionItem, MissionCurrent)


class AdvisoryLevel(IntEnum):
    NONE = 0
    TA = 1  # traffic advisory
    RA = 2  # resolution advisory


@dataclass(frozen=True, slots=True)
class Advisory:
    """The advisory state for one intruder, with the geometry that justified it."""

    intruder: IntruderKey
    level: AdvisoryLevel
    time_s: float
    reason: str  # why the level is what it is: "tau", "range", "diverging", "stale", "lost", "no_ownship", ...
    sensitivity_level: int
    range_m: float
    closure_rate_mps: float  # positive when closing
    t_cpa_s: float
    hmd_m: float  # horizontal miss distance at CPA
    vmd_m: float | None  # vertical separation at horizontal CPA (None: intruder altitude unknown)
    range_tau_s: float  # inf when not closing
    mod_tau_s: float  # modified tau with the DMOD of the active level (TA DMOD when NONE)
    vertical_tau_s: float  # time to co-altitude; inf when not converging
    altitude_datum: AltitudeDatum | None
    datum_mismatch: bool  # relative altitude formed across datums, with widened uncertainty
    pc_ta: float | None = None  # conflict probability of the TA volume at CPA (advisory/gating.py)
    pc_ra: float | None = None  # ... of the RA volume (None where the level has no RA)
    # The conflict stage's probabilities for the [conflict] zone (conflict/assess.py, docs/conflict.md):
    pc_now: float | None = None  # instantaneous
    pc_max: float | None = None  # maximum predicted over the lookahead ...
    t_pc_max_s: float | None = None  # ... and when (from now)
    pc_within: float | None = None  # probability of a conflict at any time within the lookahead
    pc_within_age_s: float | None = None  # since its Monte Carlo ran (budgeted: may exceed 1 s); None: not run
    # The resolution advisory (level RA only): one ownship manoeuvre shared by every RA threat.
    ra_sense: str | None = None  # "climb" | "descend"
    ra_strength: str | None = None  # "preventive" | "level_off" | "corrective" | "increase"
    ra_words: str | None = None  # TCAS phrase: "CLIMB", "DONT DESCEND", "INCREASE DESCENT", "CLIMB NOW", ...
    target_vertical_rate_mps: float | None = None  # None for a preventive RA (a limit, not a target)
    ra_reversed: bool = False
    ra_crossing: bool = False  # the sense takes ownship through the intruder's altitude
    # projected vertical separation from this intruder at its CPA with the RA flown, in the sense the RA has
    # against it (ra_sense); negative when the RA would leave ownship on the other side (advisory/resolution.py)
    ra_separation_m: float | None = None
    ra_composite: bool = False  # a composite RA (threats above and below): level, each ra_sense away from its threat
    # ADS-B integrity of the intruder's reports (tracking/integrity.py): "ok" or "degraded:<mode>"
    integrity: str = "ok"
    # A DO-365 alerter's own level (advisory/alerting.py: 0 NONE, 1 PREVENTIVE, 2 CORRECTIVE, 3 WARNING) and its
    # name; None where the alert levels are the advisory levels (the tcas2 alerter): see `alert`
    alert_level: int | None = None
    alert_name: str | None = None

    def ra_key(self) -> tuple:
        """What a pilot would hear change: level, sense, strength, reversal, composite, the DO-365 alert level,
        the traffic lost or found again."""
        return (self.level, self.ra_sense, self.ra_strength, self.ra_reversed, self.ra_composite, self.alert_level,
                self.lost)

    @property
    def lost(self) -> bool:
        """A lost threat (advisory/logic.py lost_hold): held on its coasted track, or ended without a clear."""
        return self.reason == LOST

    def assessment(self) -> tuple:
        """Its ASSESSMENT_FIELDS, in order."""
        return tuple(getattr(self, name) for name in ASSESSMENT_FIELDS)

    def alert(self) -> tuple[int, str]:
        """(alert level, its name): the DO-365 alerter's, or the advisory level's (0 NONE, 1 TA, 2 RA)."""
        if self.alert_level is None:
            return int(self.level), self.level.name
        return self.alert_level, self.alert_name or ""


# An advisory that ends because DAA cannot work for the intruder (not because it is clear): announced as
# "DAA UNAVAILABLE", at warning severity, never as "CLEAR OF CONFLICT".
UNAVAILABLE_REASONS = ("no_ownship", "fault", "shutdown")
# The reason of a lost threat's advisory: its reports stopped while it was alerting (advisory/logic.py lost_hold).
# Announced as "TRAFFIC LOST", never as "CLEAR OF CONFLICT": a lost track says nothing about the geometry.
LOST = "lost"


# The fields of a track's latest assessment that its publications repeat (zenoh `traffic` and `tracks/`).
ASSESSMENT_FIELDS = ("range_m", "t_cpa_s", "hmd_m", "vmd_m", "range_tau_s", "mod_tau_s", "pc_ta", "pc_ra", "pc_now",
                     "pc_max", "t_pc_max_s", "pc_within", "pc_within_age_s")


@dataclass(frozen=True, slots=True)
class TrackView:
    """One intruder track as the facade publishes it (avionics/daa.py): identity, report bookkeeping, and the
    state predicted to time_s: x = (east, north, altitude, v_east, v_north, v_up) with the position in the
    tracking plane (metres) and the velocity in true east/north at the aircraft; p its covariance (read-only)."""

    key: IntruderKey
    time_s: float  # the step that built the view: x, p and the age are as of then
    callsign: str | None
    squawk: int | None
    emitter_type: int
    simulated: bool
    last_report_s: float
    n_updates: int
    datum: AltitudeDatum | None
    altitude_valid: bool  # an altitude report within tracking.max_coast_s
    lat_deg: float
    lon_deg: float
    x: object  # numpy (6,)
    p: object  # numpy (6, 6)
    integrity: str  # "ok" | "degraded:<mode>"
    integrity_fault_m: float | None
    advisory_level: AdvisoryLevel  # its latest assessment's level (NONE: never assessed)
    advisory_of: Callable[[], Advisory | None]  # its latest assessment, built when asked (`advisory`)
    assessment: tuple | None  # that assessment's ASSESSMENT_FIELDS, in order (None: never assessed)
    modes: dict | None  # the IMM tracker's mode outputs (None for the CV filter)
    spoof_suspected: bool

    @property
    def advisory(self) -> Advisory | None:
        """Its latest assessment (a quiet intruder's is built from its step's arrays only when read)."""
        return self.advisory_of()

    @classmethod
    def of(cls, record, time_s: float, x, p, lat_deg: float, lon_deg: float, altitude_valid: bool,
           advisory: Advisory | Callable[[], Advisory | None] | None = None, modes: dict | None = None,
           spoof_suspected: bool = False, advisory_level: AdvisoryLevel | None = None,
           assessment: tuple | None = None) -> "TrackView":
        """The view of a tracker's record (tracking/record.py) with its state predicted to time_s; x and p made
        read-only.
        advisory: an Advisory, or a callable building it (then advisory_level and assessment are its level and
        its ASSESSMENT_FIELDS)."""
        x.flags.writeable = False
        p.flags.writeable = False
        integrity = record.integrity
        if not callable(advisory):
            advisory_level = advisory.level if advisory is not None else AdvisoryLevel.NONE
            assessment = advisory.assessment() if advisory is not None else None
            advisory = partial(_same, advisory)
        return cls(key=record.key, time_s=time_s, callsign=record.callsign, squawk=record.squawk,
                   emitter_type=record.emitter_type, simulated=record.simulated, last_report_s=record.last_report_s,
                   n_updates=record.n_updates,
                   datum=record.datum, altitude_valid=altitude_valid, lat_deg=lat_deg, lon_deg=lon_deg, x=x, p=p,
                   integrity=integrity.label, integrity_fault_m=integrity.fault_m if integrity.degraded else None,
                   advisory_level=advisory_level, advisory_of=advisory, assessment=assessment, modes=modes,
                   spoof_suspected=spoof_suspected)


def _same(value):
    return value
