"""The DO-365 horizontal manoeuvre (issue 27): DAIDALUS's track resolution over hand-made bands, and the closed loop
in fast time through the guidance stage and the simulated ArduCopter (the live acceptance: tests/test_guidance_live.py)."""

from __future__ import annotations

import math

import pytest
from hypothesis import HealthCheck, example, given, settings, strategies as st

from avionics.advisory.bands import BandInterval
from avionics.config import load_config
from avionics.base.units import FT
from avionics.guidance import ardupilot
from avionics.advisory.bands import Bands
from avionics.guidance.horizontal import closest_horizontal_m, horizontal_manoeuvre, track_resolution, turn_rates
from avionics.guidance.stage import GuidanceDecision
from avionics_sitl.encounters import load_encounter
from avionics_sitl.impairments import PRESETS
from avionics_sitl.replay import replay

NMAC_H_M, NMAC_V_M = 500 * FT, 100 * FT
DO365 = ["advisory.profile=do365", "vehicle.profile=multirotor", "zenoh.enabled=false", "guidance.mode=execute"]


def _bands(*pieces):
    return tuple(BandInterval(lo, hi, region) for lo, hi, region in pieces)


# A hand-made set: NONE 0-40, FAR 40-60, MID 60-100, NEAR 100-130, MID 130-150, NONE 150-300, RECOVERY ... NONE.
BANDS = _bands((0, 40, "NONE"), (40, 60, "FAR"), (60, 100, "MID"), (100, 130, "NEAR"), (130, 150, "MID"),
               (150, 300, "NONE"), (300, 360, "NONE"))


def test_the_resolution_is_the_nearest_edge_below_the_corrective_region_on_each_side():
    """BandsHysteresis.bandsHysteresis by hand: at 110 deg (NEAR) the severe bands (>= MID) run 60..150; the left
    resolution is the upper end of the FAR band (60: FAR is below the corrective region MID, so a resolution), the
    right one the lower end of the NONE band (150). Right is 40 deg away, left 50: right is preferred."""
    res = track_resolution(BANDS, 110.0)
    assert (res.left_deg, res.right_deg) == (60.0, 150.0) and res.preferred_right
    m = horizontal_manoeuvre(BANDS, 110.0, "WARNING", 5.0)
    assert m.right and m.target_track_deg == pytest.approx(155.0) and m.reason == "warning" and m.name == "turn_right"
    # at 70 deg the left edge (60) is 10 away, the right (150) 80: left, 5 deg past it (capped at half the FAR band)
    m = horizontal_manoeuvre(BANDS, 70.0, "CORRECTIVE", 5.0)
    assert not m.right and m.target_track_deg == pytest.approx(55.0)
    assert horizontal_manoeuvre(BANDS, 70.0, "CORRECTIVE", 30.0).target_track_deg == pytest.approx(50.0)
    # the side of a manoeuvre in progress is kept while it has a resolution
    assert horizontal_manoeuvre(BANDS, 70.0, "CORRECTIVE", 5.0, side=True).target_track_deg == pytest.approx(155.0)
    # a track outside the corrective bands needs none (DAIDALUS: NaN); FAR is not corrective
    assert track_resolution(BANDS, 20.0) is None and track_resolution(BANDS, 50.0) is None


def test_the_resolution_wraps_round_north_and_is_infinite_past_half_a_turn():
    wrap = _bands((0, 20, "MID"), (20, 200, "NONE"), (200, 340, "RECOVERY"), (340, 360, "NEAR"))
    res = track_resolution(wrap, 350.0)
    assert (res.left_deg, res.right_deg) == (340.0, 20.0)  # across 360/0: the NEAR and MID bands are one
    m = horizontal_manoeuvre(wrap, 350.0, "WARNING", 5.0)
    assert not m.right and m.target_track_deg == pytest.approx(335.0) and m.reason == "recovery"
    # a severe band reaching more than half a turn to the left: no left resolution (DAIDALUS to_the_left fails)
    wide = _bands((0, 10, "NONE"), (10, 250, "MID"), (250, 360, "NONE"))
    res = track_resolution(wide, 200.0)
    assert res.left_deg == -math.inf and res.right_deg == 250.0 and res.preferred_right
    assert track_resolution(_bands((0, 360, "NEAR")), 90.0).right_deg == math.inf
    assert horizontal_manoeuvre(_bands((0, 360, "NEAR")), 90.0, "WARNING", 5.0) is None


def test_the_statustext_of_a_turn_names_the_side_and_the_track():
    d = GuidanceDecision(1.0, "commanding", "turn_right", 0.0, "corrective", "GUIDED", 1.0, 155.4)
    assert d.text() == "DAA GUIDANCE COMMANDING RIGHT TRK155 corrective"


def test_the_multirotor_turns_off_the_head_on_under_do365_and_resumes_its_mission():
    scenario = load_encounter("head-on")
    result = replay(scenario, load_config(overrides=DO365), PRESETS["none"], fly_guidance=True)
    (miss,) = result.misses
    assert miss.hmd_m < NMAC_H_M and miss.vmd_without_m < NMAC_V_M  # an NMAC without
    assert miss.hmd_flown_m > NMAC_H_M, miss  # a horizontal miss flown, level
    first = result.guidance[0]
    assert first.state == "commanding" and first.manoeuvre.startswith("turn_") and first.target_track_deg is not None
    assert first.target_vertical_rate_mps == 0.0
    assert result.copter.modes[-1][1] == ardupilot.AUTO and result.guidance[-1].reason == "mission_resumed"
    setpoints = [m for _, m in result.sent if m.get_type() == "SET_POSITION_TARGET_GLOBAL_INT"]
    assert setpoints and all(m.vz == 0.0 and ardupilot.is_velocity_setpoint(m) for m in setpoints)
    # the setpoint's track turns no faster than the vehicle's turn rate
    tracks = [(m.time_boot_ms / 1000.0, math.degrees(math.atan2(m.vy, m.vx))) for m in setpoints]
    for (t0, a), (t1, b) in zip(tracks, tracks[1:]):
        assert abs((b - a + 180) % 360 - 180) <= 14.324 * (t1 - t0) + 0.02  # time_boot_ms: a millisecond's rounding


def _encounter(seed: int, min_closure_mps: float = 12.0, max_hmd_m: float = 400.0):
    """A random co-altitude-ish encounter for a 10 m/s multirotor (tests/ra_sim.py's geometry)."""
    import numpy as np
    from ra_sim import Encounter, Intruder, to_scenario

    rng = np.random.default_rng(seed)
    agl = rng.uniform(150.0, 600.0)
    t_cpa, closure, bearing = rng.uniform(25.0, 35.0), rng.uniform(min_closure_mps, 80.0), \
        rng.uniform(0, 2 * math.pi)
    hmd, vmd = rng.uniform(0.0, max_hmd_m), rng.uniform(-40.0, 40.0)
    vx, vy = -closure * math.cos(bearing), -closure * math.sin(bearing)
    cx, cy = hmd * math.sin(bearing), -hmd * math.cos(bearing)
    intruder = Intruder(cx - vx * t_cpa, cy - vy * t_cpa, vx, vy, vmd, 0.0)
    return to_scenario(Encounter(agl, 0.0, (intruder,), t_cpa + 12.0), f"generated-{seed}", own_speed_mps=10.0)


def _not_smaller(miss) -> bool:
    """The miss flown is not smaller than flying the mission on, measured in the NMAC cylinder's norm,
    max(HMD / 500 ft, VMD / 100 ft) (an NMAC is a norm below 1), with 10 m of horizontal and 1 m of vertical slack
    for the sampling and the re-join's pull back toward the path."""
    def norm(h, v):
        return max(h / NMAC_H_M, v / NMAC_V_M)
    return norm(miss.hmd_flown_m + 10.0, miss.vmd_with_m + 1.0) >= norm(miss.hmd_m, miss.vmd_without_m)


@settings(max_examples=12, deadline=None, derandomize=True,
          suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])
@given(seed=st.integers(0, 2**32 - 1), profile=st.sampled_from(["do365", "f3442"]))
@example(seed=6, profile="f3442")  # a corrective (unsaturated) resolution: the drawn ones are mostly recovery
def test_the_executed_manoeuvre_never_leaves_a_smaller_miss(seed, profile):
    """Closed loop with the vehicle's dynamics: whatever is flown (the bands' track resolution, or the RA's
    vertical manoeuvre where no track resolution keeps every intruder at least as far as the present track), the
    miss flown is not smaller than flying the mission on (_not_smaller). Most drawn encounters saturate the bands
    (a 10 m/s multirotor against DO-365's 4000 ft well clear: recovery resolutions); the first explicit example
    is a corrective one (f3442, 395 m -> 627 m)."""
    result = replay(_encounter(seed), load_config(overrides=[*DO365, f"advisory.profile={profile}"]),
                    PRESETS["none"], fly_guidance=True)
    (miss,) = result.misses
    assert _not_smaller(miss), (seed, profile, miss, result.guidance[:4])


def test_a_recovery_resolution_toward_the_intruder_is_not_flown():
    """DAIDALUS's recovery resolution (saturated bands) keeps only its collision-avoidance cylinder, here by the 108 ft
    vertical separation the mission already has: it turned the multirotor toward the intruder (a 35 m horizontal
    miss where the mission flown on passes 163 m away). Both sides' resolutions pass closer than the present track
    (horizontal.py closest_horizontal_m), so the RA's descent is flown instead, and the horizontal miss is kept."""
    result = replay(_encounter(0, 20.0, 200.0), load_config(overrides=DO365), PRESETS["none"], fly_guidance=True)
    (miss,) = result.misses
    first = result.guidance[0]
    assert first.manoeuvre == "descend" and first.target_track_deg is None, first
    assert _not_smaller(miss) and miss.hmd_flown_m >= miss.hmd_m - 10.0, miss  # and here on each axis


def test_without_guidance_bands_a_do365_warning_is_flown_vertically():
    """advisory.guidance_bands = false: no track resolution to pick, so the warning's RA is flown as before."""
    config = load_config(overrides=[*DO365, "advisory.guidance_bands=false"])
    result = replay(load_encounter("head-on"), config, PRESETS["none"], fly_guidance=True)
    assert result.guidance[0].manoeuvre in ("climb", "descend") and result.guidance[0].target_track_deg is None


def test_a_turning_intruder_is_predicted_on_its_arc():
    """By hand: an intruder 300 m east at 30 m/s southbound, turning right at 0.1 rad/s, circles the origin (radius
    300 m). Straight on, it never comes within 300 m of a vehicle hovering at (0, -300); on its arc it is over it
    a quarter turn later (pi / 2 / 0.1 = 15.7 s; sampled every 0.5 s: within 30 m/s x 0.25 s of it)."""
    traffic = (((300.0, 0.0, 0.0), (0.0, -30.0, 0.0)),)
    assert closest_horizontal_m((0.0, -300.0), (0.0, 0.0), traffic, 60.0) == pytest.approx(300.0)
    assert closest_horizontal_m((0.0, -300.0), (0.0, 0.0), traffic, 60.0, [0.1]) < 7.6
    # within 10 s it has come a radian round: 300 sqrt(2 - 2 sin 1) m away
    assert closest_horizontal_m((0.0, -300.0), (0.0, 0.0), traffic, 10.0, [0.1]) == \
        pytest.approx(300.0 * math.sqrt(2.0 - 2.0 * math.sin(1.0)))


def test_turn_rates_from_two_bands_a_second_apart():
    """The track change between two bands over their interval, across north, clockwise positive, clamped at 12
    deg/s; 0 for a new intruder, a slow one, or bands more than 2.5 s apart."""
    def bands(t, *tracks_deg, speed=40.0):
        rad = [math.radians(d) for d in tracks_deg]
        return Bands(t, (), (), (), (), intruders=tuple((f"i{k}", 2) for k in range(len(rad))),
                     traffic=tuple(((0.0, 0.0, 0.0), (speed * math.sin(a), speed * math.cos(a), 0.0)) for a in rad))

    rates = turn_rates(bands(10.0, 358.0, 90.0, 90.0), bands(11.0, 4.0, 84.0, 150.0, 10.0))
    assert [math.degrees(r) for r in rates] == pytest.approx([6.0, -6.0, 12.0, 0.0])
    assert turn_rates(bands(10.0, 358.0), bands(13.0, 4.0)) == [0.0]
    assert turn_rates(None, bands(13.0, 4.0)) == [0.0]
    assert turn_rates(bands(10.0, 0.0, speed=3.0), bands(11.0, 30.0, speed=3.0)) == [0.0]
