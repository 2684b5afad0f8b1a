"""Live SITL: flies a scenario in real time over a MAVLink link and records what the DAA process sends back; the
same intruders may also be served as a ground ADS-B receiver serves them (SBS-1 BaseStation lines, Beast binary
frames, over TCP), on the MAVLink schedule's clock."""

from __future__ import annotations

import errno
import os
import time
from collections import Counter
from dataclasses import dataclass, field

from avionics.io.link import MavlinkLink
from avionics_sitl.autopilot import AutopilotConfig, Packer, schedule
from avionics_sitl.impairments import AdsbImpairments
from avionics_sitl.scenario import Scenario


class FeedServerError(OSError):
    """A receiver-feed server could not listen (port in use, address not on this machine): exit 1, one line."""


class ScenarioClock:
    """Scenario seconds on the monotonic clock, shared by the MAVLink schedule and the feed servers: `start_s` until
    start(), then start_s + the wall time since start()."""

    def __init__(self, start_s: float = 0.0):
        self.start_s = start_s
        self._wall0: float | None = None

    def start(self) -> None:
        self._wall0 = time.monotonic() - self.start_s

    def started(self) -> bool:
        return self._wall0 is not None

    @property
    def wall0(self) -> float:
        """The monotonic time of scenario time 0 (once started)."""
        if self._wall0 is None:
            raise RuntimeError("the scenario clock has not started")
        return self._wall0

    def __call__(self) -> float:
        wall0 = self._wall0
        return self.start_s if wall0 is None else time.monotonic() - wall0


def feed_servers(scenario: Scenario, impairments: AdsbImpairments, seed: int, clock: ScenarioClock, end_s: float,
                 sbs: tuple[str, int] | None = None, beast: tuple[str, int] | None = None) -> list:
    """The simulated receiver's SBS (sitl/avionics_sitl/sbs.py) and Beast (sitl/avionics_sitl/beast.py) servers, listening
    (not yet sending: start() them), paced by `clock` from its start_s (nothing due before it is sent). The same
    seed as the MAVLink schedule: the SBS lines are its ADSB_VEHICLE reports exactly. FeedServerError when one
    cannot listen; none is left open then."""
    from avionics_sitl.beast import BeastServer, beast_schedule
    from avionics_sitl.encounters import ScenarioError
    from avionics_sitl.sbs import SbsServer, sbs_schedule

    wanted = [(name, option, address, cls, make) for name, option, address, cls, make in (
        ("SBS", "--sbs", sbs, SbsServer, sbs_schedule),
        ("Beast", "--beast", beast, BeastServer, beast_schedule),
    ) if address is not None]
    servers = []
    try:
        for name, option, (host, port), cls, make in wanted:
            try:
                events = make(scenario, impairments, seed, duration_s=end_s)
            except ValueError as exc:  # Beast: a callsign or altitude the format cannot carry
                raise ScenarioError(f"{option}: the scenario cannot be encoded: {exc}") from exc
            try:
                servers.append(cls(events, host, port, start_s=clock.start_s, clock=clock))
            except OSError as exc:
                reason = os.strerror(exc.errno) if exc.errno else str(exc)
                if exc.errno == errno.EADDRINUSE:
                    reason = f"in use ({reason})"
                raise FeedServerError(f"{name} TCP port {host}:{port} cannot listen: {reason}; {option}") from exc
    except BaseException:
        for server in servers:
            server.stop()
        raise
    return servers


@dataclass(frozen=True, slots=True)
class Received:
    time_s: float  # scenario time at receipt
    msg: object


@dataclass
class Recording:
    received: list[Received] = field(default_factory=list)
    sent: int = 0
    counters: Counter = field(default_factory=Counter)
    flown: list = field(default_factory=list)  # fly_guided: (time, (east, north, up) offset from the mission path)

    def of_type(self, kind: str) -> list[Received]:
        return [r for r in self.received if r.msg.get_type() == kind]


def fly(scenario: Scenario, connection: str, impairments: AdsbImpairments, seed: int = 0,
        start_s: float = 0.0, duration_s: float | None = None, autopilot: AutopilotConfig = AutopilotConfig(),
        on_receive=None, stop=None, adsb_vehicle: bool = True, clock: ScenarioClock | None = None,
        extra_events=()) -> Recording:
    """Send the schedule from scenario time start_s in real time; receive until the end. on_receive(Received)
    is called for each message from the DAA side (e.g. to print COLLISION as it arrives). adsb_vehicle=False: the
    ownship only (the traffic goes by receiver feeds or the sensors). clock: started here once the link is open, for
    the feed servers paced by it (its start_s is start_s). extra_events: more of the autopilot's messages merged into
    the schedule (the sensors' DAA_SENSOR_MEASUREMENT, sensor_feed.py)."""
    end_s = scenario.duration_s if duration_s is None else min(scenario.duration_s, start_s + duration_s)
    events = [e for e in schedule(scenario, impairments, seed, autopilot, duration_s=end_s)
              if adsb_vehicle or e.msg.get_type() != "ADSB_VEHICLE"]
    events = sorted((e for e in [*events, *extra_events] if start_s <= e.deliver_s <= end_s),
                    key=lambda e: e.deliver_s)
    recording = Recording()
    if clock is None:
        clock = ScenarioClock(start_s)
    elif clock.start_s != start_s:
        raise ValueError(f"the clock starts at {clock.start_s} s, the flight at {start_s} s")
    link = MavlinkLink(connection, recording.counters, autopilot.system_id, autopilot.component_id)
    packer = Packer(autopilot)
    clock.start()
    wall0 = clock.wall0
    i = 0
    try:
        while True:
            now = time.monotonic() - wall0
            if now >= end_s or (stop is not None and stop.is_set()):
                break
            while i < len(events) and events[i].deliver_s <= now:
                link.conn.write(packer.pack(events[i].msg))
                recording.sent += 1
                i += 1
            next_due = events[i].deliver_s if i < len(events) else end_s
            for msg in link.receive(max(0.0, min(next_due, end_s) - (time.monotonic() - wall0))):
                if msg.get_srcComponent() == autopilot.component_id and msg.get_srcSystem() == autopilot.system_id \
                        and msg.get_type() != "COLLISION":
                    continue  # our own echo on a shared link
                received = Received(time.monotonic() - wall0, msg)
                recording.received.append(received)
                if on_receive is not None:
                    on_receive(received)
    finally:
        link.close()
    return recording


GUIDED_FLY_PERIOD_S = 0.05  # the simulated copter's dynamics step between messages


def fly_guided(scenario: Scenario, connection: str, impairments: AdsbImpairments, copter, seed: int = 0,
               start_s: float = 0.0, duration_s: float | None = None,
               autopilot: AutopilotConfig = AutopilotConfig(), on_receive=None, stop=None,
               pilot=()) -> Recording:
    """The closed loop in real time (sitl live --fly-guidance): the simulated ArduCopter (sitl/avionics_sitl/guided.py)
    flies the scenario's ownship path as its mission from start_s, sends its GLOBAL_POSITION_INT and
    SCALED_PRESSURE at autopilot.ownship_hz and HEARTBEAT at 1 Hz as it flies, the intruders' ADSB_VEHICLE on
    their schedule, and obeys the DAA process's commands (answered with COMMAND_ACK at once). pilot: (scenario
    time, custom mode) mode changes a pilot makes. The recording holds every message received."""
    from avionics_sitl.autopilot import ownship_messages

    end_s = scenario.duration_s if duration_s is None else min(scenario.duration_s, start_s + duration_s)
    events = [e for e in schedule(scenario, impairments, seed, autopilot, duration_s=end_s, ownship=False)
              if e.deliver_s >= start_s]
    own_traj = scenario.trajectories()[0]
    copter.load_mission(own_traj, scenario.duration_s)  # the path, as the guidance reads it (MISSION_ protocol)
    pilot = sorted(pilot)
    recording = Recording()
    link = MavlinkLink(connection, recording.counters, autopilot.system_id, autopilot.component_id)
    packer = Packer(autopilot)
    wall0 = time.monotonic() - start_s
    i = 0
    next_own = next_beat = start_s
    own_period = 1.0 / autopilot.ownship_hz
    try:
        while True:
            now = time.monotonic() - wall0
            if now >= end_s or (stop is not None and stop.is_set()):
                break
            while pilot and pilot[0][0] <= now:
                copter.set_mode(pilot.pop(0)[1], now)
            state = copter.fly(own_traj.state_at(now))
            recording.flown.append((now, tuple(copter.offset)))
            out = []
            if now >= next_beat:
                out += [copter.heartbeat(), copter.mission_current()]
                next_beat += 1.0
            if now >= next_own:
                if copter.reports_position(now):
                    out.extend(ownship_messages(state, scenario.ground_elevation_m, int(now * 1000)))
                next_own += own_period
            while i < len(events) and events[i].deliver_s <= now:
                out.append(events[i].msg)
                i += 1
            for msg in out:
                link.conn.write(packer.pack(msg))
                recording.sent += 1
            wait = min(GUIDED_FLY_PERIOD_S, max(0.0, min(next_own, next_beat, end_s) - (time.monotonic() - wall0)))
            for msg in link.receive(wait):
                if msg.get_srcSystem() == autopilot.system_id and msg.get_srcComponent() in (
                        autopilot.component_id, autopilot.adsb_component_id):
                    continue  # our own echo on a shared link
                received = Received(time.monotonic() - wall0, msg)
                recording.received.append(received)
                for reply in copter.receive(msg, received.time_s):
                    link.conn.write(packer.pack(reply))
                if on_receive is not None:
                    on_receive(received)
    finally:
        link.close()
    return recording
