"""The ownship's source is pinned (io/senders.py) and its fixes pass the jump check (io/ownship_check.py): one
component of our vehicle (configured, or the first autopilot HEARTBEAT's, component 1 until then) is the ownship;
a fix that is not where the previous one, flown on, puts the aircraft is rejected; rejections that go on make DAA
unavailable (`ownship_inconsistent`), announced on MAVLink. The head-on is flown through real pymavlink framing
(sitl's autopilot and receiver, FrameScanner, Harness; tests/forgery.py) with a forger on the autopilot's own
component id."""

from __future__ import annotations

from collections import Counter

import avionics.io  # noqa: F401  (MAVLINK20=1 before pymavlink is imported)
import pytest
from pymavlink.dialects.v20 import common as m2

from avionics.config import ConfigError, load_config
from avionics.base.types import OwnshipFix
from avionics.io.decode import MessageDecoder
from forgery import DURATION_S, SCENARIO, fly, forged_ownship, over_the_wire as _wire


def _gpi(lat_deg: float = 47.0, alt_m: float = 1000.0, vn: float = 0.0, ve: float = 0.0, t_ms: int = 0):
    return m2.MAVLink_global_position_int_message(t_ms, int(round(lat_deg * 1e7)), 80000000, int(alt_m * 1000), 50000,
                                                  int(vn * 100), int(ve * 100), 0, 0)


def _heartbeat(kind: int, autopilot: int):
    return m2.MAVLink_heartbeat_message(kind, autopilot, 0, 0, m2.MAV_STATE_ACTIVE, 3)


M_PER_DEG = 111_195.0  # a degree of latitude at 47 N, near enough for these distances


def test_the_ownship_is_component_1_until_an_autopilot_heartbeat_names_another():
    decoder = MessageDecoder(load_config(), Counter())
    assert decoder.decode(_wire(_gpi(), 1, 1), 0.0) is not None
    assert decoder.decode(_wire(_gpi(), 1, 200), 0.1) is None  # another component of our vehicle: a suspect
    assert decoder.decode(_wire(_gpi(), 2, 1), 0.1) is None  # another vehicle: only counted
    # a GCS, a companion computer and an ADS-B receiver say autopilot INVALID (or are such types): not the autopilot
    decoder.decode(_wire(_heartbeat(m2.MAV_TYPE_GCS, m2.MAV_AUTOPILOT_INVALID), 1, 190), 0.2)
    decoder.decode(_wire(_heartbeat(m2.MAV_TYPE_ONBOARD_CONTROLLER, m2.MAV_AUTOPILOT_GENERIC), 1, 191), 0.2)
    decoder.decode(_wire(_heartbeat(m2.MAV_TYPE_FIXED_WING, m2.MAV_AUTOPILOT_ARDUPILOTMEGA), 1, 7), 0.3)
    assert decoder.decode(_wire(_gpi(), 1, 1), 0.4) is None
    assert decoder.decode(_wire(_gpi(), 1, 7), 0.4) is not None
    # a second autopilot HEARTBEAT changes nothing: the first one heard is the autopilot
    decoder.decode(_wire(_heartbeat(m2.MAV_TYPE_QUADROTOR, m2.MAV_AUTOPILOT_PX4), 1, 1), 0.5)
    assert decoder.decode(_wire(_gpi(), 1, 7), 0.6) is not None
    c = decoder.counters
    assert (c["gpi.other_component"], c["gpi.other_system"], c["heartbeat.second_autopilot"]) == (2, 1, 1)
    assert decoder.senders.active_suspects(0.6) == {(1, 200, "ownship"), (1, 1, "ownship")}
    assert decoder.senders.active_suspects(10.7) == frozenset()  # silent for 10 s: no longer reported


def test_a_configured_ownship_component_is_not_moved_by_a_heartbeat():
    decoder = MessageDecoder(load_config(overrides=["mavlink.ownship_component=42"]), Counter())
    decoder.decode(_wire(_heartbeat(m2.MAV_TYPE_QUADROTOR, m2.MAV_AUTOPILOT_PX4), 1, 1), 0.0)
    assert decoder.decode(_wire(_gpi(), 1, 1), 0.1) is None
    assert decoder.decode(_wire(_gpi(), 1, 42), 0.1) is not None
    assert decoder.decode(_wire(m2.MAVLink_scaled_pressure_message(0, 900.0, 0.0, 1500), 1, 1), 0.2) is None
    assert decoder.counters["pressure.other_component"] == 1
    with pytest.raises(ConfigError, match="mavlink.ownship_component"):
        load_config(overrides=["mavlink.ownship_component=256"])


def test_a_fix_that_jumps_is_rejected_and_rejections_that_persist_are_reported_then_the_check_restarts():
    config = load_config()
    decoder = MessageDecoder(config, Counter())
    check, persist_s = decoder.ownship_check, config.input.ownship_jump_persist_s
    t = 0.0
    lat = 47.0
    for _ in range(10):  # 50 m/s north at 5 Hz: consistent
        assert decoder.decode(_wire(_gpi(lat, vn=50.0), 1, 1), t) is not None
        t, lat = round(t + 0.2, 6), lat + 10.0 / M_PER_DEG
    # 50 km away, and 150 m off (more than 100 m + 0.5 s at 50 m/s): rejected; 60 m off: taken
    assert decoder.decode(_wire(_gpi(lat + 0.45, vn=50.0), 1, 1), t) is None
    assert decoder.decode(_wire(_gpi(lat + 150.0 / M_PER_DEG, vn=50.0), 1, 1), t) is None
    assert decoder.decode(_wire(_gpi(lat + 60.0 / M_PER_DEG, vn=50.0), 1, 1), t) is not None
    assert decoder.counters["gpi.jump"] == 2 and not check.failing(t)
    # a vertical jump of 1 km is a jump too
    t, lat = round(t + 0.2, 6), lat + 70.0 / M_PER_DEG
    assert decoder.decode(_wire(_gpi(lat, alt_m=2000.0, vn=50.0), 1, 1), t) is None
    # a real fix interleaved with a forged one 50 km away, on the same component, for longer than persist_s
    start = t
    while t - start <= persist_s + 0.2:
        t, lat = round(t + 0.2, 6), lat + 10.0 / M_PER_DEG
        assert decoder.decode(_wire(_gpi(lat, vn=50.0), 1, 1), t) is not None
        assert decoder.decode(_wire(_gpi(lat + 0.45, vn=50.0), 1, 1), t) is None
    assert check.failing(t) and not check.failing(t + persist_s + 0.1)  # until persist_s after the last one
    # the aircraft really moved 1 km (an EKF reset): rejected until persist_s without an accepted fix, then taken
    for _ in range(round(persist_s / 0.2) - 1):
        t, lat = round(t + 0.2, 6), lat + 10.0 / M_PER_DEG
        assert decoder.decode(_wire(_gpi(lat + 0.009, vn=50.0), 1, 1), t) is None
    t, lat = round(t + 0.4, 6), lat + 20.0 / M_PER_DEG  # persist_s + 0.2 s after the last accepted fix
    assert decoder.decode(_wire(_gpi(lat + 0.009, vn=50.0), 1, 1), t) is not None
    assert decoder.counters["gpi.jump_restart"] == 1


def test_the_jump_check_allows_what_a_manoeuvring_aircraft_does():
    """10 m/s^2 (ArduPilot's GPS_GLITCH_ACCEL) for 10 s from 20 m/s, fixes 0.2 s apart and one 3 s gap: none
    rejected."""
    check = MessageDecoder(load_config(), Counter()).ownship_check
    t, pos, v, a = 0.0, 0.0, 20.0, 10.0
    times = [round(0.2 * k, 6) for k in range(50) if not 20 <= k < 35]
    for t in times:
        pos, v = 20.0 * t + 0.5 * a * t * t, 20.0 + a * t
        assert check.accept(OwnshipFix(t, 47.0 + pos / M_PER_DEG, 8.0, 1000.0, 50.0, (v, 0.0, 0.0)))
    assert not check.counters["gpi.jump"]


def test_a_forger_on_the_autopilots_own_ids_moves_nothing_and_makes_daa_unavailable_with_the_reason():
    config = load_config()
    def onsets(changes):
        return [(t, str(a.intruder), a.level.name, a.ra_words, a.reason) for t, a in changes]

    _, clean, _, _ = fly(config)
    assert [level for _, _, level, _, _ in onsets(clean)][:2] == ["TA", "RA"]
    node, changes, _, _ = fly(config, spoofer=(1, 1), forge=forged_ownship)  # 50 km north at 5 Hz from 10 s
    assert onsets(changes) == onsets(clean)  # every forged fix rejected: the same TA and RA at the same times
    sent = node.sent
    assert node.counters["gpi.jump"] == int((DURATION_S - 10.0) * 5) + 1
    texts = [(t, m.text) for t, m in sent if m.get_type() == "STATUSTEXT"]
    unavailable = [t for t, text in texts if text == "DAA UNAVAILABLE ownship jumps"]
    assert len(unavailable) == 1 and 15.0 <= unavailable[0] <= 15.5  # after persist_s of rejections
    states = {m.system_status for t, m in sent if m.get_type() == "HEARTBEAT" and t > 16.0}
    assert states == {m2.MAV_STATE_CRITICAL}
    status = node.status(DURATION_S)
    assert status["unavailable_reason"] == "ownship_inconsistent" and status["daa_available"] is False
    assert abs(status["ownship"]["lat_deg"] - SCENARIO.trajectories()[0].state_at(DURATION_S).lat_deg) < 1e-3
