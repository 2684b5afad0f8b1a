"""Avoidance that flies, over real sockets (issue 27): `avionics run` (a child process, guidance.mode=execute, a
multirotor, small-uas alerting) on UDP, the simulated ArduCopter or PX4 in this process flying the head-on's ownship
path as its mission (sitl/avionics_sitl/live.py fly_guided), a zenoh subscriber in another session. The acceptance runs
through `avionics demo --guidance` (eval/avionics_eval/demo.py), the interlocks through the same parts here."""

from __future__ import annotations

import json
import subprocess
import sys
import threading

import pytest

from avionics.advisory.vehicle import load_vehicle
from avionics.config import ZenohConfig
from avionics.base.units import FT
from avionics.guidance import ardupilot
from avionics.io.zenoh_bus import open_session
from avionics_sitl.encounters import load_encounter
from avionics_sitl.guided import SimCopter
from avionics_sitl.impairments import PRESETS
from avionics_sitl.live import fly_guided
from tests.conftest import DEADLINE_S, wait_for
from tests.test_integration_live import _wait_for_tcp

pytestmark = pytest.mark.live

NMAC_V_M = 100 * FT
START_S = 52.0  # head-on with small-uas: TA ~55 s, RA ~65.4 s, CPA 86.4 s, clear ~91.2 s, AUTO again ~94 s
GUIDANCE = ["advisory.profile=small-uas", "vehicle.profile=multirotor", "guidance.mode=execute"]


class _Onboard:
    """`avionics run` with the guidance on, and a zenoh subscriber to its `guidance` topic."""

    def __init__(self, udp_port: int, tcp_port: int, duration_s: float, settings=GUIDANCE):
        self.endpoint = f"tcp/127.0.0.1:{tcp_port}"
        sets = [a for s in [*settings, f'zenoh.listen=["{self.endpoint}"]', "vehicle.id=guideduav"]
                for a in ("--set", s)]
        self.process = subprocess.Popen(
            [sys.executable, "-m", "avionics.cli", "run", "--connection", f"udpin:127.0.0.1:{udp_port}", *sets,
             "--duration", str(duration_s + 2 * DEADLINE_S)],  # ended by the test; a backstop only
            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        self.decisions: list[dict] = []
        self._lock = threading.Lock()
        self.session = None
        _wait_for_tcp(tcp_port, self.process)
        self.session = open_session(ZenohConfig(listen=(), connect=(self.endpoint,)))
        self.subscriber = self.session.declare_subscriber("daa/guideduav/guidance", self._on_sample)
        # the guidance goes out with every status (1 Hz): once one is here the subscription is routed, and a flight
        # started now cannot put its first state change before it (a sample put before that is not delivered)
        assert wait_for(lambda: self.states()[:1] == ["idle"]), "no guidance state before the flight"

    def _on_sample(self, sample):
        with self._lock:
            self.decisions.append(json.loads(sample.payload.to_bytes()))

    def states(self) -> list[str]:
        with self._lock:
            states = [d["state"] for d in self.decisions]
        return [s for i, s in enumerate(states) if i == 0 or s != states[i - 1]]

    def close(self) -> str:
        if self.session is not None:
            self.subscriber.undeclare()
            self.session.close()
        self.process.terminate()
        _, err = self.process.communicate(timeout=DEADLINE_S)
        return err


def _statustexts(recording) -> list[str]:
    return [r.msg.text for r in recording.of_type("STATUSTEXT") if r.msg.text.startswith("DAA GUIDANCE")]


def test_the_multirotor_avoids_the_head_on_and_resumes_its_mission_live(capsys, udp_port, tcp_port):
    """Through `avionics demo --guidance` (eval/avionics_eval/demo.py): the onboard process as a child, the copter here."""
    from avionics_eval.demo import demo_guidance

    flight: dict = {}
    assert demo_guidance(port=udp_port, zenoh_port=tcp_port, noise="none", flight=flight) == 0
    out = capsys.readouterr().out
    assert "result: avoided, and back on the mission" in out and "autopilot modes: AUTO -> GUIDED -> AUTO" in out
    recording, copter, (miss,) = flight["recording"], flight["copter"], flight["misses"]
    assert miss.hmd_m < 500 * FT and miss.vmd_without_m < NMAC_V_M < miss.vmd_with_m, miss  # an NMAC without
    states = [d["state"] for d in flight["guidance"]]
    assert [s for i, s in enumerate(states) if i == 0 or s != states[i - 1]] == \
        ["idle", "commanding", "holding", "returning", "idle"]  # on zenoh
    assert [t.split()[2] for t in _statustexts(recording)] == ["COMMANDING", "HOLDING", "RETURNING", "IDLE"]
    # on the scenario's clock (the onboard process's time_s counts from its own start)
    holding_s = next(r.time_s for r in recording.of_type("STATUSTEXT") if "GUIDANCE HOLDING" in r.msg.text)
    modes = [(t, m) for t, m in copter.modes if t > 0]
    assert [m for _, m in modes] == [ardupilot.GUIDED, ardupilot.AUTO]
    # back on its mission within the quiet time after clear of conflict, plus the loop's and the link's latency
    assert modes[-1][0] - holding_s <= 2.0 + 0.5
    assert copter.counters["sim.guided_timeout"] == 0 and copter.counters["sim.setpoint_ignored"] == 0


def test_a_refused_guided_fails_with_a_statustext_live(udp_port, tcp_port):
    end_s = 72.0
    onboard = _Onboard(udp_port, tcp_port, end_s - START_S)
    copter = SimCopter(load_vehicle("multirotor"), refuse=frozenset({ardupilot.GUIDED}))
    try:
        recording = fly_guided(load_encounter("head-on"), f"udpout:127.0.0.1:{udp_port}", PRESETS["none"], copter,
                               start_s=START_S, duration_s=end_s - START_S)
        wait_for(lambda: "failed" in onboard.states())
    finally:
        err = onboard.close()
    assert onboard.states() == ["idle", "commanding", "failed"], err[-2000:]
    assert any(t.startswith("DAA GUIDANCE FAILED GUIDED refused") for t in _statustexts(recording))
    assert copter.counters["sim.mode_denied"] == 1 and copter.counters["sim.setpoint"] == 0
    assert [m for _, m in copter.modes] == [ardupilot.AUTO]


def test_a_pilot_mode_change_overrides_the_guidance_live(udp_port, tcp_port):
    end_s, pilot_s = 76.0, 70.0
    onboard = _Onboard(udp_port, tcp_port, end_s - START_S)
    copter = SimCopter(load_vehicle("multirotor"))
    try:
        recording = fly_guided(load_encounter("head-on"), f"udpout:127.0.0.1:{udp_port}", PRESETS["none"], copter,
                               start_s=START_S, duration_s=end_s - START_S, pilot=[(pilot_s, ardupilot.LOITER)])
        wait_for(lambda: "overridden" in onboard.states())
    finally:
        err = onboard.close()
    assert onboard.states() == ["idle", "commanding", "overridden"], err[-2000:]
    overridden = next(r.time_s for r in recording.of_type("STATUSTEXT") if "OVERRIDDEN" in r.msg.text)
    commands = [r.time_s for r in recording.received
                if r.msg.get_type() in ("COMMAND_LONG", "SET_POSITION_TARGET_GLOBAL_INT")]
    assert commands and max(commands) < overridden  # nothing after the override
    assert copter.modes[-1][1] == ardupilot.LOITER


def test_a_px4_offboard_stream_never_lapses_over_half_a_second_live(udp_port, tcp_port):
    from avionics.guidance import px4

    end_s = 74.0
    onboard = _Onboard(udp_port, tcp_port, end_s - START_S)
    copter = SimCopter(load_vehicle("multirotor"), firmware="px4")
    try:
        recording = fly_guided(load_encounter("head-on"), f"udpout:127.0.0.1:{udp_port}", PRESETS["none"], copter,
                               start_s=START_S, duration_s=end_s - START_S)
    finally:
        err = onboard.close()
    setpoints = [r.time_s for r in recording.of_type("SET_POSITION_TARGET_LOCAL_NED")]
    assert len(setpoints) > 20, err[-2000:]
    assert max(b - a for a, b in zip(setpoints, setpoints[1:])) <= 0.5  # received, on the wall clock
    assert [m for _, m in copter.modes] == [px4.MISSION, px4.OFFBOARD]
    assert copter.counters["sim.offboard_lost"] == 0 and copter.counters["sim.mode_denied"] == 0


def test_ownship_going_stale_mid_manoeuvre_gives_the_mission_back_and_commands_nothing_more_live(udp_port,
                                                                                                  tcp_port):
    end_s = 76.0
    onboard = _Onboard(udp_port, tcp_port, end_s - START_S)
    copter = SimCopter(load_vehicle("multirotor"), position_lost_s=70.0)  # navigation fails while it climbs
    try:
        recording = fly_guided(load_encounter("head-on"), f"udpout:127.0.0.1:{udp_port}", PRESETS["none"], copter,
                               start_s=START_S, duration_s=end_s - START_S)
        wait_for(lambda: onboard.states()[-1:] == ["idle"] and "returning" in onboard.states())
    finally:
        err = onboard.close()
    assert onboard.states() == ["idle", "commanding", "returning", "idle"], err[-2000:]
    returning = next(d for d in onboard.decisions if d["state"] == "returning")
    assert returning["reason"] == "daa_unavailable no_ownship"  # not a hold: nothing is commanded without ownship
    back_s = next(r.time_s for r in recording.of_type("STATUSTEXT") if "GUIDANCE RETURNING" in r.msg.text)
    setpoints = [r.time_s for r in recording.of_type("SET_POSITION_TARGET_GLOBAL_INT")]
    assert setpoints and max(setpoints) < back_s
    assert [m for _, m in copter.modes] == [ardupilot.AUTO, ardupilot.GUIDED, ardupilot.AUTO]


class _OffsetsCopter(SimCopter):
    """The simulated copter, keeping its offset from the path at each step (scenario time) for the flown miss."""

    def __init__(self, vehicle):
        super().__init__(vehicle)
        self.offsets: list = []

    def fly(self, mission):
        state = super().fly(mission)
        self.offsets.append((mission.t_s, tuple(self.offset)))
        return state


def test_the_multirotor_turns_off_the_head_on_under_do365_live(udp_port, tcp_port):
    """DO-365 (do365 profile: corrective and warning call for a manoeuvre): the bands' track resolution flown level
    through GUIDED, the mission given back once clear (tests/test_guidance_horizontal.py has it in fast time)."""
    from avionics_sitl.replay import _vertical_miss

    start_s, end_s = 66.0, 106.0  # CPA 86.4 s: flying on from 66 s is an NMAC (0 m, 0 ft)
    scenario = load_encounter("head-on")
    onboard = _Onboard(udp_port, tcp_port, end_s - start_s,
                       ["advisory.profile=do365", "vehicle.profile=multirotor", "guidance.mode=execute"])
    copter = _OffsetsCopter(load_vehicle("multirotor"))
    stop = threading.Event()

    def record(_received):  # the loop ends once the mission is given back and confirmed
        if onboard.states()[-2:] == ["returning", "idle"]:
            stop.set()

    try:
        recording = fly_guided(scenario, f"udpout:127.0.0.1:{udp_port}", PRESETS["none"], copter,
                               start_s=start_s, duration_s=end_s - start_s, on_receive=record, stop=stop)
    finally:
        err = onboard.close()
    states = onboard.states()
    assert states[:5] == ["idle", "commanding", "holding", "returning", "idle"], err[-2000:]
    commanding = next(d for d in onboard.decisions if d["state"] == "commanding")
    assert commanding["manoeuvre"] in ("turn_right", "turn_left") and commanding["target_track_deg"] is not None
    assert commanding["target_vertical_rate_mps"] == 0.0  # level: the vertical is unchanged
    texts = [t.split()[2] for t in _statustexts(recording)]
    assert texts[:4] == ["COMMANDING", "HOLDING", "RETURNING", "IDLE"]
    trajectories = scenario.trajectories()
    miss = _vertical_miss(scenario, trajectories[0], trajectories[1][0], "intruder", copter.offsets)
    assert miss.hmd_m < 500 * FT and miss.vmd_without_m < NMAC_V_M  # an NMAC flying on
    assert miss.hmd_flown_m > 500 * FT, miss  # outside NMAC, level
    print(f"do365 head-on live: HMD without {miss.hmd_m:.0f} m, flown {miss.hmd_flown_m:.0f} m")
    returning_s = next(r.time_s for r in recording.of_type("STATUSTEXT") if "GUIDANCE RETURNING" in r.msg.text)
    modes = [(t, m) for t, m in copter.modes if t > 0]
    assert [m for _, m in modes][:2] == [ardupilot.GUIDED, ardupilot.AUTO]
    assert modes[1][0] - returning_s <= 0.5  # AUTO asked for at the end of the quiet time, taken at once
    assert copter.counters["sim.guided_timeout"] == 0 and copter.counters["sim.setpoint_ignored"] == 0


def test_the_px4_mode_ladder_escalates_hold_then_return_each_once_live(udp_port, tcp_port):
    """guidance.ladder (avionics/guidance/ladder.py, after PX4's DAA module: one action per escalation) over real
    sockets: Hold at the TA, Return at the RA, each DO_SET_MODE sent once and confirmed by the HEARTBEAT, the
    states on zenoh and STATUSTEXT; the mission is not resumed after (PX4: conservative de-escalation)."""
    from avionics.guidance import px4

    end_s = 90.0  # held from the TA (~55 s), the ownship stopped: the RA comes at ~81 s (fast time: test_guidance_ladder)
    onboard = _Onboard(udp_port, tcp_port, end_s - START_S,
                       [*GUIDANCE, 'guidance.ladder=["hold", "return"]'])
    copter = SimCopter(load_vehicle("multirotor"), firmware="px4")
    stop, returning = threading.Event(), threading.Event()

    def record(received):  # the loop ends once Return is in force and its STATUSTEXT is here (it may follow the mode)
        msg = received.msg
        if msg.get_type() == "STATUSTEXT" and msg.text.startswith("DAA GUIDANCE COMMANDING RETURN"):
            returning.set()
        if copter.modes[-1][1] == px4.RTL and returning.is_set():
            stop.set()

    try:
        recording = fly_guided(load_encounter("head-on"), f"udpout:127.0.0.1:{udp_port}", PRESETS["none"], copter,
                               start_s=START_S, duration_s=end_s - START_S, on_receive=record, stop=stop)
        wait_for(lambda: [d["manoeuvre"] for d in onboard.decisions if d["state"] == "commanding"][-1:] == ["return"])
    finally:
        err = onboard.close()
    actions = [d["manoeuvre"] for d in onboard.decisions if d["state"] == "commanding"]
    assert [a for i, a in enumerate(actions) if i == 0 or a != actions[i - 1]] == ["hold", "return"], err[-2000:]
    asked = [px4.mode_of(r.msg) for r in recording.received if r.msg.get_type() == "COMMAND_LONG"]
    assert asked == [px4.HOLD, px4.RTL]  # once per escalation: no retry once the HEARTBEAT showed the mode
    assert [m for _, m in copter.modes] == [px4.MISSION, px4.HOLD, px4.RTL]
    texts = _statustexts(recording)
    assert any(t.startswith("DAA GUIDANCE COMMANDING HOLD level 1") for t in texts)
    assert any(t.startswith("DAA GUIDANCE COMMANDING RETURN level 2") for t in texts)
    assert copter.counters["sim.mode_denied"] == 0
