"""MAVLink messages -> validated core inputs, in SI units. Every rejected message or field is counted.

ADSB_VEHICLE: a field is used only when its ADSB_FLAGS bit says valid *and* it holds no sentinel
(INT32_MAX, UINT16_MAX, INT16_MAX) and a physical value. A field flagged valid that fails those checks is
counted as rejected ("adsb.<field>_invalid"); the report itself is rejected only without a usable position
or identity. GLOBAL_POSITION_INT and SCALED_PRESSURE are taken only from our own vehicle's system id.
"""

from __future__ import annotations

import math
from collections import Counter

from avionics.config import Config
from avionics.core.atmosphere import pressure_altitude_m
from avionics.core.types import (
    AddressSource, AltitudeDatum, Input, IntruderKey, IntruderReport, OwnshipFix, OwnshipPressure,
)
from avionics.core.units import INT16_MAX, INT32_MAX, UINT16_MAX

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

ALTITUDE_TYPES = {0: AltitudeDatum.PRESSURE, 1: AltitudeDatum.GEOMETRIC}  # ADSB_ALTITUDE_TYPE
MAX_ICAO = 0xFFFFFF
MIN_HEIGHT_ABOVE_HOME_M = -9000.0  # a home on a summit above a valley flight; anything lower is corrupt


def _lat_lon(prefix: str, lat_e7: int, lon_e7: int, counters: Counter) -> tuple[float, float] | None:
    if lat_e7 == INT32_MAX or lon_e7 == INT32_MAX:
        counters[f"{prefix}.position_sentinel"] += 1
    elif abs(lat_e7) > 90 * 10**7:
        counters[f"{prefix}.lat_out_of_range"] += 1
    elif abs(lon_e7) > 180 * 10**7:
        counters[f"{prefix}.lon_out_of_range"] += 1
    elif lat_e7 == 0 and lon_e7 == 0:
        counters[f"{prefix}.null_position"] += 1  # 0,0 is what an unset fix looks like, not a place we fly
    else:
        return lat_e7 * 1e-7, lon_e7 * 1e-7
    return None


class MessageDecoder:
    """Validates decoded pymavlink messages; decode(msg, now_s) -> core input or None (counted)."""

    def __init__(self, config: Config, counters: Counter):
        self.config = config
        self.counters = counters
        self._handlers = {
            "ADSB_VEHICLE": self._adsb_vehicle,
            "GLOBAL_POSITION_INT": self._global_position_int,
            "SCALED_PRESSURE": self._scaled_pressure,
        }

    def decode(self, msg, now_s: float) -> Input | None:
        handler = self._handlers.get(msg.get_type())
        if handler is None:
            return None  # not ours to use; not a rejection
        self.counters[f"rx.{msg.get_type().lower()}"] += 1
        return handler(msg, now_s)

    def _reject(self, reason: str) -> None:
        self.counters[reason] += 1

    # -- intruders -------------------------------------------------------------------------------------------
    def _adsb_vehicle(self, msg, now_s: float) -> IntruderReport | None:
        cfg = self.config.input
        flags = msg.flags
        if msg.ICAO_address > MAX_ICAO:
            return self._reject("adsb.address_out_of_range")
        source = AddressSource.UAT if flags & SOURCE_UAT else AddressSource.ES1090
        if source is AddressSource.ES1090 and msg.ICAO_address == self.config.vehicle.own_icao != 0:
            return self._reject("adsb.own_address")
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
            elif not cfg.min_altitude_m <= msg.altitude * 1e-3 <= cfg.max_altitude_m:
                self._reject("adsb.altitude_out_of_range")
            else:
                altitude_m, datum = msg.altitude * 1e-3, ALTITUDE_TYPES[msg.altitude_type]

        velocity = None
        if flags & VALID_VELOCITY and flags & VALID_HEADING:
            if msg.heading == UINT16_MAX or msg.hor_velocity == UINT16_MAX:
                self._reject("adsb.velocity_sentinel")
            elif msg.heading >= 36000:
                self._reject("adsb.heading_out_of_range")
            elif msg.hor_velocity * 1e-2 > cfg.max_ground_speed_mps:
                self._reject("adsb.speed_out_of_range")
            else:
                track = math.radians(msg.heading * 1e-2)
                speed = msg.hor_velocity * 1e-2
                velocity = (speed * math.sin(track), speed * math.cos(track))

        vertical_rate = None
        if flags & VERTICAL_VELOCITY_VALID:
            if msg.ver_velocity == INT16_MAX:
                self._reject("adsb.vertical_rate_sentinel")
            elif abs(msg.ver_velocity * 1e-2) > cfg.max_vertical_rate_mps:
                self._reject("adsb.vertical_rate_out_of_range")
            else:
                vertical_rate = msg.ver_velocity * 1e-2  # positive up

        callsign = None
        if flags & VALID_CALLSIGN:
            # pymavlink keeps the wire bytes in _callsign_raw; its str has U+FFFD for non-ASCII bytes, which
            # latin-1 cannot encode (that raised). Any non-ASCII text becomes non-ASCII bytes: rejected below.
            raw = getattr(msg, "_callsign_raw", msg.callsign)
            raw = raw.encode("utf-8", "surrogatepass") if isinstance(raw, str) else bytes(raw)
            text = raw.split(b"\0", 1)[0].decode("ascii", errors="replace").strip()
            if text and text.isprintable() and text.isascii() and "\ufffd" not in text:
                callsign = text
            else:
                self._reject("adsb.callsign_invalid")

        squawk = None
        if flags & VALID_SQUAWK:
            digits = f"{msg.squawk:04d}"
            if msg.squawk == UINT16_MAX or len(digits) != 4 or any(d > "7" for d in digits):
                self._reject("adsb.squawk_invalid")  # Mode A codes are four octal digits
            else:
                squawk = msg.squawk

        return IntruderReport(
            key=IntruderKey(msg.ICAO_address, source), time_s=now_s - msg.tslc, received_s=now_s,
            lat_deg=position[0], lon_deg=position[1], altitude_m=altitude_m, altitude_datum=datum,
            velocity_en_mps=velocity, vertical_rate_mps=vertical_rate, callsign=callsign, squawk=squawk,
            emitter_type=msg.emitter_type, simulated=bool(flags & SIMULATED),
        )

    # -- ownship ----------------------------------------------------------------------------------------------
    def _from_own_vehicle(self, msg, prefix: str) -> bool:
        if msg.get_srcSystem() != self.config.mavlink.source_system:
            self._reject(f"{prefix}.other_system")
            return False
        return True

    def _global_position_int(self, msg, now_s: float) -> OwnshipFix | None:
        if not self._from_own_vehicle(msg, "gpi"):
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
        return OwnshipFix(now_s, position[0], position[1], msg.alt * 1e-3, msg.relative_alt * 1e-3, velocity)

    def _scaled_pressure(self, msg, now_s: float) -> OwnshipPressure | None:
        if not self._from_own_vehicle(msg, "pressure"):
            return None
        try:
            return OwnshipPressure(now_s, pressure_altitude_m(float(msg.press_abs)))
        except ValueError:  # NaN, inf or beyond the atmosphere an aircraft flies in
            return self._reject("pressure.invalid")
