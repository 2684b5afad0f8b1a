"""Non-cooperative intruders seen by the ownship's radar, against NASA DAIDALUS v2.0.4 with every intruder on
DO-365B's `DWC_Non_Coop` alerter (issue 30's acceptance).

`../shared/conformance/daidalus/first_alerts_noncoop.csv` holds DAIDALUS's first level 1, 2 and 3 times for every
intruder of the published scenarios on their true states, every 1 s (its README says how they were made). Here no
intruder broadcasts: each file is flown through `sitl replay FILE --sensor radar --noise none --set
advisory.profile=daidalus-do365b-no-sum`, so the radar measures range, azimuth and elevation exactly, all round, at
its 10 Hz; the detections go over MAVLink (DAA_SENSOR_MEASUREMENT) into the sensor tracks (M-of-N, GNN, the IMM
banks: tracking/sensor_tracker.py, tracking/surveillance.py) with no identity, and the profile's per-intruder
alerter judges those tracks with its non-cooperative alerter (DO_365B_no_SUM.conf's DWC_Non_Coop, the profile
do365-non-coop; advisory/alerting.py Alerter.non_cooperative), as DAIDALUS with the aircraft on alerter 3. Every
first level must fall within 1 s of DAIDALUS's, none missed, none extra. The replay names each sensor track after
the aircraft nearest its estimated position at its first alert (sitl/avionics_sitl/replay.py _SensorNamer).

The data are public and stay in ../shared: the test skips where they are absent and fails under CI (CI set).
"""

from __future__ import annotations

import csv
import io

import pytest

from tests.golden.first_alerts import golden, problems, require
from tests.conftest import ResultCapture
from tests.golden.generate import CONFORMANCE, replayed_csv

pytestmark = pytest.mark.xdist_group("replays-do365")
LEVELS = {1: "level 1", 2: "level 2", 3: "level 3"}
GOLDEN = golden("DO_365B_no_SUM_non_coop", "first_alerts_noncoop.csv")
ARGS = ("--sensor", "radar", "--noise", "none", "--set", "advisory.profile=daidalus-do365b-no-sum")


def test_the_noncoop_data_is_there_under_ci():
    require(GOLDEN)
    assert len(GOLDEN) >= 20, f"expected the published scenarios, found {sorted(GOLDEN)}"


@pytest.mark.parametrize("case_file", sorted(GOLDEN) or ["(no data)"])
def test_radar_only_first_levels_within_1_s_of_daidalus_dwc_non_coop(case_file):
    require(GOLDEN)
    first: dict[tuple[str, int], float] = {}
    rows = list(csv.DictReader(io.StringIO(replayed_csv(str(CONFORMANCE / case_file), ARGS))))
    for row in rows:
        assert row["intruder"].startswith("sensor-"), f"an intruder seen other than by the radar: {row}"
        for n in range(1, int(row["alert_level"]) + 1):
            first.setdefault((row["name"], n), float(row["time_s"]))
    found = problems(GOLDEN[case_file], first, LEVELS)
    assert not found, f"{case_file}: " + "; ".join(found)


@pytest.mark.parametrize("seed", [1, 3])
def test_radar_with_its_errors_raises_no_alert_for_an_intruder_turning_away(seed):
    """scenario_5 seen by the Appendix Q radar (errors, missed detections, false returns): from 70 s the intruder
    turns away from north to east at about 3.5 deg/s, and DAIDALUS (DWC_Non_Coop, true states) raises nothing
    past level 2. A track that follows the turn's onset about 2 s late projects the intruder into the 2200 ft
    cylinder under the warning's 25 s, and on these two draws raised an extra level 3 at 80-82 s (issue 30 asks
    for none); the radar tracks' fixed-rate turn modes (tracking.radar_horizontal_modes: standard-rate turns
    either way, models.known_rate_turn) follow it. The report's own judgement: within 3 s, none missed or extra,
    where the radar sees the intruder."""
    from avionics_eval.reports.noncoop import RUNS, compare, first_levels

    require(GOLDEN)
    case_file = "daadisplays_scenario_5.daa"
    sensor, exact, profile, *_ = RUNS["radar"]
    ours = first_levels(CONFORMANCE / case_file, sensor, exact, profile, seed)
    lines = compare("radar", case_file, GOLDEN[case_file], ours, CONFORMANCE)
    assert lines and all(line["verdict"] in ("ok", "not seen") for line in lines), lines


@pytest.mark.parametrize("case_file, seed", [("daidalus_MULTI.daa", 12), ("daadisplays_s_1_turn_L_wind_0_50.daa", 2)])
def test_radar_tracks_weigh_a_second_of_range_rates_as_one(case_file, seed):
    """The Appendix Q radar's range rate has a bias for the run (seed 12: 2.1 m/s) under its white 3 m/s.
    MULTI: taken as white at 10 Hz, the range rates' declared 3.8 m/s averaged to about 1 m/s, under the bias,
    and AC1's track ran 55 m behind its detections until one fell out of the gate at 35.6 s (d² 25.1 against
    21.1); the young track that took over raised level 1 at 45 s, DAIDALUS at 41 s. With the range rates of a
    second weighing as one (tracking.range_rate_correlation_s, SensorTracker._range_rates) the track holds.
    s_1_turn_L seed 2: the intruder enters the field of regard at 1.7 km, overtaking at 17 m/s; weighing a new
    track's first range rates as if it had had a second of them left its velocity to the positions, and its
    first miss read 367 m inside DWC_Non_Coop's 671 m (levels 1 and 2 at 225 s, DAIDALUS none): a track's range
    rates share a draw only with those it has had. Every level within 3 s, none missed or extra (the report's
    judgement, as above)."""
    from avionics_eval.reports.noncoop import RUNS, compare, first_levels

    require(GOLDEN)
    sensor, exact, profile, *_ = RUNS["radar"]
    lines = compare("radar", case_file, GOLDEN[case_file], first_levels(CONFORMANCE / case_file, sensor, exact,
                                                                        profile, seed), CONFORMANCE)
    expected = sum(bool(row[f"first_level{n}_sim_s"]) for row in GOLDEN[case_file] for n in (1, 2, 3))
    assert len(lines) == expected and all(line["verdict"] in ("ok", "not seen") for line in lines), lines


TCAS3D = golden("TCAS3D")
ACTIVE_ARGS = ("--sensor", "active", "--set", "advisory.profile=daidalus-tcas3d")


@pytest.mark.parametrize("case_file, seed", [("daidalus_H0_0_120.daa", 0), ("daidalus_C1_0_120.daa", 0),
                                             ("daadisplays_sim3.daa", 0), ("daidalus_H0_0_120.daa", 1),
                                             ("daadisplays_scenario_6_ver.daa", 0),
                                             ("daadisplays_s_1_turn_R_wind_0_-50.daa", "exact")])
def test_active_surveillance_raises_the_ta_and_ra_within_3_s_of_tcas3d(case_file, seed):
    """Active surveillance (Appendix Q: 1 Hz, bearing to 9 deg, Mode C altitude) against DAIDALUS's TCAS3D on the
    true states (issue 30's acceptance for active surveillance). What held these back: the track read the range
    5 % long from the converted measurement (the head-on's TA 3 s late; now the EKF's update at the prediction,
    measurement.about_prediction); TCAS's HMD filter, fed a miss distance off by hundreds of metres (9 deg of
    bearing: metres per second of cross-range velocity), held the RAs back 4 s (C1) and 8 s (H0), so the alerter
    reads a sensor-only track's miss two sigmas low (pipeline/assessment.py Assessor._resolvable); and on seed 1
    a run of bearing errors near their 27 deg clip dragged the head-on's track sideways, its closure 85 m/s high
    (the TA 7 s early) and its miss kilometres wide (the RA 6 s late): the closure and the miss now come from the
    range track too (tracking/range_tracker.py, TCAS II's parabolic range tracker). sim3: two aircraft on the
    ground beside the taxiing ownship, a TA each from the start and no RA; the replay names each sensor track
    after the aircraft nearest its estimated position (range alone, with the sensor's 76 m range bias, gave both
    tracks one name). scenario_6_ver: an intruder overtaking 280 m below, climbing at 2.4 m/s; a Kalman filter
    taking Mode C's 100 ft steps as white noise read a young track's climb at 10 m/s, the TA 7.5 s and the RA
    10 s early; its vertical now comes from TCAS II's level-transition tracker (tracking/altitude_tracker.py).
    s_1_turn_R measured exactly (`--noise none`): the intruder crosses 1,243 m wide of the ownship, outside the
    1,019 m HMD that keeps TCAS3D from an RA. The range track's miss, a range acceleration of 0.45 m/s² at 4 km
    that its Wiener model follows late, read it narrower and raised an RA at 76 s; a track whose bearings are
    fine needs no range track (tracking.range_track_bearing_sigma_deg) and reads the miss from its positions."""
    require(TCAS3D)
    words = {1: "first_level1_sim_s", 2: "first_level2_sim_s"}
    reference = {(row["intruder"], n): float(row[w]) for row in TCAS3D[case_file] for n, w in words.items() if row[w]}
    first: dict[tuple[str, int], float] = {}
    noise = ("--noise", "none") if seed == "exact" else ("--seed", str(seed))
    replayed = replayed_csv(str(CONFORMANCE / case_file), ACTIVE_ARGS + noise)
    for row in csv.DictReader(io.StringIO(replayed)):
        for n in range(1, min(int(row["alert_level"]), 2) + 1):
            first.setdefault((row["name"], n), float(row["time_s"]))
    assert first.keys() == reference.keys(), (first, reference)
    for key, t in reference.items():
        assert abs(first[key] - t) <= 3.0, f"{case_file} {key}: ours at {first[key]:.1f} s, TCAS3D {t:.1f} s"


def test_the_noncoop_report_leaves_out_an_intruder_below_the_active_sensor_s_field_of_regard():
    """avionics_eval.reports.noncoop judges a noisy run only where its sensor could see the intruder: on
    scenario_7 the intruder is 260-285 m below the ownship at 430-460 m, 29-34 deg down, below Appendix Q
    active surveillance's field of regard (-15 to +20 deg, sitl sensors.py) in the 10 s before DAIDALUS's TA (it
    comes into view at 170 s, where our first alert is); the head-on H0_0_120 is in view."""
    from avionics_eval.reports.noncoop import sensor_sees

    require(TCAS3D)
    assert not sensor_sees(CONFORMANCE / "daadisplays_scenario_7.daa", "a63ed4", 127.5, "active")
    assert sensor_sees(CONFORMANCE / "daidalus_H0_0_120.daa", "Intruder", 52.8, "active")


def _radar_bands(case_file: str, profile: str):
    from avionics.config import load_config
    from avionics_sitl.encounters import load_scenario
    from avionics_sitl.impairments import PRESETS
    from avionics_sitl.replay import replay

    capture = ResultCapture()
    config = load_config(overrides=[f"advisory.profile={profile}", "zenoh.enabled=false",
                                    "advisory.guidance_bands=true"])
    replay(load_scenario(str(CONFORMANCE / case_file)), config, PRESETS["none"], sensors=("radar",),
           exact_sensors=True, ports=[capture])
    return [r.bands for r in capture.results if r.bands is not None]


def test_the_bands_take_a_sensor_only_intruder_with_dwc_non_coop():
    """The guidance bands take each intruder with its own alerter, as DAIDALUS's (DaidalusCore.conflict_aircraft):
    a radar-only intruder under daidalus-do365b-no-sum (Phase I, its non-cooperative alerter DWC_Non_Coop) gets the
    bands that do365-non-coop (DWC_Non_Coop for every intruder) gives it, second by second; with Phase I's volume
    they differ (0.66 nmi and 35 s against 2200 ft and no tau)."""
    require(GOLDEN)
    case_file = "daidalus_H0_0_120.daa"  # head-on: conflict bands from ~70 s before the pass
    per_intruder = _radar_bands(case_file, "daidalus-do365b-no-sum")
    non_coop = _radar_bands(case_file, "do365-non-coop")
    kinds = ("track_deg", "ground_speed_mps", "vertical_rate_mps", "altitude_m")
    assert len(per_intruder) == len(non_coop) > 60
    painted = 0
    for a, b in zip(per_intruder, non_coop):
        assert a.time_s == b.time_s
        for kind in kinds:
            assert a.intervals(kind) == b.intervals(kind), (a.time_s, kind)
        painted += any(iv.region != "NONE" for iv in a.intervals("track_deg"))
    assert painted >= 20  # the head-on does paint track bands
