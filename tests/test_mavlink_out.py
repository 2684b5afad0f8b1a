"""What the MAVLink port tells the autopilot and the ground station (docs/mavlink.md, Outputs), through real framing:
COLLISION `action` (REPORT unless mavlink.collision_action_request), HEARTBEAT `system_status` from health, callsigns
in STATUSTEXT also after a track is gone, and the optional ADSB_VEHICLE re-broadcast of the fused traffic, which
our own decoder never takes back as traffic (from our component, or relayed by the autopilot)."""

from __future__ import annotations

import math
from collections import Counter

import avionics.io  # noqa: F401
from avionics.config import load_config
from avionics.base.types import IntruderKey, AddressSource
from avionics.io.decode import MessageDecoder
from avionics.io.dialect import daa as m2
from avionics.io.framing import FrameScanner
from avionics.io.link import MavlinkLink
from avionics.ports import MavlinkOut
from avionics_sitl.autopilot import Packer, schedule
from avionics_sitl.encounters import load_encounter
from avionics_sitl.impairments import PRESETS
from harness import Harness
from tests.conftest import wait_for

HEADON = IntruderKey(0xA10001, AddressSource.ES1090)


def _events(end_s: float = 100.0, drop=None):
    events = schedule(load_encounter("head-on"), PRESETS["none"], duration_s=end_s)
    return [e for e in events if drop is None or not drop(e.deliver_s, e.msg)]


def _framed(msgs, system: int = 1, component: int = 191) -> list:
    """Each message packed by pymavlink and found again by our FrameScanner, as a receiver would."""
    mav = m2.MAVLink(None, system, component)
    scanner = FrameScanner(Counter())
    return [m for msg in msgs for m in scanner.feed(bytes(msg.pack(mav)), True)]


def _from_sitl(msgs) -> list:
    """The simulated autopilot's messages framed with its ids (autopilot 1:1, receiver 1:156) and found again."""
    packer, scanner = Packer(), FrameScanner(Counter())
    return [m for msg in msgs for m in scanner.feed(packer.pack(msg), True)]


def _fly(node: Harness, events, end_s: float, step_s: float = 0.1, results=None) -> list[tuple[float, object]]:
    """The events delivered at their times, in steps, from the simulated autopilot's and receiver's ids; the node's
    MAVLink output (framed) with its step time."""
    out, i, t = [], 0, 0.0
    while t <= end_s + 1e-9:
        batch = []
        while i < len(events) and events[i].deliver_s <= t + 1e-9:
            batch.append(events[i].msg)
            i += 1
        result = node.handle(_from_sitl(batch), t)
        if results is not None:
            results.append(result)
        out += [(t, m) for m in _framed(node.mavlink_out)]
        node.mavlink_out.clear()
        t = round(t + step_s, 6)
    return out


def _of(out, kind):
    return [m for _, m in out if m.get_type() == kind]


def test_collision_action_is_report_unless_the_config_asks_the_autopilot_to_act():
    for request, ra_action in ((False, m2.MAV_COLLISION_ACTION_REPORT),
                               (True, m2.MAV_COLLISION_ACTION_ASCEND_OR_DESCEND)):
        node = Harness(load_config(overrides=["zenoh.enabled=false",
                                              f"mavlink.collision_action_request={str(request).lower()}"]))
        collisions = _of(_fly(node, _events(95.0), 95.0), "COLLISION")
        by_level = {(c.threat_level, c.action) for c in collisions}
        assert (m2.MAV_COLLISION_THREAT_LEVEL_HIGH, ra_action) in by_level, by_level
        assert {a for lvl, a in by_level if lvl == m2.MAV_COLLISION_THREAT_LEVEL_HIGH} == {ra_action}
        assert {a for lvl, a in by_level if lvl == m2.MAV_COLLISION_THREAT_LEVEL_LOW} == {m2.MAV_COLLISION_ACTION_REPORT}
        assert {a for lvl, a in by_level if lvl == m2.MAV_COLLISION_THREAT_LEVEL_NONE} == {m2.MAV_COLLISION_ACTION_NONE}


def test_heartbeat_is_standby_before_the_first_fix_active_while_available_critical_without_and_poweroff_last():
    node = Harness(load_config(overrides=["zenoh.enabled=false"]))
    events = _events(40.0, drop=lambda t, m: t < 5.0 or 20.0 <= t < 30.0 and m.get_type() == "GLOBAL_POSITION_INT")
    out = _fly(node, events, 40.0)
    node.shutdown(40.1)
    out += [(40.1, m) for m in _framed(node.mavlink_out)]
    beats = [(t, m.system_status) for t, m in out if m.get_type() == "HEARTBEAT"]
    assert all(s == m2.MAV_STATE_STANDBY for t, s in beats if t < 5.0) and beats[0][1] == m2.MAV_STATE_STANDBY
    assert all(s == m2.MAV_STATE_ACTIVE for t, s in beats if 5.5 <= t < 20.0)
    assert all(s == m2.MAV_STATE_CRITICAL for t, s in beats if 23.0 <= t < 30.0)  # ownship_timeout_s 2 s
    assert all(s == m2.MAV_STATE_ACTIVE for t, s in beats if 30.5 <= t <= 40.0)
    assert beats[-1][1] == m2.MAV_STATE_POWEROFF
    assert m2.MAV_STATE_STANDBY not in {s for t, s in beats if t >= 5.5}  # start-up only


def test_statustext_names_the_intruder_by_callsign_also_after_its_track_restarts_without_one():
    """A receiver sends the callsign only now and then (ADS-B identification is a message of its own): from 60 s
    the reports carry none, and three implausible jumps restart the track, whose new record has no callsign.
    The advisory's end still names the intruder by the callsign it had."""
    import copy

    node = Harness(load_config(overrides=["zenoh.enabled=false"]))
    events = []
    jumps = 0
    for e in _events(100.0):
        if e.msg.get_type() == "ADSB_VEHICLE" and e.deliver_s >= 60.0:
            msg = copy.deepcopy(e.msg)
            msg.flags &= ~m2.ADSB_FLAGS_VALID_CALLSIGN
            if jumps < 3:
                msg.lat += 500_000  # 5.5 km north: an implausible jump; the third restarts the track
                jumps += 1
            e = type(e)(e.deliver_s, msg, e.truth_s)
        events.append(e)
    results: list = []
    out = _fly(node, events, 100.0, results=results)
    texts = [m.text for m in _of(out, "STATUSTEXT")]
    assert node.counters["track.restarted"] >= 1
    assert any(t.startswith("TA HEADON") for t in texts), texts
    assert not any("1090es-" in t for t in texts) and any(t.startswith("RA ") and "HEADON" in t for t in texts), texts
    # the facade no longer knew the callsign after the restart: the port remembered it
    assert any(r.callsigns.get(HEADON) is None and any(a.intruder == HEADON for a in r.changes) for r in results)


def _rebroadcast_config(*extra):
    return load_config(overrides=["zenoh.enabled=false", "mavlink.traffic_rebroadcast=true", *extra])


def test_rebroadcast_sends_the_fused_track_flagged_at_a_bounded_rate_and_our_decoder_never_takes_it_back():
    config = _rebroadcast_config()
    node = Harness(config)
    sent: list = []  # (time, component, message) as the link would send them
    clock = [0.0]
    node.loop.ports[0] = MavlinkOut(node.mavlink_out.append, config,
                                    send_as=lambda msg, comp: sent.append((clock[0], comp, msg)))
    events = _events(60.0)
    i, t = 0, 0.0
    while t <= 60.0:
        clock[0] = t
        batch = []
        while i < len(events) and events[i].deliver_s <= t + 1e-9:
            batch.append(events[i].msg)
            i += 1
        node.handle(_from_sitl(batch), t)
        node.mavlink_out.clear()
        t = round(t + 0.1, 6)
    assert sent and {comp for _, comp, _ in sent} == {192}
    times = [s for s, _, _ in sent]
    assert all(b - a >= 0.99 for a, b in zip(times, times[1:])), times  # one track, at most once a second
    assert len(sent) >= 40  # and about once a second while it is tracked
    frames = [m for s, comp, msg in sent for m in _framed([msg], 1, comp)]  # real framing, from component 192
    last = frames[-1]
    assert last.get_type() == "ADSB_VEHICLE" and last.ICAO_address == HEADON.address
    assert last.flags & m2.ADSB_FLAGS_DAA_REBROADCAST and last.flags & m2.ADSB_FLAGS_VALID_COORDS
    assert last.callsign == "HEADON" and last.tslc <= 1 and last.flags & m2.ADSB_FLAGS_VALID_ALTITUDE
    truth = min((e for e in events if e.msg.get_type() == "ADSB_VEHICLE"), key=lambda e: abs(e.deliver_s - times[-1])).msg
    assert abs(last.lat - truth.lat) < 10_000 and abs(last.lon - truth.lon) < 10_000  # ~110 m: < 1 s of flight
    assert abs(last.altitude - truth.altitude) < 30_000 and abs(last.hor_velocity - truth.hor_velocity) < 500

    # fed back into the same process: from our component, and relayed by the autopilot (system 1, component 1)
    before = dict(node.counters)
    tracks_before = len(node.daa.tracks(60.0))
    relayed = [m for _, _, msg in sent[-5:] for m in _framed([msg], 1, 1)]
    node.handle(frames[-5:] + relayed, 60.05)
    assert node.counters["adsb.own_rebroadcast"] - before.get("adsb.own_rebroadcast", 0) == 10
    assert node.counters["adsb.second_sender"] == before.get("adsb.second_sender", 0)
    assert len(node.daa.tracks(60.05)) == tracks_before


def test_rebroadcast_goes_out_on_the_link_from_its_own_component_and_comes_back_rejected(udp_port):
    """Real sockets: our link's send_as over UDP to a listening link; the receiving decoder rejects the frame
    by its flag and, with the re-broadcast on, by its sender."""
    config = _rebroadcast_config()
    node = Harness(config)
    _fly(node, _events(20.0), 20.0)
    (track,) = node.daa.tracks(20.0)
    from avionics.io import encode

    msg = encode.adsb_vehicle(track)
    counters: Counter = Counter()
    receiver = MavlinkLink(f"udpin:127.0.0.1:{udp_port}", counters, 1, 191)
    sender = MavlinkLink(f"udpout:127.0.0.1:{udp_port}", Counter(), 1, 191)
    try:
        got: list = []
        assert wait_for(lambda: (sender.send_as(msg, 192), got.extend(receiver.receive(0.05)))[1] is None
                        and any(m.get_type() == "ADSB_VEHICLE" for m in got))
    finally:
        sender.close()
        receiver.close()
    frame = next(m for m in got if m.get_type() == "ADSB_VEHICLE")
    assert (frame.get_srcSystem(), frame.get_srcComponent()) == (1, 192)
    for cfg in (config, load_config(overrides=["zenoh.enabled=false"])):  # re-broadcast on, or off (flag only)
        seen: Counter = Counter()
        assert MessageDecoder(cfg, seen).decode(frame, 20.1) is None and seen["adsb.own_rebroadcast"] == 1
    # the same fields without the flag would be a report from a trusted sender: it is the flag (and the sender)
    # that refuses it
    frame.flags &= ~m2.ADSB_FLAGS_DAA_REBROADCAST
    seen = Counter()
    trusting = load_config(overrides=["zenoh.enabled=false", 'mavlink.traffic_sources=["1"]'])
    assert MessageDecoder(trusting, seen).decode(frame, 20.1) is not None
    assert math.isfinite(frame.lat)
