"""Trusted traffic sources: ADSB_VEHICLE is used only from mavlink.traffic_sources (default: our vehicle's
autopilot and ADS-B receiver components, io/senders.py), and an intruder belongs to the first sender that reported
it. The head-on encounter is
flown through real pymavlink framing (sitl's autopilot and ADS-B receiver, FrameScanner, Harness) with a second
MAVLink system sending the intruder's address at 5 Hz from somewhere harmless: it can neither take over the
track nor suppress the RA. A fabricated intruder from an untrusted system gets nothing."""

from __future__ import annotations

import json
from collections import Counter

import avionics.io  # noqa: F401  (MAVLINK20=1 before pymavlink is imported)
import pytest
from pymavlink.dialects.v20 import common as m2

from avionics.config import ConfigError, load_config, traffic_source_ids
from avionics.base.types import AddressSource, IntruderKey
from avionics.io.decode import MessageDecoder
from avionics.io.zenoh_bus import to_json
from forgery import DURATION_S, INTRUDER, fly, over_the_wire

KEY = IntruderKey(INTRUDER.icao_address, INTRUDER.address_source)


def onsets(changes) -> list[tuple[float, str, str]]:
    return [(t, str(a.intruder), a.level.name) for t, a in changes]


@pytest.fixture(scope="module")
def clean():
    node, changes, tracks, _ = fly(load_config())
    assert [level for _, _, level in onsets(changes)][:2] == ["TA", "RA"]
    return node, changes, tracks


@pytest.mark.parametrize("sources, spoofer, trusted", [
    ((), (2, 156), False),  # default: only our vehicle's system is trusted; system 2 is not
    (("1", "2"), (2, 156), True),  # both systems trusted: system 2 is a second sender of the address
    (("1:156",), (1, 99), False),  # our system, another component, with only the receiver trusted
    ((), (1, 99), False),  # default: our system, a component neither the autopilot nor an ADS-B receiver
    (("1",), (1, 99), True),  # our system, any component trusted: a second sender
])
def test_a_second_sender_at_5_hz_neither_takes_over_the_track_nor_suppresses_the_ra(clean, sources, spoofer,
                                                                                     trusted):
    clean_node, clean_changes, clean_tracks = clean
    overrides = [f"mavlink.traffic_sources={json.dumps(list(sources))}"]
    node, changes, tracks, collisions = fly(load_config(overrides=overrides), spoofer=spoofer)
    assert onsets(changes) == onsets(clean_changes)  # same TA and RA, at the same times
    assert [c.threat_level for c in collisions] and max(c.threat_level for c in collisions) == 2
    track = node.core.tracker.tracks[KEY]
    clean_track = clean_node.core.tracker.tracks[KEY]
    assert track.n_updates == clean_track.n_updates  # every real report, and no other, in its history
    assert [p["lon_deg"] for p in tracks] == pytest.approx([p["lon_deg"] for p in clean_tracks])
    spoofed = int((DURATION_S - 10.0) * 5) + 1
    if trusted:
        assert node.counters["adsb.second_sender"] == spoofed and not node.counters["adsb.untrusted_source"]
        assert node.status(DURATION_S)["spoof_suspected"] == [str(KEY)]
        assert tracks[-1]["spoof_suspected"] is True and not any(p["spoof_suspected"] for p in tracks[:19])
        status = [p for s, p in _status_payloads(node)]
        assert status and status[-1]["spoof_suspected"] == [str(KEY)]
        assert status[-1]["counters"]["adsb.second_sender"] == spoofed
        # its real reports could have been the ones dropped: DAA says it cannot vouch for that intruder
        assert status[-1]["daa_available"] is False and status[-1]["unavailable_reason"] == "spoof_suspected"
        texts = [m.text for _, m in node.sent if m.get_type() == "STATUSTEXT"]
        assert texts.count(f"DAA UNAVAILABLE spoof {KEY}") == 1
        assert m2.MAV_STATE_CRITICAL in {m.system_status for _, m in node.sent if m.get_type() == "HEARTBEAT"}
    else:
        assert node.counters["adsb.untrusted_source"] == spoofed and not node.counters["adsb.second_sender"]
        assert node.status(DURATION_S)["spoof_suspected"] == []  # never seen: nothing to suspect
        assert node.status(DURATION_S)["daa_available"] is True
        texts = [m.text for _, m in node.sent if m.get_type() == "STATUSTEXT"]
        own_system = spoofer[0] == 1  # a component of our vehicle posing as a receiver is announced
        assert ("SPOOF? 1:99 SENDS TRAFFIC, IGNORED" in texts) == own_system
        assert not any(p["spoof_suspected"] for p in tracks)
    json.loads(to_json(tracks[-1]))


def _status_payloads(node):
    node.zenoh_out.clear()
    node.zenoh._status.next_s = None  # due now
    node.handle([], DURATION_S)
    return [(s, p) for s, p in node.zenoh_out if s == "status"]


def test_a_fabricated_intruder_from_an_untrusted_system_gets_nothing():
    """The head-on intruder's reports, but sent by system 2 only: no track, no advisory, no COLLISION."""
    node, changes, tracks, collisions = fly(load_config(), intruder_sender=(2, 156))
    assert changes == [] and tracks == [] and collisions == []
    assert node.core.tracker.tracks == {} and node.counters["track.initiated"] == 0
    assert node.counters["adsb.untrusted_source"] == node.counters["rx.adsb_vehicle"] > 70


def test_the_same_intruder_from_a_trusted_other_system_is_used_when_configured():
    node, changes, _, _ = fly(load_config(overrides=['mavlink.traffic_sources=["2:156"]']),
                              intruder_sender=(2, 156))
    assert [a.level.name for _, a in changes][:2] == ["TA", "RA"]
    assert not node.counters["adsb.untrusted_source"]


# -- the decoder's rules --------------------------------------------------------------------------------------
def _adsb(system: int, component: int, address: int = 0xA1B2C3, uat: bool = False, lat_e7: int = 474000000):
    flags = 0x1FF | (0x8000 if uat else 0)
    msg = m2.MAVLink_adsb_vehicle_message(address, lat_e7, 85500000, 0, 914400, 18000, 6430, 0, b"DLH4AB", 1, 0,
                                          flags, 7000)
    return over_the_wire(msg, system, component)


def test_sources_match_a_whole_system_or_one_component():
    decoder = MessageDecoder(load_config(overrides=['mavlink.traffic_sources=["3", "1:156", 7]']), Counter())
    assert decoder.decode(_adsb(3, 42, 0x1), 0.0) is not None
    assert decoder.decode(_adsb(1, 156, 0x2), 0.0) is not None
    assert decoder.decode(_adsb(7, 0, 0x3), 0.0) is not None
    assert decoder.decode(_adsb(1, 1, 0x4), 0.0) is None  # our system, but only component 156 is trusted
    assert decoder.decode(_adsb(4, 156, 0x5), 0.0) is None
    assert decoder.counters["adsb.untrusted_source"] == 2


def test_the_first_sender_owns_an_intruder_until_its_track_can_no_longer_exist():
    config = load_config(overrides=['mavlink.traffic_sources=["1"]'])
    decoder = MessageDecoder(config, Counter())
    expiry = config.tracking.delete_after_s + 1.0
    assert decoder.decode(_adsb(1, 156), 0.0) is not None
    # a second receiver hearing the same aircraft (64.3 m/s due south: 32 m in 0.5 s): dropped, not suspected
    assert decoder.decode(_adsb(1, 157, lat_e7=474000000 - 2900), 0.5) is None
    assert decoder.counters["adsb.second_sender"] == 1 and decoder.spoof_suspected == set()
    # ... the same address 2 km away: dropped and suspected
    assert decoder.decode(_adsb(1, 157, lat_e7=474000000 - 180000), 0.5) is None
    assert decoder.counters["adsb.second_sender"] == 2
    assert decoder.spoof_suspected == {IntruderKey(0xA1B2C3, AddressSource.ES1090)}
    # the same number as a UAT address is another aircraft, and another sender may own it
    assert decoder.decode(_adsb(1, 157, uat=True), 1.0) is not None
    assert decoder.decode(_adsb(1, 156), 1.0) is not None  # the owner goes on
    assert decoder.decode(_adsb(1, 157), 1.0 + expiry - 0.1) is None
    # the owner silent for longer than a track can live: the address is free again, no longer suspected
    assert decoder.decode(_adsb(1, 157), 1.0 + expiry + 0.1) is not None
    assert decoder.spoof_suspected == set()
    assert decoder.decode(_adsb(1, 156), 1.0 + expiry + 0.2) is None  # and now the old owner is the second one


def test_a_suspicion_ends_when_the_disagreeing_sender_stops_while_the_owner_goes_on():
    """One bad report of a second receiver does not make DAA unavailable for the rest of the flight: the flag lasts
    as long as a track of that report could (tracking.delete_after_s + 1 s, checked every that long)."""
    config = load_config(overrides=['mavlink.traffic_sources=["1"]'])
    decoder = MessageDecoder(config, Counter())
    expiry = config.tracking.delete_after_s + 1.0
    key = IntruderKey(0xA1B2C3, AddressSource.ES1090)
    assert decoder.decode(_adsb(1, 156), 0.0) is not None
    assert decoder.decode(_adsb(1, 157, lat_e7=474000000 - 180000), 1.0) is None
    suspected = []
    for t in range(1, 61):  # the owner goes on at 1 Hz
        decoder.decode(_adsb(1, 156), float(t))
        suspected.append(key in decoder.spoof_suspected)
    assert suspected[0] and all(suspected[:int(expiry)]) and not any(suspected[int(2 * expiry) + 1:])


def test_owners_of_silent_addresses_are_forgotten_under_address_churn():
    config = load_config()
    decoder = MessageDecoder(config, Counter())
    for n in range(5000):
        decoder.decode(_adsb(1, 156, address=n + 1), n * 0.01)
    assert len(decoder._senders) <= (config.tracking.delete_after_s + 1.0) * 2 / 0.01 + 1


@pytest.mark.parametrize("entry", ['"0"', '"256"', '"1:256"', '"1:"', '"x"', '"1:2:3"', "true"])
def test_a_bad_traffic_source_is_a_configuration_error(entry):
    with pytest.raises(ConfigError, match=r"mavlink\.traffic_sources"):
        load_config(overrides=[f"mavlink.traffic_sources=[{entry}]"])


def _heartbeat(system: int, component: int, kind: int, autopilot: int = m2.MAV_AUTOPILOT_INVALID):
    return over_the_wire(m2.MAVLink_heartbeat_message(kind, autopilot, 0, 0, m2.MAV_STATE_ACTIVE, 3), system, component)


def test_the_default_is_the_autopilot_and_the_receivers_of_our_vehicle_that_say_so():
    """traffic_sources = []: the ownship (autopilot) component, MAV_COMP_ID_ADSB and any component of our system whose
    HEARTBEAT says MAV_TYPE_ADSB. Another component of our system that reports traffic first does not become a
    source: it is rejected, counted and a suspect; another system's is only counted."""
    config = load_config(overrides=["mavlink.source_system=7"])
    assert traffic_source_ids(config.mavlink) == ()
    decoder = MessageDecoder(config, Counter())
    assert decoder.decode(_adsb(7, 200, 0x1), 0.0) is None  # first, but nobody
    assert decoder.decode(_adsb(7, 1, 0x1), 0.1) is not None  # the autopilot (component 1 until a HEARTBEAT)
    assert decoder.decode(_adsb(7, 156, 0x2), 0.1) is not None  # MAV_COMP_ID_ADSB
    assert decoder.decode(_adsb(8, 156, 0x3), 0.1) is None  # another system
    assert decoder.counters["adsb.untrusted_source"] == 2
    assert decoder.senders.active_suspects(0.1) == {(7, 200, "traffic")}
    decoder.decode(_heartbeat(7, 42, m2.MAV_TYPE_ADSB), 0.2)  # a receiver on its own port announces itself
    assert decoder.decode(_adsb(7, 42, 0x4), 0.2) is not None
    decoder.decode(_heartbeat(7, 9, m2.MAV_TYPE_QUADROTOR, m2.MAV_AUTOPILOT_PX4), 0.3)  # the autopilot is 9
    assert decoder.decode(_adsb(7, 9, 0x5), 0.3) is not None
    assert decoder.decode(_adsb(7, 1, 0x6), 0.3) is None
