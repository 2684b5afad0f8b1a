"""Core advisories -> MAVLink messages: COLLISION per threat, STATUSTEXT for people, our HEARTBEAT."""

from __future__ import annotations

import math

import avionics.io  # noqa: F401
from avionics.io.dialect import daa as mavlink2  # ardupilotmega.xml plus our DAA_ADVISORY, DAA_BANDS

from avionics.contract import mavlink as contract
from avionics.contract.bands import BAND_KINDS, BAND_REGION_UNKNOWN, BAND_REGIONS
from avionics.base.types import UNAVAILABLE_REASONS, Advisory, AdvisoryLevel, AltitudeDatum, AddressSource
from avionics.base.units import FPM, FT, ground_speed_mps, track_deg


def _values(names: dict) -> dict:
    """A contract table of dialect entry names -> the same table of their values."""
    return {key: getattr(mavlink2, name) for key, name in names.items()}


# avionics/contract/mavlink.py says what each value becomes (and why); these are its tables in the dialect's numbers
THREAT_LEVEL = _values(contract.THREAT_LEVEL)
DO365_THREAT_LEVEL = _values(contract.DO365_THREAT_LEVEL)


def threat_level(advisory: Advisory) -> int:
    """COLLISION threat_level: from the DO-365 alert level under a DO-365 alerter, else from the TA/RA level. A lost
    threat held at its level keeps it (its alert level is held with it)."""
    if advisory.alert_level is None or advisory.level is AdvisoryLevel.NONE:
        return THREAT_LEVEL[advisory.level]
    return DO365_THREAT_LEVEL.get(advisory.alert_level, getattr(mavlink2, contract.DO365_THREAT_LEVEL_ABOVE))


ACTION = _values(contract.ACTION)
ACTION_REQUEST = _values(contract.ACTION_REQUEST)
SEVERITY = _values(contract.SEVERITY)
STATUSTEXT_LEN = contract.STATUSTEXT_LEN


def collision(advisory: Advisory, request_action: bool = False):
    """COLLISION for one intruder. altitude_minimum_delta is NaN when the intruder's altitude is unknown.
    request_action: an RA says ASCEND_OR_DESCEND (the autopilot may act) instead of REPORT, except a composite RA
    (threats above and below): ArduCopter answers ASCEND_OR_DESCEND by moving away from the one intruder's
    altitude (AP_Avoidance_Copter::handle_avoidance_vertical), that is toward the other threat, so every threat
    of a composite RA says REPORT (the level-off is in DAA_ADVISORY)."""
    request = request_action and not advisory.ra_composite
    return mavlink2.MAVLink_collision_message(
        src=mavlink2.MAV_COLLISION_SRC_ADSB,
        id=advisory.intruder.address,
        action=(ACTION_REQUEST if request else ACTION)[advisory.level],
        threat_level=threat_level(advisory),
        time_to_minimum_delta=advisory.t_cpa_s,
        altitude_minimum_delta=advisory.vmd_m if advisory.vmd_m is not None else math.nan,
        horizontal_minimum_delta=advisory.hmd_m,
    )


def advisory_text(advisory: Advisory, callsign: str | None = None) -> str:
    """One line for a pilot's ground station, at most 50 characters: "RA CLIMB 1500 FPM ABC123". A lost threat
    (advisory/logic.py lost_hold) is "TRAFFIC LOST <who> RA HELD" while held, "TRAFFIC LOST <who> (ended)" at its
    end: never "CLEAR OF CONFLICT". Under a DO-365 alerter the level is named as the standard names it (a stock
    ground station shows only this text): "DAA CORRECTIVE <who> TAU ...", "DAA WARNING CLIMB 1500 FPM <who>"."""
    who = callsign or str(advisory.intruder)
    level = advisory.level.name if advisory.alert_level is None else f"DAA {advisory.alert_name or advisory.alert_level}"
    if advisory.level is AdvisoryLevel.NONE and advisory.reason in UNAVAILABLE_REASONS:
        return f"DAA UNAVAILABLE {who} ({advisory.reason})"[:STATUSTEXT_LEN]
    if advisory.lost:
        state = "(ended)" if advisory.level is AdvisoryLevel.NONE else f"{level.removeprefix('DAA ')} HELD"
        return f"TRAFFIC LOST {who} {state}"[:STATUSTEXT_LEN]
    if advisory.level is AdvisoryLevel.NONE:
        return f"CLEAR OF CONFLICT {who} ({advisory.reason})"[:STATUSTEXT_LEN]
    if advisory.level is AdvisoryLevel.RA and advisory.ra_words:
        rate = advisory.target_vertical_rate_mps
        target = "" if rate is None or rate == 0 else f" {abs(rate) / FPM:.0f} FPM"
        return f"{'RA' if advisory.alert_level is None else level} {advisory.ra_words}{target} {who}"[:STATUSTEXT_LEN]
    vertical = "ALT?" if advisory.vmd_m is None else f"{advisory.vmd_m / FT:+.0f}FT"
    tau = "--" if math.isinf(advisory.mod_tau_s) else f"{advisory.mod_tau_s:.0f}S"
    return f"{level} {who} TAU {tau} {advisory.hmd_m:.0f}M {vertical}"[:STATUSTEXT_LEN]


SENSE = _values(contract.SENSE)
STRENGTH = _values(contract.STRENGTH)
INTEGRITY = _values(contract.INTEGRITY)


def _nan_if_none_or_inf(value: float | None) -> float:
    return math.nan if value is None or math.isinf(value) else value


def daa_advisory(advisory: Advisory, callsign: str | None = None, pc: float | None = None):
    """The project's DAA_ADVISORY (avionics/io/dialect/daa.xml): the whole advisory for an autopilot.
    pc defaults to the conflict probability of the advisory's own volume (RA volume for an RA)."""
    if pc is None:
        pc = advisory.pc_ra if advisory.level is AdvisoryLevel.RA else advisory.pc_ta
    flags = ((mavlink2.DAA_ADVISORY_FLAGS_REVERSED if advisory.ra_reversed else 0)
             | (mavlink2.DAA_ADVISORY_FLAGS_CROSSING if advisory.ra_crossing else 0)
             | (mavlink2.DAA_ADVISORY_FLAGS_COMPOSITE if advisory.ra_composite else 0)
             | (mavlink2.DAA_ADVISORY_FLAGS_DATUM_MISMATCH if advisory.datum_mismatch else 0)
             | (mavlink2.DAA_ADVISORY_FLAGS_ALTITUDE_UNKNOWN if advisory.vmd_m is None else 0)
             | (mavlink2.DAA_ADVISORY_FLAGS_UAT if advisory.intruder.source.value == "uat" else 0)
             | (mavlink2.DAA_ADVISORY_FLAGS_INTEGRITY_DEGRADED if advisory.integrity != "ok" else 0)
             | (mavlink2.DAA_ADVISORY_FLAGS_TRAFFIC_LOST if advisory.lost else 0))
    return mavlink2.MAVLink_daa_advisory_message(
        id=advisory.intruder.address, level=int(advisory.level), sense=SENSE[advisory.ra_sense],
        strength=STRENGTH[advisory.ra_strength], flags=flags, sensitivity_level=advisory.sensitivity_level,
        target_vertical_rate=_nan_if_none_or_inf(advisory.target_vertical_rate_mps), range=advisory.range_m,
        time_to_cpa=advisory.t_cpa_s, horizontal_miss=advisory.hmd_m,
        vertical_miss=_nan_if_none_or_inf(advisory.vmd_m), tau=_nan_if_none_or_inf(advisory.range_tau_s),
        mod_tau=_nan_if_none_or_inf(advisory.mod_tau_s), pc=_nan_if_none_or_inf(pc),
        callsign=(callsign or "").encode("ascii", "replace")[:contract.CALLSIGN_LEN], integrity=INTEGRITY.get(advisory.integrity, 0),
        alert_level=advisory.alert()[0])


BANDS_KINDS = {kind.name: getattr(mavlink2, kind.mavlink) for kind in BAND_KINDS}
BANDS_REGIONS = _values(BAND_REGIONS)
BANDS_REGION_UNKNOWN = getattr(mavlink2, BAND_REGION_UNKNOWN)
BANDS_PER_MESSAGE = contract.BANDS_PER_MESSAGE


def daa_bands(bands) -> list:
    """The project's DAA_BANDS messages (avionics/io/dialect/daa.xml) of one bands result (advisory/bands.py
    Bands): per kind one message of up to 10 intervals, more when it has more (part of parts)."""
    out = []
    time_boot_ms = int(round(bands.time_s * 1000.0)) & 0xFFFFFFFF
    for name, kind in BANDS_KINDS.items():
        intervals = list(getattr(bands, name))
        flags = (mavlink2.DAA_BANDS_FLAGS_RECOVERY if bands.recovery.get(name) else 0) | \
            (0 if intervals else mavlink2.DAA_BANDS_FLAGS_NOT_COMPUTED)
        chunks = [intervals[i:i + BANDS_PER_MESSAGE] for i in range(0, len(intervals), BANDS_PER_MESSAGE)] or [[]]
        for part, chunk in enumerate(chunks):
            pad = BANDS_PER_MESSAGE - len(chunk)
            out.append(mavlink2.MAVLink_daa_bands_message(
                time_boot_ms=time_boot_ms, kind=kind, flags=flags, part=part, parts=len(chunks), count=len(chunk),
                lower=[float(b.lower) for b in chunk] + [math.nan] * pad,
                upper=[float(b.upper) for b in chunk] + [math.nan] * pad,
                region=[BANDS_REGIONS.get(b.region, BANDS_REGION_UNKNOWN) for b in chunk]
                + [BANDS_REGION_UNKNOWN] * pad))
    return out


def advisory_severity(advisory: Advisory) -> int:
    """STATUSTEXT severity of an advisory change: by level; an end for lack of DAA, or of a lost threat, is a
    warning (not the INFO of a clear of conflict)."""
    if advisory.level is AdvisoryLevel.NONE and (advisory.reason in UNAVAILABLE_REASONS or advisory.lost):
        return mavlink2.MAV_SEVERITY_WARNING
    return SEVERITY[advisory.level]


def availability_text(reason: str | None, detail: str = "") -> str:
    """"DAA UNAVAILABLE <why>[ <detail>]" (reason: DaaResult.unavailable_reason), or "DAA AVAILABLE"."""
    if reason is None:
        return "DAA AVAILABLE"
    return " ".join(w for w in ("DAA UNAVAILABLE", contract.UNAVAILABLE_WORDS.get(reason, reason), detail) if w)[:STATUSTEXT_LEN]


def output_fault_text(fault) -> str:
    """"OUTPUT TLOG FAILED (ENOSPC): CLOSED" (fault: io/sinks.py SinkFault; the DAA goes on)."""
    return f"OUTPUT {fault.sink.upper()} FAILED ({fault.code.upper()}): {fault.state.upper()}"[:STATUSTEXT_LEN]


def rejected_sender_text(system: int, component: int, role: str) -> str:
    """"SPOOF? 1:200 SENDS OWNSHIP, IGNORED": a component of our vehicle claimed to send the ownship (position,
    pressure, an autopilot HEARTBEAT) or traffic, and was rejected (DaaResult.rejected_senders)."""
    return f"SPOOF? {system}:{component} SENDS {role.upper()}, IGNORED"[:STATUSTEXT_LEN]


def statustext(text: str, severity: int):
    return mavlink2.MAVLink_statustext_message(severity, text.encode("ascii", "replace")[:STATUSTEXT_LEN])


def system_status(available: bool, starting: bool = False, final: bool = False) -> int:
    """HEARTBEAT system_status from the DAA's health (docs/mavlink.md, HEARTBEAT): POWEROFF in the last one,
    STANDBY from start-up until the first ownship fix, ACTIVE while DAA is available, CRITICAL while it is not
    (no ownship, no pressure altitude, a fault). Not EMERGENCY: MAVLink defines it as the system "in mayday and
    going down", which an unavailable DAA function does not say."""
    if final:
        return mavlink2.MAV_STATE_POWEROFF
    if starting:
        return mavlink2.MAV_STATE_STANDBY
    return mavlink2.MAV_STATE_ACTIVE if available else mavlink2.MAV_STATE_CRITICAL


def heartbeat(system_status: int = mavlink2.MAV_STATE_ACTIVE):
    """Our HEARTBEAT (system_status: see system_status())."""
    return mavlink2.MAVLink_heartbeat_message(
        mavlink2.MAV_TYPE_ONBOARD_CONTROLLER, mavlink2.MAV_AUTOPILOT_INVALID, 0, 0, system_status, 3,
    )


REBROADCAST_FLAGS = (mavlink2.ADSB_FLAGS_VALID_COORDS | mavlink2.ADSB_FLAGS_VALID_HEADING
                     | mavlink2.ADSB_FLAGS_VALID_VELOCITY | mavlink2.ADSB_FLAGS_VERTICAL_VELOCITY_VALID
                     | mavlink2.ADSB_FLAGS_DAA_REBROADCAST)


def adsb_vehicle(track):
    """A fused track (base.types.TrackView, predicted to its time_s) as ADSB_VEHICLE for a ground station's traffic
    display (docs/mavlink.md, "ADSB_VEHICLE re-broadcast"): flagged ADSB_FLAGS_DAA_REBROADCAST so that no DAA
    process takes it as a report; the altitude (type as received: 0 pressure, 1 geometric) only while the track
    has one; tslc the age of its last report."""
    x = track.x
    east, north, up = float(x[3]), float(x[4]), float(x[5])
    flags = REBROADCAST_FLAGS
    altitude_mm, altitude_type = 0, mavlink2.ADSB_ALTITUDE_TYPE_PRESSURE_QNH
    if track.altitude_valid and track.datum is not None and math.isfinite(float(x[2])):
        flags |= mavlink2.ADSB_FLAGS_VALID_ALTITUDE
        altitude_mm = int(round(float(x[2]) * 1000.0))
        altitude_type = (mavlink2.ADSB_ALTITUDE_TYPE_GEOMETRIC if track.datum is AltitudeDatum.GEOMETRIC
                         else mavlink2.ADSB_ALTITUDE_TYPE_PRESSURE_QNH)
    callsign = (track.callsign or "").encode("ascii", "replace")[:8]
    flags |= mavlink2.ADSB_FLAGS_VALID_CALLSIGN if callsign else 0
    squawk = track.squawk if track.squawk is not None else 0
    flags |= mavlink2.ADSB_FLAGS_VALID_SQUAWK if track.squawk is not None else 0
    flags |= mavlink2.ADSB_FLAGS_SIMULATED if track.simulated else 0
    flags |= mavlink2.ADSB_FLAGS_SOURCE_UAT if track.key.source is AddressSource.UAT else 0
    return mavlink2.MAVLink_adsb_vehicle_message(
        ICAO_address=track.key.address, lat=int(round(track.lat_deg * 1e7)), lon=int(round(track.lon_deg * 1e7)),
        altitude_type=altitude_type, altitude=max(-2**31 + 1, min(2**31 - 2, altitude_mm)),
        heading=int(round(track_deg(east, north) * 100.0)) % 36000,
        hor_velocity=min(65534, int(round(ground_speed_mps(east, north) * 100.0))),
        ver_velocity=max(-32767, min(32766, int(round(up * 100.0)))), callsign=callsign,
        emitter_type=track.emitter_type if 0 <= track.emitter_type <= 255 else 0,
        tslc=min(254, max(0, int(track.time_s - track.last_report_s))), flags=flags, squawk=squawk)
