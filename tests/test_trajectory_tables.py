"""Trajectory tables (avionics_sitl.tables): OpenSky / traffic CSV and Parquet tables replayed through the chain.

The real sample (tests/data/opensky_cdg_crossing.csv, provenance in tests/data/README.md) is checked against
computations made here from its own rows, by hand, independently of the reader: the TCAS II v7.1 TA criterion
(tau/DMOD, ZTHR) for a UAV hovering under a departure, and the closest approach of a 1000 ft crossing.
"""

import csv
import math
from datetime import datetime
from pathlib import Path

import pytest
from hypothesis import given, settings, strategies as st

from avionics_sitl.autopilot import schedule
from avionics_sitl.cli import main
from avionics_sitl.encounters import load_encounter
from avionics_sitl.impairments import PRESETS
from avionics_sitl.tables import read_table

pytestmark = pytest.mark.xdist_group("trajectory_tables")

DATA = Path(__file__).resolve().parent / "data"
SAMPLE = DATA / "opensky_cdg_crossing.csv"
HOVER = DATA / "hover_uav_cdg.csv"
FT, KT, FPM, NM = 0.3048, 1852.0 / 3600.0, 0.3048 / 60.0, 1852.0  # by definition (international foot, nautical mile)
A_WGS84, E2_WGS84 = 6378137.0, 6.69437999014e-3


# --- independent helpers: the table's own rows, flat earth at a reference point --------------------------------

def sample_rows(path=SAMPLE, t_from=None, t_to=None):
    with open(path, newline="") as fh:
        rows = list(csv.DictReader(fh))
    for r in rows:
        r["t"] = datetime.fromisoformat(r["timestamp"]).timestamp()
    return [r for r in rows if (t_from is None or r["t"] >= t_from) and (t_to is None or r["t"] <= t_to)]


def write_rows(path, rows):
    fields = [k for k in rows[0] if k != "t"]
    with open(path, "w", newline="") as fh:
        writer = csv.DictWriter(fh, fieldnames=fields, extrasaction="ignore")
        writer.writeheader()
        writer.writerows(rows)
    return path


def en(lat, lon, lat0, lon0):
    """East/north metres from (lat0, lon0) with the WGS-84 radii of curvature there (good to ~1e-3 within 10 km)."""
    s = math.sin(math.radians(lat0))
    n_radius = A_WGS84 / math.sqrt(1 - E2_WGS84 * s * s)
    m_radius = A_WGS84 * (1 - E2_WGS84) / (1 - E2_WGS84 * s * s) ** 1.5
    return (math.radians(lon - lon0) * n_radius * math.cos(math.radians(lat0)),
            math.radians(lat - lat0) * m_radius)


def ta_criterion(s_e, s_n, v_e, v_n, sz, vz, tau_s, dmod_m, zthr_m) -> bool:
    """TCAS II v7.1 TA test (docs/algorithms.md section 4): horizontal (r <= DMOD, or closing with modified tau
    (DMOD^2 - r^2)/(s.v) <= tau) and vertical (|sz| <= ZTHR, or converging with -sz/vz <= tau)."""
    r2 = s_e * s_e + s_n * s_n
    sv = s_e * v_e + s_n * v_n
    horizontal = r2 <= dmod_m ** 2 or (sv < 0 and (dmod_m ** 2 - r2) / sv <= tau_s)
    vertical = abs(sz) <= zthr_m or (sz * vz < 0 and -sz / vz <= tau_s)
    return horizontal and vertical


def replay_csv(capsys, *argv):
    code = main(["replay", *map(str, argv)])
    captured = capsys.readouterr()
    assert code == 0, captured.err
    return list(csv.DictReader(captured.out.splitlines())) if "--out" not in argv else None


def read_csv(path):
    with open(path, newline="") as fh:
        return list(csv.DictReader(fh))


# --- the real sample through the chain -----------------------------------------------------------------------

def test_hovering_uav_under_a_departure_gets_its_ta_when_the_table_meets_the_tcas_criterion(tmp_path, capsys):
    rows = sample_rows()
    t0 = min(r["t"] for r in rows)
    window = write_rows(tmp_path / "cdg_first_130s.csv", [r for r in rows if r["t"] <= t0 + 130])
    out = tmp_path / "out.csv"
    replay_csv(capsys, window, "--ownship-file", HOVER, "--noise", "none", "--out", out)
    advisories = read_csv(out)

    (hover,) = read_csv(HOVER)
    lat0, lon0, alt0_m = float(hover["latitude"]), float(hover["longitude"]), float(hover["altitude"]) * FT
    # SL 4: ownship at 3600 ft, ground 0 (2350 ft AGL < 3600 ft <= 5000 ft): TA tau 30 s, DMOD 0.48 nm, ZTHR 850 ft
    sl4 = dict(tau_s=30.0, dmod_m=0.48 * NM, zthr_m=850 * FT)
    onset = {}
    for r in rows:
        if r["t"] > t0 + 130:
            continue
        e, n = en(float(r["latitude"]), float(r["longitude"]), lat0, lon0)
        gs, trk = float(r["groundspeed"]) * KT, math.radians(float(r["track"]))
        if ta_criterion(e, n, gs * math.sin(trk), gs * math.cos(trk), float(r["altitude"]) * FT - alt0_m,
                        float(r["vertical_rate"]) * FPM, **sl4):
            onset.setdefault(r["icao24"], r["t"] - t0)
    assert set(onset) == {"3944e7"}  # AFR23PJ, over the UAV; BAW308 stays 25 km away at 11000 ft
    first_ta = {}
    for a in advisories:
        if a["advisory"] in ("TA", "RA"):
            first_ta.setdefault(a["name"], float(a["time_s"]))
    assert set(first_ta) == set(onset)  # a TA iff the truth meets the criterion
    # the tracker needs a report or two (1 Hz, no noise) to see it: no earlier than 1 s before, at most 2.5 s after
    assert onset["3944e7"] - 1.0 <= first_ta["3944e7"] <= onset["3944e7"] + 2.5, (onset, first_ta)


def test_crossing_aircraft_ownship_cpa_matches_the_table_and_parquet_gives_the_same_csvs(tmp_path, capsys):
    pa = pytest.importorskip("pyarrow")
    import pyarrow.csv as pv
    import pyarrow.parquet as pq

    rows = sample_rows()
    t0 = max(r["t"] for r in rows) - 120  # the last two minutes: BAW308 and AFR23PJ cross at t0 + 80 s
    window = write_rows(tmp_path / "crossing.csv", [r for r in rows if r["t"] >= t0])
    parquet = tmp_path / "crossing.parquet"
    types = {"icao24": pa.string(), "callsign": pa.string(), "squawk": pa.string()}  # 3944e7 is not a number
    table = pv.read_csv(window, convert_options=pv.ConvertOptions(column_types=types))
    assert pa.types.is_timestamp(table.schema.field("timestamp").type)  # a real datetime column in the Parquet
    pq.write_table(table, parquet)
    outputs = {}
    for source in (window, parquet):
        out, misses = tmp_path / f"{source.suffix[1:]}_out.csv", tmp_path / f"{source.suffix[1:]}_misses.csv"
        replay_csv(capsys, source, "--ownship", "400804", "--seed", "3", "--out", out, "--misses", misses)
        outputs[source.suffix] = (out.read_text(), misses.read_text())
    assert outputs[".csv"] == outputs[".parquet"]

    # closest approach straight from the rows: both aircraft are reported every second; linear in between
    own = {r["t"]: r for r in rows if r["icao24"] == "400804" and r["t"] >= t0}
    afr = {r["t"]: r for r in rows if r["icao24"] == "3944e7" and r["t"] >= t0}
    best = (math.inf, None, None)
    for t in sorted(set(own) & set(afr)):
        if t + 1 not in own or t + 1 not in afr:
            continue
        for k in range(10):
            u = k / 10

            def at(rs, key):
                return (1 - u) * float(rs[t][key]) + u * float(rs[t + 1][key])

            e, n = en(at(afr, "latitude"), at(afr, "longitude"), at(own, "latitude"), at(own, "longitude"))
            h = math.hypot(e, n)
            if h < best[0]:
                best = (h, t + u - t0, (at(afr, "altitude") - at(own, "altitude")) * FT)
    hmd_m, t_cpa_s, dz_m = best
    assert 600 < hmd_m < 700 and abs(dz_m + 1000 * FT) < 30  # the 1000 ft crossing, as published
    misses = {m["name"]: m for m in read_csv(tmp_path / "csv_misses.csv")}
    assert set(misses) == {"3944e7", "484163"}
    m = misses["3944e7"]
    assert float(m["t_cpa_s"]) == pytest.approx(t_cpa_s, abs=0.3)
    assert float(m["hmd_m"]) == pytest.approx(hmd_m, abs=10.0)
    assert float(m["vmd_unflown_m"]) == pytest.approx(abs(dz_m), abs=10.0)

    # SL 6 at 11000 ft (TA tau 45 s, DMOD 1.0 nm, ZTHR 850 ft): 1000 ft apart and level, the criterion never holds,
    # and the replay (default ADS-B noise) raises nothing
    for r in rows:
        if r["t"] < t0 or r["icao24"] == "400804" or r["t"] not in own:
            continue
        o = own[r["t"]]
        e, n = en(float(r["latitude"]), float(r["longitude"]), float(o["latitude"]), float(o["longitude"]))
        gi, ti = float(r["groundspeed"]) * KT, math.radians(float(r["track"]))
        go, to = float(o["groundspeed"]) * KT, math.radians(float(o["track"]))
        assert not ta_criterion(e, n, gi * math.sin(ti) - go * math.sin(to), gi * math.cos(ti) - go * math.cos(to),
                                (float(r["altitude"]) - float(o["altitude"])) * FT,
                                (float(r["vertical_rate"]) - float(o["vertical_rate"])) * FPM,
                                tau_s=45.0, dmod_m=1.0 * NM, zthr_m=850 * FT), r
    assert [a for a in read_csv(tmp_path / "csv_out.csv") if a["advisory"] != "NONE"] == []


# --- units ----------------------------------------------------------------------------------------------------

OPENSKY_HEADER = "time,icao24,lat,lon,baroaltitude,velocity,heading,vertrate,callsign"
TRAFFIC_HEADER = "timestamp,icao24,latitude,longitude,altitude,groundspeed,track,vertical_rate,callsign"


def one_aircraft(tmp_path, name, header, rows):
    path = tmp_path / name
    path.write_text(header + "\n" + "\n".join(rows) + "\n")
    return read_table(path)


def test_opensky_si_and_traffic_nautical_columns_give_the_same_samples(tmp_path):
    # 1000 m, 100 m/s, 5 m/s  ==  3280.8399 ft, 194.38445 kt, 984.25197 ft/min
    si = one_aircraft(tmp_path, "os.csv", OPENSKY_HEADER, ["1633610444,3944E7,49,2.4,1000,100,90,5,AFR23PJ"])
    nautical = one_aircraft(tmp_path, "tr.csv", TRAFFIC_HEADER,
                            ["2021-10-07 12:40:44+00:00,3944e7,49,2.4,3280.839895,194.3844492,90,984.2519685,afr23pj"])
    assert si.layout.units == "opensky" and nautical.layout.units == "traffic"
    (a,), (b,) = si.aircraft["3944e7"].samples, nautical.aircraft["3944e7"].samples
    assert a.t == b.t == 1633610444.0
    for field in ("lat", "lon", "alt_m", "ve", "vn", "vu"):
        assert getattr(a, field) == pytest.approx(getattr(b, field), abs=1e-6), field
    assert (a.alt_m, a.ve, a.vu) == pytest.approx((1000.0, 100.0, 5.0))
    assert si.aircraft["3944e7"].callsign == nautical.aircraft["3944e7"].callsign == "AFR23PJ"


def test_geoaltitude_alone_is_geometric_and_an_ambiguous_table_needs_units(tmp_path):
    geo = one_aircraft(tmp_path, "geo.csv", "time,icao24,lat,lon,geoaltitude,velocity,heading,vertrate",
                       ["0,abc123,47,8,500,10,0,0"])
    assert geo.layout.datum.name == "GEOMETRIC" and geo.layout.units == "opensky"
    path = tmp_path / "mixed.csv"  # OpenSky's REST names velocity (m/s) with traffic's vertical_rate (ft/min)
    path.write_text("timestamp,icao24,latitude,longitude,geoaltitude,velocity,track,vertical_rate\n"
                    "0,abc123,47,8,500,10,0,2\n")
    with pytest.raises(ValueError, match="units are ambiguous.*velocity.*vertical_rate.*--units"):
        read_table(path)
    as_si = read_table(path, units="opensky").aircraft["abc123"].samples[0]
    as_traffic = read_table(path, units="traffic").aircraft["abc123"].samples[0]
    assert (as_si.alt_m, as_si.vn, as_si.vu) == pytest.approx((500.0, 10.0, 2.0))
    assert (as_traffic.alt_m, as_traffic.vn, as_traffic.vu) == pytest.approx((500 * FT, 10 * KT, 2 * FPM))
    heading = tmp_path / "heading.csv"  # traffic's heading is the nose (Comm-B), not the track
    heading.write_text("timestamp,icao24,latitude,longitude,altitude,groundspeed,heading,vertical_rate\n"
                       "0,abc123,47,8,500,10,0,0\n")
    with pytest.raises(ValueError, match="heading is the aircraft's heading"):
        read_table(heading)


# --- rows: order, duplicates, missing fields, gaps -------------------------------------------------------------

ROW = st.tuples(st.sampled_from(["a00001", "a00002", "a00003"]), st.integers(0, 40),
                st.floats(46.9, 47.1), st.floats(7.9, 8.1), st.floats(0, 20000), st.floats(0, 400),
                st.floats(0, 359.9), st.floats(-3000, 3000))


def table_text(rows):
    lines = [TRAFFIC_HEADER] + [f"{t},{icao},{la!r},{lo!r},{alt!r},{gs!r},{trk!r},{vs!r},X{icao[-1]}"
                                for icao, t, la, lo, alt, gs, trk, vs in rows]
    return "\n".join(lines) + "\n"


def samples_of(path):
    return {k: [(s.t, s.lat, s.lon, s.alt_m, s.ve, s.vn, s.vu) for s in ac.samples]
            for k, ac in read_table(path).aircraft.items()}


@settings(max_examples=40, deadline=None)
@given(st.lists(ROW, min_size=1, max_size=30, unique_by=lambda r: (r[0], r[1])), st.randoms())
def test_row_order_does_not_matter(tmp_path_factory, rows, rnd):
    d = tmp_path_factory.mktemp("order")
    (d / "a.csv").write_text(table_text(rows))
    shuffled = rows[:]
    rnd.shuffle(shuffled)
    (d / "b.csv").write_text(table_text(shuffled))
    a, b = samples_of(d / "a.csv"), samples_of(d / "b.csv")
    assert a == b
    for samples in a.values():
        assert all(s1[0] < s2[0] for s1, s2 in zip(samples, samples[1:]))


@settings(max_examples=40, deadline=None)
@given(st.lists(ROW, min_size=1, max_size=30))
def test_a_repeated_timestamp_keeps_the_last_row(tmp_path_factory, rows):
    path = tmp_path_factory.mktemp("dups") / "t.csv"
    path.write_text(table_text(rows))
    last = {}
    for icao, t, la, lo, alt, gs, trk, vs in rows:
        last[(icao, t)] = (la, lo, alt * FT, vs * FPM)
    got = {(k, s[0]): (s[1], s[2], s[3], s[6]) for k, samples in samples_of(path).items() for s in samples}
    assert got.keys() == last.keys()
    for key, want in last.items():
        assert got[key] == pytest.approx(want), key


def test_a_missing_field_is_no_sample_not_a_zero(tmp_path):
    t = one_aircraft(tmp_path, "nan.csv", TRAFFIC_HEADER,
                     ["0,a00001,47,8,3000,100,90,0,", "1,a00001,47,8.001,,100,90,0,",
                      "2,a00001,47,8.002,3000,NaN,90,0,", "3,a00001,47,8.003,3000,100,90,0,"])
    ac = t.aircraft["a00001"]
    assert [s.t for s in ac.samples] == [0.0, 3.0] and ac.incomplete_rows == 2


def test_an_intruder_is_not_reported_in_its_gaps(tmp_path):
    own = [f"{t},c0ffee,47,8,3000,0,0,0,UAV" for t in (0, 100)]
    # intruder heard 0..30 s, silent 30..70 s (a gap > 20 s), heard 70..100 s; flying east at 100 kt
    # (level, but reporting 1000 ft/min: a cubic across the gap would climb, the chord stays level)
    intr = [f"{t},a00002,47.01,{8 + t * 1e-4:.6f},3000,100,90,1000,GA"
            for t in list(range(0, 31, 2)) + list(range(70, 101, 2))]
    path = tmp_path / "gap.csv"
    path.write_text(TRAFFIC_HEADER + "\n" + "\n".join(own + intr) + "\n")
    scenario = load_encounter(str(path), ownship="c0ffee")
    times = [e.truth_s for e in schedule(scenario, PRESETS["none"]) if e.msg.get_type() == "ADSB_VEHICLE"]
    assert times and all(t <= 30 or t >= 70 for t in times)
    assert any(t < 30 for t in times) and any(t > 70 for t in times)
    (traj,) = scenario.trajectories()[1]  # the truth crosses the gap on the chord, not on a cubic
    quarter = [0.75 * a + 0.25 * b for a, b in zip(traj.enu_at(30.0), traj.enu_at(70.0))]
    assert traj.enu_at(40.0) == pytest.approx(quarter, abs=1e-6)
    assert traj.enu_at(40.0)[2] == pytest.approx(3000 * FT, abs=1e-6)
    closed = load_encounter(str(path), ownship="c0ffee", gap_s=60.0)  # --gap 60: the same silence is bridged
    times = [e.truth_s for e in schedule(closed, PRESETS["none"]) if e.msg.get_type() == "ADSB_VEHICLE"]
    assert any(30 < t < 70 for t in times)


# --- the command line: errors, progress, live ------------------------------------------------------------------

def run_cli(capsys, *argv):
    code = main(list(map(str, argv)))
    captured = capsys.readouterr()
    return code, captured.out, captured.err


@pytest.mark.parametrize("content, ownship, message", [
    ("timestamp,icao24,latitude,longitude,altitude,groundspeed,vertical_rate\n0,a00001,47,8,1,1,1\n", "a00001",
     "missing column(s): track or heading"),
    (TRAFFIC_HEADER + "\n0,a00001,47,8,3000,100,90,0,X\n", "a00002", "no row of ownship a00002"),
    (TRAFFIC_HEADER + "\n0,a00001,47,8,3000,100,90,0,X\n1,a00002,47,eight,3000,100,90,0,X\n", "a00001",
     "row 2: longitude 'eight' is not a number"),
    (TRAFFIC_HEADER + "\n1633610444000,a00001,47,8,3000,100,90,0,X\n", "a00001", "looks like milliseconds"),
])
def test_a_malformed_table_is_a_one_line_error_exit_2(tmp_path, capsys, content, ownship, message):
    path = tmp_path / "bad.csv"
    path.write_text(content)
    code, out, err = run_cli(capsys, "replay", path, "--ownship", ownship)
    assert code == 2 and len(err.splitlines()) == 1 and "Traceback" not in err, err
    assert err.startswith("sitl: ") and str(path) in err and message in err, err


def test_a_broken_parquet_file_and_a_table_without_ownship_are_errors(tmp_path, capsys):
    broken = tmp_path / "broken.parquet"
    broken.write_bytes(b"PAR1 this is not parquet")
    code, _, err = run_cli(capsys, "replay", broken, "--ownship", "a00001")
    assert code == 2 and len(err.splitlines()) == 1 and "Parquet" in err, err
    code, _, err = run_cli(capsys, "replay", SAMPLE)
    assert code == 2 and "--ownship ICAO24" in err and len(err.splitlines()) == 1, err


def test_progress_bar_only_when_asked(tmp_path, capsys):
    rows = sample_rows()
    t0 = min(r["t"] for r in rows)
    window = write_rows(tmp_path / "short.csv", [r for r in rows if r["t"] <= t0 + 10])
    code, out, err = run_cli(capsys, "replay", window, "--ownship", "400804", "--noise", "none")
    assert code == 0 and err == "" and out.startswith("time_s,")  # stderr is not a terminal here
    code, out, err = run_cli(capsys, "replay", window, "--ownship", "400804", "--noise", "none", "--progress")
    assert code == 0 and "reading short.csv" in err and "100%" in err, err


@pytest.mark.live
def test_sitl_live_flies_a_table(tmp_path):
    import socket
    import subprocess
    import sys

    from pymavlink.dialects.v20 import common as mavlink2

    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as sock:
        sock.bind(("127.0.0.1", 0))
        sock.settimeout(10.0)
        port = sock.getsockname()[1]
        proc = subprocess.Popen([sys.executable, "-m", "avionics_sitl.cli", "live", str(SAMPLE), "--ownship",
                                 "400804", "--noise", "none", "--start", "300", "--duration", "3",
                                 "--connection", f"udpout:127.0.0.1:{port}"],
                                stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        parser = mavlink2.MAVLink(None)
        seen = set()
        try:
            while not {"ADSB_VEHICLE", "GLOBAL_POSITION_INT"} <= {kind for kind, _ in seen}:
                for msg in parser.parse_buffer(sock.recv(4096)) or []:
                    seen.add((msg.get_type(), getattr(msg, "ICAO_address", None)))
        finally:
            _, err = proc.communicate(timeout=30)
    assert proc.returncode == 0, err
    assert ("ADSB_VEHICLE", 0x3944E7) in seen  # AFR23PJ, from the table


def test_progress_bar_follows_the_replay_of_a_long_file(tmp_path, capsys):
    rows = sample_rows()
    t0 = min(r["t"] for r in rows)
    window = write_rows(tmp_path / "short.csv", [r for r in rows if r["t"] <= t0 + 10])
    code, out, err = run_cli(capsys, "replay", window, "--ownship", "400804", "--noise", "none", "--progress")
    assert code == 0 and out.startswith("time_s,") and "replaying" in err and err.count("100%") >= 2, err
