"""The DAA facade: one object fed with decoded inputs and a time, returning one immutable `DaaResult`.

NASA DAIDALUS's `Daidalus` over `DaidalusCore` is the model: every shell (the live loop, fast-time replay, the
bench, the demo, the monitor's simulated vehicle) drives this object and reads only its results, never the
core's insides. What the result carries is what the output ports need: the step's advisory changes, the active
advisories with their intruders' callsigns, DAA availability (and when it changed), and, when asked for, the
published track states (geodetic and local) and the status with the counters.

Availability (docs/architecture.md, "Failure states"): DAA is unavailable without ownship, while ownship fixes
keep failing the jump check, without ownship pressure altitude while a pressure-altitude intruder is tracked,
while an intruder or the step is in the failed state (pipeline/containment.py), while an intruder is spoof-suspected (its
real reports may be the ones dropped), while its only traffic source is down (`traffic_down`), and once the
process stops. A change is reported once (`availability_changed`); start-up without ownship, and the first fix
after it, are not changes (HEARTBEAT and status say it).
"""

from __future__ import annotations

from collections import Counter
from dataclasses import dataclass
from types import MappingProxyType
from typing import Iterable, Mapping, Sequence

from avionics.config import Config
from avionics.base.frame import true_of
from avionics.base.faults import FaultLog
from avionics.base.schedule import Every
from avionics.base.types import (
    AUTOPILOT_INPUTS, Advisory, AdvisoryLevel, AltitudeDatum, Input, IntruderKey, TrackView, UNAVAILABLE_REASONS,
)
from avionics.advisory.inhibits import RaInhibitWatch
from avionics.base.units import FT
from avionics.io.diagnostics import Diagnostic
from avionics.pipeline.daa_core import DaaCore
from avionics.pipeline.views import ViewRound

STARTUP = "startup"  # availability before the first ownship fix: unavailable, but not announced
_UNSET = object()


@dataclass(frozen=True, slots=True)
class SourceStatus:
    """What the input side knows that the core cannot: intruders a second sender reports somewhere else (its
    reports are dropped: docs/mavlink.md, "Trusted sources"), our last ownship pressure rejected as implausible,
    the health of the receiver feeds (avionics/io/feeds/source.py FeedHealth: path, connected, error, reports,
    last_report_s, warning, as_dict(); docs/traffic-inputs.md), the components of our vehicle whose claim to send
    the ownship or traffic was rejected in the last 10 s ((system, component, "ownship" | "traffic"),
    io/senders.py), whether ownship fixes have failed the jump check for input.ownship_jump_persist_s
    (io/ownship_check.py), and whether the MAVLink link has delivered traffic (an accepted ADSB_VEHICLE) since
    start; wiring: the active wiring diagnostics (io/diagnostics.py Diagnostic: no MAVLink, ownship from another
    system, untrusted traffic, a feed down, ...)."""

    spoof_suspected: frozenset[IntruderKey] = frozenset()
    pressure_rejected: bool = False
    feeds: tuple = ()
    rejected_senders: frozenset[tuple[int, int, str]] = frozenset()
    ownship_inconsistent: bool = False
    mavlink_traffic: bool = False
    wiring: tuple = ()
    link_authenticated: bool = False  # io/link.py MavlinkLink.authenticated (guidance.require_signing)


def traffic_down(sources: SourceStatus) -> tuple:
    """The receiver feeds, when they are the only traffic source and every one of them is down (FeedHealth of
    each); () otherwise. A feed is down once it has failed (refused, closed, timed out: `error`) and is not
    connected again; one still making its first connection is not. The MAVLink link counts as a traffic source
    once it has delivered traffic: an autopilot's ADSB_VEHICLE path says nothing of its receiver's health, and
    silence on it is also an empty sky (docs/mavlink.md, Availability)."""
    feeds = sources.feeds
    if not feeds or sources.mavlink_traffic or any(f.connected or f.error is None for f in feeds):
        return ()
    return feeds


NO_SOURCE_STATUS = SourceStatus()


class _Callsigns(Mapping):
    """The callsigns of the intruders of a result's changes and active advisories (None: not known), read from
    their track records when asked: the ports ask for a few of them at each step, not for every active one."""

    __slots__ = ("_changed", "_active", "_record")

    def __init__(self, changed: set, active: Mapping, record):
        self._changed, self._active, self._record = changed, active, record

    def __getitem__(self, key):
        if key not in self._changed and key not in self._active:
            raise KeyError(key)
        r = self._record(key)
        return r.callsign if r is not None else None

    def __iter__(self):
        yield from self._active
        yield from (k for k in self._changed if k not in self._active)

    def __len__(self) -> int:
        return len(self._active) + sum(k not in self._active for k in self._changed)


@dataclass(frozen=True, slots=True)
class DaaResult:
    """Everything a shell needs of one step. Read-only: `active` is a view of a copy, tuples are tuples;
    `assessed` builds each advisory when read and `callsigns` reads the track records when asked (the ports
    read both in the step they get the result)."""

    time_s: float
    changes: tuple[Advisory, ...]  # advisories whose level, RA sense or strength changed (announce these)
    assessed: Sequence[Advisory]  # the advisory of every intruder assessed in this step (each built when read)
    active: Mapping[IntruderKey, Advisory]  # the latest advisory of every intruder at TA or RA
    callsigns: Mapping[IntruderKey, str | None]  # of the intruders in changes and active (read when asked)
    # no_ownship | ownship_inconsistent | no_pressure_altitude | fault | spoof_suspected | no_traffic_source |
    # shutdown; None: available
    unavailable_reason: str | None
    availability_changed: bool  # announce it (STATUSTEXT, log)
    # "track 1090es-A10001 +1" while unavailable for a fault, "1090es-A10001" for a spoof, the feed down for
    # no_traffic_source
    fault_detail: str
    sensitivity_level: int | None
    # when asked for, at the step that completes their round (step's tracks_within_s): every track, each
    # predicted to the step that built its view (TrackView.time_s)
    tracks: tuple[TrackView, ...] | None = None
    status: Mapping | None = None  # when asked for: the status topic's body (docs/zenoh.md, Status)
    counters: Mapping[str, int] | None = None  # when asked for (with the status): a snapshot
    final: bool = False  # the last result: the process stops
    bands: object | None = None  # advisory/bands.py Bands: a DO-365 alerter's guidance bands, once a second
    starting: bool = False  # no ownship fix yet since start-up (unavailable, reason no_ownship, not announced)
    # components of our vehicle rejected as a source of ownship or traffic in the last 10 s, (system, component,
    # role), sorted: announce them (ports.py: STATUSTEXT, log)
    rejected_senders: tuple[tuple[int, int, str], ...] = ()
    # the active wiring diagnostics (io/diagnostics.py Diagnostic): ports.py announces each onset
    wiring: tuple = ()
    # guidance.mode advise / execute (avionics/guidance/stage.py): the decision of this step, whether its state
    # changed (announce it), and the MAVLink commands for the autopilot (ports.py MavlinkOut sends them)
    guidance: object | None = None
    guidance_changed: bool = False
    guidance_commands: tuple = ()
    guidance_reads: tuple = ()  # the guidance reading the autopilot's mission (avionics/guidance/mission.py)

    @property
    def available(self) -> bool:
        return self.unavailable_reason is None


class Daa:
    """The DAA process's core behind one door: step(now, inputs) -> DaaResult; shutdown(now) -> the last one."""

    def __init__(self, config: Config, counters: Counter | None = None, core: DaaCore | None = None):
        self.config = config
        self.counters = counters if counters is not None else Counter()
        self._core = core if core is not None else DaaCore(config, self.counters)
        self._availability = Every(1.0 / config.advisory.assessment_hz)
        self._unavailable: str | None = STARTUP  # the availability last reported (None: available)
        self._fault_detail = ""
        self._stopped = False
        self._fault = FaultLog(self.counters)
        # a profile that leaves a flying drone without RAs, named after a minute (advisory/inhibits.py)
        self._ra_watch = RaInhibitWatch(self._core.profile, config.advisory.ra_enabled)
        self._ra_inhibited: tuple = ()  # () or (the Diagnostic,) while the watch says so
        self._guidance = None  # avionics/guidance/stage.py GuidanceStage (guidance.mode advise or execute)
        if config.guidance.mode != "passive":
            from avionics.guidance.stage import GuidanceStage, HorizontalLimits, Ownship, VerticalLimits

            profile = self._core.profile
            self._guidance = GuidanceStage(config.guidance, VerticalLimits.of(profile.response),
                                           config.mavlink.source_system,
                                           horizontal=HorizontalLimits.of(profile) if config.advisory.guidance_bands
                                           else None)  # no bands: a DO-365 warning's vertical RA is flown
            if config.guidance.ladder:  # a mode per alert level instead of the manoeuvre (guidance/ladder.py)
                from avionics.guidance.ladder import ModeLadder

                self._guidance = ModeLadder(config.guidance, config.mavlink.source_system)
            self._ownship = Ownship  # imported only with guidance (start-up, issue 13)
        self._autopilot_inputs: list = []  # HEARTBEAT and COMMAND_ACK of this step, for the guidance
        self._views = ViewRound(config.advisory.assessment_slice)  # the track views asked for, a slice a step

    @property
    def profile(self):
        """The alerting profile in force (advisory/tables.py AlertProfile)."""
        return self._core.profile

    @property
    def response_model(self):
        """The alerting profile's model of how ownship flies an RA (sitl's closed loop flies it)."""
        return self._core.profile.response

    def step(self, now_s: float, inputs: Iterable[Input] = (), *, sources: SourceStatus = NO_SOURCE_STATUS,
             tracks: bool = False, status: bool = False, tracks_within_s: float = 0.0) -> DaaResult:
        """One step of the core at now_s with the inputs received since the last one. tracks / status: include
        the track states and the status (the output ports ask for them at their own rates); the tracks' views
        are built in slices over the steps of the next tracks_within_s (0: in this step) and come with the
        result of the step that completes them (pipeline/views.py ViewRound)."""
        if self._guidance is not None:
            inputs = list(inputs)
            self._autopilot_inputs = [i for i in inputs if isinstance(i, AUTOPILOT_INPUTS)]
            if self._autopilot_inputs:
                inputs = [i for i in inputs if not isinstance(i, AUTOPILOT_INPUTS)]
        core_result = self._core.step(now_s, inputs)  # contains its own faults (pipeline/containment.py)
        return self._result(now_s, tuple(core_result.changes), core_result.assessed, sources, tracks, status,
                            bands=core_result.bands, tracks_within_s=tracks_within_s)

    def shutdown(self, now_s: float, sources: SourceStatus = NO_SOURCE_STATUS) -> DaaResult:
        """The process stops: every active advisory ends with reason `shutdown`, DAA is unavailable (shutdown);
        the result carries the status for a last publication."""
        self._stopped = True
        try:
            ended = tuple(self._core.end_all(now_s, "shutdown"))
        except Exception as exc:  # noqa: BLE001  (what it can still end, it ends)
            self._fault("shutdown", exc)
            ended = ()
        return self._result(now_s, ended, (), sources, False, True, final=True)

    # -- the result ------------------------------------------------------------------------------------------
    def _result(self, now_s, changes, assessed, sources, tracks, status, final=False, bands=None,
                tracks_within_s=0.0) -> DaaResult:
        changed = False
        if final or self._availability.due(now_s) or any(a.reason in UNAVAILABLE_REASONS for a in changes):
            changed = self._check_availability(now_s, sources)
            self._watch_ra_inhibit(now_s)
        track_views = body = None
        try:  # a publication's fault must not stop the advisories
            if tracks or self._views.running:
                track_views = self._views.step(now_s, tracks, tracks_within_s,
                                               lambda: sorted(self._core.tracker.tracks),
                                               lambda keys: self.tracks(now_s, sources, keys))
            body = self.status(now_s, sources) if status else None
        except Exception as exc:  # noqa: BLE001
            self._fault("output", exc)
        level = self._core.level
        record = self._core.tracker.tracks.get
        active = self._core.active_view()
        unavailable = self._unavailable if self._unavailable != STARTUP else "no_ownship"
        guidance = self._guide(now_s, active, unavailable, sources, bands) if self._guidance is not None else None
        return DaaResult(
            time_s=now_s, changes=changes, assessed=assessed, active=active,
            callsigns=_Callsigns({a.intruder for a in changes}, active, record),
            unavailable_reason=self._unavailable if self._unavailable != STARTUP else "no_ownship",
            availability_changed=changed, fault_detail=self._fault_detail,
            sensitivity_level=level.sl if level else None, tracks=track_views,
            status=MappingProxyType(body) if body is not None else None,
            counters=MappingProxyType(dict(self.counters)) if body is not None else None, final=final, bands=bands,
            starting=self._unavailable == STARTUP, rejected_senders=tuple(sorted(sources.rejected_senders)),
            wiring=sources.wiring + self._ra_inhibited,
            guidance=guidance.decision if guidance is not None else None,
            guidance_changed=guidance is not None and guidance.changed,
            guidance_commands=guidance.commands if guidance is not None else (),
            guidance_reads=guidance.reads if guidance is not None else ())

    def _guide(self, now_s: float, active, unavailable: str | None, sources: SourceStatus, bands=None):
        """The guidance stage's step (avionics/guidance/stage.py), with ownship's velocity and height above home;
        its fault is contained: the advisories go on, nothing is commanded (the stage is not stepped)."""
        try:
            own = self._core.ownship.state_at(now_s)
            ownship = None
            if own is not None:
                def true(x=own.x, plane=self._core.frame.plane):  # this step's plane, should it move before
                    lat, lon, (ve, vn) = true_of(plane, x[0], x[1], x[3:5])
                    return float(lat), float(lon), float(vn), float(ve)

                ownship = self._ownship.converted(float(own.x[5]), own.height_above_home_m, true)
            inputs, self._autopilot_inputs = self._autopilot_inputs, []
            return self._guidance.update(now_s, active, unavailable, ownship, inputs, sources.spoof_suspected,
                                         sources.link_authenticated, bands,
                                         return_conflict=lambda moves: self._core.ra_threatened_if(now_s, moves))
        except Exception as exc:  # noqa: BLE001
            self._fault("guidance", exc)
            return None

    def _watch_ra_inhibit(self, now_s: float) -> None:
        try:
            own = self._core.ownship.state_at(now_s)
            message = self._ra_watch.update(now_s, self._core.agl_m(own) if own is not None else None)
        except Exception as exc:  # noqa: BLE001  (a warning's fault must not stop the advisories)
            self._fault("output", exc)
            return
        height_ft = self._ra_watch.height_m / FT
        self._ra_inhibited = () if message is None else (Diagnostic(
            "ra_inhibited", f"NO RA BELOW {height_ft:.0f} FT AGL: PROFILE {self._core.profile.name.upper()}"[:50],
            message),)

    # -- availability ----------------------------------------------------------------------------------------
    def _unavailable_reason(self, now_s: float, sources: SourceStatus, own=_UNSET) -> str | None:
        """Why DAA cannot protect now; None when it can. A faulty ownship pressure (status "pressure_fault")
        is no pressure altitude: no_pressure_altitude."""
        core = self._core
        if self._stopped:
            return "shutdown"
        if own is _UNSET:
            try:
                own = core.ownship.state_at(now_s)
            except Exception:  # noqa: BLE001  (the core restarts a failed ownship filter at its next assessment)
                own = None
        if own is None:
            return "no_ownship"
        if sources.ownship_inconsistent:  # the ownship may be another sender's, or a glitch
            return "ownship_inconsistent"
        if core.step_fault is not None or core.faults:
            return "fault"
        if sources.spoof_suspected:  # the intruder's real reports may be the ones dropped: its alert may be lost
            return "spoof_suspected"
        if traffic_down(sources):
            return "no_traffic_source"
        if own.pressure_altitude_m is None and any(t.datum is AltitudeDatum.PRESSURE
                                                   for t in core.tracker.tracks.values()):
            return "no_pressure_altitude"
        return None

    def _detail(self, reason: str | None, sources: SourceStatus) -> str:
        """What the availability text adds to reason: the failed stage and intruder, the spoofed intruder, or the
        feed down."""
        if reason == "spoof_suspected":
            first, *more = sorted(str(k) for k in sources.spoof_suspected)
            return first + (f" +{len(more)}" if more else "")
        if reason == "no_traffic_source":
            down = traffic_down(sources)
            return down[0].path + (f" +{len(down) - 1}" if len(down) > 1 else "")
        if reason != "fault":
            return ""
        core = self._core
        if core.step_fault is not None:
            return "step"
        if core.faults:
            key, fault = min(core.faults.items(), key=lambda kv: (kv[1].since_s, kv[0]))
            more = f" +{len(core.faults) - 1}" if len(core.faults) > 1 else ""
            return f"{fault.stage} {key}{more}"
        return ""

    def _check_availability(self, now_s: float, sources: SourceStatus) -> bool:
        """Whether availability changed (to be announced once). Start-up without ownship is silent, and so is
        the first fix after it."""
        reason = self._unavailable_reason(now_s, sources)
        previous = self._unavailable
        if reason == previous or previous == STARTUP and reason in ("no_ownship", None):
            if previous == STARTUP and reason is None:
                self._unavailable = None
            return False
        self._unavailable = reason
        self._fault_detail = self._detail(reason, sources)
        return True

    # -- tracks and status -----------------------------------------------------------------------------------
    def tracks(self, now_s: float, sources: SourceStatus = NO_SOURCE_STATUS,
               keys: Sequence[IntruderKey] | None = None) -> tuple[TrackView, ...]:
        """Every track (or those of keys that are still tracks, in their order) predicted to now_s (a query: the
        core does not step)."""
        core = self._core
        keys = sorted(core.tracker.tracks) if keys is None else [k for k in keys if k in core.tracker.tracks]
        if not keys or core.frame.plane is None:
            return ()
        keys, xs, ps = core.predict_tracks(keys, now_s)  # an intruder that fails here fails as in a step
        if not keys:
            return ()
        lats, lons, velocities = core.frame.to_true(xs[:, 0], xs[:, 1], xs[:, 3:5])
        xs = xs.copy()
        xs[:, 3:5] = velocities  # published in true east/north at the aircraft (traces of p are unchanged)
        try:
            modes = core.tracker.mode_infos(keys, now_s)
        except Exception as exc:  # noqa: BLE001  (the IMM mode outputs are for displays: left out)
            self._fault("modes", exc)
            modes = [None] * len(keys)
        max_coast_s = self.config.tracking.max_coast_s
        out = []
        for i, key in enumerate(keys):
            record = core.tracker.tracks[key]
            level, advisory, assessment = core.advisory_reader(key)
            out.append(TrackView.of(record, now_s, xs[i], ps[i], float(lats[i]), float(lons[i]),
                                    record.altitude_valid(now_s, max_coast_s), advisory, modes[i],
                                    key in sources.spoof_suspected, level, assessment))
        return tuple(out)

    def status(self, now_s: float, sources: SourceStatus = NO_SOURCE_STATUS) -> dict:
        """Health for the status topic: ownship, datums, sensitivity level, advisory counts, warnings (as
        DaaResult.status; a query: the core does not step)."""
        core = self._core
        own = core.ownship.state_at(now_s)
        advisories = core.active.values()
        pressure_intruders = [str(k) for k, t in core.tracker.tracks.items() if t.datum is AltitudeDatum.PRESSURE]
        unavailable = self._unavailable_reason(now_s, sources, own)
        # The cross-check's verdict (tracking/baro_check.py), or the decoder's when it rejected our last
        # SCALED_PRESSURE (not a number, or outside the range the ISA model inverts).
        pressure_fault = core.ownship.pressure_fault
        if pressure_fault is None and sources.pressure_rejected:
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
        if sources.ownship_inconsistent:
            warnings.append("ownship fixes keep failing the jump check: the ownship may be wrong")
        if sources.spoof_suspected:
            warnings.append(f"spoof suspected: {len(sources.spoof_suspected)} intruder(s) reported elsewhere by a "
                            "second sender, whose reports are dropped: their alerts may be lost")
        if self._stopped:
            warnings.append("shutdown: no advisories")
        warnings.extend(feed.warning for feed in sources.feeds if feed.warning)  # a receiver feed down
        warnings.extend(d.message for d in sources.wiring + self._ra_inhibited
                        if not d.key.startswith("feed:"))  # the feed's is above
        if traffic_down(sources):
            warnings.append("no traffic source: every receiver feed is down and MAVLink has delivered no traffic")
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
            "datum_mismatch_intruders": sorted(str(k) for k in core.datum_mismatch_keys()),
            "sensitivity_level": core.level.sl if core.level else None,
            "tracks": len(core.tracker.tracks),
            "advisories": {lvl.name: sum(a.level is lvl for a in advisories) for lvl in (AdvisoryLevel.TA,
                                                                                          AdvisoryLevel.RA)},
            "warnings": warnings,
            "daa_available": unavailable is None,
            "unavailable_reason": unavailable,  # as DaaResult.unavailable_reason
            "failed_intruders": {str(k): f.stage for k, f in sorted(core.faults.items())},
            "spoof_suspected": sorted(str(k) for k in sources.spoof_suspected),  # reported elsewhere by a second sender
            # components of our vehicle rejected as a source of ownship or traffic: "SYS:COMP role"
            "rejected_senders": [f"{s}:{c} {role}" for s, c, role in sorted(sources.rejected_senders)],
            "traffic_feeds": [feed.as_dict() for feed in sources.feeds],  # avionics run --traffic
            # io/diagnostics.py: key, text, message (and ra_inhibited: advisory/inhibits.py RaInhibitWatch)
            "wiring": [d.as_dict() for d in sources.wiring + self._ra_inhibited],
        }
