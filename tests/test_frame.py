"""The tracking frame (avionics/base/frame.py): the geometry an intruder gets does not depend on where on Earth
the encounter is, how far the ownship has flown since the process started, or which aircraft was heard first.

Oracles: the tangent plane at the ownship itself (what DAIDALUS projects around at every step), finite
differences of WGS-84 positions from the prime-vertical and meridian radii of curvature, and the same encounter
flown near the origin."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from avionics.conflict.cpa import pair_geometry
from avionics.base.frame import MAX_HOP_M, RECENTRE_M, FrameChange, TrackingFrame
from avionics.base.geodesy import WGS84_A, WGS84_E2, LocalTangentPlane, geodetic_to_ecef
from avionics.base.types import AddressSource, AdvisoryLevel, IntruderKey, IntruderReport
from synthetic import Encounter, Mover

NM = 1852.0
ALT = 1000.0  # m: sensitivity level 4 (TCAS II table, 1000-2350 ft AGL above home at 0 m)


def radii(lat_deg):
    """Meridian and prime-vertical radii of curvature (m) at a latitude."""
    s2 = math.sin(math.radians(lat_deg)) ** 2
    return WGS84_A * (1 - WGS84_E2) / (1 - WGS84_E2 * s2) ** 1.5, WGS84_A / math.sqrt(1 - WGS84_E2 * s2)


latitudes = st.floats(-85.0, 85.0)
longitudes = st.floats(-180.0, 180.0)


@settings(max_examples=200)
@given(latitudes, longitudes, latitudes, longitudes, st.floats(-math.pi, math.pi))
def test_velocity_matrix_is_the_derivative_of_the_projection(lat0, lon0, dlat, dlon, heading):
    """J maps 1 m/s true east/north at a point to the plane's rate of change there (finite differences of
    positions displaced along the ellipsoid by 0.1 m, from the radii of curvature)."""
    lat, lon = lat0 + dlat / 90.0, lon0 + dlon / 90.0  # a point within ~200 km of the plane's origin
    plane = LocalTangentPlane(lat0, lon0)
    m, n = radii(lat)
    ds = 0.1
    ve, vn = math.sin(heading), math.cos(heading)
    lat2 = lat + math.degrees(vn * ds / m)
    lon2 = lon + math.degrees(ve * ds / (n * math.cos(math.radians(lat))))
    e1, n1 = plane.to_en(lat, lon)
    e2, n2 = plane.to_en(lat2, lon2)
    fd = np.array([e2 - e1, n2 - n1]) / ds
    assert plane.velocity_matrix(lat, lon) @ np.array([ve, vn]) == pytest.approx(fd, abs=1e-5)


@settings(max_examples=200)
@given(latitudes, longitudes, st.floats(-300e3, 300e3), st.floats(-300e3, 300e3))
def test_one_point_and_many_points_go_to_the_same_place(lat0, lon0, east, north):
    """to_geodetic takes one point through math and arrays through numpy (the flight loop converts one point a
    step): the same surface point both ways, within a micrometre, and to_en brings it back to the plane point."""
    plane = LocalTangentPlane(lat0, lon0)
    lat, lon = plane.to_geodetic(east, north)
    lats, lons = plane.to_geodetic(np.array([east, 0.0]), np.array([north, 0.0]))
    assert isinstance(lat, float) and lats.shape == (2,)
    assert (lat, lon) == pytest.approx((lats[0], lons[0]), abs=1e-11)  # degrees: 1e-11 deg is about 1 um
    assert plane.to_en(lat, lon) == pytest.approx((east, north), abs=1e-6)


@settings(max_examples=200)
@given(latitudes, longitudes, st.floats(0, 2 * math.pi), st.floats(0, 30 * NM), st.floats(0, 2 * math.pi),
       st.floats(0, RECENTRE_M), st.floats(0, 2 * math.pi), st.floats(5, 300), st.floats(0, 2 * math.pi),
       st.floats(5, 300))
def test_frame_contribution_to_cpa_is_within_budget(lat, lon, bearing, dist, off_bearing, off_dist, own_trk,
                                                    own_v, int_trk, int_v):
    """An intruder within 30 nm: its HMD and CPA time in the tracking plane (origin anywhere within RECENTRE_M of
    the ownship) equal those in the plane tangent at the ownship to 1 m and 0.05 s, for CPAs within 120 s."""
    own_plane = LocalTangentPlane(lat, lon)
    at_own = TrackingFrame()
    at_own.plane = own_plane
    int_lat, int_lon = own_plane.to_geodetic(dist * math.sin(bearing), dist * math.cos(bearing))
    org_lat, org_lon = own_plane.to_geodetic(off_dist * math.sin(off_bearing), off_dist * math.cos(off_bearing))
    tracking = TrackingFrame()
    tracking.plane = LocalTangentPlane(float(org_lat), float(org_lon))
    v_own = (own_v * math.sin(own_trk), own_v * math.cos(own_trk))
    v_int = (int_v * math.sin(int_trk), int_v * math.cos(int_trk))

    def geometry(frame):
        e, n, v = frame.to_plane(np.array([lat, float(int_lat)]), np.array([lon, float(int_lon)]),
                                 np.array([v_own, v_int]))
        return pair_geometry(np.array([[e[1] - e[0], n[1] - n[0]]]), (v[1] - v[0])[None], np.zeros(1), np.zeros(1))

    ref, got = geometry(at_own), geometry(tracking)
    if not 0 < ref.t_cpa_s[0] <= 120:
        return
    assert got.hmd_m[0] == pytest.approx(ref.hmd_m[0], abs=1.0)
    assert got.t_cpa_s[0] == pytest.approx(ref.t_cpa_s[0], abs=0.05)


@settings(max_examples=100)
@given(latitudes, longitudes, st.floats(0, 2 * math.pi), st.floats(0, 20e3), st.floats(-300, 300),
       st.floats(-300, 300), st.floats(1.5e3, 5e3))
def test_a_carried_state_moves_as_the_aircraft_does(lat, lon, bearing, dist, ve, vn, hop):
    """A state carried into the next plane is the aircraft's: its position is the same surface point, and its
    velocity is the rate of change of the new-plane position along the same surface path (finite differences)."""
    old = LocalTangentPlane(lat, lon)
    new_lat, new_lon = old.to_geodetic(hop, 0.0)
    change = FrameChange(old, LocalTangentPlane(float(new_lat), float(new_lon)))
    x = np.array([[dist * math.sin(bearing), dist * math.cos(bearing), ALT, ve, vn, 1.0]])
    p = np.diag([25.0, 36.0, 16.0, 4.0, 9.0, 1.0])[None]
    x2, p2, _ = change.carry(x, p, vectors=(3,))
    lat1, lon1 = old.to_geodetic(x[0, 0], x[0, 1])
    lat2, lon2 = change.new.to_geodetic(x2[0, 0], x2[0, 1])
    assert (float(lat2), float(lon2)) == pytest.approx((float(lat1), float(lon1)), abs=1e-9)
    dt = 0.01
    e_a, n_a = change.new.to_en(*old.to_geodetic(x[0, 0] + ve * dt, x[0, 1] + vn * dt))
    assert x2[0, 3:5] == pytest.approx([(e_a - x2[0, 0]) / dt, (n_a - x2[0, 1]) / dt], abs=1e-3)
    assert x2[0, 2] == ALT and x2[0, 5] == 1.0
    assert np.trace(p2[0, :2, :2]) == pytest.approx(61.0, rel=1e-4)  # the map is a rotation to first order
    assert np.linalg.eigvalsh(p2[0]).min() > 0


def head_on(plane: LocalTangentPlane, heading_deg: float = 90.0, transit_m: float = 0.0, **kw) -> Encounter:
    """A true head-on (zero miss, co-altitude) whose CPA is at the plane's origin, 90 s after the intruder is
    first heard; the ownship has flown transit_m before that."""
    v_own, v_int = 60.0, 120.0
    u = np.array([math.sin(math.radians(heading_deg)), math.cos(math.radians(heading_deg))])
    t_cpa = round(transit_m / v_own) + 90.0  # whole seconds: every run samples the encounter at the same instants
    own = Mover((*(-v_own * t_cpa * u), ALT), (*(v_own * u), 0.0))
    intruder = Mover((*(v_int * t_cpa * u), ALT), (*(-v_int * u), 0.0))
    return Encounter(own, intruder, plane=plane, report_from_s=t_cpa - 90.0, **kw), t_cpa


def onsets(encounter: Encounter, t_cpa: float, extra=None):
    """(TA onset, RA onset) relative to CPA, and the advisories at those onsets."""
    first = {}
    core, changes = encounter.run(t_cpa + 5.0) if extra is None else extra(encounter, t_cpa)
    for t, a in changes:
        if a.intruder == encounter.key and a.level not in first and a.level is not AdvisoryLevel.NONE:
            first[a.level] = (t - t_cpa, a)
    return first, core


def assert_same(ref, got):
    for level in (AdvisoryLevel.TA, AdvisoryLevel.RA):
        (t_ref, a_ref), (t_got, a_got) = ref[level], got[level]
        assert t_got == pytest.approx(t_ref, abs=0.1), level
        assert a_got.hmd_m == pytest.approx(a_ref.hmd_m, abs=1.0), level
        assert a_got.t_cpa_s == pytest.approx(a_ref.t_cpa_s, abs=0.05), level
        assert a_got.range_m == pytest.approx(a_ref.range_m, abs=1.0), level
        assert (a_got.ra_sense, a_got.ra_words) == (a_ref.ra_sense, a_ref.ra_words)
        for name in ("pc_now", "pc_max", "pc_ta", "pc_ra"):
            if getattr(a_ref, name) is not None:
                assert getattr(a_got, name) == pytest.approx(getattr(a_ref, name), abs=1e-6), (level, name)


@pytest.fixture(scope="module")
def near_origin():
    """The reference: the head-on flown where the process started, at 47 N."""
    first, _ = onsets(*head_on(LocalTangentPlane(47.0, 8.0)))
    assert set(first) == {AdvisoryLevel.TA, AdvisoryLevel.RA} and abs(first[AdvisoryLevel.TA][1].hmd_m) < 5.0
    return first


def test_after_300_km_of_flight_the_head_on_is_the_same(near_origin):
    got, core = onsets(*head_on(LocalTangentPlane(47.0, 8.0), transit_m=300e3))
    assert_same(near_origin, got)
    assert core.counters["plane.recentred"] >= 299  # the plane followed the ownship, 1 km at a time


@pytest.mark.parametrize("site", [(85.0, 0.0), (-85.0, 123.0), (0.0, 180.0), (52.0, -180.0)],
                         ids=["85N", "85S", "antimeridian-equator", "antimeridian-52N"])
def test_the_head_on_is_the_same_anywhere_on_earth(near_origin, site):
    got, _ = onsets(*head_on(LocalTangentPlane(*site), transit_m=20e3))
    assert_same(near_origin, got)


def test_an_airliner_heard_first_350_km_away_changes_nothing(near_origin):
    """The first input of all is a report of an airliner 350 km away: the plane starts there, and moves to the
    ownship with its first fix."""
    encounter, t_cpa = head_on(LocalTangentPlane(47.0, 8.0))
    far_lat, far_lon = encounter.plane.to_geodetic(350e3, 0.0)
    airliner = IntruderReport(IntruderKey(0x4B1234, AddressSource.ES1090), 0.0, 0.0, float(far_lat), float(far_lon),
                              11000.0, encounter.datum, (230.0, 0.0), 0.0)

    def run(enc, t):
        core = enc.core()
        core.step(-0.1, [airliner])
        return enc.run(t + 5.0, core=core)

    got, core = onsets(encounter, t_cpa, run)
    assert_same(near_origin, got)
    # the plane reached the ownship (in hops of at most MAX_HOP_M) and stayed with it
    own = core.ownship_state()
    assert math.hypot(own.x[0], own.x[1]) <= RECENTRE_M and core.counters["plane.recentred"] >= 350e3 / MAX_HOP_M
    assert core.counters["track.initiated"] == 2


@settings(max_examples=200)
@given(latitudes, longitudes, latitudes, longitudes, st.floats(0, 2 * math.pi), st.floats(0, 50e3),
       st.floats(-300, 300), st.floats(-300, 300))
def test_a_wild_fix_moves_the_plane_one_hop_and_back_loses_nothing(lat, lon, wild_lat, wild_lon, bearing, dist,
                                                                  ve, vn):
    """A fix anywhere on Earth (a glitch, a corrupted message) moves the plane at most MAX_HOP_M; carried there
    and back, a track 50 km around is what it was (the plane can only hold its own hemisphere: a whole-Earth move
    would have folded it)."""
    frame = TrackingFrame()
    frame.follow(lat, lon)
    start = frame.plane
    x = np.array([[dist * math.sin(bearing), dist * math.cos(bearing), ALT, ve, vn, 1.0]])
    p = np.diag([25.0, 36.0, 16.0, 4.0, 9.0, 1.0])[None]
    there = frame.follow(wild_lat, wild_lon)
    if there is None:
        return
    hop = math.dist(geodetic_to_ecef(start.lat0_deg, start.lon0_deg, 0.0),
                    geodetic_to_ecef(frame.plane.lat0_deg, frame.plane.lon0_deg, 0.0))
    assert hop <= MAX_HOP_M * 1.01  # a great circle of the normals: within the ellipsoid's flattening
    x1, p1, _ = there.carry(x, p, vectors=(3,))
    back = frame.follow(lat, lon)
    x2, p2, _ = back.carry(x1, p1, vectors=(3,))
    assert x2 == pytest.approx(x, abs=1e-6) and p2 == pytest.approx(p, abs=1e-6)


@settings(max_examples=4)
@given(st.floats(-85.0, 85.0), st.floats(-180.0, 180.0), st.floats(0.0, 360.0), st.floats(0.0, 100e3))
def test_the_same_encounter_anywhere_and_after_any_flight_gives_the_same_advisories(near_origin, lat, lon, heading,
                                                                                   transit):
    """The property: the head-on placed at a random place on Earth, flown in a random direction after a random
    transit, gives the advisories and miss distances of the reference (the motion models are isotropic)."""
    got, _ = onsets(*head_on(LocalTangentPlane(lat, lon), heading_deg=heading, transit_m=transit))
    assert_same(near_origin, got)
