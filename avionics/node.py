"""The onboard DAA node without its transports: MAVLink messages in; core step; what to send and when.

The live runner (avionics run) and the fast-time replay (sitl replay) both use this class, so the same
decoding, core and output policy run in both.

Availability (docs/architecture.md, "Failure states"): DAA is unavailable without ownship, without ownship
pressure altitude while a pressure-altitude intruder is tracked, while an intruder or the step is in the failed
state (pipeline.py), and once the process stops. HEARTBEAT `system_status` is then MAV_STATE_CRITICAL (ACTIVE
when available), each change is announced once by STATUSTEXT ("DAA UNAVAILABLE <why>" at WARNING, "DAA
AVAILABLE" at NOTICE), and the zenoh status says `daa_available` and `unavailable_reason`.
"""

from __future__ import annotations

import logging
from collections import Counter

from avionics.config import Config
from avionics.core.types import Advisory, AdvisoryLevel, AltitudeDatum
from avionics.io import encode
from avionics.io.decode import MessageDecoder
from avionics.io.payloads import advisory_payload, ownship_payload, status_payload, track_payload
from avionics.pipeline import DaaCore, StepResult

log = logging.getLogger("avionics.node")
STARTUP = "startup"  # availability before the first ownship fix: unavailable, but not announced
_UNSET = object()


class Every:
    """True once per period on a caller-supplied clock (live or simulated), without drift."""

    def __init__(self, period_s: float):
        self.period_s = period_s
        self.next_s: float | None = None

    def due(self, now_s: float) -> bool:
        if self.next_s is not None and now_s < self.next_s - 1e-9:
            return False
        late = self.next_s is None or now_s - self.next_s > self.period_s
        self.next_s = (now_s if late else self.next_s) + self.period_s
        return True


class DaaNode:
    def __init__(self, config: Config, counters: Counter | None = None):
        self.config = config
        self.counters = counters if counters is not None else Counter()
        self.decoder = MessageDecoder(config, self.counters)
        self.core = DaaCore(config, self.counters)
        self.vehicle = config.vehicle.id
        self._heartbeat = Every(1.0 / config.mavlink.heartbeat_hz)
        self._tracks = Every(1.0 / config.zenoh.tracks_hz)
        self._status = Every(1.0 / config.zenoh.status_hz)
        self._refresh: dict = {}  # intruder -> next COLLISION/advisory refresh time while active
        self._availability = Every(1.0 / config.advisory.assessment_hz)
        self._unavailable: str | None = STARTUP  # the availability last announced (None: available)
        self._stopped = False
        self._traced: set = set()
        self.mavlink_out: list = []
        self.zenoh_out: list[tuple[str, dict]] = []

    def handle(self, msgs, now_s: float) -> StepResult:
        """Decode, step the core and queue the outputs due at now_s (drain mavlink_out and zenoh_out)."""
        inputs = []
        for m in msgs:
            try:
                item = self.decoder.decode(m, now_s)
            except Exception as exc:  # noqa: BLE001  (one message's fault: it is dropped, the rest go on)
                self._fault("decode", exc)
                continue
            if item is not None:
                inputs.append(item)
        result = self.core.step(now_s, inputs)  # contains its own faults (pipeline.py)
        self._queue_outputs(result, now_s)
        return result

    # -- output policy ---------------------------------------------------------------------------------------
    def _queue_outputs(self, result: StepResult, now_s: float) -> None:
        cfg = self.config
        for advisory in result.changes:
            self._announce(advisory, now_s)
        for key, due in list(self._refresh.items()):
            entry = self.core.assessments.get(key)
            if now_s >= due and entry is not None:
                self._emit_advisory(entry.advisory)
                self._refresh[key] = now_s + cfg.mavlink.collision_refresh_s
        if self._availability.due(now_s) or any(a.reason in encode.UNAVAILABLE_REASONS for a in result.changes):
            self._check_availability(now_s)
        if self._heartbeat.due(now_s):
            self.mavlink_out.append(encode.heartbeat(self._system_status()))
        try:
            if cfg.zenoh.enabled and self._tracks.due(now_s):
                self.zenoh_out.extend(self.track_messages(now_s))
            if cfg.zenoh.enabled and self._status.due(now_s):
                self._queue_status(now_s)
        except Exception as exc:  # noqa: BLE001  (a publication's fault must not stop the advisories)
            self._fault("output", exc)

    def _announce(self, advisory: Advisory, now_s: float) -> None:
        """An advisory change: COLLISION + DAA_ADVISORY + zenoh, STATUSTEXT; refreshed while TA or RA."""
        cfg = self.config
        self._emit_advisory(advisory)
        if cfg.mavlink.statustext:
            self.mavlink_out.append(encode.statustext(encode.advisory_text(advisory, self._callsign(advisory)),
                                                      encode.advisory_severity(advisory)))
        if advisory.level is AdvisoryLevel.NONE:
            self._refresh.pop(advisory.intruder, None)
        else:
            self._refresh[advisory.intruder] = now_s + cfg.mavlink.collision_refresh_s

    def _queue_status(self, now_s: float) -> None:
        status = self.status(now_s)
        self.zenoh_out.append(("ownship", ownship_payload(self.vehicle, now_s, status["ownship"])))
        self.zenoh_out.append(("status", status_payload(self.vehicle, now_s, status, self.counters)))

    def _fault(self, stage: str, exc: Exception) -> None:
        """A fault of the node's own stages (decoding, publication): counted, logged (traceback once per kind)."""
        self.counters[f"fault.{stage}"] += 1
        first = (stage, type(exc).__name__) not in self._traced
        self._traced.add((stage, type(exc).__name__))
        if first:
            log.error("%s failed (%s: %s): skipped, the rest goes on", stage, type(exc).__name__, exc, exc_info=exc)

    # -- availability ----------------------------------------------------------------------------------------
    def unavailable_reason(self, now_s: float, own=_UNSET) -> str | None:
        """Why DAA cannot protect now: shutdown, no_ownship, fault, no_pressure_altitude; None when it can. A
        faulty ownship pressure (status "pressure_fault") is no pressure altitude: no_pressure_altitude."""
        core = self.core
        if self._stopped:
            return "shutdown"
        if own is _UNSET:
            try:
                own = core.ownship.state_at(now_s)
            except Exception:  # noqa: BLE001  (the core restarts a failed ownship filter at its next assessment)
                own = None
        if own is None:
            return "no_ownship"
        if core.step_fault is not None or core.faults:
            return "fault"
        if own.pressure_altitude_m is None and any(t.datum is AltitudeDatum.PRESSURE
                                                   for t in core.tracker.tracks.values()):
            return "no_pressure_altitude"
        return None

    def _fault_detail(self) -> str:
        core = self.core
        if core.step_fault is not None:
            return "step"
        if core.faults:
            key, fault = min(core.faults.items(), key=lambda kv: (kv[1].since_s, kv[0]))
            more = f" +{len(core.faults) - 1}" if len(core.faults) > 1 else ""
            return f"{fault.stage} {key}{more}"
        return ""

    def _check_availability(self, now_s: float, own=_UNSET) -> None:
        """Announce a change of availability once: STATUSTEXT and the log. Start-up without ownship is silent
        (HEARTBEAT and status say it), and so is the first fix after it."""
        reason = self.unavailable_reason(now_s, own)
        previous = self._unavailable
        if reason == previous or previous == STARTUP and reason in ("no_ownship", None):
            if previous == STARTUP and reason is None:
                self._unavailable = None
            return
        self._unavailable = reason
        text = encode.availability_text(reason, self._fault_detail() if reason == "fault" else "")
        if reason is None:
            log.info("t=%7.2f %s", now_s, text)
        else:
            log.warning("t=%7.2f %s", now_s, text)
        if self.config.mavlink.statustext:
            self.mavlink_out.append(encode.statustext(
                text, encode.mavlink2.MAV_SEVERITY_NOTICE if reason is None else encode.mavlink2.MAV_SEVERITY_WARNING))

    def _system_status(self) -> int:
        if self._stopped:
            return encode.mavlink2.MAV_STATE_POWEROFF
        return encode.mavlink2.MAV_STATE_ACTIVE if self._unavailable is None else encode.mavlink2.MAV_STATE_CRITICAL

    def shutdown(self, now_s: float) -> list[Advisory]:
        """The process stops: every active advisory ends with reason `shutdown` (COLLISION threat NONE,
        DAA_ADVISORY level 0, zenoh advisory, STATUSTEXT), "DAA UNAVAILABLE shutdown", a last HEARTBEAT
        (MAV_STATE_POWEROFF) and a last status (daa_available false). Queued like handle()'s outputs."""
        ended = []
        try:
            ended = self.core.end_all(now_s, "shutdown")
        except Exception as exc:  # noqa: BLE001  (what it can still end, it ends)
            self._fault("shutdown", exc)
        for advisory in ended:
            self._announce(advisory, now_s)
        self._refresh.clear()
        self._stopped = True
        self._check_availability(now_s)
        self.mavlink_out.append(encode.heartbeat(self._system_status()))
        if self.config.zenoh.enabled:
            try:
                self._queue_status(now_s)
            except Exception as exc:  # noqa: BLE001
                self._fault("output", exc)
        return ended

    def _callsign(self, advisory: Advisory) -> str | None:
        track = self.core.tracker.tracks.get(advisory.intruder)
        return track.callsign if track else None

    def _emit_advisory(self, advisory: Advisory) -> None:
        callsign = self._callsign(advisory)
        self.mavlink_out.append(encode.collision(advisory))
        self.mavlink_out.append(encode.daa_advisory(advisory, callsign))
        if self.config.zenoh.enabled:
            self.zenoh_out.append((f"advisories/{advisory.intruder}",
                                   advisory_payload(self.vehicle, advisory, callsign)))

    def track_messages(self, now_s: float) -> list[tuple[str, dict]]:
        core = self.core
        keys = sorted(core.tracker.tracks)
        if not keys or core.frame.plane is None:
            return []
        keys, xs, ps = core.predict_tracks(keys, now_s)  # an intruder that fails here fails as in a step
        if not keys:
            return []
        lats, lons, velocities = core.frame.to_true(xs[:, 0], xs[:, 1], xs[:, 3:5])
        xs = xs.copy()
        xs[:, 3:5] = velocities  # published in true east/north at the aircraft (traces of p are unchanged)
        advisories = core.advisories()
        try:
            modes = core.tracker.mode_infos(keys, now_s)
        except Exception as exc:  # noqa: BLE001  (the IMM mode outputs are for displays: left out)
            self._fault("modes", exc)
            modes = [None] * len(keys)
        out = []
        for i, key in enumerate(keys):
            track = core.tracker.tracks[key]
            valid_alt = track.altitude_valid(now_s, self.config.tracking.max_coast_s)
            out.append((f"tracks/{key}", track_payload(self.vehicle, track, now_s, xs[i], ps[i], float(lats[i]),
                                                       float(lons[i]), valid_alt, advisories.get(key), modes[i],
                                                       spoof_suspected=key in self.decoder.spoof_suspected)))
        return out

    def status(self, now_s: float) -> dict:
        """Health for the status topic: ownship, datums, sensitivity level, advisory counts, warnings."""
        core = self.core
        own = core.ownship.state_at(now_s)
        advisories = core.advisories().values()
        pressure_intruders = [str(k) for k, t in core.tracker.tracks.items() if t.datum is AltitudeDatum.PRESSURE]
        unavailable = self.unavailable_reason(now_s, own)
        # The cross-check's verdict (tracking/baro_check.py), or the decoder's when it rejected our last
        # SCALED_PRESSURE (not a number, or outside the range the ISA model inverts).
        pressure_fault = core.ownship.pressure_fault
        if pressure_fault is None and self.decoder.pressure_rejection is not None:
            pressure_fault = "implausible"
        warnings = []
        if pressure_fault is not None:
            warnings.append(f"ownship pressure {pressure_fault}: readings not used; pressure-altitude traffic is "
                            "compared with GNSS altitude until the pressure is plausible again")
        if own is None:
            warnings.append("no ownship position: no advisories")
        elif own.pressure_altitude_m is None and pressure_intruders:
            warnings.append(
                f"no ownship pressure altitude: {len(pressure_intruders)} pressure-altitude intruder(s) compared "
                f"with GNSS altitude, vertical thresholds widened by {self.config.altitude.datum_mismatch_margin_m:.0f} m")
        if core.step_fault is not None:
            warnings.append(f"fault: the DAA step failed ({core.step_fault.error}): no advisories")
        if core.faults:
            warnings.append(f"fault: {len(core.faults)} intruder(s) failed in a stage: no advisories for them")
        if self._stopped:
            warnings.append("shutdown: no advisories")
        ownship = None
        if own is not None:
            lat, lon, (ve, vn) = core.frame.to_true(own.x[0], own.x[1], own.x[3:5])
            ownship = {"lat_deg": float(lat), "lon_deg": float(lon), "alt_msl_m": float(own.x[2]),
                       "pressure_altitude_m": own.pressure_altitude_m,
                       "height_above_home_m": own.height_above_home_m,
                       "velocity_enu_mps": [float(ve), float(vn), float(own.x[5])]}
        return {
            "ownship": ownship,
            "ownship_valid": own is not None,
            "pressure_altitude_available": own is not None and own.pressure_altitude_m is not None,
            "pressure_fault": pressure_fault,  # stuck | jump | implausible | None (docs/altitude.md)
            "datum_mismatch_intruders": sorted(str(a.intruder) for a in advisories if a.datum_mismatch),
            "sensitivity_level": core.level.sl if core.level else None,
            "tracks": len(core.tracker.tracks),
            "advisories": {lvl.name: sum(a.level is lvl for a in advisories) for lvl in (AdvisoryLevel.TA,
                                                                                          AdvisoryLevel.RA)},
            "warnings": warnings,
            "daa_available": unavailable is None,
            "unavailable_reason": unavailable,  # no_ownship | no_pressure_altitude | fault | shutdown
            "failed_intruders": {str(k): f.stage for k, f in sorted(core.faults.items())},
            "spoof_suspected": sorted(str(k) for k in self.decoder.spoof_suspected),  # also sent by a second sender
        }
