"""SITL world: leg and sampled trajectories, scenario files, built-in encounters, ADS-B impairments."""

from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st
from scipy.integrate import quad, solve_ivp

from avionics.base.geodesy import WGS84_A, WGS84_E2, LocalTangentPlane
from avionics.base.types import AddressSource, AltitudeDatum
from avionics.base.units import FPM, FT, KT, NM
from avionics_sitl.aircraft import AircraftSpec, Leg
from avionics_sitl.builtin import BUILTIN, REFERENCE
from avionics_sitl.encounters import load_encounter
from avionics_sitl.impairments import DEFAULT, NONE, AdsbImpairments
from avionics_sitl.scenario import Scenario, load_scenario_file, parse_scenario_toml
from avionics_sitl.trajectory import (
    KinematicState,
    _arc_integrals,
    LegKinematics,
    LegTrajectory,
    SampledTrajectory,
    plane_velocity_to_true,
    true_velocity_to_plane,
)

REPO = Path(__file__).resolve().parents[1]
PLANE = LocalTangentPlane(47.4, 8.5)
FAST = settings(max_examples=40, deadline=None)


def spec(heading=0.0, speed=100.0, legs=(), vs=0.0, east=0.0, north=0.0, alt=1000.0, **kw) -> AircraftSpec:
    lat, lon = PLANE.to_geodetic(east, north)
    return AircraftSpec("ac", 0xABCDEF, float(lat), float(lon), alt, heading, speed, vs, tuple(legs), **kw)


def en(traj, t):
    """East/north of a trajectory's WGS-84 output, back on PLANE: checks the geodetic round trip too."""
    s = traj.state_at(t)
    e, n = PLANE.to_en(s.lat_deg, s.lon_deg)
    return np.array([float(e), float(n)])


def local_metres_per_degree(lat_deg):
    s2 = math.sin(math.radians(lat_deg)) ** 2
    w = math.sqrt(1.0 - WGS84_E2 * s2)
    meridian = WGS84_A * (1.0 - WGS84_E2) / w**3
    normal = WGS84_A / w
    return math.radians(1.0) * normal * math.cos(math.radians(lat_deg)), math.radians(1.0) * meridian


# --- straight flight ------------------------------------------------------------------------------------------


def test_straight_north_matches_hand_computed_latitude():
    traj = LegTrajectory(spec(heading=0.0, speed=100.0), PLANE)
    s = traj.state_at(100.0)  # 10 km north along the meridian
    _, m_per_deg_lat = local_metres_per_degree(47.4 + 0.045)  # mid-latitude of the arc
    assert s.lon_deg == pytest.approx(8.5, abs=1e-12)
    assert s.lat_deg == pytest.approx(47.4 + 10_000.0 / m_per_deg_lat, abs=2e-7)  # 2 cm
    assert (s.vel_east_mps, s.vel_north_mps, s.vel_up_mps) == pytest.approx((0.0, 100.0, 0.0), abs=1e-3)
    assert s.alt_msl_m == 1000.0


def test_straight_east_hand_numbers():
    traj = LegTrajectory(spec(heading=90.0, speed=100.0), PLANE)
    assert en(traj, 60.0) == pytest.approx([6000.0, 0.0], abs=1e-3)
    s0 = traj.state_at(0.0)
    assert s0.ground_speed_mps == pytest.approx(100.0)
    assert s0.track_deg == pytest.approx(90.0)


@FAST
@given(
    heading=st.floats(0.0, 359.999),
    speed=st.floats(0.0, 300.0),
    t=st.floats(-100.0, 600.0),
)
def test_straight_flight_position_and_velocity(heading, speed, t):
    traj = LegTrajectory(spec(heading=heading, speed=speed), PLANE)
    h = math.radians(heading)
    want = [speed * t * math.sin(h), speed * t * math.cos(h)]
    assert traj.enu_at(t)[:2] == pytest.approx(want, abs=1e-6)
    # Through WGS-84 and back: bounded by avionics.base.geodesy's inverse (~1 mm at 80 km, 2 cm at 150 km).
    assert en(traj, t) == pytest.approx(want, abs=0.05)
    s = traj.state_at(t)
    ve, vn = true_velocity_to_plane(PLANE, s.lat_deg, s.lon_deg, s.vel_east_mps, s.vel_north_mps)
    assert (ve, vn) == pytest.approx((speed * math.sin(h), speed * math.cos(h)), abs=1e-6)


def test_reported_velocity_matches_position_rate_far_from_origin():
    """Velocities are true east/north at the aircraft: a finite difference of its WGS-84 positions must agree,
    also 50 nm from the plane origin where the plane's north is ~0.5 deg off true north."""
    sc = BUILTIN["radosavljevic-2"]()
    own, (intr,) = sc.trajectories()
    for traj in (own, intr):
        for t in (0.0, 100.0, 190.0, 300.0):
            a, b, mid = traj.state_at(t - 0.005), traj.state_at(t + 0.005), traj.state_at(t)
            m_e, m_n = local_metres_per_degree(mid.lat_deg)
            fd = np.array([(b.lon_deg - a.lon_deg) * m_e, (b.lat_deg - a.lat_deg) * m_n]) / 0.01
            assert fd == pytest.approx([mid.vel_east_mps, mid.vel_north_mps], abs=1e-4)  # of 311 m/s


@FAST
@given(east=st.floats(-80e3, 80e3), north=st.floats(-80e3, 80e3), ve=st.floats(-300, 300), vn=st.floats(-300, 300))
def test_plane_true_velocity_round_trip_and_meridian_convergence(east, north, ve, vn):
    lat, lon = (float(x) for x in PLANE.to_geodetic(east, north))
    back = true_velocity_to_plane(PLANE, lat, lon, *plane_velocity_to_true(PLANE, lat, lon, ve, vn))
    assert back == pytest.approx((ve, vn), abs=1e-9)
    # True north east of the origin points west of the plane's north (meridians converge to the pole).
    pe, pn = true_velocity_to_plane(PLANE, lat, lon, 0.0, 1.0)
    assert math.copysign(1.0, -pe) == math.copysign(1.0, east) or abs(east) < 1.0


# --- turns, climbs, acceleration ------------------------------------------------------------------------------


@FAST
@given(
    speed=st.floats(10.0, 300.0),
    rate=st.floats(0.5, 20.0),
    right=st.booleans(),
    heading=st.floats(0.0, 359.9),
)
def test_full_turn_returns_to_start_on_circle_of_radius_v_over_omega(speed, rate, right, heading):
    omega = rate if right else -rate
    k = LegKinematics(0.0, 0.0, 0.0, heading, speed, 0.0, (Leg(360.0 / rate, turn_rate_dps=omega),))
    radius = speed / math.radians(rate)
    h = math.radians(heading)
    side = 1.0 if right else -1.0
    centre = np.array([math.cos(h), -math.sin(h)]) * radius * side  # to the right of the heading for a right turn
    for t in np.linspace(0.0, 360.0 / rate, 13):
        e, n, *_ = k.at(t)
        assert math.hypot(e - centre[0], n - centre[1]) == pytest.approx(radius, rel=1e-9, abs=1e-6)
    e, n, _, ve, vn, _ = k.at(360.0 / rate)
    assert (e, n) == pytest.approx((0.0, 0.0), abs=1e-6 * radius + 1e-6)
    assert (ve, vn) == pytest.approx((speed * math.sin(h), speed * math.cos(h)), abs=1e-6 * speed)


def test_positive_turn_rate_turns_right():
    k = LegKinematics(0.0, 0.0, 0.0, 0.0, 100.0, 0.0, (Leg(10.0, turn_rate_dps=3.0),))
    e, n, _, ve, vn, _ = k.at(10.0)
    assert math.degrees(math.atan2(ve, vn)) == pytest.approx(30.0)
    assert e > 0.0


def test_climb_then_level_after_last_leg():
    traj = LegTrajectory(spec(legs=(Leg(60.0, vertical_rate_mps=5.0),)), PLANE)
    assert traj.state_at(30.0).alt_msl_m == pytest.approx(1150.0)
    assert traj.state_at(30.0).vel_up_mps == 5.0
    after = traj.state_at(200.0)
    assert after.alt_msl_m == pytest.approx(1300.0)
    assert after.vel_up_mps == 0.0


def test_without_legs_vertical_rate_holds_forever_including_before_start():
    traj = LegTrajectory(spec(vs=-2.0), PLANE)
    assert traj.state_at(100.0).alt_msl_m == pytest.approx(800.0)
    assert traj.state_at(-10.0).alt_msl_m == pytest.approx(1020.0)


def test_vertical_rate_with_legs_is_ambiguous():
    with pytest.raises(ValueError, match="vertical_rate_mps"):
        spec(vs=1.0, legs=(Leg(10.0),))


def test_acceleration_leg_hand_numbers():
    k = LegKinematics(0.0, 0.0, 0.0, 90.0, 50.0, 0.0, (Leg(10.0, acceleration_mps2=2.0),))
    e, n, _, ve, vn, _ = k.at(10.0)
    assert (e, n) == pytest.approx((50 * 10 + 0.5 * 2 * 100, 0.0), abs=1e-9)
    assert (ve, vn) == pytest.approx((70.0, 0.0), abs=1e-12)
    e2, *_ = k.at(20.0)  # then constant speed
    assert e2 == pytest.approx(600.0 + 700.0)


def test_speed_may_not_become_negative():
    with pytest.raises(ValueError, match="negative"):
        LegKinematics(0.0, 0.0, 0.0, 0.0, 10.0, 0.0, (Leg(10.0, acceleration_mps2=-2.0),))


def test_before_start_is_straight_along_initial_velocity():
    k = LegKinematics(100.0, 200.0, 50.0, 90.0, 40.0, 0.0, (Leg(30.0, turn_rate_dps=5.0, vertical_rate_mps=1.0),))
    assert k.at(-10.0)[:3] == pytest.approx((100.0 - 400.0, 200.0, 40.0))


@pytest.mark.parametrize("theta", [0.0, 1e-9, -3e-4, 0.0101, 0.0499, -0.0501, -0.5, 2.0, -6.0])
def test_arc_integrals_match_quadrature_on_both_sides_of_the_series_switch(theta):
    want = [
        quad(lambda u: math.cos(theta * u), 0, 1, epsabs=1e-14)[0],
        quad(lambda u: math.sin(theta * u), 0, 1, epsabs=1e-14)[0],
        quad(lambda u: u * math.cos(theta * u), 0, 1, epsabs=1e-14)[0],
        quad(lambda u: u * math.sin(theta * u), 0, 1, epsabs=1e-14)[0],
    ]
    assert _arc_integrals(theta) == pytest.approx(want, rel=1e-12, abs=1e-14)


legs_strategy = st.lists(
    st.builds(
        Leg,
        duration_s=st.floats(5.0, 200.0),
        turn_rate_dps=st.one_of(st.just(0.0), st.floats(-10.0, 10.0)),
        vertical_rate_mps=st.floats(-10.0, 10.0),
        acceleration_mps2=st.one_of(st.just(0.0), st.floats(-0.5, 0.5)),
    ),
    min_size=1,
    max_size=4,
)


def keeps_flying(speed, legs) -> bool:
    """The leg program never decelerates below 1 m/s (LegKinematics rejects negative speeds)."""
    for leg in legs:
        speed += leg.acceleration_mps2 * leg.duration_s
        if speed < 1.0:
            return False
    return True


@settings(max_examples=15, deadline=None)
@given(legs=legs_strategy, speed=st.floats(120.0, 250.0), heading=st.floats(0.0, 359.0))
def test_leg_program_matches_numerical_integration(legs, speed, heading):
    """Closed-form legs against an independent ODE integration: < 0.5 m over up to 10 minutes."""
    total = sum(leg.duration_s for leg in legs)
    assume(total <= 600.0 and keeps_flying(speed, legs))
    k = LegKinematics(0.0, 0.0, 0.0, heading, speed, 0.0, legs)
    y = np.array([0.0, 0.0, 0.0, math.radians(heading), speed])  # e, n, z, psi, v
    t0 = 0.0
    for leg in legs:
        w, a, vz = math.radians(leg.turn_rate_dps), leg.acceleration_mps2, leg.vertical_rate_mps

        def rhs(_t, s, w=w, a=a, vz=vz):
            return [s[4] * math.sin(s[3]), s[4] * math.cos(s[3]), vz, w, a]

        sol = solve_ivp(rhs, (t0, t0 + leg.duration_s), y, method="DOP853", rtol=1e-11, atol=1e-8)
        y = sol.y[:, -1]
        t0 += leg.duration_s
        e, n, z, ve, vn, _ = k.at(t0)
        assert math.hypot(e - y[0], n - y[1]) < 0.5
        assert z == pytest.approx(y[2], abs=1e-6)
        assert (ve, vn) == pytest.approx((y[4] * math.sin(y[3]), y[4] * math.cos(y[3])), abs=1e-4)


@FAST
@given(legs=legs_strategy)
def test_leg_program_is_continuous_at_leg_boundaries(legs):
    assume(keeps_flying(200.0, legs))
    k = LegKinematics(0.0, 0.0, 0.0, 30.0, 200.0, 0.0, legs)
    t = 0.0
    for leg in legs:
        t += leg.duration_s
        before, after = np.array(k.at(t - 1e-7)), np.array(k.at(t + 1e-7))
        assert np.allclose(before[:3], after[:3], atol=1e-3)  # positions
        assert np.allclose(before[3:5], after[3:5], atol=1e-3)  # horizontal velocity


# --- sampled trajectories -------------------------------------------------------------------------------------


@FAST
@given(
    heading=st.floats(0.0, 359.9),
    speed=st.floats(0.0, 300.0),
    vs=st.floats(-20.0, 20.0),
    start=st.tuples(st.floats(-20e3, 20e3), st.floats(-20e3, 20e3)),
    times=st.lists(st.floats(0.0, 300.0), min_size=1, max_size=8, unique=True).map(sorted),
    query=st.floats(-60.0, 400.0),
)
def test_hermite_is_exact_on_straight_lines(heading, speed, vs, start, times, query):
    assume(all(b - a > 1e-3 for a, b in zip(times, times[1:])))
    truth = LegTrajectory(spec(heading=heading, speed=speed, vs=vs, east=start[0], north=start[1]), PLANE)
    samples = [truth.state_at(t) for t in times]
    sampled = SampledTrajectory(
        times, [s.lat_deg for s in samples], [s.lon_deg for s in samples], [s.alt_msl_m for s in samples],
        [s.vel_east_mps for s in samples], [s.vel_north_mps for s in samples], [s.vel_up_mps for s in samples],
        plane=PLANE,
    )
    assert np.allclose(sampled.enu_at(query), truth.enu_at(query), atol=1e-3)
    got, want = sampled.state_at(query), truth.state_at(query)
    assert (got.vel_east_mps, got.vel_north_mps, got.vel_up_mps) == pytest.approx(
        (want.vel_east_mps, want.vel_north_mps, want.vel_up_mps), abs=1e-6
    )


def _sampled_turn(dt=5.0):
    truth = LegTrajectory(spec(heading=0.0, speed=150.0, legs=(Leg(60.0, turn_rate_dps=3.0, vertical_rate_mps=3.0),)),
                          PLANE)
    times = np.arange(0.0, 60.0 + 1e-9, dt)
    samples = [truth.state_at(t) for t in times]
    cols = [[getattr(s, f) for s in samples] for f in
            ("lat_deg", "lon_deg", "alt_msl_m", "vel_east_mps", "vel_north_mps", "vel_up_mps")]
    return truth, SampledTrajectory(times, *cols, plane=PLANE), times


def test_sampled_trajectory_passes_through_samples_and_is_continuous():
    truth, sampled, times = _sampled_turn()
    for t in times:
        assert np.allclose(sampled.enu_at(t), truth.enu_at(t), atol=1e-6)
        assert np.allclose(sampled.enu_at(t - 1e-6), sampled.enu_at(t + 1e-6), atol=1e-3)
        s = sampled.state_at(t)
        w = truth.state_at(t)
        assert (s.vel_east_mps, s.vel_north_mps) == pytest.approx((w.vel_east_mps, w.vel_north_mps), abs=1e-9)


def test_sampled_trajectory_on_a_turn_stays_close_between_samples():
    truth, sampled, _ = _sampled_turn()
    worst = max(np.hypot(*(np.array(sampled.enu_at(t)[:2]) - truth.enu_at(t)[:2])) for t in np.arange(0, 60, 0.25))
    assert worst < 0.5  # 3 deg/s turn at 150 m/s sampled every 5 s


def test_sampled_velocity_is_linear_between_samples():
    _, sampled, _ = _sampled_turn()

    def plane_velocity(t):
        s = sampled.state_at(t)
        return np.array(true_velocity_to_plane(PLANE, s.lat_deg, s.lon_deg, s.vel_east_mps, s.vel_north_mps))

    for t0 in (0.0, 25.0, 50.0):
        for u in (0.25, 0.5):
            want = (1 - u) * plane_velocity(t0) + u * plane_velocity(t0 + 5.0)
            assert plane_velocity(t0 + 5.0 * u) == pytest.approx(want, abs=1e-9)


def test_sampled_trajectory_extrapolates_with_end_velocity():
    _, sampled, _ = _sampled_turn()
    last = np.array(sampled.enu_at(60.0))
    s = sampled.state_at(60.0)
    ve, vn = true_velocity_to_plane(PLANE, s.lat_deg, s.lon_deg, s.vel_east_mps, s.vel_north_mps)
    assert np.allclose(sampled.enu_at(70.0), last + 10.0 * np.array([ve, vn, s.vel_up_mps]), atol=1e-6)


@pytest.mark.parametrize(
    "times, lat",
    [([0.0, 0.0], [47.4, 47.4]), ([1.0, 0.0], [47.4, 47.4]), ([0.0, 1.0], [47.4]), ([], []),
     ([0.0, float("nan")], [47.4, 47.4])],
)
def test_sampled_trajectory_rejects_bad_samples(times, lat):
    n = len(times)
    with pytest.raises(ValueError):
        SampledTrajectory(times, lat, [8.5] * n, [0.0] * n, [0.0] * n, [0.0] * n, [0.0] * n)


# --- scenarios and TOML files ---------------------------------------------------------------------------------


def _docs_toml_example() -> str:
    text = (REPO / "docs" / "scenarios.md").read_text(encoding="utf-8")
    blocks = re.findall(r"```toml\n(.*?)```", text, re.S)
    assert blocks, "docs/scenarios.md must hold a ```toml example"
    return blocks[0]


def test_documented_toml_example_loads_with_its_units(tmp_path):
    path = tmp_path / "example.toml"
    path.write_text(_docs_toml_example())
    sc = load_scenario_file(path)
    assert sc.ownship.alt_msl_m == pytest.approx(3000 * FT)
    assert sc.ownship.speed_mps == pytest.approx(90 * KT)
    assert sc.ownship.emitter_type == 14
    assert len(sc.intruders) == 2
    climber, turner = sc.intruders
    assert climber.icao_address == 0xA1B2C3 and climber.altitude_datum is AltitudeDatum.GEOMETRIC
    assert climber.address_source is AddressSource.UAT
    assert climber.legs[0].vertical_rate_mps == pytest.approx(1500 * FPM)
    assert turner.legs[1].turn_rate_dps == pytest.approx(-3.0) and turner.legs[1].acceleration_mps2 == 0.5
    # east/north are on the [reference] plane, which the scenario integrates in
    own, (_, t2) = sc.trajectories()
    ref = LocalTangentPlane(*sc.origin)
    e, n = ref.to_en(turner.lat_deg, turner.lon_deg)
    assert (float(e), float(n)) == pytest.approx((2 * NM, -1 * NM), abs=1e-3)
    assert sc.ground_elevation_m == pytest.approx(1400 * FT)
    assert own.state_at(0.0).alt_msl_m == pytest.approx(3000 * FT)


MINIMAL = """
duration_s = 60
[ownship]
lat_deg = 47.4
lon_deg = 8.5
alt_ft = 3000
heading_deg = 0
speed_kt = 90
[[intruder]]
lat_deg = 47.45
lon_deg = 8.5
alt_m = 900
heading_deg = 180
speed_mps = 50
"""


def test_minimal_toml_defaults():
    sc = parse_scenario_toml(MINIMAL, default_name="minimal")
    assert sc.name == "minimal" and sc.duration_s == 60.0 and sc.ground_elevation_m == 0.0
    assert sc.ownship.icao_address == 0xA00001 and sc.intruders[0].icao_address == 0xA00002
    assert sc.intruders[0].speed_mps == 50.0 and sc.intruders[0].alt_msl_m == 900.0


@FAST
@given(
    alt_m=st.floats(0.0, 15000.0), speed_mps=st.floats(0.0, 300.0), vs_mps=st.floats(-50.0, 50.0),
    heading=st.floats(0.0, 359.99), east_m=st.floats(-50e3, 50e3), north_m=st.floats(-50e3, 50e3),
    alt_in_ft=st.booleans(), speed_in_kt=st.booleans(), vs_in_fpm=st.booleans(), offsets_in_nm=st.booleans(),
)
def test_toml_units_convert_to_si(alt_m, speed_mps, vs_mps, heading, east_m, north_m, alt_in_ft, speed_in_kt,
                                  vs_in_fpm, offsets_in_nm):
    ft, kt, nm = 0.3048, 1852.0 / 3600.0, 1852.0  # by hand, not from avionics.base.units
    alt = f"alt_ft = {alt_m / ft!r}" if alt_in_ft else f"alt_m = {alt_m!r}"
    speed = f"speed_kt = {speed_mps / kt!r}" if speed_in_kt else f"speed_mps = {speed_mps!r}"
    vs = f"vs_fpm = {vs_mps / (ft / 60)!r}" if vs_in_fpm else f"vs_mps = {vs_mps!r}"
    pos = (f"east_nm = {east_m / nm!r}\nnorth_nm = {north_m / nm!r}" if offsets_in_nm
           else f"east_m = {east_m!r}\nnorth_m = {north_m!r}")
    text = (f"duration_s = 10\n[reference]\nlat_deg = 47.4\nlon_deg = 8.5\n"
            f"[ownship]\n{pos}\n{alt}\nheading_deg = {heading!r}\n{speed}\n{vs}\n")
    own = parse_scenario_toml(text).ownship
    assert own.alt_msl_m == pytest.approx(alt_m, rel=1e-12, abs=1e-9)
    assert own.speed_mps == pytest.approx(speed_mps, rel=1e-12, abs=1e-9)
    assert own.vertical_rate_mps == pytest.approx(vs_mps, rel=1e-12, abs=1e-9)
    e, n = PLANE.to_en(own.lat_deg, own.lon_deg)
    assert (float(e), float(n)) == pytest.approx((east_m, north_m), abs=1e-3)


@pytest.mark.parametrize(
    "edit, message",
    [
        (lambda t: t.replace("speed_kt = 90", "speed_kt = 90\nspeed_knots = 1"),
         r"ownship: unknown key\(s\) speed_knots"),
        (lambda t: t.replace("duration_s = 60\n", ""), r"missing key duration_s"),
        (lambda t: t.replace("heading_deg = 0\n", ""), r"ownship: missing key heading_deg"),
        (lambda t: t.replace("alt_m = 900", "alt_m = 900\nalt_ft = 3000"), r"intruder\[0\]: give only one of"),
        (lambda t: t.replace("heading_deg = 180", "heading_deg = 400"), r"intruder\[0\]: heading_deg = 400"),
        (lambda t: t.replace("speed_mps = 50", "speed_mps = 5000"), r"intruder\[0\]: speed_mps = 5000"),
        (lambda t: t.replace("lat_deg = 47.45", "east_m = 100\nnorth_m = 0"), r"give the position as exactly one"),
        (lambda t: t.replace("lat_deg = 47.45\nlon_deg = 8.5", "east_m = 100\nnorth_m = 0"), r"need a \[reference\]"),
        (lambda t: t + "[[intruder.legs]]\nduration_s = -1\n", r"intruder\[0\]\.legs\[0\]: duration_s"),
        (lambda t: t + "[[intruder.legs]]\nduration_s = 10\nturn = 3\n", r"legs\[0\]: unknown key\(s\) turn"),
        (lambda t: t.replace("alt_ft = 3000", 'alt_ft = "3000"'), r"ownship\.alt_ft: expected a finite number"),
        (lambda t: t.replace("speed_kt = 90", "speed_kt = 90\naltitude_datum = 'baro'"), r"altitude_datum"),
        (lambda t: t.replace("speed_kt = 90", "speed_kt = 90\nicao = 0x1000000"), r"icao_address"),
        (lambda t: t.replace("[ownship]", "[ownship"), r"not valid TOML"),
        (lambda t: t.replace("speed_kt = 90", "speed_kt = 90\ncallsign = 'way-too-long'"), r"callsign"),
    ],
)
def test_bad_toml_says_what_and_where(edit, message):
    with pytest.raises(ValueError, match=message):
        parse_scenario_toml(edit(MINIMAL))


def test_load_scenario_file_names_the_file(tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text("duration_s = 1\n")
    with pytest.raises(ValueError, match=r"bad\.toml: scenario: missing table \[ownship\]"):
        load_scenario_file(bad)


def test_load_encounter_dispatches(tmp_path):
    assert load_encounter("head-on").name == "head-on"
    path = tmp_path / "mini.toml"
    path.write_text(MINIMAL)
    assert load_encounter(str(path)).name == "mini"
    assert load_encounter(str(REPO / "tests" / "data" / "head_on_3000ft.daa")).name == "head_on_3000ft"
    with pytest.raises(ValueError, match="unknown encounter"):
        load_encounter("no-such-encounter")


def test_scenario_rejects_duplicate_addresses():
    a = spec()
    with pytest.raises(ValueError, match="share an ICAO address"):
        Scenario("x", "", a, (a,), 10.0)


# --- built-in encounters ---------------------------------------------------------------------------------------


def separation(sc: Scenario, t: float, intruder: int = 0) -> tuple[float, float]:
    """(horizontal, vertical) separation in metres, measured from the WGS-84 output on a plane at ownship."""
    own, intruders = sc.trajectories()
    a, b = own.state_at(t), intruders[intruder].state_at(t)
    plane = LocalTangentPlane(a.lat_deg, a.lon_deg)
    e, n = plane.to_en(b.lat_deg, b.lon_deg)
    return math.hypot(float(e), float(n)), b.alt_msl_m - a.alt_msl_m


def cpa(sc: Scenario, step: float = 0.05, intruder: int = 0) -> tuple[float, float]:
    """(time, horizontal range) of the closest approach, on the scenario plane, refined on the WGS-84 output."""
    own, intruders = sc.trajectories()
    times = np.arange(0.0, sc.duration_s + 1e-9, step)
    d = [math.dist(own.enu_at(t)[:2], intruders[intruder].enu_at(t)[:2]) for t in times]
    t_min = float(times[int(np.argmin(d))])
    return t_min, separation(sc, t_min, intruder)[0]


def plane_heading(traj, t):
    _, _, _, ve, vn, _ = traj.kinematics.at(t)
    return math.degrees(math.atan2(ve, vn)) % 360.0


def angle_between(a_deg, b_deg):
    return abs((a_deg - b_deg + 180.0) % 360.0 - 180.0)


@pytest.mark.parametrize("name", sorted(BUILTIN))
def test_every_builtin_loads_and_flies(name):
    sc = BUILTIN[name]()
    assert sc.name == name and sc.description and sc.intruders
    own, intruders = sc.trajectories()
    for traj in (own, *intruders):
        for t in (0.0, sc.duration_s):
            s = traj.state_at(t)
            assert isinstance(s, KinematicState) and math.isfinite(s.lat_deg)
    assert sc.origin == REFERENCE


def test_head_on():
    sc = BUILTIN["head-on"]()
    own, intr = sc.ownship, sc.intruders[0]
    assert separation(sc, 0.0) == pytest.approx((6 * NM, 0.0), abs=0.5)
    assert own.alt_msl_m == intr.alt_msl_m == pytest.approx(3000 * FT)
    assert (own.heading_deg, intr.heading_deg) == pytest.approx((0.0, 180.0), abs=1e-9)
    assert own.speed_mps + intr.speed_mps == pytest.approx(250 * KT, rel=1e-5)
    t_cpa, d = cpa(sc)
    assert t_cpa == pytest.approx(86.4, abs=0.05) and d < 50.0
    assert sc.duration_s >= t_cpa + 30.0


def test_crossing_90():
    sc = BUILTIN["crossing-90"]()
    t_cpa, d = cpa(sc)
    assert t_cpa == pytest.approx(90.0, abs=0.05) and d < 50.0
    own, (intr,) = sc.trajectories()
    a, b = own.state_at(t_cpa), intr.state_at(t_cpa)
    angle = math.degrees(math.acos((a.vel_east_mps * b.vel_east_mps + a.vel_north_mps * b.vel_north_mps)
                                   / (a.ground_speed_mps * b.ground_speed_mps)))
    assert angle == pytest.approx(90.0, abs=0.05)
    assert separation(sc, t_cpa)[1] == 0.0


def test_overtaking():
    sc = BUILTIN["overtaking"]()
    own, intr = sc.ownship, sc.intruders[0]
    assert intr.speed_mps > own.speed_mps
    assert intr.heading_deg == pytest.approx(own.heading_deg, abs=0.05)
    o, (i,) = sc.trajectories()
    rel = np.array(i.enu_at(0.0)[:2]) - o.enu_at(0.0)[:2]
    assert rel[0] < 0  # behind an eastbound ownship
    t_cpa, d = cpa(sc)
    assert d == pytest.approx(100.0, abs=1.0)
    assert t_cpa == pytest.approx(1.5 * NM / (70 * KT), abs=0.05)


def test_climbing_intruder():
    sc = BUILTIN["climbing-intruder"]()
    intr = sc.intruders[0]
    assert intr.legs[0].vertical_rate_mps == pytest.approx(1500 * FPM)
    assert sc.ownship.alt_msl_m - intr.alt_msl_m == pytest.approx(1500 * FT)
    t_cpa, d = cpa(sc)
    assert t_cpa == pytest.approx(60.0, abs=0.05) and d < 50.0
    assert separation(sc, 60.0)[1] == pytest.approx(0.0, abs=0.01)  # crossing ownship's altitude at CPA
    assert separation(sc, 30.0)[1] < 0 < separation(sc, 90.0)[1]
    _, (traj,) = sc.trajectories()
    assert traj.state_at(119.0).vel_up_mps > 0 and traj.state_at(121.0).vel_up_mps == 0.0


def test_baek_bang_1():
    sc = BUILTIN["baek-bang-1"]()
    b = sc.ownship
    assert b.speed_mps == 0.0 and sc.duration_s == 130.0
    own, (traj_a,) = sc.trajectories()
    rel = np.array(own.enu_at(0.0)[:2]) - traj_a.enu_at(0.0)[:2]
    assert rel == pytest.approx([7 * NM, -2 * NM], abs=1e-3)  # B at (7, -2) nm from A's start
    assert plane_heading(traj_a, 49.0) == pytest.approx(90.0)
    assert plane_heading(traj_a, 80.0) == pytest.approx(45.0)  # 30 s into a 1.5 deg/s left turn
    assert angle_between(plane_heading(traj_a, 120.0), 0.0) < 1e-9
    t_cpa, d = cpa(sc)
    assert 2 * NM < d < 2.4 * NM and 50.0 < t_cpa < 110.0  # A's turn keeps it out of B's 2 nm conflict zone
    assert np.allclose(own.enu_at(0.0), own.enu_at(130.0))  # B does not move


def test_baek_bang_2_overtake_with_2_nm_clearance():
    sc = BUILTIN["baek-bang-2"]()
    own, (a,) = sc.trajectories()
    assert sc.intruders[0].speed_mps > sc.ownship.speed_mps
    _, d = cpa(sc)
    assert d == pytest.approx(2 * NM, rel=0.01)
    x0 = a.enu_at(0.0)[0] - own.enu_at(0.0)[0]
    x1 = a.enu_at(sc.duration_s)[0] - own.enu_at(sc.duration_s)[0]
    assert x0 == pytest.approx(-5 * NM, abs=1e-3) and x1 > 0  # A starts 5 nm behind and ends ahead
    assert a.enu_at(0.0)[1] - own.enu_at(0.0)[1] == pytest.approx(2 * NM, abs=1e-3)


def test_hwang_tracking_schedule():
    sc = BUILTIN["hwang-tracking"]()
    _, (traj,) = sc.trajectories()
    assert sc.intruders[0].speed_mps == pytest.approx(480 * KT, rel=1e-5)
    # Plane headings: left 3 deg/s over 30-50 s, left 1.5 deg/s over 70-90 s, right 4.5 deg/s over 110-130 s.
    expected = {15: 90, 40: 60, 60: 30, 80: 15, 100: 0, 120: 45, 140: 90, 149: 90}
    for t, heading in expected.items():
        assert angle_between(plane_heading(traj, t), heading) < 1e-6
    assert traj.kinematics.at(100.0)[3:5] == pytest.approx((0.0, 480 * KT), abs=1e-6)
    t_cpa, d = cpa(sc)
    assert t_cpa == pytest.approx(170.0, abs=0.05) and d < 50.0
    assert min(separation(sc, t)[0] for t in range(0, 131, 10)) > 6 * NM  # maneuvers seen from >= 6 nm


def test_radosavljevic_1():
    sc = BUILTIN["radosavljevic-1"]()
    assert sc.ownship.speed_mps == pytest.approx(311.0, rel=1e-5)
    own, (traj,) = sc.trajectories()
    t_cpa, d = cpa(sc)
    assert t_cpa == pytest.approx(32 * 5.0, abs=0.05) and d < 50.0
    assert plane_heading(own, 0.0) == pytest.approx(45.0) and plane_heading(own, 300.0) == pytest.approx(45.0)
    crossing = (plane_heading(traj, 160.0) - plane_heading(own, 160.0)) % 360.0
    assert crossing == pytest.approx(270.0)  # crosses from the right at 90 deg
    g_turn = math.degrees(9.80665 / 311.0)
    for (t0, t1), load in zip(((50, 140), (185, 225), (275, 290), (325, 365)), (-1, 2, -1, 3)):
        change = (plane_heading(traj, t1) - plane_heading(traj, t0) + 180.0) % 360.0 - 180.0
        assert change == pytest.approx(((load * g_turn * (t1 - t0)) + 180.0) % 360.0 - 180.0, abs=1e-6)


def test_radosavljevic_2_mirror_meeting_on_the_north_axis():
    sc = BUILTIN["radosavljevic-2"]()
    own, (traj,) = sc.trajectories()
    e0, n0, _ = own.enu_at(0.0)
    assert e0 == pytest.approx(n0) and e0 < 0 and plane_heading(own, 0.0) == pytest.approx(45.0)  # toward radar
    for t in (0.0, 100.0, 190.0, 215.0, 300.0):
        a, b = own.enu_at(t), traj.enu_at(t)
        assert b[0] == pytest.approx(-a[0], abs=1e-6) and b[1] == pytest.approx(a[1], abs=1e-6)
    t_cpa, d = cpa(sc)
    assert t_cpa == pytest.approx(44 * 5.0, abs=0.05) and d < 50.0
    assert own.enu_at(220.0)[0] == pytest.approx(0.0, abs=1e-2)  # via WGS-84 start 73 km out: 0.2 mm
    turn = plane_heading(own, 215.0) - plane_heading(own, 165.0)
    assert turn == pytest.approx(math.degrees(9.80665 / 311.0) * 40.0)


# --- impairments -------------------------------------------------------------------------------------------------


TRUTH = KinematicState(12.0, 47.4, 8.5, 914.4, 30.0, -40.0, 2.0)


def test_none_is_exact_instant_and_lossless():
    for _ in range(200):
        out = NONE.impair(TRUTH)
        assert out is not None and out.state == TRUTH and out.latency_s == 0.0


def test_default_is_reproducible_by_seed():
    def run(seed):
        imp = DEFAULT.with_seed(seed)
        return [imp.impair(TRUTH) for _ in range(50)]

    assert run(7) == run(7)
    assert run(7) != run(8)


def test_default_statistics_and_quantisation():
    imp = DEFAULT.with_seed(1)
    m_e, m_n = local_metres_per_degree(TRUTH.lat_deg)
    reports = [imp.impair(TRUTH) for _ in range(4000)]
    kept = [r for r in reports if r is not None]
    assert 0.035 < 1 - len(kept) / len(reports) < 0.065  # 5 % dropouts
    de = np.array([(r.state.lon_deg - TRUTH.lon_deg) * m_e for r in kept])
    dn = np.array([(r.state.lat_deg - TRUTH.lat_deg) * m_n for r in kept])
    for err in (de, dn):
        assert abs(err.mean()) < 1.0 and np.std(err) == pytest.approx(30.0 / 2.4477, rel=0.06)  # NACp 9
    latencies = np.array([r.latency_s for r in kept])
    assert latencies.min() >= 0.2 and latencies.max() <= 0.5 and latencies.mean() == pytest.approx(0.35, abs=0.01)
    for r in kept:
        s = r.state
        assert s.t_s == TRUTH.t_s
        assert (s.alt_msl_m / FT) == pytest.approx(round(s.alt_msl_m / FT / 25) * 25, abs=1e-6)
        assert (s.vel_up_mps / FPM) == pytest.approx(round(s.vel_up_mps / FPM / 64) * 64, abs=1e-6)
        assert (s.vel_east_mps / KT) == pytest.approx(round(s.vel_east_mps / KT), abs=1e-6)
    assert np.mean([r.state.alt_msl_m for r in kept]) == pytest.approx(3000 * FT)  # 3000 ft is on the grid
    vel_err = np.array([r.state.vel_north_mps - TRUTH.vel_north_mps for r in kept])
    assert np.std(vel_err) == pytest.approx(math.hypot(3.0 / 2.4477, KT / math.sqrt(12)), rel=0.08)


@pytest.mark.parametrize(
    "kwargs",
    [dict(position_sigma_m=-1.0), dict(dropout_probability=1.0), dict(latency_s=0.1, latency_jitter_s=0.2),
     dict(velocity_sigma_mps=float("nan"))],
)
def test_impairments_reject_bad_levels(kwargs):
    with pytest.raises(ValueError):
        AdsbImpairments(**kwargs)
