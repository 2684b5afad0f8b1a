"""Per-aircraft merge of a receiver's partial messages into IntruderReports, with the MAVLink path's checks.

A receiver reports an aircraft piecewise: SBS MSG,3 (airborne position and altitude), MSG,4 (velocity and vertical
rate), MSG,1 (callsign), MSG,5/7 (altitude), MSG,6 (squawk); Beast frames are single Mode S messages (DF17 TC 9-18
position, TC 19 velocity, TC 1-4 identification, TC 31 NACp); a readsb aircraft.json entry has all of them at once.
Each message becomes an `Observation` (any subset of fields, SI units, time on our loop clock); `AircraftMerge`
keeps the latest value of every field per address and makes a report when a new position arrives, with the other
fields when they are recent (traffic.merge_max_age_s before the position's time; callsign, squawk and emitter type
while the aircraft is heard).

Validation is the MAVLink decoder's (avionics/io/checks.py, InputConfig limits, [vehicle] own_icao): a field that
fails is dropped and counted `traffic.<scheme>.rejected.<reason>`; the observation is then used without it. A
position that fails, or comes too late (input.max_report_age_s after its time), or is not newer than the address's
last one, makes no report. Counters go to the Counter given (`traffic.<scheme>.reports`, `.rejected.<reason>`).

Accuracy: a NACp (1..11) becomes the report's position_sigma_m through the DO-260B / ED-102A EPU bound (95 %,
`NACP_EPU_M`) and tracking/integrity.py position_sigma_per_axis; a NACv (1..4) the velocity_sigma_mps through
`NACV_HFOM_MPS`; without them (0, unknown or absent) the source's configured defaults (traffic.<scheme>_*_sigma_*).
"""

from __future__ import annotations

import math
from collections import Counter
from dataclasses import dataclass

from avionics.base.types import AddressSource, AltitudeDatum, IntruderKey, IntruderReport
from avionics.io.checks import (
    address_problem, altitude_problem, position_problem, speed_problem, squawk_valid, vertical_rate_problem,
)
from avionics.tracking.integrity import position_sigma_per_axis

# Navigation Accuracy Category for Position -> Estimated Position Uncertainty bound (95 % horizontal), metres.
# RTCA DO-260B Table 2-70 (= EUROCAE ED-102A; also DO-282B for UAT): NACp 1 < 10 NM, 2 < 4 NM, 3 < 2 NM, 4 < 1 NM,
# 5 < 0.5 NM, 6 < 0.3 NM, 7 < 0.1 NM, 8 < 0.05 NM, 9 < 30 m, 10 < 10 m, 11 < 3 m. NACp 0: unknown (>= 10 NM).
NACP_EPU_M = {1: 18520.0, 2: 7408.0, 3: 3704.0, 4: 1852.0, 5: 926.0, 6: 555.6, 7: 185.2, 8: 92.6, 9: 30.0,
              10: 10.0, 11: 3.0}
# Navigation Accuracy Category for Velocity -> horizontal velocity error bound (95 %), m/s. DO-260B Table 2-22
# (ED-102A): NACv 1 < 10 m/s, 2 < 3 m/s, 3 < 1 m/s, 4 < 0.3 m/s. NACv 0: unknown (>= 10 m/s).
NACV_HFOM_MPS = {1: 10.0, 2: 3.0, 3: 1.0, 4: 0.3}
MAX_EMITTER_TYPE = 19  # MAVLink ADSB_EMITTER_TYPE: 0 NO_INFO ... 19 POINT_OBSTACLE (common.xml)
# Category set/letter (DO-260B 2.2.3.2.5.2: A1..A7, B1..B7, C1..C7; readsb "category") -> ADSB_EMITTER_TYPE.
_CATEGORY_EMITTER = {"A1": 1, "A2": 2, "A3": 3, "A4": 4, "A5": 5, "A6": 6, "A7": 7, "B1": 9, "B2": 10, "B3": 11,
                     "B4": 12, "B6": 14, "B7": 15, "C1": 17, "C2": 18, "C3": 19}
# Aircraft not heard for this long are forgotten (bounded memory). 60 s: readsb's own aircraft timeout (it drops an
# aircraft from aircraft.json 60 s after its last message), far beyond any track's life (tracking.delete_after_s).
FORGET_AFTER_S = 60.0
# More aircraft than this from one source are refused (counted): bounded memory under address churn (garbage that
# decodes to random addresses). Four times the largest traffic the bench measures (1000 intruders,
# docs/performance.md); a receiver hears a few hundred at the busiest sites.
MAX_AIRCRAFT = 4000


def emitter_type_of_category(category: str | None) -> int | None:
    """A DO-260B emitter category ("A3") as MAVLink ADSB_EMITTER_TYPE (3 = LARGE); None when unknown."""
    return _CATEGORY_EMITTER.get(category.strip().upper()) if isinstance(category, str) else None


def nacp_sigma_m(nacp: int | None) -> float | None:
    """The 1-sigma per-axis position error of a NACp, None when it says nothing (0, unknown, absent)."""
    epu = NACP_EPU_M.get(nacp) if isinstance(nacp, int) else None
    return None if epu is None else position_sigma_per_axis(epu)


def nacv_sigma_mps(nacv: int | None) -> float | None:
    """The 1-sigma per-axis velocity error of a NACv (the same 95 % circular bound conversion), or None."""
    bound = NACV_HFOM_MPS.get(nacv) if isinstance(nacv, int) else None
    return None if bound is None else position_sigma_per_axis(bound)


@dataclass(slots=True)
class Observation:
    """What one receiver message says of one aircraft (any subset of fields), SI units, time on our loop clock."""

    address: int
    time_s: float  # time of applicability, already aligned to our clock
    received_s: float
    address_source: AddressSource = AddressSource.ES1090
    lat_deg: float | None = None
    lon_deg: float | None = None
    altitude_m: float | None = None
    altitude_datum: AltitudeDatum | None = None
    velocity_en_mps: tuple[float, float] | None = None
    vertical_rate_mps: float | None = None
    callsign: str | None = None
    squawk: int | None = None
    emitter_type: int | None = None
    nacp: int | None = None
    nacv: int | None = None
    nic: int | None = None


class _Aircraft:
    """The latest value of each field of one address, with its time (loop clock)."""

    __slots__ = ("heard_s", "position_s", "altitude", "altitude_s", "velocity", "velocity_s", "vertical_rate",
                 "vertical_rate_s", "callsign", "squawk", "emitter_type", "nacp", "nacv", "nic")

    def __init__(self) -> None:
        self.heard_s = -math.inf
        self.position_s = -math.inf
        self.altitude: tuple[float, AltitudeDatum] | None = None
        self.altitude_s = -math.inf
        self.velocity: tuple[float, float] | None = None
        self.velocity_s = -math.inf
        self.vertical_rate: float | None = None
        self.vertical_rate_s = -math.inf
        self.callsign: str | None = None
        self.squawk: int | None = None
        self.emitter_type = 0
        self.nacp: int | None = None
        self.nacv: int | None = None
        self.nic: int | None = None


def _number(value) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)


class AircraftMerge:
    """Per-address latest fields; a report when a new position arrives (with the other fields if recent)."""

    def __init__(self, path: str, config, counters: Counter):
        """path: the source, e.g. "sbs:127.0.0.1:30003" (its scheme names the counters and the default accuracy);
        config: the assembled configuration (its input, vehicle and traffic sections); counters: where to count."""
        self.path = path
        self.scheme = path.split(":", 1)[0]
        self.prefix = f"traffic.{self.scheme}."
        self.input = config.input
        self.own_icao = config.vehicle.own_icao
        self.max_age_s = config.traffic.merge_max_age_s
        self.default_sigmas = config.traffic.default_sigmas(self.scheme)
        self.counters = counters
        self._aircraft: dict[IntruderKey, _Aircraft] = {}
        self._next_prune_s = -math.inf

    def __len__(self) -> int:
        return len(self._aircraft)

    def _reject(self, reason: str) -> None:
        self.counters[f"{self.prefix}rejected.{reason}"] += 1

    def observe(self, obs: Observation) -> IntruderReport | None:
        """Merge one observation; the report it completes (a new, valid position) or None. Never raises on a
        value: every implausible field is counted and dropped."""
        if not (_number(obs.time_s) and _number(obs.received_s)) or not isinstance(obs.address, int):
            return self._reject("time_invalid" if isinstance(obs.address, int) else "address_out_of_range")
        if not isinstance(obs.address_source, AddressSource):
            return self._reject("address_source_unknown")
        problem = address_problem(self.own_icao, obs.address, obs.address_source is AddressSource.ES1090)
        if problem is not None:
            return self._reject(problem)
        key = IntruderKey(obs.address, obs.address_source)
        ac = self._aircraft.get(key)
        if ac is None:
            self._prune(obs.received_s)
            if len(self._aircraft) >= MAX_AIRCRAFT:
                return self._reject("too_many_aircraft")
            ac = self._aircraft[key] = _Aircraft()
        ac.heard_s = max(ac.heard_s, obs.received_s)
        self._fields(ac, obs)
        if obs.lat_deg is None and obs.lon_deg is None:
            return None
        return self._position(key, ac, obs)

    def _fields(self, ac: _Aircraft, obs: Observation) -> None:
        cfg, t = self.input, obs.time_s
        if obs.altitude_m is not None:
            if not _number(obs.altitude_m):
                self._reject("altitude_out_of_range")
            elif not isinstance(obs.altitude_datum, AltitudeDatum):
                self._reject("altitude_type_unknown")
            elif (problem := altitude_problem(cfg, obs.altitude_m)) is not None:
                self._reject(problem)
            elif t >= ac.altitude_s:
                ac.altitude, ac.altitude_s = (float(obs.altitude_m), obs.altitude_datum), t
        if obs.velocity_en_mps is not None:
            v = obs.velocity_en_mps
            if not (isinstance(v, tuple) and len(v) == 2 and _number(v[0]) and _number(v[1])):
                self._reject("velocity_invalid")
            elif (problem := speed_problem(cfg, math.hypot(*v))) is not None:
                self._reject(problem)
            elif t >= ac.velocity_s:
                ac.velocity, ac.velocity_s = (float(v[0]), float(v[1])), t
        if obs.vertical_rate_mps is not None:
            if not _number(obs.vertical_rate_mps):
                self._reject("vertical_rate_out_of_range")
            elif (problem := vertical_rate_problem(cfg, obs.vertical_rate_mps)) is not None:
                self._reject(problem)
            elif t >= ac.vertical_rate_s:
                ac.vertical_rate, ac.vertical_rate_s = float(obs.vertical_rate_mps), t
        if obs.callsign is not None:
            text = obs.callsign.strip() if isinstance(obs.callsign, str) else ""
            if text and len(text) <= 8 and text.isascii() and text.isprintable():  # 8 characters: DO-260B TC 1-4
                ac.callsign = text
            else:
                self._reject("callsign_invalid")
        if obs.squawk is not None:
            if isinstance(obs.squawk, int) and squawk_valid(obs.squawk):
                ac.squawk = obs.squawk
            else:
                self._reject("squawk_invalid")  # Mode A codes are four octal digits
        if obs.emitter_type is not None:
            if isinstance(obs.emitter_type, int) and 0 <= obs.emitter_type <= MAX_EMITTER_TYPE:
                ac.emitter_type = obs.emitter_type
            else:
                self._reject("emitter_type_invalid")
        for name, top in (("nacp", 11), ("nacv", 4), ("nic", 11)):  # DO-260B: NACp 0-11, NACv 0-4, NIC 0-11
            value = getattr(obs, name)
            if value is None:
                continue
            if isinstance(value, int) and 0 <= value <= top:
                setattr(ac, name, value)
            else:
                self._reject(f"{name}_invalid")

    def _position(self, key: IntruderKey, ac: _Aircraft, obs: Observation) -> IntruderReport | None:
        if obs.lat_deg is None or obs.lon_deg is None or not (_number(obs.lat_deg) and _number(obs.lon_deg)):
            return self._reject("position_invalid")
        problem = position_problem(obs.lat_deg, obs.lon_deg)
        if problem is not None:
            return self._reject(problem)
        t = obs.time_s
        if obs.received_s - t > self.input.max_report_age_s:
            return self._reject("stale")
        if t <= ac.position_s:
            return self._reject("not_newer")  # a repeated or reordered position: the tracker has it already
        ac.position_s = t
        recent = t - self.max_age_s
        altitude = ac.altitude if ac.altitude_s >= recent else None
        velocity = ac.velocity if ac.velocity_s >= recent else None
        vertical_rate = ac.vertical_rate if ac.vertical_rate_s >= recent else None
        position_sigma = nacp_sigma_m(ac.nacp)
        velocity_sigma = nacv_sigma_mps(ac.nacv)
        self.counters[f"{self.prefix}reports"] += 1
        return IntruderReport(
            key=key, time_s=t, received_s=obs.received_s, lat_deg=float(obs.lat_deg), lon_deg=float(obs.lon_deg),
            altitude_m=altitude[0] if altitude else None, altitude_datum=altitude[1] if altitude else None,
            velocity_en_mps=velocity, vertical_rate_mps=vertical_rate, callsign=ac.callsign, squawk=ac.squawk,
            emitter_type=ac.emitter_type,
            position_sigma_m=self.default_sigmas[0] if position_sigma is None else position_sigma,
            velocity_sigma_mps=self.default_sigmas[1] if velocity_sigma is None else velocity_sigma,
            path=self.path)

    def _prune(self, now_s: float) -> None:
        if now_s < self._next_prune_s:
            return
        self._next_prune_s = now_s + FORGET_AFTER_S / 4
        for key in [k for k, ac in self._aircraft.items() if now_s - ac.heard_s > FORGET_AFTER_S]:
            del self._aircraft[key]
