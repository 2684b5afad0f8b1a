"""Harness: the output policy and the status a ground monitor sees, driven by real MAVLink messages."""

import json

import avionics.io  # noqa: F401
from pymavlink.dialects.v20 import common as mavlink2

from avionics.config import load_config
from avionics.io.zenoh_bus import to_json
from harness import Harness
from avionics_sitl.autopilot import ownship_messages, schedule
from avionics_sitl.impairments import PRESETS
from avionics_sitl.encounters import load_encounter


def fly(node, scenario, until_s, drop_pressure=False):
    """Deliver the scenario's exact schedule to the node on a 0.1 s grid; returns outputs per time."""
    events = [e for e in schedule(scenario, PRESETS["none"], duration_s=until_s)
              if not (drop_pressure and e.msg.get_type() == "SCALED_PRESSURE")]
    mav = mavlink2.MAVLink(None, 1, 1)
    out, i = [], 0
    for k in range(int(until_s * 10) + 1):
        t = k / 10
        batch = []
        while i < len(events) and events[i].deliver_s <= t + 1e-9:
            msg = events[i].msg
            msg.pack(mav)  # sets the header (source system 1) as on the wire
            batch.append(msg)
            i += 1
        node.handle(batch, t)
        out.append((t, list(node.mavlink_out), list(node.zenoh_out)))
        node.mavlink_out.clear()
        node.zenoh_out.clear()
    return out


def test_collision_is_refreshed_every_second_while_active_and_heartbeat_runs_at_1_hz():
    node = Harness(load_config())
    out = fly(node, load_encounter("head-on"), 80.0)
    collisions = [(t, m) for t, mav, _ in out for m in mav if m.get_type() == "COLLISION"]
    heartbeats = [t for t, mav, _ in out for m in mav if m.get_type() == "HEARTBEAT"]
    assert len(heartbeats) == 81
    active = [t for t, m in collisions if t > 56.0]
    gaps = [b - a for a, b in zip(active, active[1:])]
    assert gaps and max(gaps) <= 1.0 + 1e-6  # the autopilot never waits more than 1 s for a live threat
    texts = [m.text for _, mav, _ in out for m in mav if m.get_type() == "STATUSTEXT"]
    assert texts[0] == "TA HEADON TAU 30S 0M +0FT"  # the intruder's callsign, as a pilot would read it
    assert texts[1] in ("RA CLIMB 1500 FPM HEADON", "RA DESCEND 1500 FPM HEADON")


def test_tracks_and_status_are_published_at_their_rates_as_json():
    node = Harness(load_config())
    out = fly(node, load_encounter("head-on"), 10.0)
    tracks = [(t, p) for t, _, z in out for s, p in z if s.startswith("tracks/")]
    status = [(t, p) for t, _, z in out for s, p in z if s == "status"]
    assert len(status) == 11 and 19 <= len(tracks) <= 21  # 1 Hz and 2 Hz over 10 s
    t, track = tracks[-1]
    assert track["intruder"] == "1090es-A10001" and track["altitude_datum"] == "pressure"
    assert abs(track["ground_speed_mps"] - 64.3) < 0.5 and abs(track["track_deg"] - 180.0) < 0.5
    json.loads(to_json(track))  # inf/NaN become null: strict JSON


def test_status_says_when_only_mismatched_datums_exist():
    node = Harness(load_config())
    fly(node, load_encounter("head-on"), 60.0, drop_pressure=True)
    status = node.status(60.0)
    assert not status["pressure_altitude_available"]
    assert status["datum_mismatch_intruders"] == ["1090es-A10001"]
    assert any("no ownship pressure altitude" in w and "widened" in w for w in status["warnings"])


def test_own_address_and_other_systems_never_become_traffic_or_ownship():
    config = load_config(overrides=["vehicle.own_icao=0xA10001"])
    node = Harness(config)
    fly(node, load_encounter("head-on"), 70.0)
    assert node.core.tracker.tracks == {} and node.counters["adsb.own_address"] > 50
    # an ownship fix from another system id is not ours
    scenario = load_encounter("head-on")
    own, _ = scenario.trajectories()
    gpi, _ = ownship_messages(own.state_at(0.0), 0.0, 0)
    gpi.pack(mavlink2.MAVLink(None, 7, 1))
    fresh = Harness(load_config())
    fresh.handle([gpi], 0.0)
    assert fresh.core.ownship.last_fix is None and fresh.counters["gpi.other_system"] == 1
