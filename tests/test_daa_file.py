"""DAIDALUS .daa files: columns, units, snapshots and samples, interleaving, errors, round trips."""

from __future__ import annotations

import math
import os
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from avionics.base.geodesy import LocalTangentPlane
from avionics_sitl.builtin import BUILTIN
from avionics_sitl.daa_file import EUCLIDEAN_ORIGIN, format_daa, read_daa
from avionics_sitl.aircraft import Leg
from avionics_sitl.trajectory import LegKinematics, SampledTrajectory

DATA = Path(__file__).resolve().parent / "data"
# NASA's public DAIDALUS / daa-displays files, read where they are (never copied into the project).
CONFORMANCE = Path(__file__).resolve().parents[1].parent / "shared" / "conformance" / "daidalus"
# Hand constants, deliberately not imported from avionics.base.units: the reader's unit table is under test.
M_PER_NMI, M_PER_FT, MPS_PER_KT = 1852.0, 0.3048, 1852.0 / 3600.0
FAST = settings(max_examples=30, deadline=None)


def horizontal_range(a, b) -> float:
    plane = LocalTangentPlane(a.lat_deg, a.lon_deg)
    e, n = plane.to_en(b.lat_deg, b.lon_deg)
    return math.hypot(float(e), float(n))


def closest_approach(sc, step=0.02):
    own, (intr,) = sc.trajectories()
    times = np.arange(0.0, sc.duration_s, step)
    ranges = [math.dist(own.enu_at(t)[:2], intr.enu_at(t)[:2]) for t in times]
    i = int(np.argmin(ranges))
    return float(times[i]), horizontal_range(own.state_at(times[i]), intr.state_at(times[i]))


# --- the example files ------------------------------------------------------------------------------------------


def test_head_on_file_hand_numbers():
    sc = read_daa(DATA / "head_on_3000ft.daa")
    own, (intr,) = sc.ownship, sc.intruders
    assert (own.name, intr.name) == ("Ownship", "Intruder")
    assert (own.icao_address, intr.icao_address) == (0xA00001, 0xA00002)
    assert own.alt_msl_m == intr.alt_msl_m == pytest.approx(3000 * M_PER_FT)  # 914.4 m
    assert own.speed_mps == pytest.approx(125 * MPS_PER_KT) and intr.speed_mps == pytest.approx(125 * MPS_PER_KT)
    assert (own.heading_deg, intr.heading_deg) == pytest.approx((0.0, 180.0), abs=1e-9)
    assert sc.ground_elevation_m == 0.0 and sc.duration_s == 120.0
    assert sc.precomputed_trajectories is None  # a snapshot: straight lines from the specs
    o, (i,) = sc.trajectories()
    assert horizontal_range(o.state_at(0.0), i.state_at(0.0)) == pytest.approx(6 * M_PER_NMI, abs=0.5)
    # 250 kt closing: 6 nm take 86.4 s; 30 s before that the range is 250 kt * 30 s = 2.083 nm.
    assert horizontal_range(o.state_at(56.4), i.state_at(56.4)) == pytest.approx(250 * 30 / 3600 * M_PER_NMI, abs=0.5)
    t_cpa, d = closest_approach(sc)
    assert t_cpa == pytest.approx(86.4, abs=0.03) and d < 1.0


def test_head_on_file_is_the_builtin_head_on():
    from_file, builtin = read_daa(DATA / "head_on_3000ft.daa"), BUILTIN["head-on"]()
    (fo, (fi,)), (bo, (bi,)) = from_file.trajectories(), builtin.trajectories()
    for t in (0.0, 43.2, 86.4, 120.0):
        assert horizontal_range(fo.state_at(t), bo.state_at(t)) < 0.05
        assert horizontal_range(fi.state_at(t), bi.state_at(t)) < 0.05


def _turning_truth():
    nm, ft, kt, fpm = M_PER_NMI, M_PER_FT, MPS_PER_KT, M_PER_FT / 60.0
    own = LegKinematics(0.0, 0.0, 2000 * ft, 90.0, 90 * kt)
    intr = LegKinematics(2 * nm, 2 * nm, 2500 * ft, 180.0, 120 * kt, 0.0,
                         (Leg(20.0, 0.0, -500 * fpm), Leg(30.0, 3.0, -500 * fpm), Leg(20.0, 0.0, -500 * fpm)))
    return own, intr


def test_euclidean_multi_sample_file():
    sc = read_daa(DATA / "turning_intruder_euclidean.daa")
    assert sc.origin == EUCLIDEAN_ORIGIN
    assert sc.ground_elevation_m == pytest.approx(400 * M_PER_FT)
    assert sc.duration_s == 60.0 + 60.0
    own, (intr,) = sc.trajectories()
    assert isinstance(own, SampledTrajectory) and len(intr.times) == 13
    truth_own, truth_intr = _turning_truth()
    for traj, truth in ((own, truth_own), (intr, truth_intr)):
        for t in np.arange(-5.0, 90.0, 0.5):  # through the samples, between them, and extrapolated
            want = truth.at(min(t, 60.0)) if t <= 60.0 else None
            if want is None:  # after the last sample: straight on with the last velocity
                last = truth.at(60.0)
                want = (last[0] + last[3] * (t - 60), last[1] + last[4] * (t - 60), last[2] + last[5] * (t - 60))
            elif t < 0:
                first = truth.at(0.0)
                want = (first[0] + first[3] * t, first[1] + first[4] * t, first[2] + first[5] * t)
            assert np.allclose(traj.enu_at(t), want[:3], atol=0.05), t
    assert intr.state_at(30.0).vel_up_mps == pytest.approx(-500 * M_PER_FT / 60.0)


# --- units ---------------------------------------------------------------------------------------------------

LENGTH = {"m": 1.0, "ft": M_PER_FT, "nmi": M_PER_NMI, "NM": M_PER_NMI, "km": 1000.0}
SPEED = {"knot": MPS_PER_KT, "kn": MPS_PER_KT, "kts": MPS_PER_KT, "m/s": 1.0, "mps": 1.0,
         "fpm": M_PER_FT / 60.0, "ft/min": M_PER_FT / 60.0}
ANGLE = {"deg": 1.0, "rad": 180.0 / math.pi}
TIME = {"s": 1.0, "ms": 1e-3, "min": 60.0}


@FAST
@given(
    length=st.sampled_from(sorted(LENGTH)),
    alt_unit=st.sampled_from(sorted(LENGTH)),
    speed=st.sampled_from(sorted(SPEED)),
    vs_unit=st.sampled_from(sorted(SPEED)),
    angle=st.sampled_from(sorted(ANGLE)),
    time=st.sampled_from(sorted(TIME)),
    sx=st.floats(-20e3, 20e3), sy=st.floats(-20e3, 20e3), alt=st.floats(0.0, 10e3),
    gs=st.floats(1.0, 250.0), trk=st.floats(0.0, 359.0), vs=st.floats(-20.0, 20.0), dt=st.floats(1.0, 100.0),
)
def test_units_convert_to_si(length, alt_unit, speed, vs_unit, angle, time, sx, sy, alt, gs, trk, vs, dt):
    """Write SI values in any supported units; reading them back gives the SI values."""
    def row(name, t, x, y):
        return (f"{name}, {x / LENGTH[length]!r}, {y / LENGTH[length]!r}, {alt / LENGTH[alt_unit]!r}, "
                f"{trk / ANGLE[angle]!r}, {gs / SPEED[speed]!r}, {vs / SPEED[vs_unit]!r}, {t / TIME[time]!r}")
    text = "\n".join([
        "NAME, sx, sy, sz, trk, gs, vs, time",
        f"[none], [{length}], [{length}], [{alt_unit}], [{angle}], [{speed}], [{vs_unit}], [{time}]",
        row("own", 0.0, 0.0, 0.0),
        row("other", 0.0, sx, sy),
        row("own", dt, 1.0, 1.0),
        row("other", dt, sx + 1.0, sy + 1.0),
    ]) + "\n"
    sc = read_daa(text)
    _, (intr,) = sc.trajectories()
    e, n, z = intr.enu_at(0.0)
    assert (e, n, z) == pytest.approx((sx, sy, alt), abs=1e-4)  # geodesy round trip: 1e-6 m at 20 km
    assert intr.times[-1] == pytest.approx(dt, rel=1e-12)
    s = intr.state_at(0.0)
    assert s.vel_up_mps == pytest.approx(vs, abs=1e-9)
    _, _, _, ve, vn, _ = LegKinematics(0, 0, 0, trk, gs).at(0.0)
    assert intr._vel[0][:2] == pytest.approx([ve, vn], abs=1e-9)  # along the Euclidean axes


def test_closing_speed_in_metres_per_second_and_kilometres():
    # Head-on along sx at 250 kt closing, written in km and m/s: 128.611 m/s; 11.112 km = 6 nm.
    text = """NAME sx sy sz vx vy vz time
[none] [km] [km] [m] [m/s] [m/s] [m/s] [s]
A 0 0 914.4 64.30555556 0 0 0
B 11.112 0 914.4 -64.30555556 0 0 0
"""
    sc = read_daa(text)
    t_cpa, d = closest_approach(sc)
    assert t_cpa == pytest.approx(6 * M_PER_NMI / (250 * MPS_PER_KT), abs=0.03) and d < 0.1


def test_default_units_without_units_line_and_without_time():
    text = "NAME lat lon alt trk gs vs\nown 47.4 8.5 1000 90 100 500\nintruder 47.41 8.5 1000 270 100 0\n"
    sc = read_daa(text)
    assert sc.ownship.alt_msl_m == pytest.approx(1000 * M_PER_FT)
    assert sc.ownship.speed_mps == pytest.approx(100 * MPS_PER_KT)
    assert sc.ownship.vertical_rate_mps == pytest.approx(500 * M_PER_FT / 60)
    assert sc.ownship.heading_deg == pytest.approx(90.0)
    assert sc.duration_s == 120.0


def test_separators_comments_ignored_columns_and_parameters():
    text = """## written by hand
horizontal_nmac = 500 [ft]
NAME,lat ,lon, alt,trk,gs,vs,time,alerter,s_EW_std
# a comment between header and data

own,47.4,8.5,3000,0,125,0,0,1,0.0,
intruder   47.5  8.5  3000  180  125  0  0  1  0.0
"""
    sc = read_daa(text)
    assert [a.name for a in sc.aircraft] == ["own", "intruder"]
    assert sc.intruders[0].heading_deg == 180.0


# --- samples and interleaving -----------------------------------------------------------------------------------


def _row(name: str, k: int, t: float) -> str:
    return f"{name}, {47.4 + 0.01 * k + 1e-5 * t:.8f}, 8.5, {3000 + t:.3f}, 0, 36, 60, {t}"


@FAST
@given(st.permutations(["a"] * 4 + ["b"] * 4 + ["own"] * 3))
def test_rows_of_different_aircraft_may_interleave_arbitrarily(labels):
    names, times = ["own", "a", "b"], [0.0, 10.0, 20.0, 30.0]
    header = "NAME lat lon alt trk gs vs time\n"
    in_order = [_row(n, k, t) for t in times for k, n in enumerate(names)]
    reference = read_daa(header + "\n".join(in_order) + "\n")
    # The k-th occurrence of a name takes that aircraft's k-th row: any interleaving that keeps each
    # aircraft's rows in time order; ownship's first row leads (the first name is the ownship).
    next_row = {n: iter(times) for n in names}
    order = ["own"] + list(labels)
    shuffled = [_row(n, names.index(n), next(next_row[n])) for n in order]
    got = read_daa(header + "\n".join(shuffled) + "\n")
    assert [a.name for a in got.aircraft] == ["own"] + [n for n in dict.fromkeys(labels) if n != "own"]
    ref = dict(zip((a.name for a in reference.aircraft), [reference.trajectories()[0], *reference.trajectories()[1]]))
    out = dict(zip((a.name for a in got.aircraft), [got.trajectories()[0], *got.trajectories()[1]]))
    for name in names:
        assert [ref[name].state_at(t) for t in (0.0, 5.0, 25.0, 40.0)] == \
            [out[name].state_at(t) for t in (0.0, 5.0, 25.0, 40.0)]


def test_time_is_shifted_to_start_at_zero_and_late_starters_are_extrapolated():
    text = """NAME lat lon alt trk gs vs time
own 47.4 8.5 3000 90 100 0 100
own 47.4 8.505 3000 90 100 0 110
late 47.5 8.5 3000 180 100 0 105
late 47.495 8.5 3000 180 100 0 115
"""
    sc = read_daa(text)
    own, (late,) = sc.trajectories()
    assert list(own.times) == [0.0, 10.0] and list(late.times) == [5.0, 15.0]
    assert sc.duration_s == 15.0 + 60.0
    # The late aircraft's spec is its state at simulation time 0: 5 s of 100 kt back along its track.
    e, n, _ = late.enu_at(0.0)
    e5, n5, _ = late.enu_at(5.0)
    assert n - n5 == pytest.approx(5 * 100 * MPS_PER_KT, rel=1e-3)
    assert horizontal_range(sc.intruders[0], late.state_at(0.0)) < 1e-3


# --- round trip with the writer ---------------------------------------------------------------------------------


@pytest.mark.parametrize("name", ["hwang-tracking", "climbing-intruder", "radosavljevic-2"])
def test_format_then_read_returns_the_truth(name):
    sc = BUILTIN[name]()
    times = np.arange(0.0, sc.duration_s + 1e-9, 1.0)
    back = read_daa(format_daa(sc, times))
    assert [a.name for a in back.aircraft] == [a.name for a in sc.aircraft]
    assert back.duration_s == pytest.approx(times[-1] + 60.0)
    (o1, i1), (o2, i2) = sc.trajectories(), back.trajectories()
    for a, b in ((o1, o2), (i1[0], i2[0])):
        for t in times[::7]:
            s, r = a.state_at(t), b.state_at(t)
            # < 1 cm: bounded by the geodesy inverse 50 nm from the plane origins, not by the file's digits
            assert horizontal_range(s, r) < 0.01 and r.alt_msl_m == pytest.approx(s.alt_msl_m, abs=1e-5)
            assert (r.vel_east_mps, r.vel_north_mps, r.vel_up_mps) == pytest.approx(
                (s.vel_east_mps, s.vel_north_mps, s.vel_up_mps), abs=1e-5)
        for t in times[:-1:5] + 0.5:  # between samples: Hermite on up to 5.4 deg/s turns at 1 s spacing
            assert horizontal_range(a.state_at(t), b.state_at(t)) < 0.05


# --- errors ---------------------------------------------------------------------------------------------------

GOOD = """NAME, lat, lon, alt, trk, gs, vs, time
[none], [deg], [deg], [ft], [deg], [knot], [fpm], [s]
own, 47.4, 8.5, 3000, 0, 125, 0, 0
intruder, 47.5, 8.5, 3000, 180, 125, 0, 0
"""


@pytest.mark.parametrize(
    "old, new, line, message",
    [
        ("vs, time", "vs, time, foo", 1, "unknown column 'foo'"),
        ("lat, lon, alt,", "lat, lon,", 1, "header lacks position column"),
        ("lat, lon, alt, trk, gs, vs", "lat, lon, alt, sx, trk, gs, vs", 1, "mixes"),
        ("trk, gs, vs,", "", 1, "header lacks velocity columns"),
        ("NAME,", "", 1, "no NAME column"),
        ("[knot]", "[furlong]", 2, "unknown unit"),
        ("[ft], [deg]", "[deg], [deg]", 2, "not a length unit"),
        ("[s]\n", "\n", 2, "units line has 7 fields"),
        ("own, 47.4, 8.5, 3000, 0, 125, 0, 0", "own, 47.4, 8.5, 3000, 0, 125, 0", 3, "7 fields"),
        ("own, 47.4, 8.5, 3000", "own, 47.4, 8.5, 3k", 3, "'3k' is not a number"),
        ("own, 47.4,", "own, nan,", 3, "not finite"),
        ("intruder, 47.5, 8.5, 3000, 180, 125", "intruder, 47.5, 8.5, 3000, 180, inf", 4, "not finite"),
        ("own, 47.4,", "own, 95,", 3, "out of range"),
        ("intruder, 47.5, 8.5, 3000, 180, 125, 0, 0", "own, 47.5, 8.5, 3000, 180, 125, 0, -1", 4, "is not after"),
    ],
)
def test_bad_files_name_the_line(old, new, line, message):
    text = GOOD.replace(old, new, 1)
    assert text != GOOD
    with pytest.raises(ValueError, match=rf"line {line}: .*{message}"):
        read_daa(text)


def test_rows_of_one_aircraft_must_be_in_time_order():
    text = GOOD + "own, 47.41, 8.5, 3000, 0, 125, 0, 10\nown, 47.42, 8.5, 3000, 0, 125, 0, 5\n"
    with pytest.raises(ValueError, match=r"line 6: time 5 s of 'own' is not after .*line 5"):
        read_daa(text)


def test_bad_ground_comment_names_the_line():
    with pytest.raises(ValueError, match="line 1: ground_ft"):
        read_daa("# ground_ft = lots\n" + GOOD)
    assert read_daa("# ground_ft = 1500\n" + GOOD).ground_elevation_m == pytest.approx(1500 * M_PER_FT)


def test_fewer_than_two_aircraft():
    with pytest.raises(ValueError, match="at least two aircraft"):
        read_daa(GOOD.split("intruder")[0])
    with pytest.raises(ValueError, match="no header"):
        read_daa("# only comments\n\n")


def test_invalid_aircraft_state_names_the_line():
    with pytest.raises(ValueError, match=r"line 4: aircraft 'intruder': speed_mps"):
        read_daa(GOOD.replace("180, 125", "180, 5000"))


def test_missing_file():
    with pytest.raises(ValueError, match="cannot read"):
        read_daa(DATA / "no_such_file.daa")


# --- DAIDALUS's behaviour: units of ignored columns, repeated time stamps -----------------------------------


def test_units_of_ignored_columns_are_not_checked():
    # DAIDALUS never converts a column it does not use, so any unit text there is fine.
    text = """NAME, lat, lon, alt, trk, gs, vs, time, alerter, heading
[none], [deg], [deg], [m], [deg], [knot], [fpm], [s], [furlong], -
own, 47.4, 8.5, 1000, 0, 125, 0, 0, 1, 0
intruder, 47.5, 8.5, 1000, 180, 125, 0, 0, 1, 180
"""
    sc = read_daa(text)
    assert [a.name for a in sc.aircraft] == ["own", "intruder"]
    assert sc.ownship.alt_msl_m == pytest.approx(1000.0)  # the units line was read: alt in metres
    assert sc.stated_uncertainty is None  # no *_std column: nothing stated
    # The columns we use are still checked, naming the line and the column.
    with pytest.raises(ValueError, match=r"line 2: unit '\[deg\]' is not a length unit \(column 'alt'\)"):
        read_daa(text.replace("[deg], [m]", "[deg], [deg]", 1))
    with pytest.raises(ValueError, match=r"line 2: unknown unit '\[furlong\]' for column 'alt'"):
        read_daa(text.replace("[m]", "[furlong]", 1))


STD_TEXT = """NAME, lat, lon, alt, trk, gs, vs, time, s_EW_std, s_NS_std, s_EN_std, sz_std, v_EW_std, vz_std
[none], [deg], [deg], [ft], [deg], [knot], [fpm], [s], [nmi], [nmi], [nmi], [ft], [nmi/s], [fpm]
own, 47.4, 8.5, 3000, 0, 125, 0, 0, 0.02, 0.03, -0.01, 100, 0.0005, 60
intruder, 47.5, 8.5, 3000, 180, 125, 0, 0, 0, 0, 0, 0, 0, 0
intruder, 47.49, 8.5, 3000, 180, 125, 0, 1, 0.1, 0.1, 0, 50, 0, 0
"""


def test_std_columns_are_each_rows_stated_uncertainty():
    # DaidalusFileWalker passes each row's *_std columns, converted from the units line, to
    # set*Uncertainty (SUMData); a column left out is 0. The replay attaches them to the aircraft's reports.
    sc = read_daa(STD_TEXT)
    own = sc.uncertainty_at("own", 0.0)
    assert (own.s_ew_std_m, own.s_ns_std_m, own.s_en_std_m) == pytest.approx((37.04, 55.56, -18.52))
    assert own.sz_std_m == pytest.approx(100 * 0.3048) and own.v_ew_std_mps == pytest.approx(0.926)
    assert own.v_ns_std_mps == 0.0 and own.v_en_std_mps == 0.0 and own.vz_std_mps == pytest.approx(60 * 0.3048 / 60)
    assert sc.uncertainty_at("intruder", 0.5).sz_std_m == 0.0  # the latest row at or before the time
    assert sc.uncertainty_at("intruder", 1.0).sz_std_m == pytest.approx(50 * 0.3048)
    assert sc.uncertainty_at("nobody", 0.0) is None


def test_std_columns_are_checked():
    with pytest.raises(ValueError, match=r"line 2: unit '\[nmi/s\]' is not a length unit \(column 's_ew_std'\)"):
        read_daa(STD_TEXT.replace("[s], [nmi]", "[s], [nmi/s]", 1))
    with pytest.raises(ValueError, match=r"line 3: uncertainty sz_std_m must be >= 0"):
        read_daa(STD_TEXT.replace("-0.01, 100", "-0.01, -100", 1))
    with pytest.raises(ValueError, match=r"line 3: column 'vz_std': 'x' is not a number"):
        read_daa(STD_TEXT.replace("0.0005, 60", "0.0005, x", 1))


def test_a_repeated_time_keeps_the_last_row():
    # DAIDALUS's SequenceReader keeps one state per (aircraft, time): the last row read.
    text = GOOD.replace("own, 47.4, 8.5, 3000, 0, 125, 0, 0\n",
                        "own, 47.3, 8.4, 2000, 90, 100, 0, 0\nown, 47.4, 8.5, 3000, 0, 125, 0, 0\n", 1)
    text += ("own, 47.41, 8.5, 3000, 0, 125, 0, 10\n"
             "intruder, 47.49, 8.5, 3000, 180, 125, 0, 10\n"
             "own, 47.9, 8.9, 9000, 270, 200, 500, 10\n"  # replaced by the next own row at 10 s
             "own, 47.42, 8.5, 3000, 0, 125, 0, 10\n")
    sc = read_daa(text)
    assert [a.name for a in sc.aircraft] == ["own", "intruder"]
    own, (intr,) = sc.trajectories()
    assert list(own.times) == [0.0, 10.0] and list(intr.times) == [0.0, 10.0]
    assert sc.origin == (47.4, 8.5)  # geodetic plane at the ownship's first kept row, not the replaced one
    assert (sc.ownship.lat_deg, sc.ownship.lon_deg) == pytest.approx((47.4, 8.5))
    assert sc.ownship.heading_deg == pytest.approx(0.0, abs=1e-9)
    s10 = own.state_at(10.0)  # the last row's, not the replaced 47.9 N (moved to DAIDALUS's geometry: < 1e-4 deg)
    assert (s10.lat_deg, s10.lon_deg, s10.alt_msl_m) == pytest.approx((47.42, 8.5, 3000 * M_PER_FT), abs=1e-4)
    assert "4 samples" in sc.description
    # Repeated rows at the one time of a snapshot leave a snapshot.
    snap = read_daa(GOOD + "intruder, 47.6, 8.5, 3000, 180, 125, 0, 0\n")
    assert snap.precomputed_trajectories is None and snap.duration_s == 120.0
    assert snap.intruders[0].lat_deg == pytest.approx(47.6, abs=2e-4)  # 22 km north: DAIDALUS's sphere


def test_a_time_going_backwards_is_still_an_error_naming_the_line():
    text = GOOD + ("own, 47.41, 8.5, 3000, 0, 125, 0, 10\n"
                   "own, 47.42, 8.5, 3000, 0, 125, 0, 10\n"  # repeats 10 s: replaces line 5
                   "own, 47.43, 8.5, 3000, 0, 125, 0, 9.5\n")
    with pytest.raises(ValueError, match=r"line 7: time 9.5 s of 'own' is not after .*\(line 6, 10 s\)"):
        read_daa(text)


# --- NASA's own files (public data in ../shared/conformance/daidalus) ---------------------------------------


def conformance_file(name: str) -> Path:
    """A file of the DAIDALUS conformance set; skip if the set is absent (a plain clone), fail if under CI."""
    if not CONFORMANCE.is_dir():
        reason = f"DAIDALUS conformance set not found at {CONFORMANCE} (public NASA data, not in the repository)"
        if "CI" in os.environ:
            pytest.fail(f"{reason}; it is required under CI")
        pytest.skip(reason)
    path = CONFORMANCE / name
    if not path.is_file():
        pytest.fail(f"{path}: missing from the DAIDALUS conformance set")
    return path


def _by_name(sc):
    own, intruders = sc.trajectories()
    return {a.name: (a, traj) for a, traj in zip(sc.aircraft, (own, *intruders))}


def _assert_same_trajectories(a, b):
    """Same aircraft (ownship first), same sample times, same states at those times and between them."""
    assert a.ownship.name == b.ownship.name
    ta, tb = _by_name(a), _by_name(b)
    assert sorted(ta) == sorted(tb)
    assert a.origin == b.origin and a.duration_s == b.duration_s
    for name, (spec_a, traj_a) in ta.items():
        spec_b, traj_b = tb[name]
        assert (spec_a.lat_deg, spec_a.lon_deg, spec_a.alt_msl_m, spec_a.heading_deg, spec_a.speed_mps,
                spec_a.vertical_rate_mps) == (spec_b.lat_deg, spec_b.lon_deg, spec_b.alt_msl_m, spec_b.heading_deg,
                                              spec_b.speed_mps, spec_b.vertical_rate_mps), name
        assert list(traj_a.times) == list(traj_b.times), name
        times = np.asarray(traj_a.times)
        for t in [*times, *(times[:-1] + 0.5)]:
            assert traj_a.state_at(float(t)) == traj_b.state_at(float(t)), (name, t)


def test_daidalus_h1_sum_reads_as_its_file_without_std_columns():
    # The same aircraft and trajectories; the *_std columns ([nmi], [nmi/s]) are the stated uncertainties.
    sc = read_daa(conformance_file("daidalus_H1_SUM.daa"))
    assert [a.name for a in sc.aircraft] == ["Ownship", "Intruder_1"]
    own, (intr,) = sc.trajectories()
    assert (len(own.times), len(intr.times)) == (230, 203)
    assert own.times[0] == 0.0 and own.times[-1] == 229.0 and sc.duration_s == 229.0 + 60.0
    nostd = read_daa(conformance_file("daidalus_H1_SUM_nostd.daa"))
    assert [a for a in sc.aircraft] == [a for a in nostd.aircraft]  # same specs, same ICAO addresses
    _assert_same_trajectories(sc, nostd)
    assert nostd.stated_uncertainty is None
    first = sc.uncertainty_at("Ownship", 0.0)  # 0.020248380129590 nmi, 0.016457883330230 nmi (100 ft)
    assert first.s_ew_std_m == pytest.approx(0.020248380129590 * 1852) and first.sz_std_m == pytest.approx(30.48)


def test_daa_displays_sim3_keeps_the_last_row_of_each_repeated_stamp():
    path = conformance_file("daadisplays_sim3.daa")
    raw_rows = sum(1 for line in path.read_text().splitlines()[2:] if line.strip())
    sc = read_daa(path)
    assert [a.name for a in sc.aircraft] == ["ownship", "traffic1", "traffic2"]
    by_name = _by_name(sc)
    assert {n: len(t.times) for n, (_, t) in by_name.items()} == {"ownship": 127, "traffic1": 129, "traffic2": 129}
    assert raw_rows == 6474  # 385 (aircraft, time) stamps, most repeated
    assert "385 samples over 128 s" in sc.description and "file time 17 s is simulation time 0" in sc.description
    lastrow = read_daa(conformance_file("daadisplays_sim3_lastrow.daa"))
    # The publisher's de-duplicated file lists traffic2 first at 17 s; the intruders' order (and so their ICAO
    # addresses) follows each file's first appearance, as DAIDALUS's does. Everything else is identical.
    assert [a.name for a in lastrow.aircraft] == ["ownship", "traffic2", "traffic1"]
    _assert_same_trajectories(sc, lastrow)
