"""A simulated 1090 MHz receiver's Beast output: a scenario's intruders as DF17 extended squitters in Beast binary
frames, served over TCP (dump1090/readsb's port 30005) in real time or fast time.

The encoder is written from the standards, independently of any decoder (pyModeS is its test oracle,
tests/test_beast.py):

- Mode S long reply DF17: DF(5) CA(3) AA(24) ME(56) PI(24), the parity the CRC-24 of ICAO Annex 10 Vol IV
  §3.1.2.3.3 (generator polynomial 0x1FFF409) over the first 88 bits.
- ME field formats of RTCA DO-260B §2.2.3.2 (ICAO Doc 9871 Appendix A), as explained by Junzi Sun, "The 1090 MHz
  Riddle" (2nd ed., 2021, https://mode-s.org/1090mhz/): identification TC 1-4 (BDS 0,8), airborne position
  TC 9-18 with barometric altitude (BDS 0,5) and CPR, airborne velocity TC 19 subtype 1 (BDS 0,9),
  aircraft operational status TC 31 subtype 0 (BDS 6,5) with ADS-B version 2 and NACp.
- CPR encoding: DO-260B §A.1.7.1 (Nb = 17, NZ = 15), the Riddle's chapter "Compact Position Reporting":
  YZ = floor(2^17 mod(lat, dLat)/dLat + 1/2), Rlat = dLat (YZ/2^17 + floor(lat/dLat)), dLon = 360/max(NL(Rlat) - i, 1),
  XZ = floor(2^17 mod(lon, dLon)/dLon + 1/2), both mod 2^17. The latitude quantum is dLat/2^17 = 5.1 m (even)
  and the longitude's dLon/2^17 = 5.2 m at the equator (less towards the poles, by cos(lat) NL-steps).
- Beast binary framing (dump1090's net_io.c "Beast output"): 0x1a, type '3' (Mode S long), 6-byte 12 MHz
  timestamp, 1 signal byte, the 14 message bytes, every 0x1a in the timestamp, signal or message doubled.

The schedule (`beast_schedule`) follows DO-260B's nominal airborne rates: position and velocity 2 Hz each (even and
odd positions alternating), identification every 5 s, operational status every 2.5 s, each intruder at its own
phase, each message impaired as avionics_sitl.autopilot impairs ADSB_VEHICLE reports (noise, quantisation,
latency, dropouts: avionics_sitl.impairments). A message is received `latency_s` after its time of applicability
and stamped with the receiver's 12 MHz counter then; the counter starts at an arbitrary value and wraps at 2^48.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from avionics.base.types import AddressSource, AltitudeDatum
from avionics.base.units import FPM, FT, KT
from avionics_sitl.feed_server import FeedServer
from avionics_sitl.impairments import AdsbImpairments
from avionics_sitl.scenario import Scenario
from avionics_sitl.trajectory import KinematicState

CRC24_GENERATOR = 0x1FFF409  # ICAO Annex 10 Vol IV §3.1.2.3.3.1.2: x^24 + x^23 + ... + x^10 + x^3 + 1
BEAST_ESCAPE = 0x1A
BEAST_MODE_AC, BEAST_MODE_S_SHORT, BEAST_MODE_S_LONG = b"1", b"2", b"3"
CLOCK_HZ = 12_000_000  # the Beast timestamp counts a 12 MHz clock ...
CLOCK_WRAP = 1 << 48  # ... in 48 bits
NZ = 15  # CPR latitude zones per quadrant (DO-260B §A.1.7.1)
CPR_BITS = 17

# MAVLink ADSB_EMITTER_TYPE -> (type code, emitter category) of the identification message (DO-260B §2.2.3.2.5.2,
# Table 2-16: TC 4 set A, TC 3 set B, TC 2 set C). The inverse is the decoder's (avionics/io/feeds/beast.py).
EMITTER_CATEGORY = {
    0: (4, 0), 1: (4, 1), 2: (4, 2), 3: (4, 3), 4: (4, 4), 5: (4, 5), 6: (4, 6), 7: (4, 7),
    9: (3, 1), 10: (3, 2), 11: (3, 3), 12: (3, 4), 14: (3, 6), 15: (3, 7),
    17: (2, 1), 18: (2, 2), 19: (2, 3),
}
_CALLSIGN_CHARS = "#ABCDEFGHIJKLMNOPQRSTUVWXYZ##### ###############0123456789######"  # the 6-bit IA-5 subset


def crc24(data: bytes) -> int:
    """The Mode S parity of `data` (the first 88 or 32 bits of a reply): the remainder of data * x^24 divided by
    the generator, bit by bit as the standard defines it."""
    remainder = int.from_bytes(data, "big") << 24
    for bit in range(len(data) * 8 + 23, 23, -1):
        if remainder >> bit & 1:
            remainder ^= CRC24_GENERATOR << (bit - 24)
    return remainder


def df17(icao: int, me: int, ca: int = 5) -> bytes:
    """A DF17 extended squitter: the 56-bit ME field from `icao` (CA 5: level 2+ transponder, airborne)."""
    head = ((17 << 3 | ca) << 24 | icao) << 56 | me
    data = head.to_bytes(11, "big")
    return data + crc24(data).to_bytes(3, "big")


# --- ME fields --------------------------------------------------------------------------------------------------
def identification_me(callsign: str, emitter_type: int) -> int:
    """TC 1-4 (BDS 0,8): the category from the MAVLink emitter type, the callsign in 8 six-bit characters."""
    tc, category = EMITTER_CATEGORY.get(emitter_type, (4, 0))
    text = callsign.upper()[:8].ljust(8)
    me = tc << 3 | category
    for char in text:
        index = _CALLSIGN_CHARS.find(char) if char != "#" else -1
        if index < 0:
            raise ValueError(f"callsign {callsign!r}: {char!r} is not in the Mode S character set (A-Z, 0-9, space)")
        me = me << 6 | index
    return me


def cpr_nl(lat_deg: float) -> int:
    """NL(lat), the number of longitude zones (DO-260B §A.1.7.2.d), from its closed form."""
    lat = abs(lat_deg)
    if lat == 0.0:
        return 59
    if lat == 87.0:
        return 2
    if lat > 87.0:
        return 1
    a = 1.0 - math.cos(math.pi / (2 * NZ))
    b = math.cos(math.radians(lat)) ** 2
    return int(math.floor(2.0 * math.pi / math.acos(1.0 - a / b)))


def cpr_encode(lat_deg: float, lon_deg: float, odd: bool) -> tuple[int, int]:
    """Airborne CPR (DO-260B §A.1.7.1, Nb = 17): (YZ, XZ) of one format, i = 1 odd, 0 even."""
    i = 1 if odd else 0
    scale = 1 << CPR_BITS
    d_lat = 360.0 / (4 * NZ - i)
    yz = math.floor(scale * (lat_deg % d_lat) / d_lat + 0.5)
    r_lat = d_lat * (yz / scale + math.floor(lat_deg / d_lat))
    d_lon = 360.0 / max(cpr_nl(r_lat) - i, 1)
    xz = math.floor(scale * (lon_deg % d_lon) / d_lon + 0.5)
    return yz % scale, xz % scale


def altitude_code_25ft(alt_ft: float) -> int:
    """The 12-bit AC field with Q = 1 (25 ft steps from -1000 ft, up to 50175 ft): N in 11 bits, Q the 8th bit."""
    n = int(round((alt_ft + 1000.0) / 25.0))
    if not 0 <= n < 1 << 11:
        raise ValueError(f"altitude {alt_ft:.0f} ft is outside the 25 ft coding (-1000 to 50175 ft)")
    return (n >> 4) << 5 | 1 << 4 | (n & 0xF)


# NIC -> the airborne position type code with barometric altitude (DO-260B Table 2-14, NIC supplements 0).
NIC_TYPE_CODE = {11: 9, 10: 10, 8: 11, 7: 12, 6: 13, 5: 14, 4: 15, 2: 16, 1: 17, 0: 18}


def airborne_position_me(lat_deg: float, lon_deg: float, alt_ft: float, odd: bool, nic: int = 8) -> int:
    """TC 9-18 (BDS 0,5): surveillance status 0, NIC supplement-B 0, barometric altitude, T 0, CPR."""
    tc = NIC_TYPE_CODE[nic]
    yz, xz = cpr_encode(lat_deg, lon_deg, odd)
    me = tc << 2 | 0  # SS
    me = me << 1 | 0  # NIC supplement-B
    me = me << 12 | altitude_code_25ft(alt_ft)
    me = me << 1 | 0  # T: not UTC-coupled
    me = me << 1 | (1 if odd else 0)
    return (me << 17 | yz) << 17 | xz


def _signed_field(value: float, bits: int) -> tuple[int, int]:
    """(sign, magnitude + 1) of a velocity component in its LSBs, saturating at the field's top (value - 1)."""
    magnitude = min(int(round(abs(value))), (1 << bits) - 2)
    return (1 if value < 0 and magnitude else 0), magnitude + 1


def airborne_velocity_me(vel_east_mps: float, vel_north_mps: float, vel_up_mps: float, nacv: int = 2,
                         baro_rate: bool = True) -> int:
    """TC 19 subtype 1 (BDS 0,9): east/west and north/south ground speed in 1 kt, vertical rate in 64 fpm,
    NACv (v2; NUCr in v0), GNSS-minus-baro difference unavailable."""
    s_ew, v_ew = _signed_field(vel_east_mps / KT, 10)
    s_ns, v_ns = _signed_field(vel_north_mps / KT, 10)
    s_vr, vr = _signed_field(vel_up_mps / FPM / 64.0, 9)
    me = 19 << 3 | 1  # subtype 1: subsonic ground speed
    me = me << 1 | 0  # intent change flag
    me = me << 1 | 0  # IFR capability
    me = me << 3 | nacv
    me = ((me << 1 | s_ew) << 10 | v_ew)
    me = ((me << 1 | s_ns) << 10 | v_ns)
    me = me << 1 | (1 if baro_rate else 0)
    me = ((me << 1 | s_vr) << 9 | vr)
    me = me << 2  # reserved
    return (me << 1 | 0) << 7 | 0  # GNSS - baro: no information


def operational_status_me(nacp: int, version: int = 2, nic_a: int = 0, sil: int = 3) -> int:
    """TC 31 subtype 0 (BDS 6,5, airborne): capability and operational mode codes 0, version, NIC supplement-A,
    NACp, GVA 0, SIL, NIC_baro 1, HRD 0 (true north), SIL supplement 0."""
    me = 31 << 3 | 0
    me = me << 16  # capability class
    me = me << 16  # operational mode
    me = ((me << 3 | version) << 1 | nic_a) << 4 | nacp
    me = me << 2  # GVA
    me = (me << 2 | sil) << 1 | 1  # NIC_baro
    return ((me << 1 | 0) << 1 | 0) << 1  # HRD, SIL supplement, reserved


# --- Beast framing ----------------------------------------------------------------------------------------------
def beast_frame(message: bytes, ticks: int, signal: int = 0xA0) -> bytes:
    """One Beast binary frame of a Mode S reply (7 or 14 bytes) or Mode A/C (2 bytes), 0x1a escaped."""
    kind = {2: BEAST_MODE_AC, 7: BEAST_MODE_S_SHORT, 14: BEAST_MODE_S_LONG}[len(message)]
    body = (ticks % CLOCK_WRAP).to_bytes(6, "big") + bytes([signal]) + message
    return bytes([BEAST_ESCAPE]) + kind + body.replace(b"\x1a", b"\x1a\x1a")


# --- a scenario's intruders as a receiver hears them ------------------------------------------------------------
@dataclass(frozen=True, slots=True)
class BeastEvent:
    deliver_s: float  # when the frame reaches the DAA process (scenario time)
    frame: bytes  # one Beast frame
    truth_s: float  # time of applicability of what it says
    kind: str  # "position" | "velocity" | "identification" | "status"


@dataclass(frozen=True)
class BeastConfig:
    position_hz: float = 2.0  # DO-260B §2.2.3.3.1.4: airborne position and velocity, 2 Hz each
    velocity_hz: float = 2.0
    identification_period_s: float = 5.0  # identification every 5 s in flight
    status_period_s: float = 2.5  # operational status every 2.5 s (version 2, not changing)
    nacp: int = 9  # EPU < 30 m, as avionics_sitl.impairments.DEFAULT's noise
    nacv: int = 2  # < 3 m/s
    nic: int = 8  # Rc < 0.1 NM: type code 11
    clock_start_ticks: int = 0x123456789A  # the receiver's counter at scenario time 0


def _intruder_messages(kind: str, state: KinematicState, icao: int, spec, config: BeastConfig,
                       odd: bool) -> bytes | None:
    if kind == "position":
        if spec.altitude_datum is not AltitudeDatum.PRESSURE:
            return None  # the simulator sends barometric altitude only (docs/traffic-inputs.md, Beast)
        me = airborne_position_me(state.lat_deg, state.lon_deg, state.alt_msl_m / FT, odd, config.nic)
    elif kind == "velocity":
        me = airborne_velocity_me(state.vel_east_mps, state.vel_north_mps, state.vel_up_mps, config.nacv)
    elif kind == "identification":
        me = identification_me(spec.callsign, spec.emitter_type)
    else:
        me = operational_status_me(config.nacp)
    return df17(icao, me)


def beast_schedule(scenario: Scenario, impairments: AdsbImpairments, seed: int = 0,
                   config: BeastConfig = BeastConfig(), duration_s: float | None = None) -> list[BeastEvent]:
    """Every Beast frame of the scenario's 1090ES intruders in delivery order (UAT intruders are not on 1090 MHz
    and are left out). Each message is impaired on its own, with one generator per intruder and message kind."""
    duration = scenario.duration_s if duration_s is None else duration_s
    _, trajectories = scenario.trajectories()
    events: list[BeastEvent] = []
    periods = {"position": 1.0 / config.position_hz, "velocity": 1.0 / config.velocity_hz,
               "identification": config.identification_period_s, "status": config.status_period_s}
    for i, (spec, traj) in enumerate(zip(scenario.intruders, trajectories)):
        if spec.address_source is not AddressSource.ES1090:
            continue
        for j, (kind, period) in enumerate(periods.items()):
            rng = impairments.with_seed((seed, spec.icao_address, j))
            phase = (0.113 + 0.271 * i + 0.047 * j) % period
            for k in range(int(math.floor((duration - phase) / period)) + 1):
                t = phase + k * period
                report = rng.impair(traj.state_at(t))
                if report is None:
                    continue
                message = _intruder_messages(kind, report.state, spec.icao_address, spec, config, odd=bool(k % 2))
                if message is None:
                    continue
                received = t + report.latency_s
                ticks = config.clock_start_ticks + int(round(received * CLOCK_HZ))
                events.append(BeastEvent(received, beast_frame(message, ticks), t, kind))
    events.sort(key=lambda e: e.deliver_s)
    return events


class BeastServer(FeedServer):
    """Beast binary frames over TCP, each event at its delivery time (feed_server.py: clocks, clients, stop)."""

    name = "beast server"
    sent_key = "beast_frames"

    def __init__(self, events: list[BeastEvent], host: str = "127.0.0.1", port: int = 30005, **kw):
        super().__init__(events, host, port, **kw)

    @staticmethod
    def payload(event: BeastEvent) -> bytes:
        return event.frame
