"""Beast binary (dump1090/readsb TCP port 30005) -> Mode S extended squitters -> Observations.

Framing (dump1090's net_io.c "Beast output", Mode-S Beast receiver's binary format): every frame is

    0x1a | type | 6-byte timestamp (12 MHz counter, big-endian, wraps at 2^48) | 1 signal byte | message

with type '1' (0x31) Mode A/C, 2 message bytes; '2' (0x32) Mode S short, 7 bytes; '3' (0x33) Mode S long, 14
bytes; and every 0x1a byte after the type (timestamp, signal or message) sent twice. An unescaped 0x1a inside a
frame is the start of the next one.

`BeastDeframer` finds frames in a byte stream (TCP reads split frames anywhere) and resynchronises after garbage:
every 0x1a followed by a type byte is a candidate. A frame is consumed (the scan jumps past it) only when it is a
DF17/DF18 extended squitter whose CRC-24 parity checks (pyModeS); any other candidate (broken, failed parity,
Mode A/C, a reply whose parity cannot be checked without the interrogation) moves the scan one byte on, so a
garbage candidate that ran into a real frame never costs that frame. Frames are counted by what they are; the
candidates that start inside an already-parsed frame are not counted again.

`BeastDecoder` decodes the extended squitters with pyModeS (3.x: `pyModeS.decode`, `pyModeS.position`) into
Observations for the shared per-aircraft merge (feeds/aircraft.py):

- TC 1-4 identification (BDS 0,8): callsign, emitter category -> MAVLink ADSB_EMITTER_TYPE;
- TC 9-18 airborne position with barometric altitude (BDS 0,5): CPR position, pressure-altitude datum, NIC from the
  type code (with the NIC supplements of the operational status and the message, by ADS-B version). TC 20-22
  (GNSS height) positions are used without their altitude (docs/traffic-inputs.md: the height is HAE and the
  references disagree on its coding); surface positions TC 5-8 are not used;
- TC 19 airborne velocity (BDS 0,9) subtypes 1-2: east/north ground speed from the signed components (pyModeS
  rounds the speed down to whole knots, so they are read from the message), vertical rate, NACv (NUCr in v0);
  subtypes 3-4 (airspeed and heading) give the vertical rate only;
- TC 31 airborne operational status (BDS 6,5): ADS-B version, NIC supplement-A, NACp (versions 1 and 2);
  TC 29 target state and status (BDS 6,2, subtype 1, version 2): NACp.

Positions (DO-260B §A.1.7, "The 1090 MHz Riddle", Junzi Sun, chapter "Airborne position"): a CRC-valid message is
not a true one (a parity collision, or a transmitter that forges an aircraft's address: issue 25), and one CPR
message is ambiguous by whole zones, so a position must agree with the aircraft's other messages before it is used:

- While the aircraft has a reference (its last accepted position, at most `LOCAL_REFERENCE_MAX_S` old), each message
  is decoded locally against it (DO-260B §A.1.7.5) and accepted when the aircraft can have flown there
  (input.max_ground_speed_mps x elapsed + `POSITION_MARGIN_M`, dump1090-fa/readsb's speed check); a message that
  fails is rejected (`cpr_implausible`) and the reference is kept: junk cannot reset it.
- Without one (or for a message the reference rejected: a reference that no message confirms any more is replaced
  this way), an even and an odd message at most `PAIR_MAX_S` (10 s) apart (DO-260B §A.1.7.3; pyModeS) decode
  globally into a candidate, when the two decode to positions the aircraft can have flown between
  (`cpr_pair_inconsistent` otherwise). The candidate becomes the reference, and its position is used, only once
  later messages of both formats, decoded locally against it, have confirmed it (`cpr_global`; until then
  `cpr_held`), and the reference it replaces has had no message since its pair (else `cpr_contested`: two position
  streams under one address, the one heard first kept). Both formats, because the even and odd zones differ (6 and
  6.1 degrees of latitude): a pair with one junk half decodes to an image of the aircraft whole zones away, which
  the aircraft's messages of one format confirm and of the other never do. pyModeS's PipeDecoder waits for three
  consistent positions the same way (pyModeS/_pipe.py, bootstrap), readsb for its `pos_reliable` count.

A position message that is not accepted says nothing else either (its altitude and NIC are the same junk): it makes
no observation.

DF18 (extended squitter / non-transponder, ICAO Annex 10 Vol IV §3.1.2.8.7; DO-260B's CF field of DF18): CF 0
(ADS-B from a non-transponder device with an ICAO 24-bit address) is decoded as DF17. CF 1 (non-ICAO address),
2, 3 and 5 (TIS-B fine and coarse, ICAO or not), 4 (TIS-B/ADS-R management) and 6 (ADS-R rebroadcast) are counted
per CF and not used: a non-ICAO address may equal an ICAO one and our intruder keys have no namespace for it, and
TIS-B/ADS-R messages need their IMF bit and their own formats read (docs/traffic-inputs.md, known limits).

Counters: traffic.beast.<what> (see docs/traffic-inputs.md).
"""

from __future__ import annotations

import logging
import math
from collections import Counter, deque
from dataclasses import dataclass

from pyModeS import Message
from pyModeS.position import airborne_position_pair, airborne_position_with_ref

from avionics.base.geodesy import WGS84_A
from avionics.base.types import AltitudeDatum
from avionics.base.units import FT, FPM, KT
from avionics.io.feeds.aircraft import FORGET_AFTER_S, MAX_AIRCRAFT, AircraftMerge, Observation
from avionics.io.feeds.clock import ReceiverClock

log = logging.getLogger("avionics.traffic")
ESCAPE = 0x1A
MESSAGE_BYTES = {0x31: 2, 0x32: 7, 0x33: 14}  # type '1' Mode A/C, '2' Mode S short, '3' Mode S long
CLOCK_HZ = 12_000_000.0  # the Beast timestamp: a 12 MHz counter ...
CLOCK_WRAP_S = 2**48 / CLOCK_HZ  # ... of 48 bits (wraps every 271 days)
PAIR_MAX_S = 10.0  # an even/odd pair further apart may straddle a latitude zone (DO-260B §A.1.7.3; pyModeS)
LOCAL_REFERENCE_MAX_S = 30.0  # local decoding needs the reference within half a zone (~180 NM); 30 s is far inside
POSITION_MARGIN_M = 1000.0  # plausibility: the distance flown at max speed, plus this (CPR quantum, noise)
FRAMES_KEPT = 8  # position messages kept per format for pairing: 8 s of one aircraft's 1 Hz per format
MAX_CANDIDATES = 5  # unconfirmed candidate positions per aircraft (pyModeS's bootstrap keeps five)

# Identification type code and category -> MAVLink ADSB_EMITTER_TYPE (DO-260B §2.2.3.2.5: TC 4 set A, 3 set B,
# 2 set C; set A 1 light, 2 small, 3 large, 4 high vortex large, 5 heavy, 6 high performance, 7 rotorcraft; set B
# 1 glider, 2 lighter than air, 3 parachutist, 4 ultralight, 6 UAV, 7 space; set C 1 emergency surface vehicle,
# 2 service surface vehicle, 3 point obstacle, 4 cluster and 5 line obstacle, which MAVLink has not: point obstacle).
# The same as readsb's "category" letters in feeds/aircraft.py. Category 0, reserved codes and TC 1 (set D): 0.
EMITTER_TYPE = {(4, c): c for c in range(1, 8)} | {
    (3, 1): 9, (3, 2): 10, (3, 3): 11, (3, 4): 12, (3, 6): 14, (3, 7): 15,
    (2, 1): 17, (2, 2): 18, (2, 3): 19, (2, 4): 19, (2, 5): 19,
}


def nic_of_type_code(tc: int, version: int | None, nic_a: int, nic_b: int) -> int | None:
    """The NIC an airborne position's type code says (DO-260B, "NIC and type code" of the airborne position
    message; the Riddle's chapter "ADS-B uncertainty"). TC 11 and 16 depend on the NIC supplements: version 2 needs
    supplement-A (operational status) and supplement-B (this message) both 1 for NIC 9 / 3; version 1 has one
    supplement (operational status). Without a known version 1 or 2 (version 0, or no operational status heard
    yet) the lower NIC is taken, and TC 16 gives 1: version 0's NUCp 2 bound (10 NM) exceeds NIC 2's (8 NM)."""
    fixed = {9: 11, 10: 10, 12: 7, 13: 6, 14: 5, 15: 4, 17: 1, 18: 0, 20: 11, 21: 10, 22: 0}
    if tc in fixed:
        return fixed[tc]
    if tc not in (11, 16):
        return None
    if version == 2:
        high = nic_a == 1 and nic_b == 1
    elif version == 1:
        high = nic_a == 1
    else:
        return 8 if tc == 11 else 1
    return (9 if high else 8) if tc == 11 else (3 if high else 2)


@dataclass(frozen=True, slots=True)
class BeastFrame:
    kind: int  # 0x31 Mode A/C, 0x32 Mode S short, 0x33 Mode S long
    ticks: int  # the receiver's 12 MHz counter at reception (0: the receiver gave none)
    signal: int
    message: bytes


def _parse(buf: bytearray, start: int) -> tuple[str, int, BeastFrame | None]:
    """The candidate frame at buf[start] (0x1a, type): ("ok", end, frame), ("broken", index of the unescaped 0x1a,
    None) or ("incomplete", len(buf), None)."""
    kind = buf[start + 1]
    need = 7 + MESSAGE_BYTES[kind]
    body = bytearray()
    i, n = start + 2, len(buf)
    while len(body) < need:
        if i >= n:
            return "incomplete", n, None
        b = buf[i]
        if b == ESCAPE:
            if i + 1 >= n:
                return "incomplete", n, None
            if buf[i + 1] != ESCAPE:
                return "broken", i, None
            i += 1
        body.append(b)
        i += 1
    return "ok", i, BeastFrame(kind, int.from_bytes(body[:6], "big"), body[6], bytes(body[7:]))


def _valid_squitter(frame: BeastFrame) -> bool | None:
    """True: a DF17/18 whose parity checks; False: a DF17/18 whose parity fails; None: not checkable."""
    if frame.kind != 0x33 or (frame.message[0] >> 3) not in (17, 18):
        return None
    return Message(frame.message).crc_valid is True


class BeastDeframer:
    """Bytes in any pieces -> Beast frames. feed(data) returns the frames completed; reset() forgets a partial frame
    (a new connection is a new stream). Counters (prefix traffic.beast.): frames, bad_frame (an unescaped 0x1a
    inside a frame), crc_failed (DF17/18 whose parity fails), garbage_bytes (outside any frame)."""

    def __init__(self, counters: Counter, prefix: str = "traffic.beast."):
        self.counters, self.prefix = counters, prefix
        self._buf = bytearray()
        self._shadow = 0  # candidates before this index start inside a frame already parsed: not counted again

    def reset(self) -> None:
        self._buf.clear()
        self._shadow = 0

    def _count(self, what: str, n: int = 1) -> None:
        self.counters[self.prefix + what] += n

    @staticmethod
    def _next_candidate(buf: bytearray, p: int) -> int:
        """The next index >= p of 0x1a followed by a type byte; len(buf) - 1 for a trailing 0x1a; -1 for none."""
        while True:
            i = buf.find(ESCAPE, p)
            if i < 0:
                return -1
            if i + 1 >= len(buf):
                return i
            if buf[i + 1] in MESSAGE_BYTES:
                return i
            p = i + 1

    def feed(self, data: bytes) -> list[BeastFrame]:
        buf = self._buf
        buf += data
        frames: list[BeastFrame] = []
        p = 0
        while True:
            s = self._next_candidate(buf, p)
            if s < 0:
                self._garbage(p, len(buf))
                p = len(buf)
                break
            self._garbage(p, s)
            if s + 1 >= len(buf):  # a 0x1a at the end: its type byte has not arrived
                p = s
                break
            status, end, frame = _parse(buf, s)
            if status == "incomplete":
                later = self._complete_squitter_after(buf, s + 1)
                if later is None:
                    p = s  # wait for the rest
                    break
                if s >= self._shadow:
                    self._count("bad_frame")  # a real frame followed: this one was garbage
                p = later
                continue
            if status == "broken":
                if s >= self._shadow:
                    self._count("bad_frame")
                p = s + 1
                continue
            valid = _valid_squitter(frame)
            if valid:
                self._count("frames")
                frames.append(frame)
                p, self._shadow = end, max(self._shadow, end)
                continue
            if s >= self._shadow:
                if valid is False:
                    self._count("crc_failed")
                else:
                    self._count("frames")
                    frames.append(frame)  # not checkable here: the decoder counts and ignores it
                self._shadow = max(self._shadow, end)
            p = s + 1
        del buf[:p]
        self._shadow = max(0, self._shadow - p)
        return frames

    def _garbage(self, start: int, end: int) -> None:
        start = max(start, self._shadow)
        if end > start:
            self._count("garbage_bytes", end - start)

    @staticmethod
    def _complete_squitter_after(buf: bytearray, p: int) -> int | None:
        """The start of a complete, parity-checked extended squitter at or after p, if the buffer holds one."""
        while True:
            s = BeastDeframer._next_candidate(buf, p)
            if s < 0 or s + 1 >= len(buf):
                return None
            status, _, frame = _parse(buf, s)
            if status == "ok" and _valid_squitter(frame):
                return s
            p = s + 1


class _Candidate:
    """A position decoded from an even/odd pair, waiting for later messages of both formats to confirm it."""

    __slots__ = ("lat", "lon", "t", "since", "confirmed")

    def __init__(self, lat: float, lon: float, t: float) -> None:
        self.lat, self.lon, self.t = lat, lon, t  # its position, as last confirmed
        self.since = t  # when its pair decoded
        self.confirmed: set[int] = set()  # the CPR formats (0 even, 1 odd) of the messages that confirmed it


class _CprState:
    __slots__ = ("frames", "position", "candidates", "version", "nic_a", "heard_s")

    def __init__(self) -> None:
        self.frames = (deque(maxlen=FRAMES_KEPT), deque(maxlen=FRAMES_KEPT))  # even, odd: (lat, lon raw, time)
        self.position: tuple[float, float, float] | None = None  # the reference: the last accepted (lat, lon, time)
        self.candidates: list[_Candidate] = []
        self.version: int | None = None  # ADS-B version from the operational status
        self.nic_a = 0
        self.heard_s = -math.inf


def _local(fmt: int, lat_raw: int, lon_raw: int, lat_ref: float, lon_ref: float) -> tuple[float, float]:
    """One CPR message decoded against a reference within half a zone of it (DO-260B §A.1.7.5; pyModeS)."""
    lat, lon = airborne_position_with_ref(fmt, lat_raw, lon_raw, lat_ref, lon_ref)
    return lat, (lon + 180.0) % 360.0 - 180.0


def _distance_m(lat1: float, lon1: float, lat2: float, lon2: float) -> float:
    """Great-circle distance on the equatorial-radius sphere (a plausibility bound, not a measurement)."""
    p1, p2 = math.radians(lat1), math.radians(lat2)
    h = math.sin((p2 - p1) / 2) ** 2 + math.cos(p1) * math.cos(p2) * math.sin(math.radians(lon2 - lon1) / 2) ** 2
    return 2.0 * WGS84_A * math.asin(min(1.0, math.sqrt(h)))


class BeastDecoder:
    """Beast frames -> Observations (None for a frame that says nothing we use; counted). The receiver's 12 MHz
    timestamps are aligned to our loop clock by a ReceiverClock (feeds/clock.py); a frame without one gets its
    receipt time."""

    def __init__(self, counters: Counter, clock: ReceiverClock | None = None, max_ground_speed_mps: float = 300.0,
                 prefix: str = "traffic.beast."):
        self.counters, self.prefix = counters, prefix
        self.clock = clock if clock is not None else ReceiverClock(wrap_s=CLOCK_WRAP_S)
        self.max_ground_speed_mps = max_ground_speed_mps
        self._aircraft: dict[int, _CprState] = {}
        self._next_prune_s = -math.inf

    def _count(self, what: str) -> None:
        self.counters[self.prefix + what] += 1

    def decode(self, frame: BeastFrame, received_s: float) -> Observation | None:
        if frame.kind == 0x31:
            return self._count("mode_ac")
        if frame.kind == 0x32:
            return self._count("mode_s_short")
        df = frame.message[0] >> 3
        if df not in (17, 18):
            return self._count("mode_s_long_other")
        message = Message(frame.message)
        if message.crc_valid is not True:
            return self._count("crc_failed")
        if df == 18:
            cf = frame.message[0] & 0x7
            self._count(f"df18.cf{cf}")
            if cf != 0:
                return None
        receiver_s = frame.ticks / CLOCK_HZ if frame.ticks else None
        t = self.clock.align(receiver_s, received_s)
        address = int(message.icao, 16)
        decoded = message.decode()
        tc = decoded.get("typecode")
        state = self._state(address, received_s)
        if state is None:
            return None
        if tc is None or tc == 0:
            return self._count("tc0")
        if 1 <= tc <= 4:
            return self._identification(address, t, received_s, tc, decoded)
        if 9 <= tc <= 18 or 20 <= tc <= 22:
            return self._position(address, t, received_s, tc, decoded, state)
        if tc == 19:
            return self._velocity(address, t, received_s, frame.message, decoded)
        if tc == 31:
            return self._status(address, t, received_s, decoded, state)
        if tc == 29 and decoded.get("subtype") == 1:
            nacp = decoded.get("nac_p")
            return Observation(address, t, received_s, nacp=nacp) if nacp else None
        if 5 <= tc <= 8:
            return self._count("surface_position")
        return self._count(f"tc{tc}_unused")

    def _state(self, address: int, now_s: float) -> _CprState | None:
        state = self._aircraft.get(address)
        if state is None:
            if now_s >= self._next_prune_s:  # bounded memory under address churn
                self._next_prune_s = now_s + FORGET_AFTER_S / 4
                for a in [a for a, s in self._aircraft.items() if now_s - s.heard_s > FORGET_AFTER_S]:
                    del self._aircraft[a]
            if len(self._aircraft) >= MAX_AIRCRAFT:
                return self._count("too_many_aircraft")
            state = self._aircraft[address] = _CprState()
        state.heard_s = max(state.heard_s, now_s)
        return state

    def _identification(self, address, t, received_s, tc, decoded) -> Observation:
        callsign = decoded.get("callsign") or None
        if callsign is not None and "#" in callsign:
            self._count("callsign_invalid")  # a 6-bit code outside the Mode S character set
            callsign = None
        category = decoded.get("category", 0)
        emitter = EMITTER_TYPE.get((tc, category), 0) if category else 0
        return Observation(address, t, received_s, callsign=callsign, emitter_type=emitter)

    def _position(self, address, t, received_s, tc, decoded, state: _CprState) -> Observation | None:
        fmt, lat_raw, lon_raw = decoded["cpr_format"], decoded["cpr_lat"], decoded["cpr_lon"]
        position = self._cpr(state, fmt, lat_raw, lon_raw, t)
        state.frames[fmt].append((lat_raw, lon_raw, t))
        if position is None:
            return None  # not (yet) consistent with the aircraft's other messages: nothing of it is used
        obs = Observation(address, t, received_s, lat_deg=position[0], lon_deg=position[1],
                          nic=nic_of_type_code(tc, state.version, state.nic_a, decoded.get("nic_b", 0)))
        if tc <= 18:
            altitude_ft = decoded.get("altitude")
            if altitude_ft is None:
                self._count("altitude_unavailable")
            else:
                obs.altitude_m, obs.altitude_datum = altitude_ft * FT, AltitudeDatum.PRESSURE
        else:
            self._count("gnss_height_unused")
        return obs

    def _reachable(self, lat1: float, lon1: float, t1: float, lat2: float, lon2: float, t2: float) -> bool:
        """Can the aircraft have flown from one position to the other in the time between them?"""
        reach = self.max_ground_speed_mps * abs(t2 - t1) + POSITION_MARGIN_M
        return _distance_m(lat1, lon1, lat2, lon2) <= reach

    def _cpr(self, state: _CprState, fmt: int, lat_raw: int, lon_raw: int, t: float) -> tuple[float, float] | None:
        """The message's position if it is accepted (module docstring, "Positions"), else None (counted)."""
        ref = state.position
        if ref is not None and abs(t - ref[2]) <= LOCAL_REFERENCE_MAX_S:
            lat, lon = _local(fmt, lat_raw, lon_raw, ref[0], ref[1])
            if self._reachable(ref[0], ref[1], ref[2], lat, lon, t):
                self._count("cpr_local")
                state.position = (lat, lon, t)
                return lat, lon
            self._count("cpr_implausible")  # the reference is kept; the message may still start a candidate
        for candidate in state.candidates:
            lat, lon = _local(fmt, lat_raw, lon_raw, candidate.lat, candidate.lon)
            if t - candidate.t <= PAIR_MAX_S and self._reachable(candidate.lat, candidate.lon, candidate.t,
                                                                 lat, lon, t):
                candidate.lat, candidate.lon, candidate.t = lat, lon, t
                candidate.confirmed.add(fmt)
                if len(candidate.confirmed) < 2:
                    return self._count("cpr_held")
                if ref is not None and abs(t - ref[2]) <= LOCAL_REFERENCE_MAX_S and ref[2] >= candidate.since:
                    state.candidates.remove(candidate)  # the reference is alive: messages confirmed it meanwhile
                    return self._count("cpr_contested")
                self._count("cpr_global")  # confirmed by both formats: the aircraft's reference
                state.position = (lat, lon, t)
                state.candidates.clear()
                return lat, lon
        pair = self._pair(state, fmt, lat_raw, lon_raw, t)
        if pair is not None:
            self._count("cpr_held")
            candidates = [c for c in state.candidates if t - c.t <= PAIR_MAX_S]
            if len(candidates) >= MAX_CANDIDATES:  # the least confirmed, then the oldest, makes room
                candidates.remove(min(candidates, key=lambda c: (len(c.confirmed), c.t)))
            state.candidates = candidates + [_Candidate(pair[0], pair[1], t)]
        return None

    def _pair(self, state: _CprState, fmt: int, lat_raw: int, lon_raw: int, t: float) -> tuple[float, float] | None:
        """The message's position decoded globally with the newest message of the other format at most PAIR_MAX_S
        away whose own position (the same pair decoded at its time) the aircraft can have flown from; None (counted
        by why) when there is none."""
        why = "cpr_no_pair"  # an aircraft's first position needs an even and an odd message
        for other_lat, other_lon, other_t in reversed(state.frames[1 - fmt]):
            if abs(t - other_t) > PAIR_MAX_S:
                continue
            even, odd = ((lat_raw, lon_raw), (other_lat, other_lon)) if fmt == 0 else ((other_lat, other_lon),
                                                                                        (lat_raw, lon_raw))
            this = airborne_position_pair(even[0], even[1], odd[0], odd[1], even_is_newer=fmt == 0)
            other = airborne_position_pair(even[0], even[1], odd[0], odd[1], even_is_newer=fmt == 1)
            if this is None or other is None:
                why = "cpr_zone_mismatch"  # the two straddle a longitude-zone boundary
                continue
            if self._reachable(other[0], other[1], other_t, this[0], this[1], t):
                return this
            why = "cpr_pair_inconsistent"  # two positions farther apart than it can fly: one of them is not true
        return self._count(why)

    def _velocity(self, address, t, received_s, message: bytes, decoded) -> Observation | None:
        obs = Observation(address, t, received_s)
        subtype = decoded.get("subtype")
        if subtype in (1, 2):
            me = int.from_bytes(message[4:11], "big")  # the 56-bit ME field
            ew, ns = (me >> 32) & 0x3FF, (me >> 21) & 0x3FF
            if ew and ns:  # 0: no velocity information
                scale = KT * (4 if subtype == 2 else 1)  # subtype 2: supersonic, 4 kt steps
                east = (ew - 1) * scale * (-1 if (me >> 42) & 1 else 1)
                north = (ns - 1) * scale * (-1 if (me >> 31) & 1 else 1)
                obs.velocity_en_mps = (east, north)
            else:
                self._count("velocity_unavailable")
        elif subtype in (3, 4):
            self._count("velocity_airspeed")  # heading and airspeed, not a ground velocity
        else:
            return self._count("velocity_subtype_unknown")
        rate = decoded.get("vertical_rate")
        if rate is not None:
            obs.vertical_rate_mps = rate * FPM
        nacv = decoded.get("nac_v")
        obs.nacv = nacv if nacv else None
        if obs.velocity_en_mps is None and obs.vertical_rate_mps is None:
            return None
        return obs

    def _status(self, address, t, received_s, decoded, state: _CprState) -> Observation | None:
        if decoded.get("subtype") != 0:
            return self._count("surface_status")
        version = decoded.get("version")
        state.version = version
        state.nic_a = decoded.get("nic_supplement_a", 0)
        if version not in (1, 2):
            return None  # version 0 (DO-260) has no NACp
        nacp = decoded.get("nac_p")
        return Observation(address, t, received_s, nacp=nacp) if nacp else None


class BeastParser:
    """One Beast stream -> IntruderReports: the deframer, the decoder and the shared per-aircraft merge."""

    def __init__(self, path: str, config, counters: Counter):
        self.deframer = BeastDeframer(counters)
        self.decoder = BeastDecoder(counters, ReceiverClock(config.traffic.clock_window_s, wrap_s=CLOCK_WRAP_S),
                                    config.input.max_ground_speed_mps)
        self.merge = AircraftMerge(path, config, counters)
        self._logged = False  # the first decoding fault is logged with its traceback, the others counted

    def reset(self) -> None:
        """A new connection: a partial frame of the old one is dropped; aircraft and CPR state are kept."""
        self.deframer.reset()

    def feed(self, data: bytes, received_s: float) -> list:
        reports = []
        for frame in self.deframer.feed(data):
            try:
                obs = self.decoder.decode(frame, received_s)
            except Exception:  # noqa: BLE001  (one message's fault: counted and logged; the stream goes on)
                self.decoder.counters[self.decoder.prefix + "decode_errors"] += 1
                if not self._logged:
                    self._logged = True
                    log.exception("beast: a frame could not be decoded: %s", frame.message.hex())
                continue
            if obs is not None:
                report = self.merge.observe(obs)
                if report is not None:
                    reports.append(report)
        return reports


def make_session(path: str, target: str, config):
    """The feed framework's session (feeds/source.py) for `--traffic beast:HOST:PORT`: connect, read, parse, emit
    until the connection fails. The aircraft, CPR and clock state outlive a connection (a receiver that comes back
    within LOCAL_REFERENCE_MAX_S needs no new even/odd pair); a partial frame does not."""
    from avionics.io.feeds.source import parse_host_port
    from avionics.io.feeds.transport import tcp_chunks

    host, port = parse_host_port(path, target)
    counters: Counter = Counter()  # the parser's, handed to each session's ctx.counters after every chunk
    parser = BeastParser(path, config, counters)

    def session(ctx) -> None:
        parser.reset()
        try:
            for chunk, received_s in tcp_chunks(host, port, ctx):
                for report in parser.feed(chunk, received_s):
                    ctx.emit(report)
                ctx.counters.update(counters)
                counters.clear()
                ctx.flush()
        finally:
            ctx.counters.update(counters)
            counters.clear()

    return session
