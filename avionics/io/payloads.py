"""JSON payloads of the zenoh contract (avionics/contract/zenoh.py, docs/zenoh.md). Plain dicts of SI numbers,
enums as strings, keys in the contract's order."""

from __future__ import annotations

import math

from avionics import __version__
from avionics.contract.bands import BAND_KIND_NAMES
from avionics.contract.zenoh import ADVISORY, SCHEMA_VERSION, TRACK_MODEL_CV
from avionics.base.types import ASSESSMENT_FIELDS, AddressSource, Advisory, TrackView
from avionics.base.units import ground_speed_mps, track_deg

# The advisory fields that are not an Advisory attribute of the same name, each from (vehicle, advisory, callsign)
_ADVISORY_MADE = {
    "schema": lambda vehicle, a, callsign: SCHEMA_VERSION,
    "vehicle": lambda vehicle, a, callsign: vehicle,
    "intruder": lambda vehicle, a, callsign: str(a.intruder),
    "address": lambda vehicle, a, callsign: a.intruder.address,
    "address_source": lambda vehicle, a, callsign: a.intruder.source.value,
    "callsign": lambda vehicle, a, callsign: callsign,
    "level": lambda vehicle, a, callsign: a.level.name,
    # the alerter's level number and name (advisory/alerting.py; tcas2: 0 NONE, 1 TA, 2 RA; a DO-365 alerter:
    # 0 NONE, 1 PREVENTIVE, 2 CORRECTIVE, 3 WARNING)
    "alert_level": lambda vehicle, a, callsign: a.alert()[0],
    "alert_name": lambda vehicle, a, callsign: a.alert()[1],
    "altitude_datum": lambda vehicle, a, callsign: a.altitude_datum.value if a.altitude_datum else None,
    # which alerter judged it (advisory/alerting.py Alerter.non_cooperative): by how the intruder is seen
    "surveillance": lambda vehicle, a, callsign:
        "non_cooperative" if a.intruder.source is AddressSource.SENSOR else "cooperative",
}
_ADVISORY_FIELDS = tuple((f.name, _ADVISORY_MADE.get(f.name)) for f in ADVISORY)


def advisory_payload(vehicle: str, advisory: Advisory, callsign: str | None = None) -> dict:
    """The contract's advisory fields, in order: the Advisory's attribute of the same name, or made above."""
    return {name: made(vehicle, advisory, callsign) if made else getattr(advisory, name)
            for name, made in _ADVISORY_FIELDS}


def track_payload(vehicle: str, track: TrackView) -> dict:
    """One track as the facade publishes it (base/types.py TrackView). Its `modes` (IMM filters; None for the CV
    filter): filter name, mode probabilities Markov-propagated to now, most likely mode, turn rate (deg/s,
    positive right), vertical mode, VB noise estimate (docs/tracking.md). spoof_suspected: a second MAVLink
    sender also reported this intruder (its reports are dropped; docs/mavlink.md, "Trusted sources")."""
    x, p, altitude_valid = track.x, track.p, track.altitude_valid
    ve, vn, vu = (float(v) for v in x[3:6])
    return {
        "schema": SCHEMA_VERSION,
        "vehicle": vehicle,
        "intruder": str(track.key),
        "address": track.key.address,
        "address_source": track.key.source.value,
        "callsign": track.callsign,
        "squawk": track.squawk,
        "emitter_type": track.emitter_type,
        "simulated": track.simulated,
        "spoof_suspected": track.spoof_suspected,
        "model": TRACK_MODEL_CV,  # an IMM filter's modes overwrite this with the filter's name
        "time_s": track.time_s,
        "last_report_s": track.last_report_s,
        "age_s": track.time_s - track.last_report_s,
        "updates": track.n_updates,
        "lat_deg": track.lat_deg,
        "lon_deg": track.lon_deg,
        "altitude_m": float(x[2]) if altitude_valid else None,
        "altitude_datum": track.datum.value if altitude_valid and track.datum else None,
        "velocity_enu_mps": [ve, vn, vu],
        "ground_speed_mps": ground_speed_mps(ve, vn),
        "track_deg": track_deg(ve, vn),
        "vertical_rate_mps": vu if altitude_valid else None,
        "position_sigma_m": math.sqrt(max(p[0, 0] + p[1, 1], 0.0)),
        "velocity_sigma_mps": math.sqrt(max(p[3, 3] + p[4, 4], 0.0)),
        "advisory": track.advisory_level.name,
        "integrity": track.integrity,  # "ok" | "degraded:<mode>" (docs/tracking.md, "Integrity monitor")
        "integrity_fault_m": track.integrity_fault_m,
        **dict(zip(ASSESSMENT_FIELDS, track.assessment or (None,) * len(ASSESSMENT_FIELDS))),
        **(track.modes or {}),
    }


def status_payload(vehicle: str, now_s: float, status: dict, counters: dict) -> dict:
    return {"schema": SCHEMA_VERSION, "vehicle": vehicle, "version": __version__, "time_s": now_s, **status,
            "counters": dict(sorted(counters.items()))}


def ownship_payload(vehicle: str, now_s: float, ownship: dict | None) -> dict:
    """Topic ownship: the filtered ownship state (status's `ownship`), with course and speed for displays."""
    out = {"schema": SCHEMA_VERSION, "vehicle": vehicle, "time_s": now_s, "valid": ownship is not None}
    if ownship is None:
        return out
    ve, vn, vu = ownship["velocity_enu_mps"]
    return {**out, **ownship, "ground_speed_mps": ground_speed_mps(ve, vn), "track_deg": track_deg(ve, vn),
            "vertical_rate_mps": vu}


def bands_payload(vehicle: str, alerter: str, bands) -> dict:
    """Topic bands: a DO-365 alerter's guidance bands (advisory/bands.py Bands, its intruders as (intruder, alert
    level, level name); docs/zenoh.md, Bands). alerter: the profile's name. altitude_m is geometric (GNSS, MSL) like the ownship
    topic's."""
    ve, vn, vu = bands.ownship_vel
    return {
        "schema": SCHEMA_VERSION, "vehicle": vehicle, "time_s": bands.time_s, "alerter": alerter,
        "ownship": {"track_deg": track_deg(ve, vn), "ground_speed_mps": ground_speed_mps(ve, vn),
                    "vertical_rate_mps": vu, "altitude_m": bands.ownship_pos[2]},
        **{kind: [{"lower": b.lower, "upper": b.upper, "region": b.region} for b in getattr(bands, kind)]
           for kind in BAND_KIND_NAMES},
        "recovery": {kind: bool(bands.recovery.get(kind, False)) for kind in BAND_KIND_NAMES},
        "intruders": [{"intruder": key, "alert_level": level, "alert_name": name}
                      for key, level, name in bands.intruders],
    }


def guidance_payload(vehicle: str, decision) -> dict:
    """Topic guidance (guidance.mode advise or execute): the guidance's decision (avionics/guidance/stage.py
    GuidanceDecision), on each change of state and with the status."""
    return {"schema": SCHEMA_VERSION, "vehicle": vehicle, **decision.as_dict()}
