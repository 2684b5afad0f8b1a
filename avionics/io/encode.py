"""Core advisories -> MAVLink messages: COLLISION per threat, STATUSTEXT for people, our HEARTBEAT."""

from __future__ import annotations

import math

import avionics.io  # noqa: F401
from pymavlink.dialects.v20 import common as mavlink2

from avionics.core.types import Advisory, AdvisoryLevel
from avionics.core.units import FT

THREAT_LEVEL = {
    AdvisoryLevel.NONE: mavlink2.MAV_COLLISION_THREAT_LEVEL_NONE,
    AdvisoryLevel.TA: mavlink2.MAV_COLLISION_THREAT_LEVEL_LOW,
    AdvisoryLevel.RA: mavlink2.MAV_COLLISION_THREAT_LEVEL_HIGH,
}
ACTION = {
    AdvisoryLevel.NONE: mavlink2.MAV_COLLISION_ACTION_NONE,
    AdvisoryLevel.TA: mavlink2.MAV_COLLISION_ACTION_REPORT,
    AdvisoryLevel.RA: mavlink2.MAV_COLLISION_ACTION_ASCEND_OR_DESCEND,
}
SEVERITY = {
    AdvisoryLevel.NONE: mavlink2.MAV_SEVERITY_INFO,
    AdvisoryLevel.TA: mavlink2.MAV_SEVERITY_WARNING,
    AdvisoryLevel.RA: mavlink2.MAV_SEVERITY_CRITICAL,
}
STATUSTEXT_LEN = 50


def collision(advisory: Advisory):
    """COLLISION for one intruder. altitude_minimum_delta is NaN when the intruder's altitude is unknown."""
    return mavlink2.MAVLink_collision_message(
        src=mavlink2.MAV_COLLISION_SRC_ADSB,
        id=advisory.intruder.address,
        action=ACTION[advisory.level],
        threat_level=THREAT_LEVEL[advisory.level],
        time_to_minimum_delta=advisory.t_cpa_s,
        altitude_minimum_delta=advisory.vmd_m if advisory.vmd_m is not None else math.nan,
        horizontal_minimum_delta=advisory.hmd_m,
    )


def advisory_text(advisory: Advisory) -> str:
    """One line for a pilot's ground station, at most 50 characters."""
    who = str(advisory.intruder)
    if advisory.level is AdvisoryLevel.NONE:
        return f"DAA clear {who} ({advisory.reason})"[:STATUSTEXT_LEN]
    vertical = "alt?" if advisory.vmd_m is None else f"{advisory.vmd_m / FT:+.0f}ft"
    tau = "--" if math.isinf(advisory.mod_tau_s) else f"{advisory.mod_tau_s:.0f}s"
    return f"DAA {advisory.level.name} {who} {tau} {advisory.hmd_m:.0f}m {vertical}"[:STATUSTEXT_LEN]


def statustext(text: str, severity: int):
    return mavlink2.MAVLink_statustext_message(severity, text.encode("ascii", "replace")[:STATUSTEXT_LEN])


def heartbeat():
    return mavlink2.MAVLink_heartbeat_message(
        mavlink2.MAV_TYPE_ONBOARD_CONTROLLER, mavlink2.MAV_AUTOPILOT_INVALID, 0, 0,
        mavlink2.MAV_STATE_ACTIVE, 3,
    )
