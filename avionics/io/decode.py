"""MAVLink messages -> validated core inputs, in SI units. Every rejected message or field is counted.

ADSB_VEHICLE: a field is used only when its ADSB_FLAGS bit says valid *and* it holds no sentinel
(INT32_MAX, UINT16_MAX, INT16_MAX) and a physical value. A field flagged valid that fails those checks is
counted as rejected ("adsb.<field>_invalid"); the report itself is rejected only without a usable position
or identity. GLOBAL_POSITION_INT and SCALED_PRESSURE are taken only from our vehicle's autopilot component, and a
fix must pass the jump check (io/senders.py, io/ownship_check.py); HEARTBEAT pins that component and announces
ADS-B receivers.

Trusted sources: ADSB_VEHICLE is used only from mavlink.traffic_sources (default: discovered, io/senders.py);
others count adsb.untrusted_source. An intruder (address and address source) belongs to the first trusted sender
(system, component) whose report of it was usable, for as long as its track can live: the same intruder from a
second sender is never merged into that track but dropped (adsb.second_sender). When that report is not where the
owner's last report, flown on, puts the aircraft (two receivers hearing one aircraft agree; a forged one does not),
the intruder is spoof-suspected (spoof_suspected: status, track, and DAA unavailable while it lasts, daa.py).
"""

from __future__ import annotations

import math
from collections import Counter

from avionics.io.checks import (
    address_problem, altitude_problem, callsign_text, position_problem, speed_problem, squawk_valid,
    vertical_rate_problem,
)
from avionics.io.ownship_check import OwnshipJumpCheck
from avionics.io.params import DecoderConfig as Config
from avionics.io.senders import Senders
from avionics.io.sensor_input import SensorMessageDecoder
from avionics.tracking.measurement import PolarMeasurement
from avionics.base.atmosphere import MAX_VALID_HPA, MIN_VALID_HPA, pressure_altitude_m
from avionics.base.geodesy import flat_offset_m
from avionics.base.types import (
    AddressSource, AltitudeDatum, AutopilotHeartbeat, CommandAck, Input, IntruderKey, IntruderReport, MissionCount,
    MissionCurrent, MissionItem, OwnshipFix, OwnshipPressure,
)
from avionics.base.units import INT16_MAX, INT32_MAX, UINT16_MAX

# ADSB_FLAGS (MAVLink common.xml)
VALID_COORDS = 1
VALID_ALTITUDE = 2
VALID_HEADING = 4
VALID_VELOCITY = 8
VALID_CALLSIGN = 16
VALID_SQUAWK = 32
SIMULATED = 64
VERTICAL_VELOCITY_VALID = 128
BARO_VALID = 256
SOURCE_UAT = 32768
DAA_REBROADCAST = 16384  # our dialect's ADSB_FLAGS_DAA_REBROADCAST: a DAA process's fused track, not a report

ALTITUDE_TYPES = {0: AltitudeDatum.PRESSURE, 1: AltitudeDatum.GEOMETRIC}  # ADSB_ALTITUDE_TYPE
MIN_HEIGHT_ABOVE_HOME_M = -9000.0  # a home on a summit above a valley flight; anything lower is corrupt
SENDER_MARGIN_S = 1.0  # an intruder stays its first sender's this long after its track can have been deleted
# Two receivers' reports of one aircraft differ by their position errors: ADSB_VEHICLE carries no NACp, so two
# 0.1 NM EPUs (NACp 7, DO-260B Table 2-14) plus the report times' whole-second tslc at the aircraft's speed.
SAME_AIRCRAFT_M = 2 * 185.2
TSLC_RESOLUTION_S = 1.0


def _same_aircraft(owner: IntruderReport, msg, now_s: float, max_speed_mps: float) -> bool:
    """Does msg (another sender's ADSB_VEHICLE) put the aircraft where owner's report, flown on at its velocity, does?
    (one aircraft, two receivers) Without the owner's velocity, anywhere it could have flown at max_speed_mps. A
    report without a valid position says nothing against the owner."""
    if not msg.flags & VALID_COORDS or INT32_MAX in (msg.lat, msg.lon) or position_problem(msg.lat * 1e-7,
                                                                                         msg.lon * 1e-7):
        return True
    dt = now_s - msg.tslc - owner.time_s
    ve, vn = owner.velocity_en_mps or (0.0, 0.0)
    speed = math.hypot(ve, vn) if owner.velocity_en_mps else max_speed_mps
    slack_s = TSLC_RESOLUTION_S if owner.velocity_en_mps else TSLC_RESOLUTION_S + abs(dt)
    north, east = flat_offset_m(owner.lat_deg, owner.lon_deg, msg.lat * 1e-7, msg.lon * 1e-7)
    return math.hypot(east - ve * dt, north - vn * dt) <= SAME_AIRCRAFT_M + speed * slack_s


def _lat_lon(prefix: str, lat_e7: int, lon_e7: int, counters: Counter) -> tuple[float, float] | None:
    if lat_e7 == INT32_MAX or lon_e7 == INT32_MAX:
        counters[f"{prefix}.position_sentinel"] += 1
    elif (problem := position_problem(lat_e7 / 10**7, lon_e7 / 10**7)) is not None:  # checks.py, shared
        counters[f"{prefix}.{problem}"] += 1
    else:
        return lat_e7 * 1e-7, lon_e7 * 1e-7
    return None


class MessageDecoder:
    """Validates decoded pymavlink messages; decode(msg, now_s) -> core input or None (counted)."""

    def __init__(self, config: Config, counters: Counter):
        self.config = config
        self.counters = counters
        self.senders = Senders(config.mavlink, counters)
        self.ownship_check = OwnshipJumpCheck(config.input, counters)
        m = config.mavlink  # our own ADSB_VEHICLE re-broadcast comes from here (ports.py MavlinkOut)
        self._own_rebroadcaster = (m.source_system, m.traffic_rebroadcast_component) if m.traffic_rebroadcast else None
        # intruder -> (its first sender, when that sender last reported it, its last usable report); kept while its
        # track can live.
        self._senders: dict[IntruderKey, tuple[tuple[int, int], float, IntruderReport]] = {}
        self._sender_expiry_s = config.tracking.delete_after_s + SENDER_MARGIN_S
        self._next_prune_s = 0.0
        self.spoof_suspected: set[IntruderKey] = set()  # a second sender reported them somewhere else
        self._suspected_s: dict[IntruderKey, float] = {}  # when it last did; the flag lasts as a track would
        # (time, reason) when our last SCALED_PRESSURE was rejected; None once one is accepted
        self.pressure_rejection: tuple[float, str] | None = None
        self._handlers = {
            "ADSB_VEHICLE": self._adsb_vehicle,
            "GLOBAL_POSITION_INT": self._global_position_int,
            "SCALED_PRESSURE": self._scaled_pressure,
            "DAA_SENSOR_MEASUREMENT": self._sensor_measurement,
        }
        self.sensors = SensorMessageDecoder(counters)  # io/sensor_input.py: one detection per message
        # guidance.mode = "execute" (avionics/guidance): our autopilot's mode (HEARTBEAT) and its answers
        # (COMMAND_ACK) are inputs too; otherwise nothing reads them
        guidance = getattr(config, "guidance", None)
        self.autopilot_inputs = guidance is not None and guidance.mode == "execute"
        if self.autopilot_inputs:
            self._handlers["COMMAND_ACK"] = self._command_ack
            # the mission, read by the guidance (avionics/guidance/mission.py)
            self._handlers["MISSION_COUNT"] = self._mission_count
            self._handlers["MISSION_ITEM_INT"] = self._mission_item
            self._handlers["MISSION_CURRENT"] = self._mission_current

    def decode(self, msg, now_s: float) -> Input | PolarMeasurement | None:
        kind = msg.get_type()
        if kind == "HEARTBEAT":
            self.senders.heartbeat(msg, now_s)  # who is who (io/senders.py)
            return self._autopilot_heartbeat(msg, now_s) if self.autopilot_inputs else None
        handler = self._handlers.get(kind)
        if handler is None:
            return None  # not ours to use; not a rejection
        self.counters[f"rx.{msg.get_type().lower()}"] += 1
        return handler(msg, now_s)

    def _reject(self, reason: str) -> None:
        self.counters[reason] += 1

    # -- intruders -------------------------------------------------------------------------------------------
    def _adsb_vehicle(self, msg, now_s: float) -> IntruderReport | None:
        flags = msg.flags
        sender = (msg.get_srcSystem(), msg.get_srcComponent())
        if flags & DAA_REBROADCAST or sender == self._own_rebroadcaster:  # never our own output as input
            return self._reject("adsb.own_rebroadcast")
        if not self.senders.traffic(sender, now_s):
            return None  # counted by senders
        source = AddressSource.UAT if flags & SOURCE_UAT else AddressSource.ES1090
        problem = address_problem(self.config.vehicle.own_icao, msg.ICAO_address, source is AddressSource.ES1090)
        if problem is not None:
            return self._reject(f"adsb.{problem}")
        key = IntruderKey(msg.ICAO_address, source)
        owner = self._owner(key, sender, now_s)
        if owner is not None:  # another sender owns it: never merged; flagged when it says something else
            if not _same_aircraft(owner, msg, now_s, self.config.input.max_ground_speed_mps):
                self.spoof_suspected.add(key)
                self._suspected_s[key] = now_s
            return self._reject("adsb.second_sender")
        report = self._adsb_report(msg, key, now_s)
        if report is not None:
            self._senders[key] = (sender, now_s, report)  # only a usable report makes or keeps the sender the owner
        return report

    def _owner(self, key: IntruderKey, sender: tuple[int, int], now_s: float) -> IntruderReport | None:
        """The last usable report of this intruder's owner when that is another sender, else None (sender owns it
        or may become its owner)."""
        if now_s >= self._next_prune_s:  # bounded memory under address churn
            self._next_prune_s = now_s + self._sender_expiry_s
            for k in [k for k, (_, last, _) in self._senders.items() if now_s - last > self._sender_expiry_s]:
                del self._senders[k]
                self.spoof_suspected.discard(k)
            for k in [k for k, last in self._suspected_s.items() if now_s - last > self._sender_expiry_s]:
                del self._suspected_s[k]
                self.spoof_suspected.discard(k)
        owner = self._senders.get(key)
        if owner is None or owner[0] == sender:
            return None
        if now_s - owner[1] > self._sender_expiry_s:  # its track is gone: a new sender may begin a new one
            self.spoof_suspected.discard(key)
            return None
        return owner[2]

    def _adsb_report(self, msg, key: IntruderKey, now_s: float) -> IntruderReport | None:
        cfg = self.config.input
        flags = msg.flags
        if not flags & VALID_COORDS:
            return self._reject("adsb.no_position")
        position = _lat_lon("adsb", msg.lat, msg.lon, self.counters)
        if position is None:
            return None
        if msg.tslc > cfg.max_report_age_s:  # tslc is whole seconds; 255 means "unknown, old"
            return self._reject("adsb.stale")

        altitude_m, datum = None, None
        if flags & VALID_ALTITUDE:
            if msg.altitude == INT32_MAX:
                self._reject("adsb.altitude_sentinel")
            elif msg.altitude_type not in ALTITUDE_TYPES:
                self._reject("adsb.altitude_type_unknown")
            elif (problem := altitude_problem(cfg, msg.altitude * 1e-3)) is not None:
                self._reject(f"adsb.{problem}")
            else:
                altitude_m, datum = msg.altitude * 1e-3, ALTITUDE_TYPES[msg.altitude_type]

        velocity = None
        if flags & VALID_VELOCITY and flags & VALID_HEADING:
            if msg.heading == UINT16_MAX or msg.hor_velocity == UINT16_MAX:
                self._reject("adsb.velocity_sentinel")
            elif msg.heading >= 36000:
                self._reject("adsb.heading_out_of_range")
            elif (problem := speed_problem(cfg, msg.hor_velocity * 1e-2)) is not None:
                self._reject(f"adsb.{problem}")
            else:
                track = math.radians(msg.heading * 1e-2)
                speed = msg.hor_velocity * 1e-2
                velocity = (speed * math.sin(track), speed * math.cos(track))

        vertical_rate = None
        if flags & VERTICAL_VELOCITY_VALID:
            if msg.ver_velocity == INT16_MAX:
                self._reject("adsb.vertical_rate_sentinel")
            elif (problem := vertical_rate_problem(cfg, msg.ver_velocity * 1e-2)) is not None:
                self._reject(f"adsb.{problem}")
            else:
                vertical_rate = msg.ver_velocity * 1e-2  # positive up

        callsign = None
        if flags & VALID_CALLSIGN:
            # pymavlink keeps the wire bytes in _callsign_raw; its str has U+FFFD for non-ASCII bytes, which
            # latin-1 cannot encode (that raised). Any non-ASCII text becomes non-ASCII bytes: rejected below.
            raw = getattr(msg, "_callsign_raw", msg.callsign)
            raw = raw.encode("utf-8", "surrogatepass") if isinstance(raw, str) else bytes(raw)
            callsign = callsign_text(raw)  # checks.py, shared with the receiver feeds
            if callsign is None:
                self._reject("adsb.callsign_invalid")

        squawk = None
        if flags & VALID_SQUAWK:
            if msg.squawk == UINT16_MAX or not squawk_valid(msg.squawk):
                self._reject("adsb.squawk_invalid")  # Mode A codes are four octal digits
            else:
                squawk = msg.squawk

        return IntruderReport(
            key=key, time_s=now_s - msg.tslc, received_s=now_s,
            lat_deg=position[0], lon_deg=position[1], altitude_m=altitude_m, altitude_datum=datum,
            velocity_en_mps=velocity, vertical_rate_mps=vertical_rate, callsign=callsign, squawk=squawk,
            emitter_type=msg.emitter_type, simulated=bool(flags & SIMULATED),
        )

    # -- our autopilot (the guidance stage's) --------------------------------------------------------------------
    def _from_autopilot(self, msg) -> bool:
        return (msg.get_srcSystem(), msg.get_srcComponent()) == (self.senders.system, self.senders.ownship_component)

    def _autopilot_heartbeat(self, msg, now_s: float) -> AutopilotHeartbeat | None:
        if not self._from_autopilot(msg) or msg.autopilot == 8:  # MAV_AUTOPILOT_INVALID: not an autopilot
            return None
        return AutopilotHeartbeat(now_s, msg.get_srcComponent(), int(msg.custom_mode), int(msg.base_mode),
                                  int(msg.autopilot), int(msg.type))

    def _command_ack(self, msg, now_s: float) -> CommandAck | None:
        """Our autopilot's answer to us: an ACK for another component (target_component set and not ours; MAVLink 2
        extension, 0 from MAVLink 1 senders) is not an answer to our command."""
        m = self.config.mavlink
        if not self._from_autopilot(msg):
            return self._reject("command_ack.other_sender")
        target_system, target_component = getattr(msg, "target_system", 0), getattr(msg, "target_component", 0)
        if target_system not in (0, m.source_system) or target_component not in (0, m.source_component):
            return None  # someone else's command
        return CommandAck(now_s, int(msg.command), int(msg.result))

    def _to_us(self, msg) -> bool:
        """Addressed to this process (target system and component ours; 0: everyone)."""
        m = self.config.mavlink
        return msg.target_system in (0, m.source_system) and msg.target_component in (0, m.source_component)

    def _mission_count(self, msg, now_s: float) -> MissionCount | None:
        if not self._from_autopilot(msg):
            return self._reject("mission.other_sender")
        if not self._to_us(msg) or msg.mission_type != 0:  # someone else's download, or a fence or rally list
            return None
        return MissionCount(now_s, int(msg.count))

    def _mission_item(self, msg, now_s: float) -> MissionItem | None:
        if not self._from_autopilot(msg):
            return self._reject("mission.other_sender")
        if not self._to_us(msg) or msg.mission_type != 0:
            return None
        # x, y: a position's degrees E7 for a navigation item, other integers for others (the reader judges)
        return MissionItem(now_s, int(msg.seq), int(msg.command), int(msg.frame), msg.x / 1e7, msg.y / 1e7)

    def _mission_current(self, msg, now_s: float) -> MissionCurrent | None:
        if not self._from_autopilot(msg):
            return self._reject("mission.other_sender")
        return MissionCurrent(now_s, int(msg.seq), int(getattr(msg, "total", 0) or 0))

    # -- ownship ----------------------------------------------------------------------------------------------
    def _sensor_measurement(self, msg, now_s: float):
        """One detection of a sensor on our vehicle (any component of our system: a radar is not the autopilot)
        as a PolarMeasurement; MavlinkInput groups a batch's detections into scans."""
        if msg.get_srcSystem() != self.senders.system:
            return self._reject("sensor.mavlink.other_system")  # another vehicle's sensor sees from elsewhere
        return self.sensors.decode(msg, now_s)

    def _from_own_vehicle(self, msg, prefix: str, now_s: float) -> bool:
        return self.senders.ownship((msg.get_srcSystem(), msg.get_srcComponent()), prefix, now_s)

    def _global_position_int(self, msg, now_s: float) -> OwnshipFix | None:
        if not self._from_own_vehicle(msg, "gpi", now_s):
            return None
        cfg = self.config.input
        position = _lat_lon("gpi", msg.lat, msg.lon, self.counters)
        if position is None:
            return None
        if msg.alt == INT32_MAX or not cfg.min_altitude_m <= msg.alt * 1e-3 <= cfg.max_altitude_m:
            return self._reject("gpi.altitude_invalid")
        if msg.relative_alt == INT32_MAX or not MIN_HEIGHT_ABOVE_HOME_M <= msg.relative_alt * 1e-3 <= cfg.max_altitude_m:
            return self._reject("gpi.relative_alt_invalid")  # it selects the AGL sensitivity levels
        velocity = (msg.vx * 1e-2, msg.vy * 1e-2, msg.vz * 1e-2)  # north, east, down
        if math.hypot(velocity[0], velocity[1]) > cfg.max_ground_speed_mps or \
                abs(velocity[2]) > cfg.max_vertical_rate_mps or INT16_MAX in (msg.vx, msg.vy, msg.vz):
            return self._reject("gpi.velocity_invalid")
        heading = msg.hdg * 1e-2 if msg.hdg < 36000 else None  # UINT16_MAX: unknown (common.xml)
        fix = OwnshipFix(now_s, position[0], position[1], msg.alt * 1e-3, msg.relative_alt * 1e-3, velocity,
                         heading_deg=heading)
        return fix if self.ownship_check.accept(fix) else None  # counted gpi.jump

    def _scaled_pressure(self, msg, now_s: float) -> OwnshipPressure | None:
        """press_abs -> pressure altitude, only within the range the ISA model inverts correctly
        (base/atmosphere.py); outside it the reading is rejected and counted, never extrapolated."""
        if not self._from_own_vehicle(msg, "pressure", now_s):
            return None
        press_abs = float(msg.press_abs)
        if not math.isfinite(press_abs):
            return self._reject_pressure(now_s, "invalid")
        if not MIN_VALID_HPA <= press_abs <= MAX_VALID_HPA:
            return self._reject_pressure(now_s, "out_of_range")
        self.pressure_rejection = None
        return OwnshipPressure(now_s, pressure_altitude_m(press_abs))

    def _reject_pressure(self, now_s: float, reason: str) -> None:
        self.pressure_rejection = (now_s, reason)  # the status names it (daa.py, via the loop's SourceStatus)
        return self._reject(f"pressure.{reason}")
