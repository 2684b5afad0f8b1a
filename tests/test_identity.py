"""One aircraft, one track (avionics/tracking/identity.py), through the real core (DaaCore: frame, tracker, gate).

The oracle is the truth each test flies: reports of one straight-flying aircraft, whichever path or address source
they come by, must end in one track; two aircraft that share an address must stay two tracks, each following its
own truth.
"""

from __future__ import annotations

import math
from dataclasses import replace

from hypothesis import HealthCheck, given, settings, strategies as st

from avionics.config import load_config
from avionics.base.types import AddressSource, AltitudeDatum, IntruderKey, IntruderReport, OwnshipFix
from avionics.pipeline.daa_core import DaaCore
from avionics_sitl.trajectory import plane_velocity_to_true
from synthetic import PLANE

ADDRESS = 0xA1B2C3
ES = IntruderKey(ADDRESS, AddressSource.ES1090)
UAT = IntruderKey(ADDRESS, AddressSource.UAT)
ALT = 1500.0


def report(key, t, east, north, ve, vn, alt=ALT, path="mavlink", sigma=None):
    lat, lon = PLANE.to_geodetic(east, north)
    v = plane_velocity_to_true(PLANE, float(lat), float(lon), ve, vn)
    return IntruderReport(key, t, t, float(lat), float(lon), alt, AltitudeDatum.PRESSURE, (float(v[0]), float(v[1])),
                          0.0, path=path, position_sigma_m=sigma)


def ownship(t):
    lat, lon = PLANE.to_geodetic(0.0, 0.0)
    return OwnshipFix(t, float(lat), float(lon), ALT - 300.0, 100.0, (0.0, 0.0, 0.0))


def fly(core, reports_at, until_s, step_s=0.5):
    """Step the core every step_s with the ownship and the reports reports_at(t) gives."""
    t = 0.0
    while t <= until_s + 1e-9:
        core.step(t, [ownship(t), *reports_at(t)])
        t = round(t + step_s, 6)


def track_position(core, key, t):
    x, _ = core.tracker.predict([key], t)
    return x[0, :2]


speeds = st.floats(-120.0, 120.0)
places = st.floats(-8000.0, 8000.0)


@settings(max_examples=15, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(e0=places, n0=places, ve=speeds, vn=speeds, es_first=st.booleans())
def test_one_aircraft_on_1090es_and_uat_is_one_track(e0, n0, ve, vn, es_first):
    """The same aircraft on both links (each at 1 Hz, half a second apart): one track, fed by both."""
    core = DaaCore(load_config(None, []))
    first, second = (ES, UAT) if es_first else (UAT, ES)

    def reports_at(t):
        key = first if t % 1.0 == 0.0 else second
        return [report(key, t, e0 + ve * t, n0 + vn * t, ve, vn)]

    fly(core, reports_at, 20.0)
    assert list(core.tracker.tracks) == [first]
    assert core.tracker.tracks[first].n_updates == 41  # every report of both links went into it
    assert core.counters["identity.fused"] == 1 and core.counters["identity.split"] == 0
    assert abs(track_position(core, first, 20.0) - (e0 + ve * 20, n0 + vn * 20)).max() < 30.0


@settings(max_examples=15, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(e0=places, n0=places, ve=speeds, vn=speeds, bearing=st.floats(0.0, 6.28), apart=st.floats(2000.0, 20000.0))
def test_two_aircraft_sharing_an_address_stay_two_tracks(e0, n0, ve, vn, bearing, apart):
    """A 1090ES aircraft and a UAT aircraft with the same 24 bits, kilometres apart: two tracks, each its own."""
    de, dn = apart * math.sin(bearing), apart * math.cos(bearing)
    core = DaaCore(load_config(None, []))

    def reports_at(t):
        return [report(ES, t, e0 + ve * t, n0 + vn * t, ve, vn),
                report(UAT, t + 0.25, e0 + de - vn * (t + 0.25), n0 + dn + ve * (t + 0.25), -vn, ve)]

    fly(core, reports_at, 15.0)
    assert set(core.tracker.tracks) == {ES, UAT}
    assert core.counters["identity.fused"] == 0
    assert abs(track_position(core, ES, 15.0) - (e0 + ve * 15, n0 + vn * 15)).max() < 30.0
    assert abs(track_position(core, UAT, 15.25) - (e0 + de - vn * 15.25, n0 + dn + ve * 15.25)).max() < 30.0


def test_a_uat_aircraft_that_flew_alongside_splits_off_when_it_turns_away():
    """Two aircraft sharing an address fly in close formation (indistinguishable: one track), then the UAT one
    turns away at 3 deg/s: its reports leave the 1090ES track and make a track of their own."""
    core = DaaCore(load_config(None, []))
    v = 60.0

    def uat_at(t):
        if t < 20.0:
            return 0.0, v * t, 0.0, v
        omega = math.radians(3.0)  # a right turn to the east, integrated in closed form (radius v / omega)
        tt = min(t - 20.0, (math.pi / 2) / omega)
        heading = omega * tt
        e = v / omega * (1 - math.cos(omega * tt))
        n = v * 20.0 + v / omega * math.sin(omega * tt)
        rest = (t - 20.0) - tt
        return e + v * rest, n, v * math.sin(heading), v * math.cos(heading)

    def reports_at(t):
        out = [report(ES, t, 0.0, v * t, 0.0, v)]
        e, n, ve, vn = uat_at(t + 0.5)
        return out + [report(UAT, t + 0.5, e, n, ve, vn)]

    fly(core, reports_at, 90.0, step_s=1.0)
    assert core.counters["identity.fused"] == 1 and core.counters["identity.split"] == 1
    assert set(core.tracker.tracks) == {ES, UAT}
    e, n, _, _ = uat_at(90.5)
    assert abs(track_position(core, UAT, 90.5) - (e, n)).max() < 30.0
    assert abs(track_position(core, ES, 90.0) - (0.0, v * 90)).max() < 30.0


def test_two_paths_of_one_address_feed_one_track_each_counted():
    """ADSB_VEHICLE over MAVLink and a ground feed (a better NACp) report the same 1090ES aircraft: one track,
    both paths applied and counted; a feed report far off the track is dropped at the gate, not merged."""
    core = DaaCore(load_config(None, []))
    sbs = "sbs:127.0.0.1:30003"

    def reports_at(t):
        e, n = 3000.0 - 50.0 * t, 2000.0
        if t % 1.0 == 0.0:
            return [report(ES, t, e, n, -50.0, 0.0)]
        if t == 12.5:  # the feed says the aircraft jumped 3 km: not this aircraft's motion
            return [report(ES, t, e + 3000.0, n, -50.0, 0.0, path=sbs, sigma=3.0)]
        return [report(ES, t, e, n, -50.0, 0.0, path=sbs, sigma=3.0)]

    fly(core, reports_at, 20.0)
    assert list(core.tracker.tracks) == [ES]
    assert core.counters["track.path.mavlink.applied"] == 21
    assert core.counters[f"track.path.{sbs}.applied"] == 19 and core.counters[f"track.path.{sbs}.dropped"] == 1
    assert core.tracker.tracks[ES].n_updates == 40
    assert abs(track_position(core, ES, 20.0) - (3000.0 - 1000.0, 2000.0)).max() < 15.0


def test_a_report_without_velocity_is_judged_on_its_position():
    """A UAT report with no velocity (a partial message) still joins the 1090ES track when its position agrees."""
    core = DaaCore(load_config(None, []))

    def reports_at(t):
        if t % 1.0 == 0.0:
            return [report(ES, t, 1000.0 + 40.0 * t, 500.0, 40.0, 0.0)]
        return [replace(report(UAT, t, 1000.0 + 40.0 * t, 500.0, 40.0, 0.0), velocity_en_mps=None)]

    fly(core, reports_at, 10.0)
    assert list(core.tracker.tracks) == [ES] and core.counters["identity.fused"] == 1


def test_both_links_first_heard_in_the_same_step_make_one_track():
    """The process starts with the aircraft already on both links: their first reports share one batch."""
    core = DaaCore(load_config(None, []))
    core.step(0.0, [ownship(0.0), report(UAT, -0.9, 2000.0 - 45.0, 0.0, 50.0, 0.0),
                    report(ES, -0.5, 2000.0 - 25.0, 0.0, 50.0, 0.0), report(UAT, -0.1, 2000.0 - 5.0, 0.0, 50.0, 0.0)])
    assert list(core.tracker.tracks) == [UAT] and core.tracker.tracks[UAT].n_updates == 3
