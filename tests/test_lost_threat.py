"""A lost threat is never "clear" (issue 25, item 3).

An alerting intruder whose reports stop for tracking.max_coast_s is a lost threat: its TA or RA is held on its
coasted track (reason `lost`, DAA_ADVISORY flag TRAFFIC_LOST, STATUSTEXT "TRAFFIC LOST ...", COLLISION at the held
level) until that track has passed its closest approach and left the level's DMOD, or is deleted; then it ends as
lost, never as "CLEAR OF CONFLICT" (advisory/logic.py lost_hold). When the only traffic source is down, DAA is
unavailable (`no_traffic_source`). The rule in numbers, in the core, on the wire, and live: `avionics run` as a
child process, real UDP and TCP on loopback, zenoh peer sessions."""

import math
import threading
import time
from collections import Counter
from dataclasses import replace

import numpy as np
import pytest
from hypothesis import assume, given, settings, strategies as st

import avionics.io  # noqa: F401
from avionics.advisory.logic import lost_hold
from avionics.config import load_config
from avionics.base.types import AddressSource, Advisory, AdvisoryLevel, AltitudeDatum, IntruderKey, OwnshipFix
from avionics.base.units import FT, NM
from avionics.daa import Daa, SourceStatus
from avionics.io import encode
from avionics.io.dialect import daa as m2
from avionics.io.feeds.source import FeedHealth
from avionics.io.framing import FrameScanner
from avionics.io.payloads import advisory_payload
from avionics_sitl.encounters import load_encounter
from avionics_sitl.impairments import PRESETS
from avionics_sitl.live import ScenarioClock
from avionics_sitl.sbs import SbsServer, sbs_schedule
from tests.conftest import DEADLINE_S, free_port, wait_for
from tests.test_failsafe import HEAD_ON, Autopilot, Onboard, _collisions, _texts, head_on_events
from tests.test_pipeline import ALT, R0, V, head_on, onset
from synthetic import Encounter, Mover

NONE, TA, RA = AdvisoryLevel.NONE, AdvisoryLevel.TA, AdvisoryLevel.RA
T_RA = onset(R0, 2 * V, 20, 0.35 * NM)  # the synthetic head-on's RA onset (65.2 s); CPA at R0 / (2 V) = 86.4 s
T_CPA = R0 / (2 * V)


# -- the rule -------------------------------------------------------------------------------------------------------

def test_lost_hold_holds_an_alerting_stale_track_while_closing_or_within_dmod():
    #             not alerting  closing  past CPA, in DMOD  past CPA, out  fresh  RA closing
    previous = np.array([0,     1,       2,                 2,             2,     2])
    stale = np.array([True,     True,    True,              True,          False, True])
    closing = np.array([True,   True,    False,             False,         True,  True])
    range_m = np.array([100.0,  3000.0,  600.0,             700.0,         600.0, 5000.0])
    dmod_m = np.array([648.0,   889.0,   648.0,             648.0,         648.0, 648.0])
    held, lost = lost_hold(previous, stale, closing, range_m, dmod_m)
    assert lost.tolist() == [False, True, True, True, False, True]
    assert held.tolist() == [False, True, True, False, False, True]


def _changes(enc, until_s=110):
    _, changes = enc.run(until_s)
    return [(t, c.level, c.reason) for t, c in changes]


def test_a_lost_ra_is_held_on_its_coasted_track_until_past_cpa_and_outside_dmod_then_ends_as_lost():
    last = math.ceil(T_RA) + 1  # reports stop 1 s into the RA
    _, changes = head_on(report_until_s=last, overrides=["tracking.delete_after_s=60"]).run(110)
    lost = [(t, c) for t, c in changes if c.reason == "lost"]
    (t_lost, held), (t_end, end) = lost
    assert t_lost == pytest.approx(last + 6.0, abs=0.11)  # tracking.max_coast_s
    assert held.level is RA and held.ra_sense is not None and held.lost  # the manoeuvre goes on
    # held until the coasted range, past CPA, leaves the RA DMOD (0.35 nm at SL 4): as the RA ends with reports
    assert t_end == pytest.approx((R0 + 0.35 * NM) / (2 * V), abs=0.11) and t_end > T_CPA
    assert end.level is NONE and end.ra_sense is None
    assert [c for t, c in changes if t > t_end] == []  # nothing more: no clear, no TA step-down
    assert not any(c.reason in ("clear", "diverging", "stale") for _, c in changes)


NEAR_M = 3 * NM  # the property's head-on starts nearer than R0: RA at about 22 s, CPA at 43 s (cheaper examples)


@settings(max_examples=8, deadline=None)  # two 43 s encounters at 10 Hz each
@given(dz_ft=st.floats(-450.0, 450.0).filter(lambda z: abs(z) > 30.0), vz_fpm=st.floats(-1200.0, 1200.0),
       into_ra_s=st.integers(1, 4))
def test_a_lost_ra_is_judged_on_its_coasted_altitude_as_if_its_reports_had_gone_on(dz_ft, vz_fpm, into_ra_s):
    """A head-on intruder dz_ft above (below) ownship, climbing or descending at vz_fpm, whose reports stop
    into_ra_s seconds into its RA. Once lost, the RA logic reads the coasted track's altitude (a straight flight's:
    what its reports would have given), so the held RA equals its twin's whose reports go on: sense and projected
    separation. It read the unknown altitude's placeholder 0 as a co-altitude threat, taking tens of metres off
    the separation, and reversed the guided Lincoln encounters' DESCENDs into intruders above
    (docs/evaluation.md)."""
    twin = Encounter(Mover((0, 0, ALT), (0, V, 0)), Mover((0, NEAR_M, ALT + dz_ft * FT), (0, -V, vz_fpm * FT / 60.0)))
    t_cpa = NEAR_M / (2 * V)
    steps_reported, steps_lost = [], []
    _, reported_changes = twin.run(t_cpa, results=steps_reported)
    t_ra = next((t for t, c in reported_changes if c.level is RA), None)
    assume(t_ra is not None and t_ra + into_ra_s + 8.0 < t_cpa)
    last = math.ceil(t_ra) + into_ra_s
    _, changes = replace(twin, report_until_s=last).run(last + 7.0, results=steps_lost)  # lost at last + 6 s
    (t_lost, held), = [(t, c) for t, c in changes if c.reason == "lost"][:1]
    i = next(k for k, r in enumerate(steps_lost) if r.time_s == t_lost)
    (reported,) = [a for a in steps_reported[i].assessed if a.intruder == held.intruder]
    assume(reported.level is RA)  # the twin's RA may have ended by then
    assert held.level is RA and held.ra_sense == reported.ra_sense and held.ra_words == reported.ra_words
    assert held.ra_separation_m == pytest.approx(reported.ra_separation_m, abs=1.0)


def test_a_lost_do365_threat_stays_in_the_guidance_bands_at_its_coasted_state():
    """do365: a co-altitude head-on whose reports stop 2 s into its warning. While the warning is held (lost), the
    guidance bands still take the intruder in, at its coasted state, so they equal its twin's whose reports go on:
    the same intruders and the same region on the present track. They dropped it as an intruder without an
    altitude, and showed the track the vehicle was resolving from free of conflict."""
    twin = Encounter(Mover((0, 0, ALT), (0, V, 0)), Mover((0, R0, ALT), (0, -V, 0)),
                     overrides=["advisory.profile=do365"])
    steps_reported, steps_lost = [], []
    _, reported_changes = twin.run(T_CPA, results=steps_reported)
    t_warning = next(t for t, c in reported_changes if c.alert()[0] == 3)
    _, changes = replace(twin, report_until_s=math.ceil(t_warning) + 2).run(T_CPA, results=steps_lost)
    (t_lost, held), (t_deleted, ended) = [(t, c) for t, c in changes if c.reason == "lost"]
    assert held.alert()[0] == 3 and ended.level is NONE  # held until the track is deleted (delete_after_s)
    compared = 0
    for lost, reported in zip(steps_lost, steps_reported):
        if lost.bands is None or not t_lost <= lost.time_s < t_deleted:
            continue
        assert [i[:2] for i in lost.bands.intruders] == [i[:2] for i in reported.bands.intruders] != []
        course = 0.0  # ownship flies north
        assert lost.bands.region_at("track_deg", course) == reported.bands.region_at("track_deg", course) != "NONE"
        compared += 1
    assert compared >= 10


def test_a_lost_ta_ends_as_lost_when_its_track_is_deleted():
    last = math.ceil(onset(R0, 2 * V, 30, 0.48 * NM)) + 1  # reports stop just after the TA onset
    assert _changes(head_on(report_until_s=last)) == [
        (pytest.approx(last - 1.1, abs=0.11), TA, "tau"),
        (pytest.approx(last + 6.1, abs=0.11), TA, "lost"),  # tracking.max_coast_s
        (pytest.approx(last + 20.1, abs=0.11), NONE, "lost")]  # tracking.delete_after_s, still closing


def test_a_lost_threat_found_again_is_announced_and_alerts_on_its_reports_again():
    gap = (math.ceil(T_RA) + 1, math.ceil(T_RA) + 11)  # a 10 s silence 1 s into the RA
    changes = _changes(head_on(report_gap_s=gap))
    reasons = [(lvl, why) for _, lvl, why in changes]
    i = reasons.index((RA, "lost"))
    assert changes[i][0] == pytest.approx(gap[0] + 6.0, abs=0.11)
    t_back, level_back, why_back = changes[i + 1]  # the next report: a change (TRAFFIC LOST is over)
    assert t_back == pytest.approx(gap[1], abs=0.11) and level_back is RA and why_back != "lost"
    # then as without the silence: RA until the RA DMOD, TA, clear once diverging outside the TA DMOD
    assert [lvl for _, lvl, _ in changes[i + 1:]][-2:] == [TA, NONE] and changes[-1][2] == "diverging"
    assert all(why != "stale" for _, _, why in changes)


def test_a_lost_ra_past_cpa_within_dmod_ends_as_lost_not_stepping_down_to_ta():
    last = math.floor(T_CPA) + 3  # reports stop just after CPA; coasting 2 s
    changes = _changes(head_on(report_until_s=last, overrides=["tracking.max_coast_s=2"]))
    assert changes[-2:] == [(pytest.approx(last + 2.1, abs=0.11), RA, "lost"),
                            (pytest.approx((R0 + 0.35 * NM) / (2 * V), abs=0.11), NONE, "lost")]


# -- on the wire ----------------------------------------------------------------------------------------------------

def _advisory(level, reason, **ra):
    return Advisory(intruder=IntruderKey(HEAD_ON, AddressSource.ES1090), level=level, time_s=73.1, reason=reason,
                    sensitivity_level=4, range_m=1711.0, closure_rate_mps=128.6, t_cpa_s=13.3, hmd_m=1.0, vmd_m=-4.0,
                    range_tau_s=13.3, mod_tau_s=12.0, vertical_tau_s=math.inf, altitude_datum=AltitudeDatum.PRESSURE,
                    datum_mismatch=False, **ra)


def _framed(msg):
    (out,) = FrameScanner(Counter()).feed(bytes(msg.pack(m2.MAVLink(None, 1, 191))), True)
    return out


@pytest.mark.parametrize("request_action", [False, True])
def test_a_lost_threat_on_mavlink_and_zenoh(request_action):
    held = _advisory(RA, "lost", ra_sense="descend", ra_strength="increase", ra_words="INCREASE DESCENT",
                     target_vertical_rate_mps=-12.7)
    ended = _advisory(NONE, "lost")
    live = _advisory(RA, "tau", ra_sense="descend", ra_strength="increase", ra_words="INCREASE DESCENT",
                     target_vertical_rate_mps=-12.7)
    assert encode.advisory_text(held, "HEADON") == "TRAFFIC LOST HEADON RA HELD"
    assert encode.advisory_severity(held) == m2.MAV_SEVERITY_CRITICAL
    assert encode.advisory_text(ended, "HEADON") == "TRAFFIC LOST HEADON (ended)"
    assert encode.advisory_severity(ended) == m2.MAV_SEVERITY_WARNING  # not the INFO of a clear of conflict
    # COLLISION is held: the level's threat and action, the coasted geometry
    collision = _framed(encode.collision(held, request_action))
    assert (collision.threat_level, collision.action) == (_framed(encode.collision(live, request_action)).threat_level,
                                                          _framed(encode.collision(live, request_action)).action)
    assert collision.threat_level == m2.MAV_COLLISION_THREAT_LEVEL_HIGH
    for advisory, level in ((held, 2), (ended, 0)):
        msg = _framed(encode.daa_advisory(advisory, "HEADON"))
        assert msg.level == level and msg.flags & m2.DAA_ADVISORY_FLAGS_TRAFFIC_LOST
        assert advisory_payload("uav1", advisory)["reason"] == "lost"
    assert msg.sense == m2.DAA_RA_SENSE_NONE
    assert not _framed(encode.daa_advisory(live)).flags & m2.DAA_ADVISORY_FLAGS_TRAFFIC_LOST
    assert held.ra_key() != live.ra_key()  # losing and finding a threat again are changes, announced


def test_the_dialect_flag_keeps_the_message_crc():
    assert m2.DAA_ADVISORY_FLAGS_TRAFFIC_LOST == 64  # uint8 flags: the seventh bit
    assert m2.MAVLink_daa_advisory_message.crc_extra == 189  # unchanged by an enum entry (as before the flag)


# -- availability: the only traffic source down -------------------------------------------------------------------

def _down(path="sbs:127.0.0.1:30003"):
    return FeedHealth(path, False, "ConnectionRefusedError: [Errno 111] Connection refused", 10, 5.0)


def _daa_with_ownship():
    daa = Daa(load_config(overrides=["zenoh.enabled=false"]), Counter())
    daa.step(0.0, [OwnshipFix(0.0, 47.0, 8.0, 900.0, 400.0, (0.0, 30.0, 0.0))])
    return daa


@pytest.mark.parametrize("sources, reason", [
    (SourceStatus(feeds=(_down(),)), "no_traffic_source"),
    (SourceStatus(feeds=(_down(), _down("beast:10.0.0.2:30005"))), "no_traffic_source"),
    (SourceStatus(feeds=(_down(), FeedHealth("beast:10.0.0.2:30005", True, None, 3, 0.5))), None),  # one is up
    (SourceStatus(feeds=(FeedHealth("sbs:127.0.0.1:30003", False, None, 0, None),)), None),  # connecting
    (SourceStatus(feeds=(_down(),), mavlink_traffic=True), None),  # the autopilot's receiver delivers traffic
    (SourceStatus(), None),  # MAVLink alone: its silence is also an empty sky
], ids=["one-down", "all-down", "one-up", "connecting", "mavlink-traffic", "mavlink-only"])
def test_daa_is_unavailable_when_its_only_traffic_source_is_down(sources, reason):
    daa = _daa_with_ownship()
    result = daa.step(0.2, [OwnshipFix(0.2, 47.0, 8.0, 900.0, 400.0, (0.0, 30.0, 0.0))], sources=sources)
    status = daa.status(0.2, sources)
    assert (result.unavailable_reason, status["unavailable_reason"], status["daa_available"]) == \
        (reason, reason, reason is None)
    if reason is not None:
        assert result.availability_changed and result.fault_detail.startswith("sbs:127.0.0.1:30003")
        assert encode.availability_text(reason, result.fault_detail).startswith(
            "DAA UNAVAILABLE traffic down sbs:127.0.0.1:30003")
        assert "no traffic source: every receiver feed is down and MAVLink has delivered no traffic" in \
            status["warnings"]


# -- live --------------------------------------------------------------------------------------------------------

SILENCE_S = 10.0
START_S = 52.0  # head-on: TA ~55 s, RA ~65.3 s, CPA 86.4 s


def _lost_flagged(autopilot, level):
    return [m for m in autopilot.messages("DAA_ADVISORY")
            if m.id == HEAD_ON and m.level == level and m.flags & 64]  # DAA_ADVISORY_FLAGS_TRAFFIC_LOST


def _end_the_silence(autopilot, onboard, silent_at: float, resume, before: int, texts_before: int):
    """The silence lasts SILENCE_S from silent_at; resume() ends it. Once the threat is found again (an RA that is
    not lost), what went out from the start of the silence (`before` COLLISION, `texts_before` STATUSTEXT) is
    checked."""
    threading.Event().wait(max(0.0, silent_at + SILENCE_S - time.monotonic()))  # a stimulus of 10 s, not a wait
    found_at = len(onboard.of("advisory"))
    resume()
    assert wait_for(lambda: any(p["level"] == "RA" and p["reason"] != "lost" for p in onboard.of("advisory")[found_at:]))
    texts = _texts(autopilot)[texts_before:]
    assert not any("CLEAR OF CONFLICT" in t for _, t in texts), texts
    assert (m2.MAV_SEVERITY_CRITICAL, "TRAFFIC LOST HEADON RA HELD") in texts, texts
    during = _collisions(autopilot)[before:]
    assert during and all(m.threat_level == m2.MAV_COLLISION_THREAT_LEVEL_HIGH for m in during)
    assert _lost_flagged(autopilot, 2)
    advisories = [(p["level"], p["reason"]) for p in onboard.of("advisory")]
    assert ("RA", "lost") in advisories and ("NONE", "stale") not in advisories, advisories


@pytest.mark.live
def test_a_traffic_silence_during_an_ra_is_announced_as_traffic_lost_never_as_clear():
    onboard = Onboard("lostuav")
    autopilot = None
    try:
        autopilot = Autopilot(f"udpout:127.0.0.1:{onboard.udp}", head_on_events(start_s=START_S))
        autopilot.start()
        assert wait_for(lambda: any(m.threat_level == m2.MAV_COLLISION_THREAT_LEVEL_HIGH for m in _collisions(autopilot)))
        before, texts_before = len(_collisions(autopilot)), len(_texts(autopilot))
        silent_at = time.monotonic()
        autopilot.drop = lambda msg: msg.get_type() == "ADSB_VEHICLE"  # the receiver goes silent, ownship flows
        assert wait_for(lambda: _lost_flagged(autopilot, 2))
        assert wait_for(lambda: ("RA", "lost") in [(p["level"], p["reason"]) for p in onboard.of("advisory")])
        # MAVLink delivered traffic before: its silence may be the sky's, DAA stays available (docs/mavlink.md)
        status_lost = onboard.of("status")[-1]

        def resume():
            autopilot.drop = None

        _end_the_silence(autopilot, onboard, silent_at, resume, before, texts_before)
    finally:
        if autopilot is not None:
            autopilot.stop()
        code, err = onboard.close()
    assert code == 0 and "Traceback" not in err, err
    assert status_lost["daa_available"] is True and status_lost["advisories"]["RA"] == 1
    back = [m for m in autopilot.messages("DAA_ADVISORY") if m.id == HEAD_ON][-1]
    assert not back.flags & m2.DAA_ADVISORY_FLAGS_TRAFFIC_LOST


@pytest.mark.live
def test_the_only_traffic_feed_down_during_an_ra_makes_daa_unavailable_and_the_threat_lost():
    port = free_port()
    events = sbs_schedule(load_encounter("head-on"), PRESETS["none"], duration_s=100.0)
    clock = ScenarioClock(START_S)
    onboard = Onboard("feedlostuav", ("--traffic", f"sbs:127.0.0.1:{port}"))
    autopilot, receivers = None, []
    try:
        # ownship over MAVLink, the traffic only from the ground receiver's SBS feed
        autopilot = Autopilot(f"udpout:127.0.0.1:{onboard.udp}", head_on_events(start_s=START_S),
                              drop=lambda msg: msg.get_type() == "ADSB_VEHICLE")
        receivers.append(SbsServer(events, port=port, start_s=START_S, clock=clock))
        clock.start()
        receivers[-1].start()
        autopilot.start()
        assert wait_for(lambda: any(m.threat_level == m2.MAV_COLLISION_THREAT_LEVEL_HIGH for m in _collisions(autopilot)))
        before, texts_before = len(_collisions(autopilot)), len(_texts(autopilot))
        silent_at = time.monotonic()
        receivers[-1].stop()  # the receiver goes away: its connection ends, reconnections are refused
        want = f"DAA UNAVAILABLE traffic down sbs:127.0.0.1:{port}"
        assert wait_for(lambda: (m2.MAV_SEVERITY_WARNING, want) in _texts(autopilot))
        assert wait_for(lambda: autopilot.messages("HEARTBEAT")[-1].system_status == m2.MAV_STATE_CRITICAL)
        assert wait_for(lambda: onboard.of("status")[-1]["unavailable_reason"] == "no_traffic_source")
        assert wait_for(lambda: _lost_flagged(autopilot, 2))
        status_down = onboard.of("status")[-1]

        def resume():  # the receiver is back on the same port
            receivers.append(SbsServer(events, port=port, start_s=clock(), clock=clock).start())

        _end_the_silence(autopilot, onboard, silent_at, resume, before, texts_before)
        assert wait_for(lambda: (m2.MAV_SEVERITY_NOTICE, "DAA AVAILABLE") in _texts(autopilot))
    finally:
        for receiver in receivers:
            receiver.stop()
        if autopilot is not None:
            autopilot.stop()
        code, err = onboard.close()
    assert code == 0 and "Traceback" not in err, err
    assert status_down["daa_available"] is False and status_down["traffic_feeds"][0]["connected"] is False
    assert status_down["advisories"]["RA"] == 1  # the lost threat is held while DAA says it is unavailable
