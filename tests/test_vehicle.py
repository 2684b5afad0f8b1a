"""Vehicle profiles (avionics/advisory/vehicle.py, issue 27 item 2): the built-in values are the autopilots'
cited defaults, a bad file is one clear error, the RA logic never asks for a rate the vehicle cannot fly, and a
closed loop through the whole stack flies what a hand computation of the vehicle's response says."""

from __future__ import annotations

import math
from dataclasses import replace
from importlib import resources

import pytest
from hypothesis import given, settings, strategies as st

from avionics.advisory.tables import ProfileError, load_profile
from avionics.advisory.vehicle import builtin_vehicles, load_vehicle
from avionics.config import ConfigError, load_config
from avionics.base.units import FT, G0
from avionics_sitl.encounters import load_scenario
from avionics_sitl.impairments import PRESETS
from avionics_sitl.replay import replay
from ra_sim import Encounter, Intruder, fly


def test_the_built_in_vehicles_carry_the_autopilots_defaults():
    copter = load_vehicle("multirotor")  # ArduCopter AC_WPNav.cpp: 250, 150 cm/s; 100 cm/s^2; 1000 cm/s
    assert (copter.climb_rate_mps, copter.descent_rate_mps, copter.vertical_accel_mps2) == (2.5, 1.5, 1.0)
    assert (copter.max_ground_speed_mps, copter.horizontal_accel_mps2) == (10.0, 2.5)
    assert copter.turn_rate_deg_s == pytest.approx(math.degrees(2.5 / 10.0), abs=0.05)
    plane = load_vehicle("fixed-wing")  # ArduPlane AP_TECS.cpp: CLMB_MAX 5, SINK_MAX 5; ROLL_LIMIT_DEG 45 at 15 m/s
    assert (plane.climb_rate_mps, plane.descent_rate_mps) == (5.0, 5.0)
    assert plane.turn_rate_deg_s == pytest.approx(math.degrees(G0 * math.tan(math.radians(45.0)) / 15.0), abs=0.05)
    assert builtin_vehicles() == ["fixed-wing", "multirotor"]
    r = copter.response_model()
    assert (r.rate(True), r.rate(False), r.rate(True, True), r.rate(False, True)) == (2.5, 1.5, 2.5, 1.5)


GOOD = (resources.files("avionics.advisory") / "vehicles" / "multirotor.toml").read_text()


@pytest.mark.parametrize("edit, match", [
    (lambda t: t.replace("climb_rate_mps = 2.5", ""), "missing"),
    (lambda t: t + "\nwingspan_m = 2.0\n", "unknown"),
    (lambda t: t.replace("descent_rate_mps = 1.5", "descent_rate_mps = -1.5"), "descent_rate_mps"),
    (lambda t: t.replace("descent_rate_mps = 1.5", "descent_rate_mps = inf"), "descent_rate_mps"),
    (lambda t: t.replace("descent_rate_mps = 1.5", "descent_rate_mps = true"), "descent_rate_mps"),
    (lambda t: t.replace("descent_rate_mps = 1.5", 'descent_rate_mps = "fast"'), "descent_rate_mps"),
    (lambda t: t.replace("response_delay_s = 1.0", "response_delay_s = 1e300"), "response_delay_s"),
    (lambda t: t.replace("climb_rate_mps = 2.5", "climb_rate_mps = "), "vehicle"),  # not TOML
])
def test_a_bad_vehicle_file_is_one_clear_error(tmp_path, edit, match):
    path = tmp_path / "vehicle.toml"
    path.write_text(edit(GOOD))
    with pytest.raises(ProfileError, match=match):
        load_vehicle(str(path))
    with pytest.raises(ConfigError, match="vehicle.profile"):
        load_config(overrides=[f'vehicle.profile="{path}"'])


def test_a_vehicle_file_that_is_not_utf8_is_one_clear_error(tmp_path):
    path = tmp_path / "vehicle.toml"
    path.write_bytes(GOOD.encode() + b"\n# \xff\xfe\n")
    with pytest.raises(ProfileError):
        load_vehicle(str(path))


VEHICLE_PROFILES = {f"{alert}/{vehicle}": replace(load_profile(alert), response=load_vehicle(vehicle).response_model())
                    for alert, vehicle in (("small-uas", "multirotor"), ("f3442", "multirotor"),
                                           ("small-uas", "fixed-wing"))}


@st.composite
def within_reach(draw, climb: float, descent: float):
    """One to three intruders within 600 ft, CPAs 15-45 s ahead, ownship at 400-3000 ft AGL flying a rate it can
    fly (its vehicle's limits)."""
    agl = draw(st.floats(400 * FT, 3000 * FT))
    vz_own = draw(st.one_of(st.just(0.0), st.floats(-descent, climb)))
    out = []
    for _ in range(draw(st.integers(1, 3))):
        t_cpa, closure, sz = draw(st.floats(15.0, 45.0)), draw(st.floats(20.0, 80.0)), draw(st.floats(-600 * FT, 600 * FT))
        vz = draw(st.one_of(st.just(0.0), st.floats(-5.0, 5.0)))
        out.append(Intruder(closure * t_cpa, draw(st.floats(-200.0, 200.0)), -closure, 0.0, sz, vz))
    return Encounter(agl, vz_own, tuple(out), duration_s=50.0)


@pytest.mark.parametrize("name", sorted(VEHICLE_PROFILES))
@settings(max_examples=150, deadline=None, derandomize=True, database=None)
@given(data=st.data())
def test_no_ra_asks_for_a_rate_the_vehicle_cannot_fly(name, data):
    profile = VEHICLE_PROFILES[name]
    climb, descent = profile.response.rate(True), profile.response.rate(False)
    out = fly(data.draw(within_reach(climb, descent)), profile)
    for t, ra, *_ in out.issued:
        assert ra.target_rate_mps is None or -descent - 1e-9 <= ra.target_rate_mps <= climb + 1e-9, (t, ra)


def test_a_multirotor_climbs_at_its_own_rate_in_the_closed_loop():
    # small-uas alerting with the multirotor's response, the built-in head-on (co-altitude, no noise): the RA is a
    # CLIMB at 2.5 m/s (it climbs faster than it descends), never an INCREASE (it has no faster rate), and the
    # vertical miss flown is the vehicle's response from the RA to CPA, by hand: 1 s delay, 1 m/s^2 to 2.5 m/s.
    config = load_config(overrides=["advisory.profile=small-uas", "vehicle.profile=multirotor", "zenoh.enabled=false"])
    result = replay(load_scenario("head-on"), config, PRESETS["none"], respond=True)
    ras = [a for a in result.changes if a.level.name == "RA"]
    assert {a.ra_words for a in ras} == {"CLIMB"} and {a.target_vertical_rate_mps for a in ras} == {2.5}
    t_ra, (miss,) = ras[0].time_s, result.misses
    t = miss.t_cpa_s - t_ra - 1.0  # after the delay
    ramp = 2.5 / 1.0
    by_hand = 0.5 * 1.0 * ramp**2 + 2.5 * (t - ramp)
    assert miss.vmd_with_m == pytest.approx(by_hand, abs=1.5)  # the 0.1 s steps and the link's latency
