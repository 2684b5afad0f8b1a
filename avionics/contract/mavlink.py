"""The MAVLink outputs (docs/mavlink.md, Outputs): what each of our advisory values becomes in COLLISION,
DAA_ADVISORY, DAA_BANDS and STATUSTEXT; and our dialect's one input, DAA_SENSOR_MEASUREMENT (docs/mavlink.md,
Inputs). Enumeration values are named as the dialect names them (avionics/io/dialect/daa.xml with common.xml);
avionics/io/encode.py resolves the names and builds the messages. A test checks docs/mavlink.md's DAA_ADVISORY,
DAA_BANDS and DAA_SENSOR_MEASUREMENT tables and the generated dialect against these."""

from __future__ import annotations

from dataclasses import dataclass

from avionics.contract.bands import BAND_KINDS, BAND_REGION_UNKNOWN, BAND_REGIONS  # noqa: F401  (DAA_BANDS)
from avionics.base.types import AdvisoryLevel


@dataclass(frozen=True, slots=True)
class MessageField:
    name: str
    type: str  # the dialect's type, e.g. uint8, float, char[9]; arrays as float[10]
    unit: str
    source: str  # the advisory (zenoh payload) field or the bands value it carries, or how it is made


# -- COLLISION (common.xml) ------------------------------------------------------------------------------------------
THREAT_LEVEL = {AdvisoryLevel.NONE: "MAV_COLLISION_THREAT_LEVEL_NONE", AdvisoryLevel.TA: "MAV_COLLISION_THREAT_LEVEL_LOW",
                AdvisoryLevel.RA: "MAV_COLLISION_THREAT_LEVEL_HIGH"}
# Under a DO-365 alerter (Advisory.alert_level set) threat_level follows the DO-365 alert level, not the TA/RA it
# raises. common.xml MAV_COLLISION_THREAT_LEVEL: LOW "mildly concerned", HIGH "panicking, and may take actions to
# avoid threat". RTCA DO-365B's preventive alert asks for no manoeuvre (only not to move into the conflict): LOW;
# its corrective alert (a caution) and its warning both ask the pilot to manoeuvre to stay or regain well clear:
# HIGH. A level above 3 (a profile with more levels) counts as HIGH.
DO365_THREAT_LEVEL = {0: "MAV_COLLISION_THREAT_LEVEL_NONE", 1: "MAV_COLLISION_THREAT_LEVEL_LOW",  # PREVENTIVE
                      2: "MAV_COLLISION_THREAT_LEVEL_HIGH", 3: "MAV_COLLISION_THREAT_LEVEL_HIGH"}  # CORRECTIVE, WARNING
DO365_THREAT_LEVEL_ABOVE = "MAV_COLLISION_THREAT_LEVEL_HIGH"
# `action` is "Action that is being taken to avoid this collision" (common.xml), and ArduPilot's AP_Avoidance takes
# it as what to do: by default no action, said so (REPORT for a TA or an RA: the manoeuvre is in DAA_ADVISORY);
# mavlink.collision_action_request asks the autopilot to climb or descend on an RA. A lost threat held at its level
# keeps that level's threat_level and action (MAV_COLLISION_ACTION has no value for "lost").
ACTION = {AdvisoryLevel.NONE: "MAV_COLLISION_ACTION_NONE", AdvisoryLevel.TA: "MAV_COLLISION_ACTION_REPORT",
          AdvisoryLevel.RA: "MAV_COLLISION_ACTION_REPORT"}
ACTION_REQUEST = {**ACTION, AdvisoryLevel.RA: "MAV_COLLISION_ACTION_ASCEND_OR_DESCEND"}

# -- DAA_ADVISORY (daa.xml) ------------------------------------------------------------------------------------------
DAA_ADVISORY = (
    MessageField("id", "uint32", "—", "address"),
    MessageField("level", "uint8", "—", "level (DAA_ADVISORY_LEVEL: 0 NONE, 1 TA, 2 RA)"),
    MessageField("sense", "uint8", "—", "ra_sense (SENSE)"),
    MessageField("strength", "uint8", "—", "ra_strength (STRENGTH)"),
    MessageField("flags", "uint8", "—", "DAA_ADVISORY_FLAGS (avionics/io/encode.py daa_advisory)"),
    MessageField("sensitivity_level", "uint8", "—", "sensitivity_level"),
    MessageField("target_vertical_rate", "float", "m/s", "target_vertical_rate_mps (NaN for null)"),
    MessageField("range", "float", "m", "range_m"),
    MessageField("time_to_cpa", "float", "s", "t_cpa_s"),
    MessageField("horizontal_miss", "float", "m", "hmd_m"),
    MessageField("vertical_miss", "float", "m", "vmd_m (NaN for null)"),
    MessageField("tau", "float", "s", "range_tau_s (NaN for null)"),
    MessageField("mod_tau", "float", "s", "mod_tau_s (NaN for null)"),
    MessageField("pc", "float", "—", "pc_ra at RA, else pc_ta (NaN for null)"),
    MessageField("callsign", "char[9]", "—", "callsign (empty for null)"),
    MessageField("integrity", "uint8", "—", "integrity (INTEGRITY)"),
    MessageField("alert_level", "uint8", "—", "alert_level"),
)
SENSE = {None: "DAA_RA_SENSE_NONE", "climb": "DAA_RA_SENSE_CLIMB", "descend": "DAA_RA_SENSE_DESCEND"}
STRENGTH = {None: "DAA_RA_STRENGTH_NONE", "preventive": "DAA_RA_STRENGTH_PREVENTIVE",
            "level_off": "DAA_RA_STRENGTH_LEVEL_OFF", "corrective": "DAA_RA_STRENGTH_CORRECTIVE",
            "increase": "DAA_RA_STRENGTH_INCREASE"}
# integrity (the modes of tracking/integrity.py) -> DAA_INTEGRITY; an unknown one is 0
INTEGRITY = {"ok": "DAA_INTEGRITY_OK", "degraded:position_loss": "DAA_INTEGRITY_POSITION_LOSS",
             "degraded:step": "DAA_INTEGRITY_STEP", "degraded:ramp": "DAA_INTEGRITY_RAMP",
             "degraded:oscillation": "DAA_INTEGRITY_OSCILLATION", "degraded:inconsistent": "DAA_INTEGRITY_INCONSISTENT"}
CALLSIGN_LEN = 9  # DAA_ADVISORY callsign, char[9]

# -- DAA_BANDS (daa.xml): per kind (BAND_KINDS' mavlink) one message of up to BANDS_PER_MESSAGE intervals, more when
# it has more (part of parts); regions by BAND_REGIONS, an unknown one BAND_REGION_UNKNOWN
BANDS_PER_MESSAGE = 10
DAA_BANDS = (
    MessageField("time_boot_ms", "uint32", "ms", "the bands' time_s x 1000"),
    MessageField("kind", "uint8", "—", "the band kind (DAA_BANDS_KIND)"),
    MessageField("flags", "uint8", "—", "recovery, or no bands computed (DAA_BANDS_FLAGS)"),
    MessageField("part", "uint8", "—", "this message's index among the kind's"),
    MessageField("parts", "uint8", "—", "the kind's messages at this time"),
    MessageField("count", "uint8", "—", "intervals used in this message"),
    MessageField("lower", f"float[{BANDS_PER_MESSAGE}]", "kind's unit", "interval starts (NaN unused)"),
    MessageField("upper", f"float[{BANDS_PER_MESSAGE}]", "kind's unit", "interval ends (NaN unused)"),
    MessageField("region", f"uint8[{BANDS_PER_MESSAGE}]", "—", "interval regions (DAA_BANDS_REGION)"),
)

# -- DAA_SENSOR_MEASUREMENT (daa.xml), an input: one detection of an onboard range/bearing sensor (issue 30); the
# fields of the zenoh sensor payload's return (contract/zenoh.py SENSOR_RETURN) in MAVLink's units (radians) and
# the wire's float32, NaN where the zenoh field is null. avionics/io/sensor_input.py builds and decodes it.
DAA_SENSOR_MEASUREMENT = (
    MessageField("time_usec", "uint64", "us", "time_s x 1e6 (the sensor's clock)"),
    MessageField("age", "uint16", "ms", "age_s x 1000"),
    MessageField("sensor_id", "uint8", "—", "the sensor instance (zenoh `sensor`: its decimal text)"),
    MessageField("kind", "uint8", "—", "kind (SENSOR_KIND)"),
    MessageField("flags", "uint8", "—", "DAA_SENSOR_FLAGS_ADDRESS_VALID when address is set"),
    MessageField("address", "uint32", "—", "address (0 when null)"),
    MessageField("range", "float", "m", "range_m"),
    MessageField("azimuth", "float", "rad", "azimuth_deg in radians"),
    MessageField("elevation", "float", "rad", "elevation_deg in radians (NaN for null)"),
    MessageField("range_rate", "float", "m/s", "range_rate_mps (NaN for null)"),
    MessageField("altitude", "float", "m", "altitude_m (NaN for null)"),
    MessageField("amplitude", "float", "dB", "amplitude_db (NaN for null)"),
    MessageField("range_std", "float", "m", "range_sigma_m"),
    MessageField("azimuth_std", "float", "rad", "azimuth_sigma_deg in radians"),
    MessageField("elevation_std", "float", "rad", "elevation_sigma_deg in radians (NaN for null)"),
    MessageField("range_rate_std", "float", "m/s", "range_rate_sigma_mps (NaN for null)"),
    MessageField("altitude_std", "float", "m", "altitude_sigma_m (NaN for null)"),
)
SENSOR_KIND = {"radar": "DAA_SENSOR_KIND_RADAR", "active": "DAA_SENSOR_KIND_ACTIVE"}
SENSOR_ADDRESS_VALID = "DAA_SENSOR_FLAGS_ADDRESS_VALID"

# -- STATUSTEXT ------------------------------------------------------------------------------------------------------
STATUSTEXT_LEN = 50  # STATUSTEXT text, char[50]
SEVERITY = {AdvisoryLevel.NONE: "MAV_SEVERITY_INFO", AdvisoryLevel.TA: "MAV_SEVERITY_WARNING",
            AdvisoryLevel.RA: "MAV_SEVERITY_CRITICAL"}
# Why DAA is unavailable (DaaResult.unavailable_reason, zenoh status `unavailable_reason`) -> the words of
# "DAA UNAVAILABLE <why>"
UNAVAILABLE_WORDS = {"no_ownship": "no ownship position", "no_pressure_altitude": "no pressure altitude",
                     "no_traffic_source": "traffic down", "fault": "fault", "shutdown": "shutdown",
                     "ownship_inconsistent": "ownship jumps", "spoof_suspected": "spoof"}
