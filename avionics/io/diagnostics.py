"""Wiring diagnostics: the integration mistakes that leave DAA silent, named while they happen (issue 26).

The rules live here; the live loop's input (loop.py MavlinkInput, receiver feeds: feeds/source.py TrafficSource)
puts the active ones on SourceStatus.wiring, the facade (daa.py) carries them to DaaResult.wiring and the status
topic, and the ports announce each onset (ports.py: one STATUSTEXT, a WARNING line on stderr repeated every
REPEAT_S while it lasts). Only `avionics run` on a live link runs them (a log has no live wiring to check). The
facade adds one rule of its own to the same path: `ra_inhibited` (advisory/inhibits.py RaInhibitWatch).

Rules (docs/integration.md, "What stderr tells you"):
- `no_mavlink`: no MAVLink message for mavlink.silence_warn_s (4 s: MAVLink's heartbeat service expects 1 Hz and
  "four or five" missed HEARTBEATs to mean a lost link, mavlink.io/en/services/heartbeat.html).
- `ownship_other_system`: no GLOBAL_POSITION_INT from mavlink.source_system for that long while another system sends
  it (the vehicle's SYSID differs from the configuration); `no_ownship_stream`: no GLOBAL_POSITION_INT at all
  though MAVLink arrives (the autopilot streams no position to this port).
- `untrusted_traffic`: ADSB_VEHICLE from another system, ignored (io/senders.py; a component of our own system is
  announced apart, as "SPOOF?"); `signing`: frames rejected by MAVLink 2 signing (io/signing.py counters).
- `feed:<path>`: a receiver feed (--traffic) that failed and is not connected (feeds/source.py FeedHealth).
- `no_pressure`: no SCALED_PRESSURE from the ownship for input.pressure_timeout_s while it is needed: the profile
  chooses sensitivity levels by pressure altitude (a level above the AGL bands with a finite ceiling: tcas2), or
  pressure-altitude traffic was reported in the last TRAFFIC_MEMORY_S (docs/altitude.md, rules 1 and 3).
- `ownship_rate`: GLOBAL_POSITION_INT from the ownship slower than mavlink.min_ownship_hz (docs/configuration.md
  gives the reason for 2 Hz), measured over RATE_WINDOW_S, with RATE_TOLERANCE for the sender's jitter.
"""

from __future__ import annotations

import math
from collections import Counter, deque
from dataclasses import dataclass

from avionics.contract.mavlink import STATUSTEXT_LEN

RATE_WINDOW_S = 3.0  # the ownship rate is the mean over this long (a rule is named within 5 s of its cause)
RATE_TOLERANCE = 0.8  # warn below this share of min_ownship_hz: a stream at exactly the minimum does not flap
TRAFFIC_MEMORY_S = 10.0  # pressure-altitude traffic or an untrusted sender counts this long after its last report
SIGNING_COUNTERS = ("signing.unsigned", "signing.bad_signature", "signing.replayed", "signing.old_stream")
PRESSURE_ALTITUDE = 0  # ADSB_ALTITUDE_TYPE_PRESSURE_QNH (decode.py ALTITUDE_TYPES)
VALID_ALTITUDE = 2  # ADSB_FLAGS_VALID_ALTITUDE


@dataclass(frozen=True, slots=True)
class Diagnostic:
    """One active wiring condition: key (what it is, stable while it lasts), text (STATUSTEXT, at most 50
    characters, upper case as the other announcements) and message (the stderr line and the status warning, naming
    the ids, the configuration key and the remedy)."""

    key: str
    text: str
    message: str

    def as_dict(self) -> dict:
        return {"key": self.key, "text": self.text, "message": self.message}


MESSAGE_LEN = 256  # the monitor's limit on a status warning (monitor/schema.py MAX_TEXT_LEN)


def _diag(key: str, text: str, message: str) -> Diagnostic:
    """A Diagnostic with its text and message cut to what STATUSTEXT and a status warning hold."""
    clip = message if len(message) <= MESSAGE_LEN else message[:MESSAGE_LEN - 1] + "…"
    return Diagnostic(key, text[:STATUSTEXT_LEN], clip)


def profile_needs_pressure(profile) -> bool:
    """Does the profile choose its sensitivity level by pressure altitude? (a level above the AGL bands with a finite
    ceiling: tcas2's SL 4-7; advisory/tables.py select_level, GNSS altitude without pressure)"""
    return any(not level.agl_band and math.isfinite(level.ceiling_m) for level in profile.levels)


class WiringDiagnostics:
    """The MAVLink-side rules. observe(msgs, now_s) sees every authentic message the link delivered (before the
    decoder's choices); conditions(now_s) -> the active Diagnostics. senders: the decoder's io/senders.py Senders
    (the ownship component and the untrusted traffic senders it rejected)."""

    def __init__(self, config, counters: Counter, senders, profile_name: str, needs_pressure: bool,
                 start_s: float = 0.0):
        m = config.mavlink
        self.connection = m.connection
        self.system = m.source_system
        self.silence_s = m.silence_warn_s
        self.min_hz = m.min_ownship_hz
        self.pressure_timeout_s = config.input.pressure_timeout_s
        self.counters = counters
        self.senders = senders
        self.profile_name = profile_name
        self.needs_pressure = needs_pressure
        self.start_s = start_s
        self.last_message_s: float | None = None
        self.own_gpi: deque[float] = deque()  # times of the ownship's GLOBAL_POSITION_INT within RATE_WINDOW_S
        self.first_own_gpi_s: float | None = None
        self.last_own_gpi_s: float | None = None
        self.other_gpi: dict[int, float] = {}  # another system -> its last GLOBAL_POSITION_INT
        self.last_pressure_s: float | None = None
        self.pressure_traffic_s: float | None = None  # the last ADSB_VEHICLE with a pressure altitude
        self._signing_seen = 0  # signing rejections counted up to the last check
        self._signing_s: float | None = None  # when the count last grew

    def observe(self, msgs, now_s: float) -> None:
        if msgs:
            self.last_message_s = now_s
        for msg in msgs:
            kind = msg.get_type()
            if kind == "GLOBAL_POSITION_INT":
                system = msg.get_srcSystem()
                if system != self.system:
                    self.other_gpi[system] = now_s
                elif msg.get_srcComponent() == self.senders.ownship_component:
                    self.own_gpi.append(now_s)
                    self.last_own_gpi_s = now_s
                    if self.first_own_gpi_s is None:
                        self.first_own_gpi_s = now_s
            elif kind == "SCALED_PRESSURE":
                if (msg.get_srcSystem(), msg.get_srcComponent()) == (self.system, self.senders.ownship_component):
                    self.last_pressure_s = now_s
            elif kind == "ADSB_VEHICLE" and msg.flags & VALID_ALTITUDE and msg.altitude_type == PRESSURE_ALTITUDE:
                self.pressure_traffic_s = now_s

    def conditions(self, now_s: float) -> tuple[Diagnostic, ...]:
        out = []
        untrusted = self._untrusted(now_s)
        since = self.last_message_s if self.last_message_s is not None else self.start_s
        if any(d.key == "signing" for d in untrusted):
            pass  # frames arrive but fail signing: that is the cause to name, not a silent link
        elif now_s - since >= self.silence_s:
            out.append(_diag(
                "no_mavlink", f"NO MAVLINK FOR {now_s - since:.0f} S",
                f"no MAVLink message for {now_s - since:.0f} s on {self.connection} (mavlink.connection): check the "
                "autopilot's telemetry port, its baud rate and where it sends (DAA has no ownship and no MAVLink "
                "traffic)"))
        elif self.last_message_s is not None:
            out.extend(self._ownship(now_s))
        return tuple(out + untrusted)

    def _ownship(self, now_s: float) -> list[Diagnostic]:
        out = []
        since = self.last_own_gpi_s if self.last_own_gpi_s is not None else self.start_s
        if now_s - since >= self.silence_s:
            others = sorted(s for s, t in self.other_gpi.items() if now_s - t < self.silence_s)
            key = "mavlink.source_system"
            if others:
                names = ", ".join(map(str, others))
                out.append(_diag(
                    "ownship_other_system", f"OWNSHIP? GPI FROM SYS {names}, NOT {self.system}",
                    f"no GLOBAL_POSITION_INT from system {self.system} ({key} = {self.system}) for "
                    f"{now_s - since:.0f} s while system {names} sends it: no ownship, no advisories; if system "
                    f"{others[0]} is this vehicle, set {key} = {others[0]}"))
            else:
                out.append(_diag(
                    "no_ownship_stream", f"NO GLOBAL_POSITION_INT FROM SYS {self.system}",
                    f"no GLOBAL_POSITION_INT from system {self.system} ({key}) for {now_s - since:.0f} s though "
                    "MAVLink arrives: no ownship, no advisories; ask the autopilot for its position stream on this "
                    "port (ArduPilot SRn_POSITION, PX4 `mavlink stream -s GLOBAL_POSITION_INT`)"))
            return out
        while self.own_gpi and now_s - self.own_gpi[0] > RATE_WINDOW_S:
            self.own_gpi.popleft()
        if self.first_own_gpi_s is not None and now_s - self.first_own_gpi_s >= RATE_WINDOW_S:
            times = self.own_gpi  # the mean rate of the intervals in the window (n / window undercounts by one)
            span = times[-1] - times[0] if len(times) >= 2 else 0.0
            hz = (len(times) - 1) / span if span > 0.0 else len(times) / RATE_WINDOW_S
            if hz < RATE_TOLERANCE * self.min_hz:
                out.append(_diag(
                    "ownship_rate", f"OWNSHIP GPI {hz:.1f} HZ, NEED {self.min_hz:g} HZ",
                    f"GLOBAL_POSITION_INT from {self.system}:{self.senders.ownship_component} at {hz:.1f} Hz, below "
                    f"the {self.min_hz:g} Hz the ownship state needs (mavlink.min_ownship_hz): raise the autopilot's "
                    "position stream rate (ArduPilot SRn_POSITION, PX4 `mavlink stream -s GLOBAL_POSITION_INT -r`)"))
        out.extend(self._pressure(now_s))
        return out

    def _pressure(self, now_s: float) -> list[Diagnostic]:
        traffic = self.pressure_traffic_s is not None and now_s - self.pressure_traffic_s <= TRAFFIC_MEMORY_S
        if not (self.needs_pressure or traffic):
            return []
        # counted from the ownship's first position: without one, the missing position is what is named
        since = self.last_pressure_s if self.last_pressure_s is not None else self.first_own_gpi_s
        if since is None or now_s - since < self.pressure_timeout_s:
            return []
        why = (f"profile {self.profile_name} selects sensitivity levels by pressure altitude (GNSS altitude used "
               "instead)" if self.needs_pressure else
               "pressure-altitude traffic is compared with GNSS altitude, vertical thresholds widened (docs/altitude.md)")
        return [_diag(
            "no_pressure", f"NO SCALED_PRESSURE FROM {self.system}:{self.senders.ownship_component}",
            f"no SCALED_PRESSURE from {self.system}:{self.senders.ownship_component} for {now_s - since:.0f} s "
            f"(input.pressure_timeout_s {self.pressure_timeout_s:g} s): {why}; ask the autopilot for it "
            "(ArduPilot SRn_RAW_SENS)")]

    def _untrusted(self, now_s: float) -> list[Diagnostic]:
        out = []
        untrusted = sorted((s, c) for (s, c), t in self.senders.untrusted.items() if now_s - t <= TRAFFIC_MEMORY_S)
        if untrusted:
            first = f"{untrusted[0][0]}:{untrusted[0][1]}"
            more = f" +{len(untrusted) - 1}" if len(untrusted) > 1 else ""
            out.append(_diag(
                "untrusted_traffic", f"TRAFFIC FROM {first}{more} NOT TRUSTED, IGNORED",
                f"ADSB_VEHICLE from {', '.join(f'{s}:{c}' for s, c in untrusted)} ignored: not a trusted traffic "
                f"source (mavlink.traffic_sources; empty: the receivers of system {self.system}, mavlink.source_system"
                f"); if it is this vehicle's receiver, add \"{first}\" to mavlink.traffic_sources"))
        rejected = sum(self.counters.get(k, 0) for k in SIGNING_COUNTERS)
        if rejected > self._signing_seen:
            self._signing_seen, self._signing_s = rejected, now_s
        if self._signing_s is not None and now_s - self._signing_s <= TRAFFIC_MEMORY_S:
            counts = ", ".join(f"{self.counters[k]} {k.split('.')[1].replace('_', ' ')}" for k in SIGNING_COUNTERS
                               if self.counters.get(k))
            out.append(_diag(
                "signing", "MAVLINK FRAMES REJECTED: SIGNING",
                f"MAVLink frames rejected by signing ({counts}; mavlink.signing_key_file, "
                "mavlink.signing_required): the sender has another key, or none"))
        return out


def wiring_diagnostics(config, counters: Counter, senders) -> WiringDiagnostics:
    """The rules for config's link and profile (loaded here for its sensitivity levels: advisory/tables.py)."""
    from avionics.advisory.tables import load_profile  # noqa: PLC0415  (io does not import the advisory at load)

    profile = load_profile(config.advisory.profile, config.advisory.profile_overrides)
    return WiringDiagnostics(config, counters, senders, profile.name, profile_needs_pressure(profile))


def feed_diagnostics(feeds) -> tuple[Diagnostic, ...]:
    """A receiver feed (feeds/source.py FeedHealth) that failed and is not connected; one still making its first
    connection is not (as daa.py traffic_down)."""
    return tuple(_diag(f"feed:{f.path}", f"TRAFFIC FEED DOWN {f.path}"[:STATUSTEXT_LEN], f.warning)
                 for f in feeds if not f.connected and f.error is not None)


REPEAT_S = 60.0  # a condition that lasts is logged again this often; a STATUSTEXT only at its onset


class Announcements:
    """Which conditions to announce now: due(conditions, now_s) -> (onsets, repeats, ended keys). An onset is a key
    not active at the last call and not announced within REPEAT_S (a flapping condition is one announcement a
    minute); a repeat is an active key last announced REPEAT_S ago."""

    def __init__(self, repeat_s: float = REPEAT_S):
        self.repeat_s = repeat_s
        self.active: set[str] = set()  # the keys active at the last call
        self._said: dict[str, float] = {}  # key -> when it was last announced

    def due(self, conditions, now_s: float) -> tuple[list, list, list]:
        onsets, repeats = [], []
        keys = {d.key for d in conditions}
        for d in conditions:
            said = self._said.get(d.key)
            if said is not None and now_s - said < self.repeat_s:
                continue
            (repeats if d.key in self.active else onsets).append(d)
            self._said[d.key] = now_s
        ended = sorted(self.active - keys)
        self.active = keys
        if len(self._said) > 1024:  # bounded: feeds and senders name keys
            self._said = {k: t for k, t in self._said.items() if now_s - t < self.repeat_s}
        return onsets, repeats, ended
