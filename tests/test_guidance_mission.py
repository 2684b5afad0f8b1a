"""The mission read over MAVLink and followed during a vertical manoeuvre (avionics/guidance/mission.py).

Oracles: the MAVLink mission protocol's sequence (mavlink.io/en/services/mission.html: REQUEST_LIST, COUNT,
REQUEST_INT per item, ITEM_INT, ACK; a request resent after its timeout) played against the simulated ArduCopter
through real MAVLink framing and our decoder; the path followed, as a property over random polylines flown
closed loop: every waypoint reached in order, never far off the legs, stopped on the last; and hand-computed
velocities on a straight leg.
"""

from __future__ import annotations

import math
from collections import Counter

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from avionics.advisory.vehicle import load_vehicle
from avionics.base.geodesy import MEAN_EARTH_RADIUS_M
from avionics.base.types import MissionCount, MissionCurrent, MissionItem
from avionics.config import load_config
from avionics.guidance import mission as m
from avionics.io.decode import MessageDecoder
from avionics.io.dialect import daa as mavlink2
from avionics.io.framing import FrameScanner
from avionics_sitl.guided import SimCopter
from avionics_sitl.trajectory import KinematicState

LAT0, LON0 = 47.0, 8.0
M_PER_DEG_LAT = math.radians(1.0) * MEAN_EARTH_RADIUS_M


def _latlon(north_m: float, east_m: float) -> tuple[float, float]:
    return LAT0 + north_m / M_PER_DEG_LAT, LON0 + east_m / (M_PER_DEG_LAT * math.cos(math.radians(LAT0)))


class _Line:
    """A path at 5 m/s north then east (two legs), as a trajectory (sitl/trajectory.py: enu_at, state_at)."""

    def enu_at(self, t):
        n, e = (5.0 * t, 0.0) if t <= 20.0 else (100.0, 5.0 * (t - 20.0))
        return e, n, 100.0

    def state_at(self, t):
        e, n, _ = self.enu_at(t)
        lat, lon = _latlon(n, e)
        ve, vn = (0.0, 5.0) if t <= 20.0 else (5.0, 0.0)
        return KinematicState(t, lat, lon, 100.0, ve, vn, 0.0)


def _link():
    """The copter's frames packed and read back through our framing and decoder (the DAA process's side)."""
    config = load_config(overrides=['guidance.mode="execute"'])
    decoder = MessageDecoder(config, Counter())
    sim_side = mavlink2.MAVLink(None, srcSystem=config.mavlink.source_system, srcComponent=1)  # our autopilot
    daa_side = mavlink2.MAVLink(None, srcSystem=config.mavlink.source_system,
                                srcComponent=config.mavlink.source_component)
    scanner = FrameScanner(Counter())

    def to_daa(msgs, now):
        out = []
        for msg in msgs:
            for back in scanner.feed(bytes(msg.pack(sim_side)), end_of_datagram=True):
                item = decoder.decode(back, now)
                if item is not None:
                    out.append(item)
        return out

    def to_copter(msgs):
        return [back for msg in msgs for back in scanner.feed(bytes(msg.pack(daa_side)), end_of_datagram=True)]

    return to_daa, to_copter


@pytest.mark.parametrize("lost", [None, 0, 2])
def test_the_mission_is_read_from_the_simulated_arducopter_and_a_lost_answer_is_asked_again(lost):
    copter = SimCopter(load_vehicle("multirotor"))
    copter.load_mission(_Line(), 40.0)
    to_daa, to_copter = _link()
    reader = m.MissionReader(1, 1)
    t, inputs, asked, dropped = 0.0, [], Counter(), False
    while reader.path is None and t < 30.0:
        for request in to_copter(reader.step(t, inputs)):
            asked[(request.get_type(), getattr(request, "seq", None))] += 1
            answers = copter.receive(request, t)
            if lost is not None and not dropped and getattr(request, "seq", None) == lost and \
                    request.get_type() == "MISSION_REQUEST_INT":
                answers, dropped = [], True  # this answer never arrives
            inputs = to_daa(answers, t)
        t += 0.1
    # home (item 0) and the three corners of the path: start, the turn, the end
    assert [(w.seq, round(w.lat_deg, 6), round(w.lon_deg, 6)) for w in reader.path.waypoints] == [
        (s, round(lat, 6), round(lon, 6)) for s, (lat, lon) in
        zip((1, 2, 3), (_latlon(0.0, 0.0), _latlon(100.0, 0.0), _latlon(100.0, 100.0)))]
    if lost is None:
        assert max(asked.values()) == 1 and t < 1.0
    else:  # asked again once, TIMEOUT_S later
        assert asked[("MISSION_REQUEST_INT", lost)] == 2 and t >= m.TIMEOUT_S
    (current,) = to_daa([copter.mission_current()], t)
    assert current == MissionCurrent(t, 1, 4)


def test_a_silent_autopilot_fails_the_download_after_the_retries_and_it_is_tried_again_later():
    reader = m.MissionReader(1, 1)
    sent = [(t / 10, msg.get_type()) for t in range(0, 300) for msg in reader.step(t / 10)]
    lists = [t for t, kind in sent if kind == "MISSION_REQUEST_LIST"]
    assert lists[:m.RETRIES + 1] == pytest.approx([k * m.TIMEOUT_S for k in range(m.RETRIES + 1)], abs=0.1 + 1e-9)
    assert reader.failures >= 1 and reader.path is None
    restart = m.TIMEOUT_S * (m.RETRIES + 1) + m.RESTART_S
    assert lists[m.RETRIES + 1] == pytest.approx(restart, abs=0.2)


def test_a_changed_mission_is_read_again_and_items_that_are_no_path_are_left_out():
    reader = m.MissionReader(1, 1)
    reader.step(0.0)
    (ask,) = reader.step(0.1, [MissionCount(0.1, 4)])
    assert ask.get_type() == "MISSION_REQUEST_INT" and ask.seq == 0
    items = [MissionItem(0.2, 0, 16, mavlink2.MAV_FRAME_GLOBAL, LAT0, LON0),  # home
             MissionItem(0.2, 1, 22, mavlink2.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, LAT0, LON0),  # takeoff: no point
             MissionItem(0.2, 2, 178, 2, 0.0, 0.0),  # DO_CHANGE_SPEED: a command, x and y not a position
             MissionItem(0.2, 3, 16, mavlink2.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, *_latlon(50.0, 0.0))]
    out = []
    for item in items:
        out = reader.step(0.2, [item])
    assert out[0].get_type() == "MISSION_ACK" and [w.seq for w in reader.path.waypoints] == [3]
    assert reader.step(1.0, [MissionCurrent(1.0, 3, 4)]) == []  # same total: nothing to read
    (again,) = reader.step(2.0, [MissionCurrent(2.0, 3, 6)])
    assert again.get_type() == "MISSION_REQUEST_LIST"


def test_on_a_straight_leg_the_velocity_is_the_leg_at_the_speed_plus_the_pull_onto_it_by_hand():
    path = m.MissionPath([m.Waypoint(1, *_latlon(0.0, 0.0)), m.Waypoint(2, *_latlon(1000.0, 0.0))])
    north, east, seq = path.velocity(2, *_latlon(500.0, 4.0), 5.0)  # 4 m east of a northbound leg
    # along 5 m/s, back west at 0.5/s x 4 m = 2 m/s, the sum cut to 5 m/s
    assert seq == 2 and math.hypot(north, east) == pytest.approx(5.0)
    assert east / north == pytest.approx(-2.0 / 5.0, rel=1e-3)
    assert path.velocity(2, *_latlon(500.0, 0.0), 0.0) == (0.0, 0.0, 2)  # a hover stays one


@settings(max_examples=60, deadline=None)
@given(legs=st.lists(st.tuples(st.floats(30.0, 400.0), st.floats(-180.0, 180.0)), min_size=1, max_size=6),
       speed=st.floats(1.0, 15.0))
def test_a_vehicle_flying_the_velocities_reaches_every_waypoint_in_order_near_the_legs_and_stops_on_the_last(
        legs, speed):
    points = [(0.0, 0.0)]
    for length, bearing in legs:
        n, e = points[-1]
        points.append((n + length * math.cos(math.radians(bearing)), e + length * math.sin(math.radians(bearing))))
    path = m.MissionPath([m.Waypoint(k + 1, *_latlon(n, e)) for k, (n, e) in enumerate(points)])
    n, e, seq, dt, seen = 0.0, 0.0, 2, 0.05, [2]
    for _ in range(int(sum(length for length, _ in legs) / speed / dt) + 2000):
        vn, ve, seq = path.velocity(seq, *_latlon(n, e), speed)
        assert math.hypot(vn, ve) <= speed + 1e-9
        if seq != seen[-1]:
            seen.append(seq)
        n, e = n + vn * dt, e + ve * dt
        # off the legs by no more than the corner it cuts (it turns to the next leg within REACHED_M of a vertex,
        # as ArduCopter does within WPNAV_RADIUS) and a step
        off = min(_to_segment((n, e), points[k], points[k + 1]) for k in range(len(points) - 1))
        assert off <= m.REACHED_M + speed * dt + 0.05
    assert seen == list(range(2, len(points) + 1))  # every item, in order, none skipped
    assert math.hypot(n - points[-1][0], e - points[-1][1]) < 0.5  # stopped on the last


def _to_segment(p, a, b) -> float:
    dx, dy = b[0] - a[0], b[1] - a[1]
    norm2 = dx * dx + dy * dy
    u = min(max(((p[0] - a[0]) * dx + (p[1] - a[1]) * dy) / norm2, 0.0), 1.0) if norm2 > 0 else 0.0
    return math.hypot(p[0] - a[0] - u * dx, p[1] - a[1] - u * dy)


def test_px4_flies_the_vertical_ra_along_its_mission_too():
    """small-uas's rotorcraft encounter 0 of set 28 (its CLIMB comes while the survey turns) flown through PX4's
    contract (OFFBOARD, items from 0): the horizontal miss is the mission's, as through ArduCopter's
    (tests/test_evaluation_guidance.py), and the mission resumes in AUTO.MISSION."""
    from avionics.guidance import px4
    from avionics_eval.evaluation import evaluate as ev
    from avionics_eval.evaluation.guided import scenario
    from avionics_eval.evaluation.lincoln import LincolnSource
    from avionics_sitl.replay import replay

    encounter = LincolnSource.of("uncor_1200exclude_rotorcraft_v1p2.txt", "uav-survey").encounter(28, 0)
    conditions = ev.Conditions("do365-adsb", None, "guidance", "multirotor")
    config, _ = ev._setup("small-uas", (*ev.EVALUATION_OVERRIDES, *conditions.overrides()))
    copter = SimCopter(load_vehicle("multirotor"), firmware="px4")
    result = replay(scenario(encounter, ev.PLANE), config, conditions.impairments(), seed=1, fly_guidance=True,
                    copter=copter)
    (miss,) = result.misses
    assert px4.OFFBOARD in [mode for _, mode in copter.modes] and copter.mode == px4.MISSION
    assert copter.counters["sim.mission_list"] == 1
    assert miss.hmd_flown_m == pytest.approx(miss.hmd_m, abs=15.0) and miss.hmd_m > 600.0


def test_mission_messages_from_another_sender_are_counted_and_dropped_and_others_downloads_ignored():
    config = load_config(overrides=['guidance.mode="execute"'])
    counters: Counter = Counter()
    decoder = MessageDecoder(config, counters)
    m_ = config.mavlink
    scanner = FrameScanner(Counter())

    def decoded(msg, src_component):
        link = mavlink2.MAVLink(None, srcSystem=m_.source_system, srcComponent=src_component)
        (back,) = scanner.feed(bytes(msg.pack(link)), end_of_datagram=True)
        return decoder.decode(back, 1.0)

    ours = mavlink2.MAVLink_mission_count_message(m_.source_system, m_.source_component, 3)
    assert decoded(ours, 1) == MissionCount(1.0, 3)  # from our autopilot, to us
    assert decoded(ours, 42) is None and counters["mission.other_sender"] == 1  # a forged autopilot
    for_a_gcs = mavlink2.MAVLink_mission_count_message(255, 190, 3)
    fence = mavlink2.MAVLink_mission_count_message(m_.source_system, m_.source_component, 3, 1)
    assert decoded(for_a_gcs, 1) is None and decoded(fence, 1) is None
    assert counters["mission.other_sender"] == 1  # someone else's download is not a rejection
