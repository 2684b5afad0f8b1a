"""The mode ladder for simple vehicles (guidance.ladder, avionics/guidance/ladder.py) in fast time: the DAA process
switches the simulated ArduCopter or PX4 (sitl/avionics_sitl/guided.py) to the mode of each alert level, once per
escalation, over MAVLink (pymavlink framing both ways), as PX4's DAA module does."""

from __future__ import annotations

import pytest

from avionics.advisory.vehicle import load_vehicle
from avionics.config import ConfigError, load_config
from avionics.base.types import AutopilotHeartbeat
from avionics.guidance import ardupilot, px4
from avionics.guidance.ladder import ModeLadder
from avionics.guidance.params import GuidanceConfig
from avionics.guidance.stage import Ownship
from avionics_sitl.encounters import load_encounter
from avionics_sitl.guided import SimCopter
from avionics_sitl.impairments import PRESETS
from avionics_sitl.replay import replay
from tests.test_guidance import BASE, KEY, _Outputs, _ra


def _config(ladder: str, mode: str = "execute"):
    return load_config(overrides=[*BASE, f"guidance.mode={mode}", f"guidance.ladder={ladder}"])


def _mode_commands(result) -> list:
    return [(t, m) for t, m in result.sent if m.get_type() == "COMMAND_LONG"]


def test_warn_at_the_ta_then_hold_at_the_ra_once_and_no_automatic_resume():
    config = _config('["warn", "hold"]')
    out = _Outputs(config)
    result = replay(load_encounter("head-on"), config, PRESETS["none"], fly_guidance=True, ports=out.ports)
    states = [(d.state, d.manoeuvre) for d in result.guidance]
    assert states == [("advising", "warn"), ("commanding", "hold"), ("idle", "none")], result.guidance
    (asked_s, asked), = _mode_commands(result)  # one mode change for the whole conflict
    assert asked.param2 == ardupilot.LOITER and asked_s == result.guidance[1].time_s
    assert [m for _, m in result.copter.modes] == [ardupilot.AUTO, ardupilot.LOITER]  # held: no resume after
    texts = out.statustexts()
    assert texts[0].startswith("DAA GUIDANCE ADVISING WARN level 1") and \
        texts[1].startswith("DAA GUIDANCE COMMANDING HOLD level 2")


def test_px4_escalates_from_hold_to_return_each_once():
    config = _config('["hold", "return"]')
    result = replay(load_encounter("head-on"), config, PRESETS["none"], fly_guidance=True, firmware="px4")
    asked = [px4.mode_of(m) for _, m in _mode_commands(result)]
    assert asked == [px4.HOLD, px4.RTL]
    assert [m for _, m in result.copter.modes] == [px4.MISSION, px4.HOLD, px4.RTL]


def test_advise_publishes_the_action_and_sends_nothing():
    result = replay(load_encounter("head-on"), _config('["warn", "land"]', "advise"), PRESETS["none"],
                    fly_guidance=True)
    assert result.sent == [] and [d.manoeuvre for d in result.guidance][:2] == ["warn", "land"]


def _ladder(ladder, mode: int, autopilot: int = 3):
    stage = ModeLadder(GuidanceConfig(mode="execute", ladder=ladder), 1)
    stage.update(0.0, {}, None, None, [AutopilotHeartbeat(0.0, 1, mode, 0, autopilot=autopilot)])
    return stage


def test_no_mode_change_from_a_mode_as_severe_or_from_offboard():
    own = Ownship(10.0, 0.0, 0.0, 100.0)
    stage = _ladder(("hold", "hold"), ardupilot.RTL)  # a Return is more severe than Hold: kept
    out = stage.update(1.0, {KEY: _ra()}, None, own)
    assert out.commands == () and out.decision.state == "advising" and "RTL kept" in out.decision.reason
    stage = _ladder(("land", "land"), px4.OFFBOARD, autopilot=12)  # someone else's offboard control
    assert stage.update(1.0, {KEY: _ra()}, None, own).commands == ()


def test_a_level_without_an_action_falls_back_to_the_level_below():
    stage = _ladder(("hold", "none"), ardupilot.AUTO)
    (ask,) = stage.update(1.0, {KEY: _ra()}, None, Ownship(10.0, 0.0, 0.0, 100.0)).commands
    assert ask.param2 == ardupilot.LOITER


def test_a_refused_mode_is_a_failure():
    config = _config('["hold", "land"]')
    copter = SimCopter(load_vehicle("multirotor"), refuse=frozenset({ardupilot.LOITER, ardupilot.LAND}))
    result = replay(load_encounter("head-on"), config, PRESETS["none"], fly_guidance=True, copter=copter)
    assert [d.state for d in result.guidance][:2] == ["commanding", "failed"]
    assert result.guidance[1].reason == f"LOITER refused: result {ardupilot.mavlink2.MAV_RESULT_DENIED}"
    assert len(_mode_commands(result)) == 1  # failed: nothing more in this conflict


@pytest.mark.parametrize("ladder", ['["warn", "climb"]', '["warn", "hold", "land", "land"]'])
def test_a_bad_ladder_is_a_clear_error(ladder):
    with pytest.raises(ConfigError, match="guidance.ladder"):
        _config(ladder)


def test_a_plane_has_no_land_mode_and_returns_instead():
    from avionics.guidance import arduplane

    stage = ModeLadder(GuidanceConfig(mode="execute", ladder=("warn", "land")), 1)
    stage.update(0.0, {}, None, None, [AutopilotHeartbeat(0.0, 1, arduplane.AUTO, 0, mav_type=1)])
    out = stage.update(1.0, {KEY: _ra()}, None, None)
    (ask,) = out.commands
    assert ask.param2 == arduplane.RTL and out.decision.reason == "level 2 land_as_return"
    assert out.decision.autopilot_mode == "AUTO" and out.decision.manoeuvre == "return"
