"""Fast-time replay: the scenario's MAVLink schedule, framed and de-framed, drives the DAA loop on simulated time.

Same decoder, facade and MAVLink port as `avionics run` (avionics/loop.py); no sockets, no waiting. The loop is
stepped at every message delivery and on the assessment grid between them, as the live loop does. What the DAA
process sends is framed and decoded on the autopilot's side: the closed loop flies the DAA_ADVISORY it receives.
"""

from __future__ import annotations

import csv
import math
from collections import Counter
from dataclasses import dataclass, field, replace
from pathlib import Path

import avionics.io  # noqa: F401
from avionics.io.dialect import daa as mavlink2

from avionics.config import Config
from avionics.base.geodesy import LocalTangentPlane
from avionics.base.types import Advisory, AddressSource, IntruderKey, IntruderReport, OwnshipFix
from avionics.daa import Daa
from avionics.io.framing import FrameScanner
from avionics.loop import Batch, Loop, MavlinkInput
from avionics.contract.advisory_csv import CSV_COLUMNS
from avionics.ports import NOTHING, MavlinkOut, csv_row
from avionics_sitl.autopilot import AutopilotConfig, Packer, ownship_messages, schedule
from avionics_sitl.impairments import AdsbImpairments
from avionics_sitl.progress import progress_bar
from avionics_sitl.response import RaResponder
from avionics_sitl.scenario import Scenario

# One row per intruder: true miss at the true horizontal CPA, without and with the RAs flown (equal open loop), and
# the lowest height above the scenario's ground that ownship flew (the same on every row).
PROGRESS_EVERY_TICKS = 50  # the bar moves every 5 s of simulated time at 10 Hz
MISS_COLUMNS = ("intruder", "name", "t_cpa_s", "hmd_m", "vmd_unflown_m", "vmd_flown_m", "min_agl_m")
# --fly-guidance: the vehicle also moves horizontally, so the flown miss is taken at the flown closest approach
GUIDANCE_MISS_COLUMNS = MISS_COLUMNS + ("hmd_flown_m",)


@dataclass
class ReplayResult:
    changes: list[Advisory]
    names: dict[int, str]  # ICAO address -> scenario aircraft name
    collisions: list[tuple[float, object]] = field(default_factory=list)  # COLLISION as the autopilot got them
    counters: Counter = field(default_factory=Counter)
    misses: list = field(default_factory=list)  # VerticalMiss per intruder
    min_agl_m: float = math.nan  # the lowest true height above the scenario's ground ownship flew, at any tick
    copter: object | None = None  # sitl/avionics_sitl/guided.py SimCopter: the vehicle the guidance flew (fly_guidance)
    guidance: list = field(default_factory=list)  # every guidance decision whose state changed (fly_guidance)
    sent: list = field(default_factory=list)  # (time, message) of every command the DAA process sent the autopilot

    sensor_names: dict = field(default_factory=dict)  # a sensor track's key -> its aircraft's name (replay's)

    def name_of(self, key: IntruderKey) -> str:
        if key.source is AddressSource.SENSOR:
            return self.sensor_names.get(key, "")
        return self.names.get(key.address, "")

    def rows(self) -> list[dict]:
        return [csv_row(a, self.name_of(a.intruder)) for a in self.changes]

    def write_csv(self, path: str | Path) -> None:
        with open(path, "w", newline="") as fh:
            writer = csv.DictWriter(fh, fieldnames=CSV_COLUMNS)
            writer.writeheader()
            writer.writerows(self.rows())

    def miss_rows(self) -> list[dict]:
        return [{
            "intruder": str(m.key) if m.key is not None else "", "name": m.intruder, "t_cpa_s": f"{m.t_cpa_s:.3f}",
            "hmd_m": f"{m.hmd_m:.3f}", "vmd_unflown_m": f"{m.vmd_without_m:.3f}", "vmd_flown_m": f"{m.vmd_with_m:.3f}",
            "min_agl_m": f"{self.min_agl_m:.3f}",
            **({"hmd_flown_m": f"{m.hmd_flown_m:.3f}"} if self.copter is not None else {}),
        } for m in self.misses]

    def write_misses_csv(self, path: str | Path) -> None:
        with open(path, "w", newline="") as fh:
            writer = csv.DictWriter(fh, fieldnames=GUIDANCE_MISS_COLUMNS if self.copter is not None else MISS_COLUMNS)
            writer.writeheader()
            writer.writerows(self.miss_rows())


class _Recorder:
    """The replay's port: the advisory changes, in order (and the guidance's changes of state)."""

    def __init__(self, changes: list, guidance: list | None = None):
        self.changes, self.guidance = changes, guidance

    def wants(self, now_s):
        return NOTHING

    def publish(self, result) -> None:
        self.changes.extend(result.changes)
        if self.guidance is not None and result.guidance_changed:
            self.guidance.append(result.guidance)

    def close(self) -> None:
        pass


class _Autopilot:
    """The autopilot's side of the link: every frame the DAA process sends is packed, framed and decoded;
    COLLISION is recorded and DAA_ADVISORY goes to the responder (closed loop)."""

    def __init__(self, config: Config, result: ReplayResult, responder: RaResponder | None, clock, copter=None,
                 replies: list | None = None):
        self.link = mavlink2.MAVLink(None, srcSystem=config.mavlink.source_system,
                                     srcComponent=config.mavlink.source_component)
        self.rx = FrameScanner(Counter())
        self.result, self.responder, self.clock = result, responder, clock
        self.copter, self.replies = copter, replies  # the simulated ArduCopter and its answers, sent back next tick

    def send(self, msg) -> None:
        now_s = self.clock()
        for back in self.rx.feed(bytes(msg.pack(self.link)), end_of_datagram=True):
            kind = back.get_type()
            if kind == "COLLISION":
                self.result.collisions.append((now_s, back))
            elif kind == "DAA_ADVISORY" and self.responder is not None:
                self.responder.receive(back, now_s)
            elif self.copter is not None and kind in ("COMMAND_LONG", "COMMAND_INT", "SET_POSITION_TARGET_GLOBAL_INT",
                                                    "SET_POSITION_TARGET_LOCAL_NED", "MISSION_SET_CURRENT"):
                self.result.sent.append((now_s, back))
                self.replies.extend(self.copter.receive(back, now_s))
            elif self.copter is not None and kind.startswith("MISSION_"):  # the guidance reading the mission
                self.replies.extend(self.copter.receive(back, now_s))


class _ScheduleSource:
    """The scenario's MAVLink schedule on simulated time: a batch per delivery and one per assessment tick; with
    a responder, ownship flies the RAs it received and its GLOBAL_POSITION_INT follows."""

    def __init__(self, scenario, impairments, seed, autopilot, tick_s, mavlink: MavlinkInput, counters,
                 responder: RaResponder | None, copter=None, pilot=(), sensors=("adsb",), exact_sensors=False):
        self.scenario, self.tick_s, self.mavlink, self.responder = scenario, tick_s, mavlink, responder
        self.names = {a.icao_address: a.name for a in scenario.intruders}
        self.copter, self.pilot = copter, sorted(pilot)  # fly_guidance: the SimCopter; (time, mode) a pilot selects
        self.replies: list = []  # the copter's answers to the DAA process, delivered at the next tick
        self.events = schedule(scenario, impairments, seed, autopilot,
                               ownship=responder is None and copter is None)
        if "adsb" not in sensors:  # the intruders do not broadcast: only the ownship's sensors see them
            self.events = [e for e in self.events if e.msg.get_type() != "ADSB_VEHICLE"]
        self.scans = []
        if set(sensors) - {"adsb"}:  # sensor_feed.py: what `sitl live --sensor` sends, on the same schedule
            from avionics_sitl.sensor_feed import mavlink_events, sensor_scans, simulated_sensors

            self.scans = sensor_scans(scenario, simulated_sensors(sensors, seed, exact=exact_sensors),
                                      scenario.duration_s + 1e-9)
            self.events = sorted([*self.events, *mavlink_events(self.scans)], key=lambda e: e.deliver_s)
        self.own_period = 1.0 / autopilot.ownship_hz
        self.scanner = FrameScanner(counters)
        self.packer = Packer(autopilot)
        self.own_traj, self.intruder_trajs = scenario.trajectories()
        if copter is not None:
            copter.load_mission(self.own_traj, scenario.duration_s)  # the path, as the guidance reads it
        self.offsets: list[tuple] = []  # (t, (east, north, up) offset of ownship from the scenario's path)
        self.min_alt_msl_m = math.inf  # the lowest true ownship altitude at any tick
        self.now_s = 0.0
        self.progress = None  # called with the simulated time now and then

    def _batch(self, msg, now_s: float) -> Batch:
        self.now_s = now_s
        msgs = msg if isinstance(msg, list) else [msg]
        inputs = self.mavlink.decode([m for one in msgs
                                      for m in self.scanner.feed(self.packer.pack(one), end_of_datagram=True)], now_s)
        if self.scenario.stated_uncertainty:
            inputs = [self._stated(item) for item in inputs]
        return Batch(now_s, inputs)

    def _stated(self, item):
        """The input with its aircraft's stated uncertainty at its time (Scenario.uncertainty_at): ADSB_VEHICLE and
        GLOBAL_POSITION_INT have no field for it, so the simulated receiver hands it over beside the message, as a
        feed that reports NACp does (IntruderReport.uncertainty)."""
        if isinstance(item, IntruderReport):
            name = self.names.get(item.key.address)
        elif isinstance(item, OwnshipFix):
            name = self.scenario.ownship.name
        else:
            return item
        stated = self.scenario.uncertainty_at(name, item.time_s) if name is not None else None
        return item if stated is None else replace(item, uncertainty=stated)

    def __iter__(self):
        events, i = self.events, 0
        for k in range(int(math.floor(self.scenario.duration_s / self.tick_s)) + 1):
            t_tick = k * self.tick_s
            if self.progress is not None and k % PROGRESS_EVERY_TICKS == 0:
                self.progress(t_tick)
            while i < len(events) and events[i].deliver_s <= t_tick + 1e-9:
                j = i + 1  # a scan's detections (DAA_SENSOR_MEASUREMENT, one time) arrive together, as live
                while j < len(events) and events[j].deliver_s == events[i].deliver_s and \
                        events[i].msg.get_type() == events[j].msg.get_type() == "DAA_SENSOR_MEASUREMENT":
                    j += 1
                yield self._batch([e.msg for e in events[i:j]] if j > i + 1 else events[i].msg, events[i].deliver_s)
                i = j
            if self.copter is not None:
                while self.pilot and self.pilot[0][0] <= t_tick + 1e-9:
                    self.copter.set_mode(self.pilot.pop(0)[1], t_tick)
                own = self.copter.fly(self.own_traj.state_at(t_tick))
                self.offsets.append((t_tick, tuple(self.copter.offset)))
                replies = list(self.replies)  # the list the autopilot side appends to: emptied in place
                self.replies.clear()
                for msg in replies:
                    yield self._batch(msg, t_tick)
                if abs(t_tick - round(t_tick)) < 1e-6:  # HEARTBEAT at 1 Hz, as ArduPilot's default stream
                    yield self._batch([self.copter.heartbeat(), self.copter.mission_current()], t_tick)
                if abs(t_tick / self.own_period - round(t_tick / self.own_period)) < 1e-6 and \
                        self.copter.reports_position(t_tick):
                    for msg in ownship_messages(own, self.scenario.ground_elevation_m, int(t_tick * 1000)):
                        yield self._batch(msg, t_tick)
            elif self.responder is not None:
                own = self.responder.fly(self.own_traj.state_at(t_tick))
                self.offsets.append((t_tick, (0.0, 0.0, self.responder.offset_m)))
                if abs(t_tick / self.own_period - round(t_tick / self.own_period)) < 1e-6:
                    for msg in ownship_messages(own, self.scenario.ground_elevation_m, int(t_tick * 1000)):
                        yield self._batch(msg, t_tick)
            else:
                own = self.own_traj.state_at(t_tick)
            self.min_alt_msl_m = min(self.min_alt_msl_m, own.alt_msl_m)
            self.now_s = t_tick
            yield Batch(t_tick, [])

    def status(self):
        return self.mavlink.status()


def replay(scenario: Scenario, config: Config, impairments: AdsbImpairments, seed: int = 0,
           autopilot: AutopilotConfig = AutopilotConfig(), respond: bool = False, ports=(),
           progress: bool | None = False, fly_guidance: bool = False, copter=None, pilot=(),
           firmware: str | None = None, core=None, sensors=("adsb",), exact_sensors: bool = False) -> ReplayResult:
    """Fly the encounter through the DAA loop in fast time. respond=True closes the loop: ownship flies the RAs
    it receives (avionics_sitl.response) and the result records the vertical miss with and without the response.
    fly_guidance=True closes it through the guidance stage instead (config guidance.mode = "execute"): the
    simulated ArduCopter (sitl/avionics_sitl/guided.py; `copter`, or one of vehicle.profile, multirotor by default)
    flies the scenario's ownship path as its mission and obeys the MAVLink commands; firmware: "ardupilot"
    (ArduCopter), "px4" or "arduplane" (sitl/avionics_sitl/guided_plane.py; None: the vehicle profile's default,
    ArduPlane for the fixed-wing); pilot: (time, custom mode)
    mode changes a pilot makes. ports: more output ports (avionics/ports.py) fed by the same loop, e.g. a CsvOut.
    progress: a bar of the simulated time on stderr (None: when stderr is a terminal). core: the DaaCore to drive
    (built from config when None): a lab instrument that reads the core's state between steps passes its own.
    sensors: how the intruders are seen (sensor_feed.py: adsb, radar, active; the loop open: the sensors measure
    the scenario's paths), exact_sensors: they measure exactly and see all round (`--noise none`). A sensor track
    is named after the aircraft whose true position is nearest the track's at its first advisory (_SensorNamer)."""
    if set(sensors) - {"adsb"} and (respond or fly_guidance):
        raise ValueError("the simulated sensors measure the scenario's paths: not with a closed loop")
    counters: Counter = core.counters if core is not None else Counter()
    daa = Daa(config, counters, core)
    result = ReplayResult([], {a.icao_address: a.name for a in scenario.intruders}, counters=counters)
    responder = RaResponder(daa.response_model) if respond and not fly_guidance else None
    if fly_guidance and copter is None:
        from avionics.advisory.vehicle import load_vehicle
        from avionics_sitl.guided_plane import simulated_autopilot

        copter = simulated_autopilot(load_vehicle(config.vehicle.profile or "multirotor"), firmware,
                                     scenario.ground_elevation_m, system_id=autopilot.system_id,
                                     component_id=autopilot.component_id, counters=counters)
    copter = copter if fly_guidance else None
    result.copter = copter
    source = _ScheduleSource(scenario, impairments, seed, autopilot, 1.0 / config.advisory.assessment_hz,
                             MavlinkInput(config, counters), counters, responder, copter, pilot, sensors,
                             exact_sensors)
    autopilot_side = _Autopilot(config, result, responder, lambda: source.now_s, copter, source.replies)
    bar, task = progress_bar(progress, f"replaying {scenario.name}", scenario.duration_s)
    if bar is not None:
        source.progress = lambda t: bar.update(task, completed=t)
    try:
        namer = [_SensorNamer(daa, source.intruder_trajs, [a.name for a in scenario.intruders],
                              result.sensor_names)] if source.scans else []
        Loop(daa, source, [MavlinkOut(autopilot_side.send, config), _Recorder(result.changes, result.guidance),
                           *namer, *ports]).run()
    finally:
        if bar is not None:
            bar.update(task, completed=scenario.duration_s)
            bar.stop()
    result.misses = [_vertical_miss(scenario, source.own_traj, traj, spec.name, source.offsets,
                                    IntruderKey(spec.icao_address, spec.address_source))
                     for spec, traj in zip(scenario.intruders, source.intruder_trajs)]
    result.min_agl_m = source.min_alt_msl_m - scenario.ground_elevation_m
    return result


class _SensorNamer:
    """The replay's port that names each sensor track after an aircraft, at the track's first advisory: the one
    whose true position is nearest the track's estimated position then (the simulator knows the truth, the process
    does not). A track's range alone named two of sim3's tracks after one aircraft: active surveillance's range
    bias is larger than the two aircraft's difference in range."""

    def __init__(self, daa: Daa, trajectories, names, out: dict):
        self.daa, self.trajectories, self.names, self.out = daa, trajectories, names, out

    def wants(self, now_s):
        return NOTHING

    def publish(self, result) -> None:
        new = {a.intruder for a in result.changes if a.intruder.source is AddressSource.SENSOR} - set(self.out)
        if not new or not self.trajectories:
            return
        for view in self.daa.tracks(result.time_s):
            if view.key in new:
                here = LocalTangentPlane(view.lat_deg, view.lon_deg)
                truths = [traj.state_at(result.time_s) for traj in self.trajectories]
                miss = [math.hypot(*here.to_en(s.lat_deg, s.lon_deg), s.alt_msl_m - float(view.x[2])) for s in truths]
                self.out[view.key] = self.names[miss.index(min(miss))]

    def close(self) -> None:
        pass


@dataclass(frozen=True, slots=True)
class VerticalMiss:
    intruder: str
    t_cpa_s: float  # true time of horizontal closest approach
    hmd_m: float
    vmd_without_m: float  # |vertical separation| at CPA on the scenario's paths
    vmd_with_m: float  # ... with ownship flying the RAs (equal when the loop is open), at the flown CPA
    key: IntruderKey | None = None  # as the node keys it (the advisory CSV's intruder column)
    hmd_flown_m: float = math.nan  # the horizontal miss flown (fly_guidance: ownship moves horizontally too)
    t_cpa_flown_s: float = math.nan


def _vertical_miss(scenario, own_traj, traj, name, offsets, key=None) -> VerticalMiss:
    """Truth at the time of least horizontal distance, sampled at 0.1 s, on the scenario's paths and on the
    paths flown (ownship's offsets from its path, the latest at or before each sample; the same time when the
    flown path has no horizontal offset, as with the RA responder)."""
    import bisect

    times = [k * 0.1 for k in range(int(scenario.duration_s * 10) + 1)]
    stamps = [tt for tt, _ in offsets]

    def offset_at(t):
        i = bisect.bisect_right(stamps, t + 1e-9)
        return offsets[i - 1][1] if i else (0.0, 0.0, 0.0)

    dist, flown = [], []
    for t in times:
        oe, on, _ = own_traj.enu_at(t)
        ie, in_, _ = traj.enu_at(t)
        dist.append(math.hypot(ie - oe, in_ - on))
        de, dn, _ = offset_at(t)
        flown.append(math.hypot(ie - oe - de, in_ - on - dn))
    k = min(range(len(times)), key=dist.__getitem__)
    t = times[k]
    without = traj.enu_at(t)[2] - own_traj.enu_at(t)[2]
    kf = min(range(len(times)), key=flown.__getitem__)
    tf = times[kf]
    with_ = traj.enu_at(tf)[2] - own_traj.enu_at(tf)[2] - offset_at(tf)[2]
    return VerticalMiss(name, t, dist[k], abs(without), abs(with_), key, flown[kf], tf)
