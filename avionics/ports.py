"""Output ports: what the DAA process tells the world, one small interface each (docs/architecture.md).

Every port gets every `DaaResult` (avionics/daa.py) and decides what to send and when: MAVLink (COLLISION,
DAA_ADVISORY, STATUSTEXT, HEARTBEAT), zenoh (advisories, tracks, ownship, status), a CSV of advisory changes, the
log. A port says before each step which of the result's costly parts it needs (`wants`): the tracks and the
status are computed only when some port publishes them then. Adding an output is one class and one line where
the loop is built.
"""

from __future__ import annotations

import csv
import logging
import math
from dataclasses import dataclass
from typing import IO, Protocol

from avionics.config import Config
from avionics.contract.advisory_csv import CSV_COLUMNS, GUIDANCE_CSV_COLUMNS, GUIDANCE_ROW
from avionics.base.schedule import Every
from avionics.base.types import UNAVAILABLE_REASONS, AddressSource, Advisory, AdvisoryLevel
from avionics.daa import DaaResult
from avionics.io import encode
from avionics.io.diagnostics import Announcements
from avionics.io.payloads import (
    advisory_payload, bands_payload, guidance_payload, ownship_payload, status_payload, track_payload,
)
from avionics.io.sinks import SinkHealth
from avionics.io.traffic import TrafficBatch


@dataclass(frozen=True, slots=True)
class Demand:
    """The result's costly parts a port needs: the status in the coming step; the track views within
    tracks_within_s (they are built in slices and come with the result of the step that completes them: a port
    that asks for them takes the next result that has them)."""

    tracks: bool = False
    status: bool = False
    tracks_within_s: float = 0.0

    def __or__(self, other: "Demand") -> "Demand":
        within = min((d.tracks_within_s for d in (self, other) if d.tracks), default=0.0)
        return Demand(self.tracks or other.tracks, self.status or other.status, within)


NOTHING = Demand()

# the track views a port asks for are built over at most this share of its period (pipeline/views.py ViewRound):
# a slice a step, so a fresh report never waits behind all of them, and done well before the next demand
VIEWS_WITHIN_PERIODS = 0.5


class OutputPort(Protocol):
    def wants(self, now_s: float) -> Demand:
        """What the port will publish from the result of the step at now_s (called once per step, before it)."""

    def publish(self, result: DaaResult) -> None:
        """Send what is due. A port's fault is contained by the loop: the others still publish."""

    def close(self) -> None:
        """Flush and release; called once, after the final result."""


class AdvisoryRefresh:
    """An active advisory is repeated every collision_refresh_s, so that a lost message or a late subscriber
    still sees it; a change restarts its period, NONE ends it."""

    def __init__(self, period_s: float):
        self.period_s = period_s
        self._due: dict = {}  # intruder -> next refresh time
        self._earliest = math.inf  # no refresh is due before this (the steps between cost nothing)

    def due(self, result: DaaResult) -> list[Advisory]:
        """Call after announcing result.changes (see changed()): the active advisories to repeat now."""
        now = result.time_s
        if now < self._earliest:
            return []
        out = []
        for key, due in list(self._due.items()):
            advisory = result.active.get(key)
            if now >= due and advisory is not None:
                out.append(advisory)
                self._due[key] = now + self.period_s
        self._earliest = min(self._due.values(), default=math.inf)
        return out

    def changed(self, advisory: Advisory, now_s: float) -> None:
        if advisory.level is AdvisoryLevel.NONE:
            self._due.pop(advisory.intruder, None)
        else:
            self._due[advisory.intruder] = now_s + self.period_s
            self._earliest = min(self._earliest, now_s + self.period_s)

    def clear(self) -> None:
        self._due.clear()
        self._earliest = math.inf


CALLSIGN_MEMORY_S = 300.0  # a callsign is remembered this long after its intruder was last seen


class CallsignMemory:
    """Callsigns outlive the track that had them (a restarted or failed track's new record has none until a report
    brings it; receivers send it only now and then): kept CALLSIGN_MEMORY_S after the intruder was last in a result
    (every intruder of the result once a second, the changed ones at once)."""

    def __init__(self):
        self._callsigns: dict = {}  # intruder -> (the last callsign known, when it was last an intruder of a result)
        self._next_prune_s = 0.0
        self._next_sweep_s = 0.0

    def remember(self, result: DaaResult) -> None:
        now = result.time_s
        if now >= self._next_sweep_s:
            self._next_sweep_s = now + 1.0
            seen = result.callsigns.items()
        else:
            seen = ((a.intruder, result.callsigns.get(a.intruder)) for a in result.changes)
        for key, callsign in seen:
            if callsign:
                self._callsigns[key] = (callsign, now)
            elif key in self._callsigns:
                self._callsigns[key] = (self._callsigns[key][0], now)
        for track in result.tracks or ():
            if track.callsign:
                self._callsigns[track.key] = (track.callsign, now)
        if now >= self._next_prune_s:
            self._next_prune_s = now + CALLSIGN_MEMORY_S
            for key in [k for k, (_, seen) in self._callsigns.items() if now - seen > CALLSIGN_MEMORY_S]:
                del self._callsigns[key]

    def callsign(self, result: DaaResult, intruder) -> str | None:
        """The intruder's callsign now, else the last one known, else None (a text then says its zenoh id)."""
        known = self._callsigns.get(intruder)
        return result.callsigns.get(intruder) or (known[0] if known else None)


class AdvisoryAnnouncements:
    """What the advisory ports (MAVLink and zenoh) send of each result: its changes, then the active advisories
    whose refresh is due, each with the callsign to name its intruder by. One refresh clock and one callsign memory
    for both ports (build one and give it to each), so that both send the same advisories at the same steps and
    name an intruder alike, also after its track was dropped. Computed once per result, whichever port asks first
    (a port whose publish fails does not take the other's refreshes with it)."""

    def __init__(self, refresh_period_s: float):
        self._refresh = AdvisoryRefresh(refresh_period_s)
        self._callsigns = CallsignMemory()
        self._result: DaaResult | None = None
        self._due: tuple = ((), ())

    @classmethod
    def of(cls, config: Config) -> "AdvisoryAnnouncements":
        return cls(config.mavlink.collision_refresh_s)

    def due(self, result: DaaResult) -> tuple[list, list]:
        """(changes, refreshes) of the result: lists of (advisory, callsign)."""
        if result is not self._result:
            self._callsigns.remember(result)
            now = result.time_s
            changes = [(a, self._callsigns.callsign(result, a.intruder)) for a in result.changes]
            for advisory in result.changes:
                self._refresh.changed(advisory, now)
            if result.final:
                self._refresh.clear()
            refreshes = [(a, self._callsigns.callsign(result, a.intruder)) for a in self._refresh.due(result)]
            self._result, self._due = result, (changes, refreshes)  # after: a raise is not remembered as done
        return self._due


REJECTED_SENDER_REPEAT_S = 10.0  # a rejected sender that goes on is announced again this often


class RejectedSenders:
    """When to announce the components of our vehicle rejected as a source (DaaResult.rejected_senders): a new one
    at once, each again every period_s while it goes on (an autopilot or ground station that joins the link later
    hears it), all of one step in one text ("+N": a forger cycling component ids costs one STATUSTEXT a step)."""

    def __init__(self, period_s: float):
        self.period_s = period_s
        self._announced: dict = {}  # suspect -> when it was last announced

    def due(self, result: DaaResult) -> str | None:
        now = result.time_s
        active = result.rejected_senders
        if len(self._announced) > len(active):
            self._announced = {k: t for k, t in self._announced.items() if k in active}
        due = [k for k in active if now - self._announced.get(k, -math.inf) >= self.period_s]
        if not due:
            return None
        for key in due:
            self._announced[key] = now
        text = encode.rejected_sender_text(*due[0])
        return text if len(due) == 1 else f"{text} +{len(due) - 1}"[:encode.STATUSTEXT_LEN]


REBROADCAST_MAX = 50  # ADSB_VEHICLE per re-broadcast cycle (a ground station's display; ~2 kB at 1 Hz)


class MavlinkOut:
    """MAVLink to the autopilot and the ground station (docs/mavlink.md): per advisory change COLLISION,
    DAA_ADVISORY and STATUSTEXT; active ones refreshed; a DO-365 alerter's bands as DAA_BANDS once a second;
    availability changes and rejected senders (a component of our vehicle posing as the autopilot or a receiver)
    as STATUSTEXT; HEARTBEAT with
    system_status STANDBY (no ownship fix yet) / ACTIVE / CRITICAL (DAA unavailable) / POWEROFF (stopped). An
    intruder is named by its callsign whenever one was ever known, also after its track is gone. send: a link's
    send(msg). sinks: the output sinks' health (avionics/io/sinks.py): each new fault is one STATUSTEXT.
    advisories: the announcements shared with the zenoh port (without one, its own)."""

    def __init__(self, send, config: Config, send_as=None, sinks: SinkHealth | None = None,
                 advisories: AdvisoryAnnouncements | None = None):
        self._send = send
        self._sinks = sinks
        self._sink_faults_sent = 0
        self._statustext = config.mavlink.statustext
        self._request_action = config.mavlink.collision_action_request
        # the fused traffic for ground stations: ADSB_VEHICLE from our re-broadcast component (send_as(msg, comp):
        # the link's; without it, send), at most traffic_rebroadcast_hz and REBROADCAST_MAX tracks per cycle
        m = config.mavlink
        self._rebroadcast = Every(1.0 / m.traffic_rebroadcast_hz) if m.traffic_rebroadcast else None
        self._rebroadcast_component = m.traffic_rebroadcast_component
        self._send_as = send_as if send_as is not None else (lambda msg, _component: send(msg))
        self._rebroadcast_wanted = False  # asked for the track views, not rebroadcast yet
        self._heartbeat = Every(1.0 / config.mavlink.heartbeat_hz)
        self._advisories = advisories or AdvisoryAnnouncements.of(config)
        self._rejected = RejectedSenders(REJECTED_SENDER_REPEAT_S)
        # io/diagnostics.py: one STATUSTEXT per wiring condition's onset (stderr repeats it, not the autopilot's
        # screen); all the active ones again when MAVLink arrives after none (an autopilot that joins a udpin link
        # late, or comes back, hears what went wrong before it could)
        self._wiring = Announcements()

    def wants(self, now_s: float) -> Demand:
        if self._rebroadcast is None or not self._rebroadcast.due(now_s):
            return NOTHING
        self._rebroadcast_wanted = True
        return Demand(tracks=True, tracks_within_s=VIEWS_WITHIN_PERIODS * self._rebroadcast.period_s)

    def publish(self, result: DaaResult) -> None:
        now = result.time_s
        changes, refreshes = self._advisories.due(result)
        for advisory, callsign in changes:
            self._advisory(advisory, callsign)
            if self._statustext:
                self._send(encode.statustext(encode.advisory_text(advisory, callsign),
                                             encode.advisory_severity(advisory)))
        for advisory, callsign in refreshes:
            self._advisory(advisory, callsign)
        for message in encode.daa_bands(result.bands) if result.bands is not None else ():
            self._send(message)
        if result.availability_changed and self._statustext:
            reason = result.unavailable_reason
            self._send(encode.statustext(
                encode.availability_text(reason, result.fault_detail),
                encode.mavlink2.MAV_SEVERITY_NOTICE if reason is None else encode.mavlink2.MAV_SEVERITY_WARNING))
        if self._sinks is not None and self._statustext:
            for fault in self._sinks.since(self._sink_faults_sent):
                self._sink_faults_sent += 1  # counted first: a failing send is not repeated at every step
                self._send(encode.statustext(encode.output_fault_text(fault), encode.mavlink2.MAV_SEVERITY_WARNING))
        rejected = self._rejected.due(result) if self._statustext and result.rejected_senders else None
        if rejected is not None:
            self._send(encode.statustext(rejected, encode.mavlink2.MAV_SEVERITY_WARNING))
        if self._statustext and (result.wiring or self._wiring.active) and not result.final:
            onsets, repeats, ended = self._wiring.due(result.wiring, now)
            due = result.wiring if "no_mavlink" in ended else onsets
            for diagnostic in due:
                self._send(encode.statustext(diagnostic.text, encode.mavlink2.MAV_SEVERITY_WARNING))
        for command in (*result.guidance_commands, *result.guidance_reads):  # to the autopilot (avionics/guidance)
            self._send(command)
        if result.guidance_changed and self._statustext:
            decision = result.guidance
            self._send(encode.statustext(decision.text(), encode.mavlink2.MAV_SEVERITY_WARNING
                                         if decision.state in ("failed", "overridden")
                                         else encode.mavlink2.MAV_SEVERITY_NOTICE))
        if self._heartbeat.due(now) or result.final:
            self._send(encode.heartbeat(encode.system_status(result.available, result.starting, result.final)))
        if self._rebroadcast_wanted and result.tracks is not None and not result.final:
            self._rebroadcast_wanted = False
            # alerting intruders first, then the most recently heard; a sensor's track has no ICAO address to
            # put in ADSB_VEHICLE (the ground sees it on the zenoh tracks topic)
            tracks = sorted((t for t in result.tracks if t.key.source is not AddressSource.SENSOR),
                            key=lambda t: (-int(t.advisory_level), -t.last_report_s))
            for track in tracks[:REBROADCAST_MAX]:
                self._send_as(encode.adsb_vehicle(track), self._rebroadcast_component)

    def _advisory(self, advisory: Advisory, callsign: str | None) -> None:
        self._send(encode.collision(advisory, self._request_action))
        self._send(encode.daa_advisory(advisory, callsign))

    def close(self) -> None:
        pass


TRACK_KEYS_PERIOD_S = 10.0  # each track's own key (tracks/<intruder>) is refreshed this often, round-robin


class ZenohOut:
    """zenoh topics daa/<vehicle>/... (docs/zenoh.md): advisories on change and refreshed while active; at
    zenoh.tracks_hz every track in one `traffic` sample (a TrafficBatch, encoded on the bus's publisher thread) and
    some per-track `tracks/<intruder>` samples: a new track's at once, then each track's every TRACK_KEYS_PERIOD_S,
    spread round-robin over the ticks; ownship and status at zenoh.status_hz. publish: a ZenohBus's
    publish(suffix, payload). sinks: the output sinks' health (avionics/io/sinks.py), in the status as
    `output_faults` and `warnings`. advisories: the announcements shared with the MAVLink port (without one, its
    own)."""

    def __init__(self, publish, config: Config, sinks: SinkHealth | None = None,
                 advisories: AdvisoryAnnouncements | None = None):
        self._publish = publish
        self._sinks = sinks
        self.vehicle = config.vehicle.id
        self._tracks = Every(1.0 / config.zenoh.tracks_hz)
        self._status = Every(1.0 / config.zenoh.status_hz)
        self._advisories = advisories or AdvisoryAnnouncements.of(config)
        self._wanted = NOTHING
        self._profile = config.advisory.profile
        self._keys_per_tick = TRACK_KEYS_PERIOD_S * config.zenoh.tracks_hz  # ticks per round of per-track keys
        self._keyed: set = set()  # tracks whose own key was published (new ones go at once)
        self._cursor = 0  # round-robin position in the sorted tracks

    def wants(self, now_s: float) -> Demand:
        self._wanted = Demand(self._tracks.due(now_s), self._status.due(now_s),
                              VIEWS_WITHIN_PERIODS * self._tracks.period_s)
        return self._wanted

    def publish(self, result: DaaResult) -> None:
        changes, refreshes = self._advisories.due(result)
        for advisory, callsign in changes + refreshes:
            self._publish(f"advisories/{advisory.intruder}", advisory_payload(self.vehicle, advisory, callsign))
        if result.guidance is not None and (result.guidance_changed or result.status is not None):
            self._publish("guidance", guidance_payload(self.vehicle, result.guidance))  # on change and with status
        if result.tracks is not None:
            self._traffic(result.tracks, result.time_s)  # the views of a round this step completed
        if result.bands is not None:
            self._publish("bands", bands_payload(self.vehicle, self._profile, result.bands))
        if result.status is not None:
            self._publish("ownship", ownship_payload(self.vehicle, result.time_s, result.status["ownship"]))
            status = dict(result.status)
            if self._sinks is not None:
                status["warnings"] = [*status["warnings"], *self._sinks.warnings()]
            status["output_faults"] = self._sinks.as_dict() if self._sinks is not None else {}
            self._publish("status", status_payload(self.vehicle, result.time_s, status, result.counters or {}))

    def _traffic(self, tracks, now_s: float) -> None:
        """One batched sample of every track, then the per-track keys due: new tracks, and the next slice of the
        round (len/keys_per_tick tracks, so that every track's key is refreshed once per TRACK_KEYS_PERIOD_S)."""
        self._publish("traffic", TrafficBatch(self.vehicle, now_s, tuple(tracks)))
        n = len(tracks)
        due = [t for t in tracks if t.key not in self._keyed]
        if n:
            size = min(n, max(1, math.ceil(n / self._keys_per_tick)))
            start = self._cursor % n
            due += [t for t in (tracks[start:start + size] + tracks[:max(0, start + size - n)]) if t.key in self._keyed]
            self._cursor = start + size
        self._keyed = {t.key for t in tracks}
        for track in due:
            self._publish(f"tracks/{track.key}", track_payload(self.vehicle, track))

    def close(self) -> None:
        pass


class LogOut:
    """The process log: advisory changes (alerts, unavailability and lost threats at WARNING, clear at INFO),
    changes of availability, rejected senders and wiring diagnostics (io/diagnostics.py: WARNING at the onset and
    every REPEAT_S while it lasts, INFO when it ends)."""

    def __init__(self, logger: logging.Logger | None = None):
        self.log = logger or logging.getLogger("avionics")
        self._rejected: frozenset = frozenset()  # the rejected senders of the last result (each logged as it starts)
        self._wiring = Announcements()

    def wants(self, now_s: float) -> Demand:
        return NOTHING

    def publish(self, result: DaaResult) -> None:
        for advisory in result.changes:
            alert = advisory.level is not AdvisoryLevel.NONE or advisory.reason in UNAVAILABLE_REASONS or advisory.lost
            self.log.log(logging.WARNING if alert else logging.INFO, "t=%7.2f %s", result.time_s,
                         encode.advisory_text(advisory, result.callsigns.get(advisory.intruder)))
        if result.availability_changed:
            reason = result.unavailable_reason
            self.log.log(logging.INFO if reason is None else logging.WARNING, "t=%7.2f %s", result.time_s,
                         encode.availability_text(reason, result.fault_detail))
        if result.rejected_senders or self._rejected:
            active = frozenset(result.rejected_senders)
            for sender in sorted(active - self._rejected):
                self.log.warning("t=%7.2f %s", result.time_s, encode.rejected_sender_text(*sender))
            self._rejected = active
        if (result.wiring or self._wiring.active) and not result.final:
            onsets, repeats, ended = self._wiring.due(result.wiring, result.time_s)
            for diagnostic in onsets + repeats:
                self.log.warning("t=%7.2f %s", result.time_s, diagnostic.message)
            for key in ended:
                self.log.info("t=%7.2f wiring ok again: %s", result.time_s, key)

    def close(self) -> None:
        pass


def csv_row(a: Advisory, name: str = "") -> dict:
    """An advisory change as a CSV row: times to 0.01 s, numbers to 0.001, unknown and infinite values empty."""
    def num(v):
        return "" if v is None or (isinstance(v, float) and math.isinf(v)) else f"{v:.3f}"

    return {
        "time_s": f"{a.time_s:.2f}", "intruder": str(a.intruder), "advisory": a.level.name,
        "ra": a.ra_words or "", "ra_sense": a.ra_sense or "", "target_vertical_rate_mps": num(a.target_vertical_rate_mps),
        "ra_separation_m": num(a.ra_separation_m), "name": name, "reason": a.reason,
        "sensitivity_level": a.sensitivity_level, "range_m": num(a.range_m),
        "closure_rate_mps": num(a.closure_rate_mps), "t_cpa_s": num(a.t_cpa_s), "hmd_m": num(a.hmd_m),
        "vmd_m": num(a.vmd_m), "range_tau_s": num(a.range_tau_s), "mod_tau_s": num(a.mod_tau_s),
        "vertical_tau_s": num(a.vertical_tau_s), "alert_level": a.alert()[0], "alert_name": a.alert()[1],
        "ra_composite": "1" if a.ra_composite else "",
    }


def guidance_cells(decision) -> dict:
    rate = decision.target_vertical_rate_mps
    return {"guidance_state": decision.state, "guidance_manoeuvre": decision.manoeuvre,
            "guidance_target_vertical_rate_mps": "" if rate is None else f"{rate:.3f}",
            "guidance_reason": decision.reason, "autopilot_mode": decision.autopilot_mode,
            "guidance_target_track_deg": "" if decision.target_track_deg is None else
            f"{decision.target_track_deg:.1f}"}


class CsvOut:
    """Advisory changes as CSV rows on an open text file (the caller owns the file; `avionics run` gives it a
    sinks.FileSink, which fails alone). names: ICAO address -> a name for the `name` column (a scenario's
    aircraft names); without one the intruder's callsign (as `sitl replay --out` names them), empty when none was
    ever heard. The rows of a step are flushed with it: a write error is seen then, not at exit. guidance: the
    GUIDANCE_CSV_COLUMNS too (guidance.mode advise or execute)."""

    def __init__(self, file: IO[str], names: dict[int, str] | None = None, guidance: bool = False):
        self._file = file
        self._names = names or {}
        self._guidance = guidance
        self._writer = csv.DictWriter(file, fieldnames=CSV_COLUMNS + (GUIDANCE_CSV_COLUMNS if guidance else ()))
        self._writer.writeheader()

    def wants(self, now_s: float) -> Demand:
        return NOTHING

    def publish(self, result: DaaResult) -> None:
        rows = [csv_row(a, self._names.get(a.intruder.address) or result.callsigns.get(a.intruder) or "")
                for a in result.changes]
        if self._guidance and result.guidance is not None:
            cells = guidance_cells(result.guidance)
            for row in rows:
                row.update(cells)
            if result.guidance_changed:
                rows.append({**{c: "" for c in CSV_COLUMNS}, "time_s": f"{result.time_s:.2f}", "advisory": GUIDANCE_ROW,
                             **cells})
        if rows:
            self._writer.writerows(rows)
            self._file.flush()

    def close(self) -> None:
        self._file.flush()
