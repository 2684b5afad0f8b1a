"""Forged MAVLink for the trusted-source tests: the head-on intruder's address reported somewhere harmless, our own
position reported 50 km away, and the head-on flown through real framing with a forger beside the simulated
autopilot (tests/test_traffic_sources.py, test_ownship_sources.py, test_sources_live.py)."""

from __future__ import annotations

import avionics.io  # noqa: F401  (MAVLINK20=1 before pymavlink is imported)
from pymavlink.dialects.v20 import common as m2

from avionics.io.framing import FrameScanner
from avionics_sitl.autopilot import Packer, adsb_vehicle, ownship_messages, schedule
from avionics_sitl.encounters import load_encounter
from avionics_sitl.impairments import PRESETS
from avionics_sitl.trajectory import KinematicState
from harness import Harness

SCENARIO = load_encounter("head-on")
INTRUDER = SCENARIO.intruders[0]
DURATION_S = 75.0  # TA at ~55 s, RA at ~65 s


def over_the_wire(msg, system: int, component: int):
    """msg as (system, component) sends it, decoded as pymavlink does on receipt."""
    return m2.MAVLink(None).decode(bytearray(msg.pack(m2.MAVLink(None, system, component))))


def forged_traffic(t: float):
    """The intruder's address, reported 20 km east of its real path, flying away: no threat at all."""
    _, (traj,) = SCENARIO.trajectories()
    real = traj.state_at(t)
    fake = KinematicState(t_s=t, lat_deg=real.lat_deg, lon_deg=real.lon_deg + 0.27, alt_msl_m=real.alt_msl_m + 900.0,
                          vel_east_mps=60.0, vel_north_mps=0.0, vel_up_mps=0.0)
    return adsb_vehicle(fake, INTRUDER.icao_address, INTRUDER.altitude_datum, INTRUDER.address_source,
                        INTRUDER.callsign, INTRUDER.emitter_type)


def forged_ownship(t: float):
    """Our own position 50 km north of where we are, at our altitude and velocity."""
    own, _ = SCENARIO.trajectories()
    real = own.state_at(t)
    fake = KinematicState(t_s=t, lat_deg=real.lat_deg + 0.45, lon_deg=real.lon_deg, alt_msl_m=real.alt_msl_m,
                          vel_east_mps=real.vel_east_mps, vel_north_mps=real.vel_north_mps, vel_up_mps=real.vel_up_mps)
    return ownship_messages(fake, SCENARIO.ground_elevation_m, int(t * 1000))[0]


def fly(config, spoofer: tuple[int, int] | None = None, spoof_from_s: float = 10.0, spoof_hz: float = 5.0,
        real_intruder: bool = True, intruder_sender: tuple[int, int] | None = None, forge=forged_traffic):
    """Fly the head-on on a 0.1 s grid through FrameScanner and Harness, as avionics_sitl.replay does. spoofer: the
    (system, component) of a forger sending forge(t) from spoof_from_s at spoof_hz (default: a second sender of the
    intruder's address); intruder_sender: who sends the real intruder's reports (default: the autopilot's ADS-B
    receiver, system 1 component 156). (node, advisory changes, track payloads, COLLISIONs); node.sent: every
    MAVLink message it sent, with its step time."""
    node = Harness(config)
    scanner = FrameScanner(node.counters)
    packer = Packer()
    fake_sender = m2.MAVLink(None, *spoofer) if spoofer else None
    other = m2.MAVLink(None, *intruder_sender) if intruder_sender else None
    events = schedule(SCENARIO, PRESETS["none"], duration_s=DURATION_S)
    if not real_intruder:
        events = [e for e in events if e.msg.get_type() != "ADSB_VEHICLE"]
    changes, tracks, collisions, i = [], [], [], 0
    node.sent = []  # (time, message): COLLISION, STATUSTEXT, HEARTBEAT, ...
    period = round(10 / spoof_hz)
    for k in range(int(DURATION_S * 10) + 1):
        t = k / 10
        datagram = b""
        while i < len(events) and events[i].deliver_s <= t + 1e-9:
            msg = events[i].msg
            is_adsb = msg.get_type() == "ADSB_VEHICLE"
            datagram += bytes(msg.pack(other)) if other is not None and is_adsb else packer.pack(msg)
            i += 1
        if fake_sender is not None and t >= spoof_from_s and k % period == 0:
            datagram += bytes(forge(t).pack(fake_sender))
        result = node.handle(scanner.feed(datagram, end_of_datagram=True), t)
        changes.extend((t, a) for a in result.changes)
        collisions.extend(m for m in node.mavlink_out if m.get_type() == "COLLISION")
        node.sent.extend((t, m) for m in node.mavlink_out)
        tracks.extend(p for s, p in node.zenoh_out if s.startswith("tracks/"))
        node.mavlink_out.clear()
        node.zenoh_out.clear()
    return node, changes, tracks, collisions
