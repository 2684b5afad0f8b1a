"""A DO-365 alerter's outputs as a user sees them (issue 16): the built-in head-on flown through `sitl replay`'s
loop (real MAVLink framing in and out) with `advisory.profile = do365`; the alert levels rise preventive ->
corrective -> warning and end; the guidance bands come once a second and put the current course in conflict
while a turn is conflict-free (checked against the well-clear volume by flying the turn, not against our own
bands code); DAA_BANDS decodes with stock pymavlink and the project's dialect; the bands topic and the snapshot
carry them over a real zenoh session on loopback."""

from __future__ import annotations

import json
import logging
import math
import re

import numpy as np
import pytest

from avionics.advisory.wcv import conflict, wcv_interval
from avionics.advisory.tables import load_profile
from avionics.config import ZenohConfig, load_config
from avionics.base.types import AdvisoryLevel
from avionics.io import encode
from avionics.io.dialect import daa as dialect
from avionics.io.payloads import bands_payload
from avionics.io.zenoh_bus import ZenohBus, open_session
from avionics.monitor.feed import wait_for
from avionics.ports import LogOut, MavlinkOut
from avionics_sitl.encounters import load_scenario
from avionics_sitl.impairments import PRESETS
from avionics_sitl.replay import replay
from tests.conftest import DEADLINE_S, ResultCapture

DO365_PHASE_I = load_profile("daidalus-do365b-no-sum").alerter.levels[-1].thresholds  # DWC_Phase_I det_3, the data


@pytest.fixture(scope="module")
def head_on():
    capture = ResultCapture()
    config = load_config(overrides=["advisory.profile=do365"])
    replay(load_scenario("head-on"), config, PRESETS["none"], ports=[capture])
    return capture.results


def test_the_alert_rises_preventive_corrective_warning_and_ends(head_on):
    changes = [a for r in head_on for a in r.changes]
    seen = [a.alert() for a in changes]
    levels = [lvl for lvl, _ in seen]
    assert levels[0] >= 1 and max(levels) == 3 and levels[-1] == 0, seen
    assert levels[: levels.index(3) + 1] == sorted(levels[: levels.index(3) + 1])  # it only rises to the warning
    names = {0: "NONE", 1: "PREVENTIVE", 2: "CORRECTIVE", 3: "WARNING"}
    assert all(name == names[lvl] for lvl, name in seen)
    advisory = {0: AdvisoryLevel.NONE, 1: AdvisoryLevel.TA, 2: AdvisoryLevel.TA, 3: AdvisoryLevel.RA}
    assert all(a.level is advisory[a.alert()[0]] for a in changes)  # profile do365: warning raises the RA
    assert any(a.ra_words for a in changes if a.alert()[0] == 3)


def test_statustext_collision_and_log_line_speak_do365(caplog):
    """Issue 26 item 3: a stock ground station shows only STATUSTEXT, so under do365 it names the DO-365 level
    ("DAA PREVENTIVE/CORRECTIVE/WARNING", the warning with its manoeuvre), never "TA"/"RA"; the stderr log line says
    the same; COLLISION's threat_level follows the DO-365 level (docs/mavlink.md). Each message is framed and parsed
    with pymavlink, as the link does."""
    config = load_config(overrides=["advisory.profile=do365"])
    mav, parser, got = dialect.MAVLink(None, srcSystem=1, srcComponent=191), dialect.MAVLink(None), []
    out = MavlinkOut(lambda m: got.extend(parser.parse_buffer(bytes(m.pack(mav))) or ()), config)
    with caplog.at_level("INFO", logger="avionics.test_do365"):
        replay(load_scenario("head-on"), config, PRESETS["none"],
               ports=[out, LogOut(logging.getLogger("avionics.test_do365"))])
    texts = [m.text for m in got if m.get_type() == "STATUSTEXT"]
    alerts = [t for t in texts if t.startswith("DAA ") and not t.startswith("DAA UNAVAILABLE")
              and not t.startswith("DAA AVAILABLE")]
    assert alerts and all(t.split()[1] in ("PREVENTIVE", "CORRECTIVE", "WARNING") for t in alerts), texts
    assert any(t.startswith("DAA CORRECTIVE ") for t in alerts), texts
    warning = next(t for t in alerts if t.startswith("DAA WARNING "))
    assert warning.split()[2] in ("CLIMB", "DESCEND", "DONT", "LEVEL", "MAINTAIN", "INCREASE"), warning  # the RA's
    assert not any(t.startswith(("TA ", "RA ")) for t in texts), texts
    logged = [re.sub(r"^t=\s*[-\d.]+ ", "", r.getMessage()) for r in caplog.records]
    assert [t for t in logged if t.startswith("DAA WARNING ")][:1] == [warning]
    assert not any(t.startswith(("TA ", "RA ")) for t in logged), logged
    # COLLISION threat_level per the DO-365 level (each COLLISION is followed by its DAA_ADVISORY): corrective and
    # warning HIGH (the corrective alert raises only a TA, whose TCAS mapping would be LOW), preventive LOW
    pairs = [(c, d) for c, d in zip(got, got[1:]) if c.get_type() == "COLLISION" and d.get_type() == "DAA_ADVISORY"]
    want = {0: dialect.MAV_COLLISION_THREAT_LEVEL_NONE, 1: dialect.MAV_COLLISION_THREAT_LEVEL_LOW,
            2: dialect.MAV_COLLISION_THREAT_LEVEL_HIGH, 3: dialect.MAV_COLLISION_THREAT_LEVEL_HIGH}
    assert {d.alert_level for _, d in pairs} >= {2, 3}
    assert all(c.threat_level == want[d.alert_level] for c, d in pairs), [(c.threat_level, d.alert_level) for c, d in pairs]
    assert any(d.alert_level == 2 and d.level == int(AdvisoryLevel.TA) for _, d in pairs)


def test_guidance_bands_off_leaves_the_alerts_and_publishes_no_bands(head_on):
    """advisory.guidance_bands = false (what the evaluation runs): the same alert changes at the same times, and
    no result carries bands."""
    capture = ResultCapture()
    config = load_config(overrides=["advisory.profile=do365", "advisory.guidance_bands=false"])
    replay(load_scenario("head-on"), config, PRESETS["none"], ports=[capture])
    assert all(r.bands is None for r in capture.results)
    assert any(r.bands is not None for r in head_on)
    assert [a for r in capture.results for a in r.changes] == [a for r in head_on for a in r.changes]


def test_bands_come_once_a_second_and_the_current_course_is_in_conflict_at_the_warning(head_on):
    bands = [r.bands for r in head_on if r.bands is not None]
    times = [b.time_s for b in bands]
    assert np.allclose(np.diff(times), 1.0) and len(bands) >= 100
    warning = next(r for r in head_on for a in r.changes if a.alert()[0] == 3)
    b = next(b for b in bands if b.time_s >= warning.time_s)
    ve, vn, _ = b.ownship_vel
    course = math.degrees(math.atan2(ve, vn)) % 360.0
    assert b.region_at("track_deg", course) in ("MID", "NEAR")
    assert any(x.region == "NONE" for x in b.track_deg)
    # independent check, from the truth and the well-clear volume (not from the bands code): flying on, the loss of
    # well clear begins within the corrective alerting time (55 s); turning at 3 deg/s (DO_365B's turn_rate) to the
    # middle of the widest NONE track band and flying straight on keeps well clear for those 55 s
    (key, level, name), = b.intruders
    assert name in ("CORRECTIVE", "WARNING") and level >= 2 and key.startswith("1090es-")
    s, v, sz, vz = _truth_relative(b.time_s)
    t_in, t_out = wcv_interval(s[None], v[None], np.array([sz]), np.array([vz]), DO365_PHASE_I, 0.0, 180.0)
    assert conflict(t_in, t_out)[0] and t_in[0] < 55.0
    widest = max((x for x in b.track_deg if x.region == "NONE"), key=lambda x: x.upper - x.lower)
    assert not _loses_well_clear_turning_to((widest.lower + widest.upper) / 2, course, b, s, v, sz, vz, 55.0)
    assert _loses_well_clear_turning_to(course, course, b, s, v, sz, vz, 55.0)


def _truth_relative(t_s):
    """Intruder minus ownship from the scenario's truth, on the tangent plane at the ownship: s, v (2,), sz, vz."""
    from avionics.base.geodesy import LocalTangentPlane

    own_traj, (intruder_traj,) = load_scenario("head-on").trajectories()
    o, i = own_traj.state_at(t_s), intruder_traj.state_at(t_s)
    plane = LocalTangentPlane(o.lat_deg, o.lon_deg)
    e, n = plane.to_en(i.lat_deg, i.lon_deg)
    s = np.array([float(e), float(n)])
    v = np.array([i.vel_east_mps - o.vel_east_mps, i.vel_north_mps - o.vel_north_mps])
    return s, v, i.alt_msl_m - o.alt_msl_m, i.vel_up_mps - o.vel_up_mps


def _loses_well_clear_turning_to(target_deg, course_deg, b, s, v, sz, vz, horizon_s, rate_dps=3.0, dt=0.05):
    """Fly ownship from its course to target at rate_dps (the shorter way), then straight; True when the well-clear
    volume (WCV_TAUMOD, DO-365 Phase I) is violated at some sampled time within horizon_s."""
    from avionics.advisory.wcv import wcv_violation

    ve, vn, _ = b.ownship_vel
    speed = math.hypot(ve, vn)
    own_v = np.array([ve, vn])
    intruder_v = v + own_v
    turn = (target_deg - course_deg + 180.0) % 360.0 - 180.0
    rel = s.copy()
    for k in range(int(horizon_s / dt) + 1):
        t = k * dt
        heading = math.radians(course_deg + math.copysign(min(abs(turn), rate_dps * t), turn))
        own_v_t = speed * np.array([math.sin(heading), math.cos(heading)])
        v_t = intruder_v - own_v_t
        if wcv_violation(rel[None], v_t[None], np.array([sz + vz * t]), np.array([vz]), DO365_PHASE_I)[0]:
            return True
        rel = rel + v_t * dt
    return False


def test_daa_bands_decode_with_stock_pymavlink(head_on):
    b = next(r.bands for r in head_on if r.bands is not None and any(x.region != "NONE" for x in r.bands.track_deg))
    mav = dialect.MAVLink(None, srcSystem=1, srcComponent=191)
    wire = b"".join(bytes(m.pack(mav)) for m in encode.daa_bands(b))
    parser = dialect.MAVLink(None)
    parsed = parser.parse_buffer(wire)
    assert {m.get_type() for m in parsed} == {"DAA_BANDS"}
    for name, kind in encode.BANDS_KINDS.items():
        msgs = sorted((m for m in parsed if m.kind == kind), key=lambda m: m.part)
        got = [(lo, up, r) for m in msgs for lo, up, r in zip(m.lower[:m.count], m.upper[:m.count], m.region[:m.count])]
        want = [(x.lower, x.upper, encode.BANDS_REGIONS[x.region]) for x in getattr(b, name)]
        assert [g[2] for g in got] == [w[2] for w in want]
        assert np.allclose([g[:2] for g in got], [w[:2] for w in want], rtol=1e-6)  # float32 on the wire
        assert msgs[0].time_boot_ms == round(b.time_s * 1000)


@pytest.mark.live
def test_bands_topic_and_snapshot_over_zenoh(head_on, tcp_port):
    b = next(r.bands for r in head_on if r.bands is not None and any(x.region != "NONE" for x in r.bands.track_deg))
    endpoint = f"tcp/127.0.0.1:{tcp_port}"
    bus = ZenohBus(ZenohConfig(listen=(endpoint,), connect=()), "uav7")
    monitor = open_session(ZenohConfig(mode="client", listen=(), connect=(endpoint,)))
    received = []
    try:
        sub = monitor.declare_subscriber("daa/uav7/bands", lambda s: received.append(json.loads(s.payload.to_bytes())))
        payload = bands_payload("uav7", "do365", b)
        assert wait_for(lambda: (bus.publish("bands", payload), bus.flush(DEADLINE_S), received)[2], DEADLINE_S)
        got = received[-1]
        assert got["alerter"] == "do365" and got["time_s"] == b.time_s
        assert [(x["lower"], x["upper"], x["region"]) for x in got["track_deg"]] == \
            [(x.lower, x.upper, x.region) for x in b.track_deg]
        assert got["intruders"][0]["alert_name"] in ("CORRECTIVE", "WARNING")
        snap = json.loads(list(monitor.get("daa/uav7/snapshot", timeout=DEADLINE_S))[0].ok.payload.to_bytes())
        assert snap["bands"]["time_s"] == b.time_s
        sub.undeclare()
    finally:
        bus.close()
        monitor.close()
