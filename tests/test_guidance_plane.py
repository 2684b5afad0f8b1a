"""The guidance flown by a small fixed-wing in fast time (issue 27, "the same with a small fixed-wing"): the DAA process
commands the simulated ArduPlane (sitl/avionics_sitl/guided_plane.py) over MAVLink (pymavlink framing both ways)
with ArduPlane's GUIDED contract (avionics/guidance/arduplane.py): DO_SET_MODE GUIDED, then COMMAND_INT
MAV_CMD_GUIDED_CHANGE_HEADING (the course kept) and MAV_CMD_GUIDED_CHANGE_ALTITUDE (the RA's rate), each
acknowledged. The encounter is tests/data/head_on_fixed_wing.toml with the small-uas alerting profile: the tcas2
profile inhibits RAs below 1000 ft above the ground, and this plane flies at 300 ft. The live acceptance over real
sockets is tests/test_guidance_live.py."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings, strategies as st

from avionics.advisory.vehicle import load_vehicle
from avionics.config import load_config
from avionics.base.types import AutopilotHeartbeat, CommandAck
from avionics.base.units import FT
from avionics.guidance import arduplane
from avionics.guidance.params import GuidanceConfig
from avionics.guidance.stage import GuidanceStage, Ownship
from avionics.io.dialect import daa as mavlink2
from avionics_sitl.encounters import load_encounter
from avionics_sitl.guided_plane import SimPlane
from avionics_sitl.impairments import PRESETS
from avionics_sitl.replay import replay
from tests.test_guidance import KEY, NMAC_H_M, NMAC_V_M, _Outputs, _ra

ENCOUNTER = str(Path(__file__).parent / "data" / "head_on_fixed_wing.toml")
BASE = ["advisory.profile=small-uas", "vehicle.profile=fixed-wing", "zenoh.enabled=false"]


def _config(*more):
    return load_config(overrides=[*BASE, "guidance.mode=execute", *more])


def _commands(result, command: int) -> list:
    return [(t, m) for t, m in result.sent if m.get_type() == "COMMAND_INT" and m.command == command]


def test_the_fixed_wing_flies_the_head_on_nmac_into_a_miss_and_resumes_its_mission():
    scenario = load_encounter(ENCOUNTER)
    (unflown,) = replay(scenario, load_config(overrides=BASE), PRESETS["none"]).misses
    assert unflown.hmd_m < NMAC_H_M and unflown.vmd_without_m < NMAC_V_M  # an NMAC without guidance

    config = _config()
    out = _Outputs(config)
    result = replay(scenario, config, PRESETS["none"], fly_guidance=True, ports=out.ports)
    (miss,) = result.misses
    assert miss.vmd_with_m > NMAC_V_M, miss  # outside NMAC at the flown closest approach
    assert [d.state for d in result.guidance] == ["commanding", "holding", "returning", "idle"], result.guidance
    commanding, holding, returning, idle = result.guidance
    assert commanding.manoeuvre == "climb" and commanding.target_vertical_rate_mps == pytest.approx(5.0)  # TECS_CLMB_MAX
    assert idle.reason == "mission_resumed" and idle.autopilot_mode == "AUTO"
    plane = result.copter
    assert [m for _, m in plane.modes] == [arduplane.AUTO, arduplane.GUIDED, arduplane.AUTO]
    # back in AUTO within the quiet time after clear of conflict (the HEARTBEAT that confirms it: 1 Hz)
    assert plane.modes[-1][0] - holding.time_s <= config.guidance.quiet_time_s + 0.25
    assert idle.time_s - holding.time_s <= config.guidance.quiet_time_s + 1.0 + 0.25
    # the contract: GUIDED first, then the course (northbound: 0 deg over ground) and the altitude target ahead at
    # the profile's rate, in MAV_FRAME_GLOBAL_RELATIVE_ALT_INT; every command acknowledged, no velocity setpoint
    guided_s = plane.modes[1][0]
    (heading_s, heading), = _commands(result, arduplane.CHANGE_HEADING)
    altitudes = _commands(result, arduplane.CHANGE_ALTITUDE)
    assert heading_s > guided_s and heading.param1 == arduplane.COURSE_OVER_GROUND
    assert min(heading.param2, 360.0 - heading.param2) < 1.0
    assert altitudes[0][0] > guided_s and all(m.frame == arduplane.ALTITUDE_FRAME for _, m in altitudes)
    first = altitudes[0][1]
    assert first.param3 == pytest.approx(5.0) and first.z == pytest.approx(300 * FT + 5.0 * 10.0, abs=1.0)
    heights = [m.z for _, m in altitudes]  # resent every second 50 m ahead, then level at the height reached
    assert len(heights) >= 5 and all(b >= a for a, b in zip(heights[:-1], heights[1:-1]))
    assert heights[-2] - 50.0 - 1.0 <= heights[-1] < heights[-2] and all(m.param3 > 0 for _, m in altitudes)
    assert not any(m.get_type().startswith("SET_POSITION_TARGET") for _, m in result.sent)
    n_int = sum(m.get_type() == "COMMAND_INT" for _, m in result.sent)
    assert result.counters["sim.command_int.0"] == n_int and result.counters["rx.command_ack"] == n_int + 2
    assert miss.hmd_flown_m < 10.0  # the course kept: no turn onto GUIDED's loiter circle
    # each state on MAVLink (STATUSTEXT) and zenoh (`guidance`), in order
    assert [t.split()[2] for t in out.statustexts()] == ["COMMANDING", "HOLDING", "RETURNING", "IDLE"]
    changes = [p["state"] for s, p in out.zenoh if s == "guidance"]
    assert [s for i, s in enumerate(changes) if i == 0 or s != changes[i - 1]] == \
        ["idle", "commanding", "holding", "returning", "idle"]


def test_a_refused_guided_command_fails_with_a_statustext_and_gives_the_mission_back():
    """A firmware built without AP_PLANE_OFFBOARD_GUIDED_SLEW_ENABLED answers UNSUPPORTED."""
    config = _config()
    out = _Outputs(config)
    plane = SimPlane(load_vehicle("fixed-wing"), home_alt_msl_m=400.0,
                     refuse_commands=frozenset({arduplane.CHANGE_ALTITUDE}))
    result = replay(load_encounter(ENCOUNTER), config, PRESETS["none"], fly_guidance=True, copter=plane,
                    ports=out.ports)
    assert [d.state for d in result.guidance][:2] == ["commanding", "failed"]
    failed = result.guidance[1]
    assert failed.reason == f"CHANGE_ALTITUDE refused: result {mavlink2.MAV_RESULT_UNSUPPORTED}"
    assert any(t.startswith("DAA GUIDANCE FAILED CHANGE_ALTITUDE refused") for t in out.statustexts())
    assert [m for _, m in plane.modes] == [arduplane.AUTO, arduplane.GUIDED, arduplane.AUTO]  # not left circling
    assert len(_commands(result, arduplane.CHANGE_ALTITUDE)) == 1  # refused: not retried
    assert all(t <= failed.time_s or m.get_type() == "COMMAND_LONG" for t, m in result.sent)


def test_a_pilot_mode_change_overrides_and_nothing_more_is_commanded():
    config = _config()
    result = replay(load_encounter(ENCOUNTER), config, PRESETS["none"], fly_guidance=True,
                    pilot=[(45.0, arduplane.LOITER)])
    assert [d.state for d in result.guidance][:2] == ["commanding", "overridden"]
    overridden = result.guidance[1]
    assert "LOITER" in overridden.reason and overridden.time_s <= 45.0 + 1.1  # the next HEARTBEAT says it
    assert all(t <= overridden.time_s for t, _ in result.sent)
    assert result.copter.modes[-1][1] == arduplane.LOITER


# -- the stage alone: the acknowledgement and its retries ---------------------------------------------------------
def _plane_stage(**config):
    stage = GuidanceStage(GuidanceConfig(mode="execute", **config), load_vehicle("fixed-wing"), 1)
    stage.update(0.0, {}, None, Ownship(15.0, 0.0, 0.0, 100.0),
                 [AutopilotHeartbeat(0.0, 1, arduplane.AUTO, 0, autopilot=3, mav_type=1)])
    assert stage.contract.name == "ArduPlane"
    return stage


def _guided(stage, now_s: float):
    """The RA, GUIDED asked for and acknowledged: the step that sends the GUIDED commands."""
    own = Ownship(15.0, 0.0, 0.0, 100.0)
    (ask,) = stage.update(now_s, {KEY: _ra(target=5.0)}, None, own).commands
    assert ask.get_type() == "COMMAND_LONG" and ask.param2 == arduplane.GUIDED
    ack = CommandAck(now_s + 0.1, mavlink2.MAV_CMD_DO_SET_MODE, mavlink2.MAV_RESULT_ACCEPTED)
    return stage.update(now_s + 0.2, {KEY: _ra(target=5.0)}, None, own, [ack]).commands


def test_an_unanswered_guided_command_is_resent_then_fails_after_the_retries():
    stage = _plane_stage(retries=2, ack_timeout_s=1.0)
    heading, altitude = _guided(stage, 1.0)
    assert (heading.command, altitude.command) == (arduplane.CHANGE_HEADING, arduplane.CHANGE_ALTITUDE)
    assert altitude.z == pytest.approx(150.0) and altitude.param3 == pytest.approx(5.0)  # 100 m + 5 m/s x 10 s
    own = Ownship(15.0, 0.0, 0.0, 100.0)
    beat = AutopilotHeartbeat(1.5, 1, arduplane.GUIDED, 0, autopilot=3, mav_type=1)
    ack = CommandAck(1.6, arduplane.CHANGE_ALTITUDE, mavlink2.MAV_RESULT_ACCEPTED)  # the heading's ACK is lost
    sent = []
    for k, inputs in enumerate([[beat, ack], [], [], []]):
        out = stage.update(2.2 + k, {KEY: _ra(target=5.0)}, None, own, inputs)
        sent.append([(m.get_type(), m.command) for m in out.commands])
    resend = ("COMMAND_INT", arduplane.CHANGE_HEADING)
    assert sent[0].count(resend) == 1 and sent[1].count(resend) == 1  # the same command, twice more
    assert out.decision.state == "failed" and out.decision.reason == "CHANGE_HEADING unconfirmed x3"
    assert ("COMMAND_LONG", mavlink2.MAV_CMD_DO_SET_MODE) in sent[2]  # the mission asked for again
    assert stage.request.mode == arduplane.AUTO


def test_level_is_sent_once_and_never_as_a_zero_rate():
    stage = _plane_stage()
    _guided(stage, 1.0)
    own = Ownship(15.0, 0.0, 0.0, 120.0)
    beat = AutopilotHeartbeat(1.5, 1, arduplane.GUIDED, 0, autopilot=3, mav_type=1)
    acks = [CommandAck(1.6, c, mavlink2.MAV_RESULT_ACCEPTED) for c in (arduplane.CHANGE_HEADING,
                                                                      arduplane.CHANGE_ALTITUDE)]
    level = stage.update(2.2, {KEY: _ra(target=0.0, strength="corrective")}, None, own, [beat, *acks]).commands
    (altitude,) = [m for m in level if m.get_type() == "COMMAND_INT"]
    assert altitude.z == pytest.approx(120.0) and altitude.param3 > 0  # 0 would be "at once" to ArduPlane
    ack = CommandAck(2.3, arduplane.CHANGE_ALTITUDE, mavlink2.MAV_RESULT_ACCEPTED)
    later = stage.update(4.2, {KEY: _ra(target=0.0, strength="corrective")}, None, own, [ack]).commands
    assert not any(m.get_type() == "COMMAND_INT" and m.command == arduplane.CHANGE_ALTITUDE for m in later)


@pytest.mark.parametrize("height, rate, floor, ceiling, expected", [
    (100.0, -5.0, 15.0, 0.0, 50.0), (40.0, -5.0, 15.0, 0.0, 15.0), (10.0, -5.0, 15.0, 0.0, 10.0),
    (100.0, 5.0, 15.0, 120.0, 120.0), (130.0, 5.0, 15.0, 120.0, 130.0), (100.0, 0.0, 15.0, 0.0, 100.0)])
def test_the_altitude_target_is_clamped_to_the_floor_and_ceiling(height, rate, floor, ceiling, expected):
    assert arduplane.altitude_target(height, rate, floor, ceiling) == pytest.approx(expected)


def test_an_altitude_of_zero_is_never_sent():
    assert arduplane.change_altitude(0.0, 5.0, 1, 1).z != 0.0


# -- the simulated ArduPlane ---------------------------------------------------------------------------------------
def _flying_plane():
    from avionics_sitl.trajectory import KinematicState

    plane = SimPlane(load_vehicle("fixed-wing"), home_alt_msl_m=0.0)

    def mission(t):
        return KinematicState(t, 47.4 + math.degrees(15.0 * t / 6371008.8), 8.5, 100.0, 0.0, 15.0, 0.0)

    plane.fly(mission(0.0))
    return plane, mission


def test_the_simulated_arduplane_answers_as_arduplane():
    plane, mission = _flying_plane()
    results = lambda *msgs: [plane.receive(m, 1.0)[0].result for m in msgs]  # noqa: E731
    assert results(arduplane.change_altitude(150.0, 5.0, 1, 1), arduplane.change_heading(0.0, 1, 1)) == \
        [mavlink2.MAV_RESULT_FAILED] * 2  # only in GUIDED
    assert results(arduplane.set_mode(9, 1, 1)) == [mavlink2.MAV_RESULT_DENIED]  # 9 is no ArduPlane mode
    assert results(arduplane.set_mode(arduplane.GUIDED, 1, 1)) == [mavlink2.MAV_RESULT_ACCEPTED]
    bad_alt = arduplane.command_int(arduplane.CHANGE_ALTITUDE, 1, 1, arduplane.ALTITUDE_FRAME, param3=5.0, z=0.0)
    bad_heading = arduplane.command_int(arduplane.CHANGE_HEADING, 1, 1, param2=360.0)
    slow = arduplane.change_speed(5.0, 1.0, 1, 1)  # below AIRSPEED_MIN
    assert results(bad_alt, bad_heading, slow) == [mavlink2.MAV_RESULT_DENIED] * 3
    assert results(arduplane.change_speed(18.0, 1.0, 1, 1)) == [mavlink2.MAV_RESULT_ACCEPTED]
    from avionics.guidance import ardupilot

    assert plane.receive(ardupilot.velocity_setpoint(15.0, 0.0, 5.0, 1, 1, 0), 1.0) == []
    assert plane.counters["sim.setpoint_ignored"] == 1  # the velocity of a setpoint: ignored by ArduPlane
    assert plane.heartbeat().type == mavlink2.MAV_TYPE_FIXED_WING


@pytest.mark.parametrize("hold_course", [False, True])
def test_guided_loiters_around_its_entry_point_unless_a_course_is_held_and_never_stops(hold_course):
    plane, mission = _flying_plane()
    plane.fly(mission(1.0))
    plane.receive(arduplane.set_mode(arduplane.GUIDED, 1, 1), 1.0)
    if hold_course:
        plane.receive(arduplane.change_heading(0.0, 1, 1), 1.0)
    plane.receive(arduplane.change_altitude(150.0, 5.0, 1, 1), 1.0)
    courses, speeds, ups = [], [], []
    for k in range(1, 601):
        state = plane.fly(mission(1.0 + 0.05 * k))
        courses.append(math.degrees(math.atan2(state.vel_east_mps, state.vel_north_mps)))
        speeds.append(math.hypot(state.vel_east_mps, state.vel_north_mps))
        ups.append(state.vel_up_mps)
    assert min(speeds) > 14.0  # a plane keeps flying
    assert max(ups) == pytest.approx(5.0, abs=0.01)  # TECS_CLMB_MAX toward the target 50 m up, then level there
    assert state.alt_msl_m == pytest.approx(150.0, abs=3.0) and abs(state.vel_up_mps) < 1.0
    turned = max(abs(c) for c in courses)
    assert (turned < 1.0) if hold_course else (turned > 90.0)


# -- the property: closed loop with the fixed-wing's dynamics -----------------------------------------------------
def _plane_encounter(seed: int):
    """A small fixed-wing's encounter at 15 m/s within its climb and sink rates (ra_sim.uav_encounter):
    (scenario, ownship height, its vertical rate)."""
    from ra_sim import uav_encounter

    return uav_encounter(seed, 15.0, (-3.0, 3.0), (30.0, 90.0), f"plane-{seed}")[:3]


@settings(max_examples=10, deadline=None, derandomize=True,
          suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])
@given(seed=st.integers(0, 2**32 - 1), floor_below_m=st.floats(5.0, 60.0))
def test_the_executed_manoeuvre_never_goes_below_the_floor_nor_leaves_a_smaller_miss(seed, floor_below_m):
    """As the multirotor's property (tests/test_guidance.py), for the fixed-wing flying ArduPlane's GUIDED altitude
    commands: never below the floor in GUIDED (unless it was already lower), and the vertical miss at the closest
    approach flown never smaller than flying the mission on (within 15 ft), where the mission stays above it."""
    scenario, agl, vz_own = _plane_encounter(seed)
    floor = agl - floor_below_m
    result = replay(scenario, _config(f"guidance.floor_m={floor}"), PRESETS["none"], fly_guidance=True)
    plane = result.copter
    guided_from = [t for t, mode in plane.modes if mode == arduplane.GUIDED]
    if not guided_from:
        return  # no RA, or one the mission complied with
    start_height = min(agl + vz_own * t for t in guided_from)
    assert plane.min_guided_alt_msl_m >= min(floor, start_height) - 0.5, (seed, floor, plane.min_guided_alt_msl_m)
    if agl + min(0.0, vz_own * scenario.duration_s) >= floor:
        (miss,) = result.misses
        assert miss.vmd_with_m >= miss.vmd_without_m - 15 * FT or miss.hmd_flown_m >= NMAC_H_M, (seed, miss)


def test_sitl_replay_flies_the_fixed_wing_through_arduplane_by_default(tmp_path, capsys):
    """`sitl replay ... --fly-guidance --vehicle fixed-wing`: the vehicle profile picks the simulated ArduPlane."""
    import csv

    from avionics_sitl.cli import main

    misses = tmp_path / "misses.csv"
    assert main(["replay", ENCOUNTER, "--fly-guidance", "--vehicle", "fixed-wing", "--noise", "none",
                 "--set", "advisory.profile=small-uas", "--misses", str(misses)]) == 0
    rows = capsys.readouterr().out.splitlines()
    assert any(",GUIDANCE," in r and r.endswith("mission_resumed,AUTO") for r in rows)  # ArduPlane's AUTO (10)
    (miss,) = csv.DictReader(misses.open())
    assert float(miss["vmd_unflown_m"]) < NMAC_V_M < float(miss["vmd_flown_m"])
    from avionics_sitl.guided_plane import simulated_autopilot

    plane = load_vehicle("fixed-wing")
    assert type(simulated_autopilot(plane)) is SimPlane  # what --vehicle fixed-wing flies without --autopilot
    assert type(simulated_autopilot(plane, "ardupilot")) is not SimPlane
    with pytest.raises(ValueError, match="autopilot 'inav'"):
        simulated_autopilot(plane, "inav")
