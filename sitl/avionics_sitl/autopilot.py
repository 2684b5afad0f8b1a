"""The simulated autopilot with an ADS-B receiver: a scenario becomes a time-ordered MAVLink schedule.

Ownship GLOBAL_POSITION_INT and SCALED_PRESSURE at ownship_hz (system 1, autopilot component), one
ADSB_VEHICLE per intruder at adsb_hz (staggered phases, receiver component), each report impaired
(noise, quantisation, latency, dropouts) by avionics_sitl.impairments. A standard day: pressure altitude equals
geometric altitude, so both datums describe the same aircraft height.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import avionics.io  # noqa: F401  (MAVLink 2)
from pymavlink.dialects.v20 import common as mavlink2

from avionics.base.atmosphere import MAX_PRESSURE_ALTITUDE_M, MIN_PRESSURE_ALTITUDE_M, pressure_hpa_at
from avionics.base.types import AddressSource, AltitudeDatum
from avionics.io import decode as flags
from avionics_sitl.impairments import AdsbImpairments
from avionics_sitl.scenario import Scenario
from avionics_sitl.trajectory import KinematicState

ISA_LAPSE_K_PER_M = 0.0065


@dataclass(frozen=True)
class AutopilotConfig:
    ownship_hz: float = 5.0
    adsb_hz: float = 1.0
    system_id: int = 1
    component_id: int = mavlink2.MAV_COMP_ID_AUTOPILOT1
    adsb_component_id: int = mavlink2.MAV_COMP_ID_ADSB


@dataclass(frozen=True, slots=True)
class Event:
    deliver_s: float  # when the message reaches the DAA process
    msg: object  # a pymavlink message
    truth_s: float  # time of applicability of what it says


def _e7(deg: float) -> int:
    return int(round(deg * 1e7))


def _clamp_int16(v: float) -> int:
    return max(-32767, min(32766, int(round(v))))


# Every state the encoders see is within the aircraft limits a scenario is checked against (sitl/avionics_sitl/aircraft.py;
# a trajectory table's rows too). Between samples a cubic can overshoot a little: each field is clamped to what its
# MAVLink type carries (common.xml: alt int32 mm, hor_velocity uint16 cm/s) and the pressure to the atmosphere's
# span, so an overshoot is a saturated value, never a struct.error in the middle of a run.
def _clamp_int32(v: float) -> int:
    return max(-(2**31) + 1, min(2**31 - 1, int(round(v))))


def _clamp_uint16(v: float) -> int:
    return max(0, min(65535, int(round(v))))


def _pressure_altitude(alt_m: float) -> float:
    return max(MIN_PRESSURE_ALTITUDE_M, min(MAX_PRESSURE_ALTITUDE_M, alt_m))


def ownship_messages(state: KinematicState, ground_elevation_m: float, boot_ms: int):
    gpi = mavlink2.MAVLink_global_position_int_message(
        boot_ms, _e7(state.lat_deg), _e7(state.lon_deg), _clamp_int32(state.alt_msl_m * 1000),
        _clamp_int32((state.alt_msl_m - ground_elevation_m) * 1000),
        _clamp_int16(state.vel_north_mps * 100), _clamp_int16(state.vel_east_mps * 100),
        _clamp_int16(-state.vel_up_mps * 100), int(round(state.track_deg * 100)) % 36000)
    temperature_c = 15.0 - ISA_LAPSE_K_PER_M * state.alt_msl_m
    pressure = mavlink2.MAVLink_scaled_pressure_message(boot_ms, pressure_hpa_at(_pressure_altitude(state.alt_msl_m)),
                                                        0.0, _clamp_int16(temperature_c * 100))
    return gpi, pressure


def adsb_vehicle(state: KinematicState, icao: int, datum: AltitudeDatum, source: AddressSource, callsign: str,
                 emitter_type: int, tslc: int = 0):
    f = (flags.VALID_COORDS | flags.VALID_ALTITUDE | flags.VALID_HEADING | flags.VALID_VELOCITY
         | flags.VERTICAL_VELOCITY_VALID | flags.SIMULATED)
    if callsign:
        f |= flags.VALID_CALLSIGN
    if datum is AltitudeDatum.PRESSURE:
        f |= flags.BARO_VALID
    if source is AddressSource.UAT:
        f |= flags.SOURCE_UAT
    return mavlink2.MAVLink_adsb_vehicle_message(
        icao, _e7(state.lat_deg), _e7(state.lon_deg), 0 if datum is AltitudeDatum.PRESSURE else 1,
        _clamp_int32(state.alt_msl_m * 1000), int(round(state.track_deg * 100)) % 36000,
        _clamp_uint16(state.ground_speed_mps * 100), _clamp_int16(state.vel_up_mps * 100),
        callsign.encode("ascii")[:9], emitter_type, tslc, f, 0)


def schedule(scenario: Scenario, impairments: AdsbImpairments, seed: int = 0,
             config: AutopilotConfig = AutopilotConfig(), duration_s: float | None = None,
             ownship: bool = True) -> list[Event]:
    """Every message of the encounter in delivery order (ownship=False: the intruders' only, for a closed
    loop that generates ownship messages as it flies)."""
    duration = scenario.duration_s if duration_s is None else duration_s
    own_traj, intruder_trajs = scenario.trajectories()
    events: list[Event] = []
    for k in range(int(math.floor(duration * config.ownship_hz)) + 1 if ownship else 0):
        t = k / config.ownship_hz
        for msg in ownship_messages(own_traj.state_at(t), scenario.ground_elevation_m, int(t * 1000)):
            events.append(Event(t, msg, t))
    period = 1.0 / config.adsb_hz
    for i, (spec, traj) in enumerate(zip(scenario.intruders, intruder_trajs)):
        rng_impair = impairments.with_seed((seed, spec.icao_address))
        phase = (0.137 + 0.379 * i) % period  # staggered, deterministic, never on the ownship grid
        heard = getattr(traj, "heard_at", None)  # a recorded track (avionics_sitl.tables): silent in its gaps
        for k in range(int(math.floor((duration - phase) * config.adsb_hz)) + 1):
            t = phase + k * period
            if heard is not None and not heard(t):
                continue
            report = rng_impair.impair(traj.state_at(t))
            if report is None:
                continue
            msg = adsb_vehicle(report.state, spec.icao_address, spec.altitude_datum, spec.address_source,
                               spec.callsign, spec.emitter_type, tslc=int(report.latency_s))
            events.append(Event(t + report.latency_s, msg, t))
    events.sort(key=lambda e: e.deliver_s)
    return events


class Packer:
    """MAVLink 2 framing with the sender ids of a real autopilot and its ADS-B receiver (own sequences)."""

    def __init__(self, config: AutopilotConfig = AutopilotConfig()):
        self._autopilot = mavlink2.MAVLink(None, srcSystem=config.system_id, srcComponent=config.component_id)
        self._receiver = mavlink2.MAVLink(None, srcSystem=config.system_id, srcComponent=config.adsb_component_id)

    def pack(self, msg) -> bytes:
        return bytes(msg.pack(self._receiver if msg.get_type() == "ADSB_VEHICLE" else self._autopilot))
