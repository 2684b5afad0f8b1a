"""The onboard DAA node without its transports: MAVLink messages in; core step; what to send and when.

The live runner (avionics run) and the fast-time replay (sitl replay) both use this class, so the same
decoding, core and output policy run in both.
"""

from __future__ import annotations

from collections import Counter

from avionics.config import Config
from avionics.core.types import Advisory, AdvisoryLevel, AltitudeDatum
from avionics.io import encode
from avionics.io.decode import MessageDecoder
from avionics.io.payloads import advisory_payload, ownship_payload, status_payload, track_payload
from avionics.pipeline import DaaCore, StepResult


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
        self.mavlink_out: list = []
        self.zenoh_out: list[tuple[str, dict]] = []

    def handle(self, msgs, now_s: float) -> StepResult:
        """Decode, step the core and queue the outputs due at now_s (drain mavlink_out and zenoh_out)."""
        inputs = [item for item in (self.decoder.decode(m, now_s) for m in msgs) if item is not None]
        result = self.core.step(now_s, inputs)
        self._queue_outputs(result, now_s)
        return result

    # -- output policy ---------------------------------------------------------------------------------------
    def _queue_outputs(self, result: StepResult, now_s: float) -> None:
        cfg = self.config
        for advisory in result.changes:
            self._emit_advisory(advisory)
            if cfg.mavlink.statustext:
                self.mavlink_out.append(encode.statustext(encode.advisory_text(advisory, self._callsign(advisory)),
                                                          encode.SEVERITY[advisory.level]))
            if advisory.level is AdvisoryLevel.NONE:
                self._refresh.pop(advisory.intruder, None)
            else:
                self._refresh[advisory.intruder] = now_s + cfg.mavlink.collision_refresh_s
        for key, due in list(self._refresh.items()):
            entry = self.core.assessments.get(key)
            if now_s >= due and entry is not None:
                self._emit_advisory(entry.advisory)
                self._refresh[key] = now_s + cfg.mavlink.collision_refresh_s
        if self._heartbeat.due(now_s):
            self.mavlink_out.append(encode.heartbeat())
        if cfg.zenoh.enabled and self._tracks.due(now_s):
            self.zenoh_out.extend(self.track_messages(now_s))
        if cfg.zenoh.enabled and self._status.due(now_s):
            status = self.status(now_s)
            self.zenoh_out.append(("ownship", ownship_payload(self.vehicle, now_s, status["ownship"])))
            self.zenoh_out.append(("status", status_payload(self.vehicle, now_s, status, self.counters)))

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
        if not keys or core.plane is None:
            return []
        xs, ps = core.tracker.predict(keys, now_s)
        lats, lons = core.plane.to_geodetic(xs[:, 0], xs[:, 1])
        advisories = core.advisories()
        modes = core.tracker.mode_infos(keys, now_s)
        out = []
        for i, key in enumerate(keys):
            track = core.tracker.tracks[key]
            valid_alt = track.altitude_valid(now_s, self.config.tracking.max_coast_s)
            out.append((f"tracks/{key}", track_payload(self.vehicle, track, now_s, xs[i], ps[i], float(lats[i]),
                                                       float(lons[i]), valid_alt, advisories.get(key), modes[i])))
        return out

    def status(self, now_s: float) -> dict:
        """Health for the status topic: ownship, datums, sensitivity level, advisory counts, warnings."""
        core = self.core
        own = core.ownship.state_at(now_s)
        advisories = core.advisories().values()
        pressure_intruders = [str(k) for k, t in core.tracker.tracks.items() if t.datum is AltitudeDatum.PRESSURE]
        warnings = []
        if own is None:
            warnings.append("no ownship position: no advisories")
        elif own.pressure_altitude_m is None and pressure_intruders:
            warnings.append(
                f"no ownship pressure altitude: {len(pressure_intruders)} pressure-altitude intruder(s) compared "
                f"with GNSS altitude, vertical thresholds widened by {self.config.altitude.datum_mismatch_margin_m:.0f} m")
        ownship = None
        if own is not None:
            lat, lon = core.plane.to_geodetic(own.x[0], own.x[1])
            ownship = {"lat_deg": float(lat), "lon_deg": float(lon), "alt_msl_m": float(own.x[2]),
                       "pressure_altitude_m": own.pressure_altitude_m,
                       "height_above_home_m": own.height_above_home_m,
                       "velocity_enu_mps": [float(v) for v in own.x[3:6]]}
        return {
            "ownship": ownship,
            "ownship_valid": own is not None,
            "pressure_altitude_available": own is not None and own.pressure_altitude_m is not None,
            "datum_mismatch_intruders": sorted(str(a.intruder) for a in advisories if a.datum_mismatch),
            "sensitivity_level": core.level.sl if core.level else None,
            "tracks": len(core.tracker.tracks),
            "advisories": {lvl.name: sum(a.level is lvl for a in advisories) for lvl in (AdvisoryLevel.TA,
                                                                                          AdvisoryLevel.RA)},
            "warnings": warnings,
        }
