"""ROS 2 on the wire (avionics/io/ros2.py): the samples decode with `rosbags`, a ROS 2 CDR reader we did not
write, from the .msg definitions we ship (and ROS's own for diagnostic_msgs), field for field equal to their JSON
twins; live, a head-on replayed through the DAA loop puts its RA on `<vehicle>/daa/advisories` over a real
zenoh session on loopback."""

from __future__ import annotations

import json
import math

import pytest
from hypothesis import given, settings, strategies as st

from avionics.config import load_config
from avionics.contract.bands import BAND_KIND_NAMES, BAND_REGIONS
from avionics.base.params import ConfigError
from avionics.io import ros2
from avionics.io.params import ZenohConfig
from avionics.io.zenoh_bus import ZenohBus, open_session
from avionics.monitor.feed import wait_for
from avionics.ports import ZenohOut
from avionics_sitl.encounters import load_scenario
from avionics_sitl.impairments import PRESETS
from avionics_sitl.replay import replay
from tests.conftest import DEADLINE_S

rosbags_typesys = pytest.importorskip("rosbags.typesys", reason="rosbags (the test extra) decodes ROS 2 CDR")


@pytest.fixture(scope="module")
def typestore():
    store = rosbags_typesys.get_typestore(rosbags_typesys.Stores.ROS2_HUMBLE)  # std_msgs, diagnostic_msgs, ...
    types = {}
    for name in ros2.OURS:
        types.update(rosbags_typesys.get_types_from_msg(ros2.definition(f"avionics_msgs/msg/{name}"),
                                                        f"avionics_msgs/msg/{name}"))
    store.register(types)
    return store


def same(a, b) -> bool:
    return (isinstance(a, float) and isinstance(b, float) and math.isnan(a) and math.isnan(b)) or a == b


def same_as_json(ros, want) -> bool:
    """JSON has no inf or NaN (both null, avionics/base/jsonsafe.py); ROS float64 keeps an infinite tau."""
    return same(ros, want) or (isinstance(want, float) and math.isnan(want) and not math.isfinite(ros))


finite = st.floats(allow_nan=False, allow_infinity=True, width=64)
text = st.text(max_size=12)


@settings(max_examples=200, deadline=None)
@given(values=st.fixed_dictionaries({
    "time_s": st.floats(0.0, 1e6), "intruder": text, "address": st.integers(0, 2**24 - 1),
    "callsign": st.one_of(st.none(), text), "level": st.sampled_from(["NONE", "TA", "RA"]),
    "alert_level": st.integers(0, 3), "alert_name": text, "reason": text,
    "sensitivity_level": st.one_of(st.none(), st.integers(0, 7)),
    **{k: st.one_of(st.none(), finite) for k in ("range_m", "closure_rate_mps", "t_cpa_s", "hmd_m", "vmd_m",
                                                 "range_tau_s", "mod_tau_s", "vertical_tau_s",
                                                 "target_vertical_rate_mps", "ra_separation_m")},
    "ra_sense": st.one_of(st.none(), st.sampled_from(["climb", "descend"])), "ra_strength": text, "ra_words": text,
    "ra_reversed": st.booleans(), "ra_crossing": st.booleans(), "ra_composite": st.booleans(), "integrity": text}))
def test_any_advisory_decodes_with_rosbags_as_its_payload(typestore, values):
    payload = {"vehicle": "uav1", **values}
    got = typestore.deserialize_cdr(ros2.serialize("avionics_msgs/msg/Advisory", ros2.advisory_message(payload)),
                                    "avionics_msgs/msg/Advisory")
    want = ros2.advisory_message(payload)
    assert got.header.frame_id == "uav1"
    assert got.header.stamp.sec + got.header.stamp.nanosec * 1e-9 == pytest.approx(values["time_s"], abs=1e-9)
    for key, value in want.items():
        if key != "header":
            assert same(getattr(got, key), value), key
    assert got.callsign == (values["callsign"] or "") and got.sensitivity_level == (
        -1 if values["sensitivity_level"] is None else values["sensitivity_level"])


@settings(max_examples=100, deadline=None)
@given(bands=st.fixed_dictionaries({k: st.lists(st.tuples(finite, finite, st.sampled_from(
    list(BAND_REGIONS))), max_size=5) for k in BAND_KIND_NAMES}),
       recovery=st.fixed_dictionaries({k: st.booleans() for k in BAND_KIND_NAMES}))
def test_any_bands_decode_with_rosbags(typestore, bands, recovery):
    payload = {"vehicle": "uav1", "time_s": 12.5, "alerter": "do365", "recovery": recovery,
               **{k: [{"lower": lo, "upper": hi, "region": r} for lo, hi, r in v] for k, v in bands.items()}}
    got = typestore.deserialize_cdr(ros2.serialize("avionics_msgs/msg/Bands", ros2.bands_message(payload)),
                                    "avionics_msgs/msg/Bands")
    assert got.alerter == "do365"
    for kind in BAND_KIND_NAMES:
        assert [(b.lower, b.upper, b.region) for b in getattr(got, kind)] == bands[kind]
        assert getattr(got, f"recovery_{kind}") is recovery[kind]


def test_a_namespace_that_is_not_a_ros_name_is_refused():
    with pytest.raises(ConfigError, match="ros2_namespace"):
        load_config(overrides=["zenoh.ros2=true", "zenoh.ros2_namespace=2fast/daa"])
    with pytest.raises(ConfigError, match="vehicle.id"):
        load_config(overrides=["zenoh.ros2=true", "vehicle.id=uav-1"])
    load_config(overrides=["zenoh.ros2=true", "vehicle.id=uav-1", "zenoh.ros2_namespace=uav_1"])


@pytest.mark.live
def test_a_replayed_head_on_puts_its_ra_on_the_ros2_topics_over_zenoh(typestore, tcp_port):
    endpoint = f"tcp/127.0.0.1:{tcp_port}"
    config = load_config(overrides=["vehicle.id=uav7", "zenoh.ros2=true"])
    bus = ZenohBus(ZenohConfig(listen=(endpoint,), connect=(), ros2=True), "uav7")
    ground = open_session(ZenohConfig(mode="client", listen=(), connect=(endpoint,)))
    samples: dict[str, list] = {"advisories": [], "traffic": [], "status": [], "json": [], "json_status": []}
    try:
        for topic in ("advisories", "traffic", "status"):
            ground.declare_subscriber(f"uav7/daa/{topic}",
                                      lambda s, topic=topic: samples[topic].append(
                                          (str(s.encoding), s.payload.to_bytes())))
        ground.declare_subscriber("daa/uav7/advisories/**",
                                  lambda s: samples["json"].append(json.loads(s.payload.to_bytes())))
        ground.declare_subscriber("daa/uav7/status",
                                  lambda s: samples["json_status"].append(json.loads(s.payload.to_bytes())))
        # the ground is connected once a sample put now arrives (a replay in fast time does not wait)
        probe = []
        ground.declare_subscriber("uav7/probe", lambda s: probe.append(1))
        assert wait_for(lambda: (bus.session.put("uav7/probe", b"1"), probe)[1], DEADLINE_S)
        replay(load_scenario("head-on"), config, PRESETS["none"], ports=[ZenohOut(bus.publish, config)])
        assert bus.flush(DEADLINE_S)
        assert wait_for(lambda: len(samples["advisories"]) == len(samples["json"]) > 0 and samples["traffic"]
                        and len(samples["status"]) == len(samples["json_status"]) > 0, DEADLINE_S)
        decoded = [typestore.deserialize_cdr(raw, "avionics_msgs/msg/Advisory") for _, raw in samples["advisories"]]
        assert all(enc == "application/cdr" for enc, _ in samples["advisories"])
        ra = next(m for m in decoded if m.level == "RA")
        assert ra.header.frame_id == "uav7" and ra.ra_words in ("CLIMB", "DESCEND") and ra.target_vertical_rate_mps != 0
        for m in decoded:  # each ROS advisory is its JSON twin's, field for field
            stamp = m.header.stamp.sec + m.header.stamp.nanosec * 1e-9
            p = next(p for p in samples["json"] if (p["intruder"], p["level"]) == (m.intruder, m.level)
                     and abs(p["time_s"] - stamp) < 1e-6)
            assert [k for k, v in ros2.advisory_message(p).items()
                    if k != "header" and not same_as_json(getattr(m, k), v)] == []
        status = typestore.deserialize_cdr(samples["status"][-1][1], "diagnostic_msgs/msg/DiagnosticArray")
        assert status.status[0].name == "daa" and status.status[0].hardware_id == "uav7"
        json_status = samples["json_status"][-1]  # its twin: the same payload, put just before it
        assert status.status[0].level == (1 if json_status["warnings"] else 0)
        assert {kv.key: kv.value for kv in status.status[0].values if not kv.key.startswith("warning")} == \
            {k: str(v) for k, v in json_status["counters"].items()}
        traffic = typestore.deserialize_cdr(samples["traffic"][-1][1], "avionics_msgs/msg/TrackArray")
        assert traffic.header.frame_id == "uav7" and len(traffic.tracks) == 1
        assert traffic.tracks[0].intruder == ra.intruder and -90 <= traffic.tracks[0].latitude_deg <= 90
    finally:
        bus.close()
        ground.close()
