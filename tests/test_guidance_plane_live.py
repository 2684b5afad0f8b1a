"""The fixed-wing acceptance of issue 27 over real sockets: `avionics run` (a child process, guidance.mode=execute, the
fixed-wing vehicle, small-uas alerting) on UDP, the simulated ArduPlane in this process flying the fixed-wing head-on
(tests/data/head_on_fixed_wing.toml) from late in the encounter, a zenoh subscriber in another session. The same
flown in fast time, and the contract's refusals, retries and overrides: tests/test_guidance_plane.py."""

from __future__ import annotations

import threading
from pathlib import Path

import pytest

from avionics.advisory.vehicle import load_vehicle
from avionics.base.units import FT
from avionics.guidance import arduplane
from avionics_sitl.encounters import load_encounter
from avionics_sitl.guided_plane import SimPlane
from avionics_sitl.impairments import PRESETS
from avionics_sitl.live import fly_guided
from tests.conftest import wait_for
from tests.test_guidance_live import _Onboard, _statustexts

pytestmark = pytest.mark.live

ENCOUNTER = str(Path(__file__).parent / "data" / "head_on_fixed_wing.toml")
# TA ~27 s, RA ~35.9 s, CPA 60 s, clear of conflict ~70 s, AUTO again ~72 s (fast time): the traffic from 32 s
START_S, END_S = 32.0, 80.0
SETTINGS = ["advisory.profile=small-uas", "vehicle.profile=fixed-wing", "guidance.mode=execute"]


def test_the_fixed_wing_avoids_the_head_on_and_resumes_its_mission_live(udp_port, tcp_port):
    scenario = load_encounter(ENCOUNTER)
    onboard = _Onboard(udp_port, tcp_port, END_S - START_S, settings=SETTINGS)
    plane = SimPlane(load_vehicle("fixed-wing"), home_alt_msl_m=scenario.ground_elevation_m)
    stop = threading.Event()
    flown: dict = {}

    def fly():
        flown["recording"] = fly_guided(scenario, f"udpout:127.0.0.1:{udp_port}", PRESETS["none"], plane,
                                        start_s=START_S, duration_s=END_S - START_S, stop=stop)

    flight = threading.Thread(target=fly)
    flight.start()
    try:
        wait_for(lambda: onboard.states()[-1:] == ["idle"] and "returning" in onboard.states() or
                 not flight.is_alive())
    finally:
        stop.set()
        flight.join()
        err = onboard.close()
    recording = flown["recording"]
    assert onboard.states() == ["idle", "commanding", "holding", "returning", "idle"], err[-2000:]  # on zenoh
    assert [t.split()[2] for t in _statustexts(recording)] == ["COMMANDING", "HOLDING", "RETURNING", "IDLE"]
    assert [m for _, m in plane.modes] == [arduplane.AUTO, arduplane.GUIDED, arduplane.AUTO]
    holding_s = next(r.time_s for r in recording.of_type("STATUSTEXT") if "GUIDANCE HOLDING" in r.msg.text)
    assert plane.modes[-1][0] - holding_s <= 2.0 + 0.5  # back in AUTO within the quiet time (plus the link)
    received = [r.msg for r in recording.received if r.msg.get_type() == "COMMAND_INT"]
    assert {m.command for m in received} == {arduplane.CHANGE_HEADING, arduplane.CHANGE_ALTITUDE}
    assert plane.counters["sim.command_int.0"] == len(received)  # every one accepted in GUIDED
    # the truth miss at the closest approach (60 s): co-altitude on the mission, outside NMAC flown
    cpa = min(recording.flown, key=lambda f: abs(f[0] - 60.0))
    assert abs(cpa[0] - 60.0) < 0.2 and cpa[1][2] > 100 * FT, cpa
