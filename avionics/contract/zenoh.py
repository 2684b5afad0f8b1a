"""The zenoh outputs: key expressions and each payload's fields (docs/zenoh.md holds the full meanings; a test
checks its field tables against these). Payloads are JSON objects of SI numbers with enumerations as strings, in
the order of these tuples; the traffic topic carries the track fields as the columns of one Arrow table."""

from __future__ import annotations

from avionics.contract.bands import BAND_KINDS
from avionics.contract.fields import (
    ALERT_LEVEL, ALTITUDE, ANGLE, DISTANCE, DURATION, ID_LEN, LATITUDE, LONGITUDE, PROBABILITY, RATE, SCHEMA,
    SENSITIVITY_LEVEL, SIGNED_DISTANCE, SPEED, TEXT_LEN, TIME, Field, flag, ident, integer, number, text,
)

SCHEMA_VERSION = 2  # every payload's `schema`; 2: RA sense, strength, target rate, conflict probabilities
TRAFFIC_LAYOUT = 2  # the traffic batch's own table layout version (the fields inside follow SCHEMA_VERSION); 2: the
#                    rows' own time_s
ARROW_STREAM = "application/vnd.apache.arrow.stream"  # the traffic sample's zenoh encoding
SNAPSHOT_SCHEMA = 1  # the snapshot reply's own version

# Key expressions under <prefix>/<vehicle>/ (zenoh.key_prefix, vehicle.id; intruder "<source>-<ICAO hex>").
KEYS = {
    "advisories/<intruder>": "advisory: on every change and each mavlink.collision_refresh_s while active",
    "traffic": "every track in one Arrow IPC sample, at zenoh.tracks_hz",
    "tracks/<intruder>": "track: a new track's at once, then each every 10 s",
    "ownship": "ownship, at zenoh.status_hz",
    "status": "status, at zenoh.status_hz",
    "guidance": "the guidance's decision, on each change and with the status",
    "bands": "bands of a DO-365 alerter, once a second",
    "snapshot": "queryable: the current picture and the recent advisory changes",
    "alive": "liveliness token, held while the process runs",
    "sensor/<id>": "an input: one scan of the ownship's range/bearing sensor <id> (radar, active surveillance)",
}

COMMON = (
    integer("schema", SCHEMA, "the payload's version: SCHEMA_VERSION"),
    ident("vehicle", "vehicle.id"),
    number("time_s", "s", TIME, "time of the assessment or the publication"),
)
_IDENTITY = (
    ident("intruder", "`<source>-<ICAO hex>`, e.g. 1090es-A1B2C3; a sensor's track: sensor-<track id>"),
    integer("address", (0, 0xFFFFFF), "24-bit ICAO address; a sensor's track: its track id"),
    ident("address_source", "`1090es`, `uat` or `sensor` (a range/bearing sensor's track: no address)"),
    ident("callsign", "the last valid callsign known; null if none"),
)
# The assessment of one intruder, as a track carries it (base/types.py ASSESSMENT_FIELDS, in that order)
ASSESSMENT = (
    number("range_m", "m", DISTANCE, "current horizontal range"),
    number("t_cpa_s", "s", DURATION, "time to horizontal CPA (straight-line relative motion)"),
    number("hmd_m", "m", DISTANCE, "horizontal miss distance at t_cpa_s"),
    number("vmd_m", "m", SIGNED_DISTANCE, "vertical separation at t_cpa_s, intruder minus ownship"),
    number("range_tau_s", "s", DURATION, "range / closure rate; null when infinite"),
    number("mod_tau_s", "s", DURATION, "TCAS modified tau with the level's DMOD; null when infinite"),
    number("pc_ta", "—", PROBABILITY, "conflict probability of the TA volume"),
    number("pc_ra", "—", PROBABILITY, "conflict probability of the RA volume"),
    number("pc_now", "—", PROBABILITY, "conflict stage: instantaneous probability"),
    number("pc_max", "—", PROBABILITY, "conflict stage: maximum predicted over the lookahead"),
    number("t_pc_max_s", "s", DURATION, "time of pc_max from now"),
    number("pc_within", "—", PROBABILITY, "conflict stage: probability of a conflict within the lookahead"),
    number("pc_within_age_s", "s", DURATION, "how old pc_within is"),
)
_A = {f.name: f for f in ASSESSMENT}

ADVISORY = (
    *COMMON[:2], *_IDENTITY,
    ident("level", "`NONE`, `TA` or `RA`"),
    integer("alert_level", ALERT_LEVEL, "the alerter's level number (0 none, higher more severe)"),
    ident("alert_name", "that level's name in the alerter"),
    text("reason", "why the level is what it is"),
    COMMON[2],
    integer("sensitivity_level", SENSITIVITY_LEVEL, "sensitivity level of the profile used"),
    _A["range_m"],
    number("closure_rate_mps", "m/s", (-1e5, 1e5), "-d(range)/dt, positive when closing"),
    _A["t_cpa_s"], _A["hmd_m"], _A["vmd_m"], _A["range_tau_s"], _A["mod_tau_s"],
    number("vertical_tau_s", "s", DURATION, "time to co-altitude; null when not converging"),
    ident("altitude_datum", "`pressure` or `geometric`; null when the intruder's altitude is unknown"),
    flag("datum_mismatch", "a pressure-altitude intruder compared with GNSS ownship altitude"),
    _A["pc_ta"], _A["pc_ra"], _A["pc_now"], _A["pc_max"], _A["t_pc_max_s"], _A["pc_within"], _A["pc_within_age_s"],
    ident("ra_sense", "RA only: `climb` or `descend`"),
    ident("ra_strength", "RA only: `preventive`, `level_off`, `corrective`, `increase`"),
    text("ra_words", "RA only: the TCAS phrase"),
    number("target_vertical_rate_mps", "m/s", RATE, "RA target vertical rate, up"),
    flag("ra_reversed", "the RA sense was reversed"),
    flag("ra_crossing", "the RA takes ownship through the intruder's altitude"),
    number("ra_separation_m", "m", SIGNED_DISTANCE, "projected vertical separation at CPA with the RA flown"),
    flag("ra_composite", "a composite RA against threats above and below"),
    ident("integrity", "ADS-B integrity: `ok` or `degraded:<mode>`"),
    ident("surveillance", "`cooperative` (ADS-B, alone or fused with a sensor's track) or `non_cooperative` (seen "
                          "only by the ownship's sensors; judged by the profile's non-cooperative alerter if any)"),
)
# What makes an advisory sample a change (and not a refresh): what a pilot would hear change.
ADVISORY_STATE_FIELDS = ("level", "ra_sense", "ra_strength", "ra_words", "ra_reversed", "ra_composite")

VELOCITY_ENU = Field("velocity_enu_mps", "float[3]", "m/s", "east, north, up", SPEED[1])
GROUND_SPEED = number("ground_speed_mps", "m/s", SPEED, "horizontal speed")
TRACK_ANGLE = number("track_deg", "deg", ANGLE, "course over ground, 0-360 clockwise from true north")
VERTICAL_RATE = number("vertical_rate_mps", "m/s", RATE, "up positive")
# The IMM trackers' mode outputs (absent with the CV filter; docs/tracking.md, Outputs)
IMM = (
    Field("mode_probabilities", "{string: float}", "—", "horizontal mode probabilities", PROBABILITY, 16),
    ident("most_likely_mode", "the most likely horizontal mode"),
    number("turn_rate_dps", "deg/s", RATE, "turn rate, positive right"),
    Field("vertical_mode_probabilities", "{string: float}", "—", "vertical mode probabilities", PROBABILITY, 16),
    ident("vertical_mode", "the most likely vertical mode"),
    Field("vb_noise", "{string: float}", "—", "VB noise estimate (vb-* filters)", (0.0, 1e8), 16),
)
TRACK = (
    *COMMON[:2], *_IDENTITY,
    integer("squawk", (0, 9_999), "last valid Mode A code, as sent"),
    integer("emitter_type", (0, 255), "ADSB_VEHICLE emitter_type"),
    flag("simulated", "the last report had the SIMULATED flag"),
    flag("spoof_suspected", "a second MAVLink sender reported this address elsewhere"),
    ident("model", "the tracking filter: imm, rmimm, vb-imm, vb-rmimm or cv-kalman"),
    COMMON[2],
    number("last_report_s", "s", TIME, "time of applicability of the last merged report"),
    number("age_s", "s", DURATION, "time_s - last_report_s"),
    integer("updates", (0, 10**15), "reports merged into this track"),
    number("lat_deg", "deg", LATITUDE, "predicted latitude, WGS-84"),
    number("lon_deg", "deg", LONGITUDE, "predicted longitude, WGS-84"),
    number("altitude_m", "m", ALTITUDE, "predicted altitude in altitude_datum"),
    ident("altitude_datum", "`pressure` or `geometric`; null with altitude_m"),
    VELOCITY_ENU, GROUND_SPEED, TRACK_ANGLE, VERTICAL_RATE,
    number("position_sigma_m", "m", DISTANCE, "1 sigma radial horizontal position uncertainty"),
    number("velocity_sigma_mps", "m/s", SPEED, "1 sigma horizontal velocity uncertainty"),
    ident("advisory", "current level: NONE, TA, RA"),
    ident("integrity", "`ok` or `degraded:<mode>`"),
    number("integrity_fault_m", "m", DISTANCE, "a degraded track's position widening"),
    *ASSESSMENT,
    *IMM,
)
TRACK_MODEL_CV = "cv-kalman"  # `model` of a track without IMM mode outputs

# The filtered ownship state (status `ownship`, and the ownship topic's fields)
OWNSHIP_STATE = (
    number("lat_deg", "deg", LATITUDE, "filtered position, WGS-84"),
    number("lon_deg", "deg", LONGITUDE, "filtered position, WGS-84"),
    number("alt_msl_m", "m", ALTITUDE, "filtered GNSS altitude above mean sea level"),
    number("pressure_altitude_m", "m", ALTITUDE, "ownship pressure altitude (ISA)"),
    number("height_above_home_m", "m", (-100_000.0, 100_000.0), "height above home"),
    VELOCITY_ENU,
)
OWNSHIP = (*COMMON, flag("valid", "ownship known; when false no other field follows"), *OWNSHIP_STATE,
           GROUND_SPEED, TRACK_ANGLE, VERTICAL_RATE)

_OBJECT = "object"
STATUS = (
    COMMON[0], COMMON[1], ident("version", "the avionics package version"), COMMON[2],
    Field("ownship", _OBJECT, "—", "the filtered ownship; null when unknown", fields=OWNSHIP_STATE),
    flag("ownship_valid", "ownship known: advisories are possible"),
    flag("pressure_altitude_available", "ownship pressure altitude known"),
    ident("pressure_fault", "the barometer cross-check withholds the pressure: stuck, jump, implausible"),
    Field("datum_mismatch_intruders", "[string]", "—", "intruders whose latest advisory was formed across datums",
          ID_LEN, 10_000),
    integer("sensitivity_level", SENSITIVITY_LEVEL, "sensitivity level of the latest assessment"),
    integer("tracks", (0, 10**9), "number of tracks"),
    Field("advisories", "{string: int}", "—", "intruders now at each level, {TA: n, RA: n}", (0, 10**9), 16),
    Field("warnings", "[string]", "—", "empty when healthy", TEXT_LEN, 64),
    flag("daa_available", "DAA can protect against every tracked intruder"),
    ident("unavailable_reason", "why not (DaaResult.unavailable_reason); null when available"),
    Field("failed_intruders", "{string: string}", "—", "intruder -> the stage it failed in", ID_LEN),
    Field("spoof_suspected", "[string]", "—", "intruders a second trusted sender reports elsewhere", ID_LEN),
    Field("rejected_senders", "[string]", "—", "`SYS:COMP ownship|traffic` rejected within the last 10 s", ID_LEN),
    Field("traffic_feeds", "[object]", "—", "the receiver feeds of `avionics run --traffic`", fields=(
        text("path", "the SPEC"), flag("connected", "the source is up now"),
        text("error", "why it is not connected"), integer("reports", (0, 10**15), "reports delivered"),
        number("last_report_s", "s", TIME, "loop time of its last report"))),
    Field("wiring", "[object]", "—", "the active wiring diagnostics", fields=(
        ident("key", "the condition"), text("text", "the STATUSTEXT of its onset"), text("message", "the stderr line"))),
    Field("output_faults", "object", "—", "sink -> {state, error, errors} of each failed output sink"),
    Field("counters", "{string: float}", "—", "every input/rejection counter, name -> count", (-1e18, 1e18), 4_096,
          key_len=128),
)

# one interval of a kind's bands, in the kind's unit and within its limit (contract/bands.py)
BAND_INTERVAL = (Field("lower", "float", "kind's", "interval start"), Field("upper", "float", "kind's", "interval end"),
                 ident("region", "one of BAND_REGIONS, or a newer one"))
BANDS = (
    *COMMON, ident("alerter", "advisory.profile"),
    Field("ownship", _OBJECT, "—", "the state the bands are for", fields=(
        TRACK_ANGLE, GROUND_SPEED, VERTICAL_RATE, number("altitude_m", "m", ALTITUDE, "geometric, GNSS MSL"))),
    *(Field(k.name, "[object]", k.unit, f"the {k.label} bands", k.limit, 256, BAND_INTERVAL) for k in BAND_KINDS),
    Field("recovery", "{string: bool}", "—", "per kind, true when its bands are recovery bands", None, 16),
    Field("intruders", "[object]", "—", "every intruder the bands took in", None, 2_000, fields=(
        _IDENTITY[0], integer("alert_level", ALERT_LEVEL, "its alert level"), ident("alert_name", "its name"))),
)

GUIDANCE = (
    COMMON[0], COMMON[1], COMMON[2],
    ident("state", "idle, advising, commanding, holding, returning, overridden, failed"),
    ident("manoeuvre", "none, climb, descend, level, turn_right, turn_left, return"),
    number("target_vertical_rate_mps", "m/s", RATE, "up; null when none"),
    text("reason", "why"), ident("autopilot_mode", "the autopilot's mode name"),
    number("since_s", "s", TIME, "when the state began"),
    number("target_track_deg", "deg", ANGLE, "a horizontal manoeuvre's resolution track"),
)

# The traffic batch: its header (the Arrow schema's metadata, all strings) and its columns (the track fields but
# schema and vehicle: each row has its own time_s). Arrow types by field type; `updates` is int64. f64[k]:
# fixed_size_list<float64> of the map's keys.
TRAFFIC_HEADER = (
    COMMON[0], integer("layout", SCHEMA, "the table layout version: TRAFFIC_LAYOUT"), COMMON[1], COMMON[2],
    Field("keys", "{string: [string]}", "—", "for each map-valued column, its keys in order", ID_LEN, 16),
)
ARROW_TYPES = {"string": "str", "int": "i32", "bool": "bool", "float": "f64", "float[3]": "f64[3]",
               "{string: float}": "f64[k]"}
TRAFFIC_COLUMNS = {f.name: "i64" if f.name == "updates" else ARROW_TYPES[f.type]
                   for f in TRACK if f.name not in ("schema", "vehicle")}
KEYED_COLUMNS = tuple(f.name for f in IMM if f.type == "{string: float}")  # maps sent as value lists

# The ownship's range/bearing sensors' measurements (issue 30), an input the process subscribes to: one sample per
# scan of one sensor, after ROS 2 radar_msgs RadarScan (header.stamp: time_s; RadarReturn[]: returns), in the
# contract's units (degrees, not RadarReturn's radians) and the aviation sign (azimuth positive right, clockwise
# from the nose, where RadarReturn's REP-103 azimuth is positive anticlockwise). avionics/io/sensor_input.py
# builds and decodes it into tracking/measurement.py PolarMeasurement.
SENSOR_ANGLE = (-180.0, 180.0)  # deg, about the nose
SENSOR_SIGMA_ANGLE = (0.0, 180.0)  # deg
MAX_SENSOR_RETURNS = 256  # detections in one scan (a receiver's bound on a sample)
MAX_SENSOR_AGE_S = 60.0  # a measurement older than this when published is not traffic any more
SENSOR_RETURN = (
    number("range_m", "m", DISTANCE, "slant range from the sensor (RadarReturn range), > 0"),
    number("azimuth_deg", "deg", SENSOR_ANGLE, "in the horizontal plane, clockwise from the ownship's nose"),
    number("elevation_deg", "deg", (-90.0, 90.0), "above the horizontal (RadarReturn elevation); radar, else null"),
    number("range_rate_mps", "m/s", (-SPEED[1], SPEED[1]), "d(range)/dt, positive opening (RadarReturn "
           "doppler_velocity); null when not measured"),
    number("amplitude_db", "dB", (-1_000.0, 1_000.0), "return strength (RadarReturn amplitude); null if none"),
    number("altitude_m", "m", ALTITUDE, "the reply's pressure altitude (Mode C/S); active surveillance, else null"),
    integer("address", (0, 0xFFFFFF), "a Mode S reply's 24-bit address; null for a radar return or Mode C"),
    number("range_sigma_m", "m", DISTANCE, "1 sigma of range_m (random and bias in quadrature)"),
    number("azimuth_sigma_deg", "deg", SENSOR_SIGMA_ANGLE, "1 sigma of azimuth_deg"),
    number("elevation_sigma_deg", "deg", SENSOR_SIGMA_ANGLE, "1 sigma of elevation_deg; with it"),
    number("range_rate_sigma_mps", "m/s", SPEED, "1 sigma of range_rate_mps; with it"),
    number("altitude_sigma_m", "m", DISTANCE, "1 sigma of altitude_m; with it"),
)
SENSOR = (
    *COMMON[:2],
    number("time_s", "s", TIME, "time of measurement on the sensor's clock (RadarScan header.stamp)"),
    ident("sensor", "the sensor's id, the key's <id>"),
    ident("kind", "`radar` or `active` (active surveillance)"),
    number("age_s", "s", (0.0, MAX_SENSOR_AGE_S), "the measurement's age when published: the receiver dates it "
           "receipt - age_s"),
    number("boresight_deg", "deg", SENSOR_ANGLE, "mount: boresight azimuth, clockwise from the nose; null 0"),
    number("half_azimuth_deg", "deg", (0.0, 180.0), "mount: field of regard's half-width about it; null 180"),
    number("elevation_min_deg", "deg", (-90.0, 90.0), "mount: field of regard's lower edge; null -90"),
    number("elevation_max_deg", "deg", (-90.0, 90.0), "mount: field of regard's upper edge; null 90"),
    number("min_range_m", "m", DISTANCE, "mount: no detection nearer; null 0"),
    number("max_range_m", "m", DISTANCE, "mount: no detection farther; null unlimited"),
    number("rate_hz", "Hz", (0.0, 1_000.0), "mount: scan rate; null 1"),
    Field("returns", "[object]", "—", "this scan's detections (RadarScan returns); empty: nothing seen", None,
          MAX_SENSOR_RETURNS, SENSOR_RETURN),
)

PAYLOADS = {"advisories": ADVISORY, "tracks": TRACK, "ownship": OWNSHIP, "status": STATUS, "bands": BANDS,
            "guidance": GUIDANCE, "traffic": TRAFFIC_HEADER, "sensor": SENSOR}
