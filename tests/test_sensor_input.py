"""Range/bearing sensor inputs on the wire (issue 30 item 1, avionics/io/sensor_input.py) and the simulator serving
them (`sitl live --sensor`, sitl/avionics_sitl/sensor_feed.py).

- zenoh: two real sessions (peer mode on loopback, scouting off): the simulator's publisher puts the radar's scans on
  `daa/uav1/sensor/0`, the receiver's SensorSubscriber files them and the decoder gives back what was measured;
  garbage, NaN and out-of-range samples and returns are counted and the next good sample decoded.
- MAVLink: bad messages over real UDP and pymavlink framing are counted and a good one after them decoded.
- `sitl live --sensor radar,active --sensor-link both` as a child process: no ADSB_VEHICLE; every
  DAA_SENSOR_MEASUREMENT (UDP) decodes to the simulator's measurement at float32 precision, every zenoh sample
  exactly.
- hypothesis over both decoders' parsing: nothing raises, nothing non-finite gets through.
"""

from __future__ import annotations

import json
import math
import subprocess
import sys
from collections import Counter

import numpy as np
import pytest
from hypothesis import given, strategies as st

import avionics.io  # noqa: F401  (MAVLink 2)
from avionics.contract import zenoh as contract
from avionics.io.dialect import daa as m2
from avionics.io.framing import FrameScanner
from avionics.io.link import MavlinkLink
from avionics.io.params import ZenohConfig
from avionics.io.sensor_input import (SensorMessageDecoder, SensorPayloadDecoder, SensorSubscriber, sensor_message,
                                      sensor_payload)
from avionics.io.zenoh_bus import open_session
from avionics.tracking.measurement import PolarMeasurement, SensorMount
from avionics_sitl.encounters import load_scenario
from avionics_sitl.live import ScenarioClock
from avionics_sitl.sensor_feed import ZenohSensorPublisher, sensor_scans, simulated_sensors
from tests.conftest import DEADLINE_S, ROOT, wait_for

RADAR = SensorMount("0", "radar", half_azimuth_deg=110.0, elevation_min_deg=-15.0, elevation_max_deg=15.0,
                    min_range_m=1219.2, rate_hz=10.0)
ACTIVE = SensorMount("1", "active")
START_S, END_S = 26.0, 27.5  # the head-on's intruder 7-8 km ahead, inside the radar's field of regard


def radar_return(**changes) -> PolarMeasurement:
    values = dict(mount=RADAR, time_s=0.0, range_m=7710.4, azimuth_rad=0.0105, range_sigma_m=26.2,
                  azimuth_sigma_rad=0.0195, elevation_rad=0.007, elevation_sigma_rad=0.0195, range_rate_mps=-128.9,
                  range_rate_sigma_mps=3.84)
    return PolarMeasurement(**{**values, **changes})


def mode_s_reply() -> PolarMeasurement:
    return PolarMeasurement(ACTIVE, 0.0, 15000.0, -0.4, 41.0, 0.157, altitude_m=1524.0, altitude_sigma_m=8.8,
                            address=0xA1B2C3)


def same(a: PolarMeasurement, b: PolarMeasurement, rel: float) -> bool:
    """Every measured value of a and b equal within rel (time and mount aside)."""
    for name in ("range_m", "azimuth_rad", "range_sigma_m", "azimuth_sigma_rad", "elevation_rad",
                 "elevation_sigma_rad", "altitude_m", "altitude_sigma_m", "range_rate_mps", "range_rate_sigma_mps"):
        x, y = getattr(a, name), getattr(b, name)
        if (x is None) != (y is None) or (x is not None and not math.isclose(x, y, rel_tol=rel, abs_tol=rel)):
            return False
    return a.address == b.address


def finite(m: PolarMeasurement) -> bool:
    values = [m.time_s, m.range_m, m.azimuth_rad, m.range_sigma_m, m.azimuth_sigma_rad, m.elevation_rad,
              m.elevation_sigma_rad, m.altitude_m, m.altitude_sigma_m, m.range_rate_mps, m.range_rate_sigma_mps]
    return all(math.isfinite(v) for v in values if v is not None) and m.problem() is None


# -- the zenoh payload -----------------------------------------------------------------------------------------------

def test_payload_has_the_contracts_fields_in_its_order_and_round_trips():
    payload = sensor_payload("uav1", RADAR, 26.0, [radar_return(), radar_return(range_m=9000.0)], age_s=0.25)
    assert list(payload) == [f.name for f in contract.SENSOR]
    assert list(payload["returns"][0]) == [f.name for f in contract.SENSOR_RETURN]
    counters = Counter()
    got = SensorPayloadDecoder(counters, "uav1").decode(json.dumps(payload).encode(), "0", 100.0)
    assert len(got) == 2 and all(m.time_s == 99.75 and m.mount == RADAR for m in got)
    assert same(got[0], radar_return(), 1e-12) and got[1].range_m == 9000.0
    reply = SensorPayloadDecoder(counters).decode(
        json.dumps(sensor_payload("uav1", ACTIVE, 3.0, [mode_s_reply()])).encode(), "1", 5.0)
    assert same(reply[0], mode_s_reply(), 1e-12) and reply[0].mount == ACTIVE  # max_range null: unlimited
    assert [k for k in counters if not k.startswith("rx.")] == []


GOOD = sensor_payload("uav1", RADAR, 26.0, [radar_return()])
BAD_SAMPLES = [  # (the sample, the counter it costs)
    (b"\xff{not json", "sensor.zenoh.json"),
    (b"[1, 2]", "sensor.zenoh.type"),
    (json.dumps({k: v for k, v in GOOD.items() if k != "kind"}).encode(), "sensor.zenoh.kind"),
    (json.dumps({**GOOD, "kind": "lidar"}).encode(), "sensor.zenoh.kind"),
    (json.dumps({**GOOD, "age_s": float("nan")}).encode(), "sensor.zenoh.age_s"),  # Python's json writes NaN
    (json.dumps({**GOOD, "age_s": 3600.0}).encode(), "sensor.zenoh.age_s"),
    (json.dumps({**GOOD, "time_s": "26"}).encode(), "sensor.zenoh.time_s"),
    (json.dumps({**GOOD, "sensor": "7"}).encode(), "sensor.zenoh.sensor_key"),
    (json.dumps({**GOOD, "vehicle": "uav2"}).encode(), "sensor.zenoh.vehicle"),
    (json.dumps({**GOOD, "elevation_min_deg": 20.0}).encode(), "sensor.zenoh.mount"),  # above its maximum
    (json.dumps({**GOOD, "returns": {"range_m": 1.0}}).encode(), "sensor.zenoh.returns"),
    (b"{" * 100_000, "sensor.zenoh.size"),
]
BAD_RETURNS = [  # (the return's fields replaced, the counter it costs)
    ({"range_m": None}, "sensor.zenoh.return.range_m"),
    ({"range_m": -5.0}, "sensor.zenoh.return.range_m"),
    ({"azimuth_deg": float("inf")}, "sensor.zenoh.return.azimuth_deg"),
    ({"azimuth_deg": 400.0}, "sensor.zenoh.return.azimuth_deg"),
    ({"range_sigma_m": -1.0}, "sensor.zenoh.return.range_sigma_m"),
    ({"address": 2**30}, "sensor.zenoh.return.address"),
    ({"altitude_m": 1000.0, "altitude_sigma_m": 8.0}, "sensor.zenoh.problem"),  # both elevation and altitude
    ({"elevation_sigma_deg": None}, "sensor.zenoh.problem"),  # an elevation without its sigma
]


def test_bad_samples_and_returns_are_counted_and_the_next_good_sample_is_decoded():
    counters = Counter()
    decoder = SensorPayloadDecoder(counters, "uav1")
    for raw, reason in BAD_SAMPLES:
        before = counters[reason]
        assert decoder.decode(raw, "0", 1.0) == [], reason
        assert counters[reason] == before + 1, (reason, counters)
    good = GOOD["returns"][0]
    returns = [{**good, **change} for change, _ in BAD_RETURNS] + [good, "not an object"]
    got = decoder.decode(json.dumps({**GOOD, "returns": returns}).encode(), "0", 2.0)
    assert len(got) == 1 and same(got[0], radar_return(), 1e-12)  # the good return of the scan is kept
    for change, reason in BAD_RETURNS:
        assert counters[reason] >= 1, (change, reason)
    assert counters["sensor.zenoh.return.type"] == 1
    unpaired = decoder.decode(json.dumps({**GOOD, "returns": [{**good, "range_rate_sigma_mps": None}]}).encode(),
                              "0", 3.0)
    assert unpaired[0].range_rate_mps is None and counters["sensor.zenoh.range_rate_unpaired"] == 1
    assert same(decoder.decode(json.dumps(GOOD).encode(), "0", 4.0)[0], radar_return(), 1e-12)


_json_value = st.recursive(st.none() | st.booleans() | st.integers(-2**40, 2**40) | st.text(max_size=8)
                           | st.floats(allow_nan=True, allow_infinity=True),
                           lambda inner: st.lists(inner, max_size=3) | st.dictionaries(st.text(max_size=8), inner,
                                                                                        max_size=3), max_leaves=8)
_scan_keys = st.sampled_from([f.name for f in contract.SENSOR])
_return_keys = st.sampled_from([f.name for f in contract.SENSOR_RETURN])


@given(scan=st.dictionaries(_scan_keys, _json_value), ret=st.dictionaries(_return_keys, _json_value),
       base=st.booleans(), raw=st.binary(max_size=64))
def test_payload_decoder_never_raises_and_never_passes_a_non_finite_value(scan, ret, base, raw):
    counters = Counter()
    decoder = SensorPayloadDecoder(counters)
    sample = {**GOOD, **scan} if base else dict(scan)
    sample["returns"] = [{**GOOD["returns"][0], **ret}, GOOD["returns"][0]]
    for blob in (json.dumps(sample).encode(), raw):
        for m in decoder.decode(blob, str(sample.get("sensor")), 10.0):
            assert finite(m)
    assert sum(v for k, v in counters.items() if k.startswith("rx.")) == 2


@pytest.mark.live
def test_simulated_radar_over_real_zenoh_sessions_is_decoded_as_measured(tcp_port):
    """The simulator's publisher (one session) -> the receiver's SensorSubscriber (another), peer mode on loopback
    with scouting off; a garbage sample in between is counted and the samples after it decoded."""
    endpoint = f"tcp/127.0.0.1:{tcp_port}"
    receiver = open_session(ZenohConfig(listen=(endpoint,), connect=()))
    sender = open_session(ZenohConfig(listen=(), connect=(endpoint,)))
    clock = ScenarioClock(START_S)
    scans = sensor_scans(load_scenario("head-on"), simulated_sensors(("radar",), 0, exact=False), END_S, START_S)
    publisher = ZenohSensorPublisher(sender, scans, clock)
    subscriber = SensorSubscriber(receiver, "daa", "uav1", clock)
    counters, got = Counter(), {}
    decoder = SensorPayloadDecoder(counters, "uav1")
    try:
        filed = []
        # Connected is not routed: the subscriber's declaration reaches the sender a moment later, and a sample put
        # before it is dropped. Garbage goes out until one arrives; from then on the scans' route is up.
        assert wait_for(lambda: sender.put("daa/uav1/sensor/0", b"\x00 garbage") or
                        filed.extend(subscriber.drain()) or filed, period_s=0.1)
        publisher.start()
        clock.start()

        garbage = []

        def drained():
            for sensor_id, raw, received_s in filed + subscriber.drain():
                filed.clear()
                if raw.startswith(b"{"):
                    got[json.loads(raw)["time_s"]] = (decoder.decode(raw, sensor_id, received_s), received_s)
                else:
                    garbage.append(decoder.decode(raw, sensor_id, received_s))
            return scans[-1].deliver_s in got

        assert wait_for(drained)
    finally:
        publisher.stop()
        subscriber.close()
        sender.close()
        receiver.close()
    assert garbage and counters["sensor.zenoh.json"] == len(garbage) and not any(garbage)  # each counted, none kept
    sent = {s.deliver_s: s.measurements for s in scans}
    assert len(got) == len(sent) and sum(len(m) for m in sent.values()) >= 10
    for time_s, (decoded, received_s) in got.items():
        assert len(decoded) == len(sent[time_s])
        for d, m in zip(decoded, sent[time_s]):
            assert same(d, m, 1e-12) and d.mount == m.mount and d.time_s == received_s  # age 0


# -- MAVLink DAA_SENSOR_MEASUREMENT ----------------------------------------------------------------------------------

def _framed(*msgs) -> list:
    mav = m2.MAVLink(None, 1, 1)
    return FrameScanner(Counter()).feed(b"".join(bytes(m.pack(mav)) for m in msgs), True)


def f32(m: PolarMeasurement) -> PolarMeasurement:
    """m as the wire's float32 carries it."""
    from dataclasses import fields, replace

    return replace(m, **{f.name: float(np.float32(getattr(m, f.name))) for f in fields(m)
                         if type(getattr(m, f.name)) is float and f.name != "time_s"})


def test_message_round_trips_radar_and_mode_s_at_float32_precision():
    counters = Counter()
    decoder = SensorMessageDecoder(counters, {"1": ACTIVE})
    radar, reply = _framed(sensor_message(radar_return(), 26.0, 0.1, 0), sensor_message(mode_s_reply(), 3.0, 0, 1))
    got = decoder.decode(radar, 50.0)
    assert radar.get_type() == "DAA_SENSOR_MEASUREMENT" and radar.time_usec == 26_000_000 and radar.age == 100
    assert got.time_s == pytest.approx(49.9) and same(got, f32(radar_return()), 0.0)
    assert got.mount == SensorMount("0", "radar")  # unconfigured: all round, of the message's kind
    got = decoder.decode(reply, 5.0)
    assert same(got, f32(mode_s_reply()), 0.0) and got.address == 0xA1B2C3 and got.mount is ACTIVE
    (second,) = _framed(sensor_message(radar_return(range_m=9000.0), 26.0, 0.1, 0))  # the same scan, read later
    assert decoder.decode(second, 50.3).time_s == pytest.approx(49.9)  # grouped with its scan's first detection
    assert [k for k in counters if not k.startswith("rx.")] == []


def _bad_messages():
    good = sensor_message(radar_return(), 1.0)
    def with_(**fields):
        msg = sensor_message(radar_return(), 1.0)
        for k, v in fields.items():
            setattr(msg, k, v)
        return msg
    return [(with_(kind=9), "kind"), (with_(age=65000), "stale"), (with_(range=math.nan), "problem"),
            (with_(azimuth_std=-0.1), "problem"), (with_(elevation=math.nan), "problem"),  # neither elev. nor alt.
            (with_(altitude=100.0, altitude_std=8.0), "problem"), (with_(range=math.inf), "problem"),
            (with_(flags=1, address=0), "address"), (with_(sensor_id=1), "kind_mismatch")], good


@pytest.mark.live
def test_bad_messages_over_real_udp_are_counted_and_a_good_one_after_them_decoded(udp_port):
    """Packed by pymavlink, sent over UDP on 127.0.0.1, read by the process's own link (MavlinkLink)."""
    import socket

    bad, good = _bad_messages()
    counters, link_counters = Counter(), Counter()
    decoder = SensorMessageDecoder(counters, {"1": ACTIVE})  # instance 1 is configured as active surveillance
    link = MavlinkLink(f"udpin:127.0.0.1:{udp_port}", link_counters, 1, 191)
    mav = m2.MAVLink(None, 1, 1)
    received = []
    try:
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as out:
            for msg, _ in bad:
                out.sendto(bytes(msg.pack(mav)), ("127.0.0.1", udp_port))
            out.sendto(bytes(good.pack(mav)), ("127.0.0.1", udp_port))
        assert wait_for(lambda: received.extend(link.receive(0.05)) or len(received) >= len(bad) + 1)
    finally:
        link.close()
    decoded = [decoder.decode(msg, 5.0) for msg in received]
    assert decoded[:-1] == [None] * len(bad) and same(decoded[-1], f32(radar_return()), 0.0)
    assert counters == Counter({"rx.sensor.mavlink": len(bad) + 1, **Counter(f"sensor.mavlink.{r}" for _, r in bad)})


_f32 = st.floats(width=32, allow_nan=True, allow_infinity=True)


@given(values=st.fixed_dictionaries({k: _f32 for k in ("range", "azimuth", "elevation", "range_rate", "altitude",
                                                        "range_std", "azimuth_std", "elevation_std", "range_rate_std",
                                                        "altitude_std", "amplitude")}),
       kind=st.integers(0, 255), flags=st.integers(0, 255), address=st.integers(0, 2**32 - 1),
       age=st.integers(0, 65535))
def test_message_decoder_never_raises_and_never_passes_a_non_finite_value(values, kind, flags, address, age):
    msg = sensor_message(radar_return(), 1.0)
    for k, v in {**values, "kind": kind, "flags": flags, "address": address, "age": age}.items():
        setattr(msg, k, v)
    (framed,) = _framed(msg)
    counters = Counter()
    m = SensorMessageDecoder(counters).decode(framed, 100.0)
    assert m is None or finite(m)
    assert (m is None) == (sum(v for k, v in counters.items() if not k.startswith("rx.")
                               and not k.endswith("range_rate_unpaired")) == 1)


@pytest.mark.live
def test_sitl_live_sensors_serve_measurements_on_both_links_and_no_adsb_vehicle(udp_port, tcp_port):
    """`sitl live head-on --sensor radar,active --sensor-link both` as a child process: what arrives on UDP
    (DAA_SENSOR_MEASUREMENT) and on zenoh (its session connects to ours) is the simulator's scans (the same seed,
    computed here), at float32 precision on MAVLink and exactly on zenoh, and no ADSB_VEHICLE."""
    endpoint = f"tcp/127.0.0.1:{tcp_port}"
    counters = Counter()
    link = MavlinkLink(f"udpin:127.0.0.1:{udp_port}", counters, 1, 191)
    receiver = open_session(ZenohConfig(listen=(endpoint,), connect=()))
    subscriber = SensorSubscriber(receiver, "daa", "uav1", lambda: 0.0)
    scans = sensor_scans(load_scenario("head-on"), simulated_sensors(("radar", "active"), 0, False), END_S, START_S)
    received, samples = [], []
    try:
        sitl = subprocess.Popen(
            [sys.executable, "-m", "avionics_sitl.cli", "live", "head-on", "--sensor", "radar,active", "--sensor-link",
             "both", "--zenoh-connect", endpoint, "--start", str(START_S), "--duration", str(END_S - START_S),
             "--connection", f"udpout:127.0.0.1:{udp_port}"],
            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, cwd=ROOT)
        try:
            wait_for(lambda: received.extend(link.receive(0.05)) or sitl.poll() is not None)
            _, err = sitl.communicate(timeout=DEADLINE_S)
        finally:
            if sitl.poll() is None:
                sitl.kill()
                sitl.communicate()
        received.extend(link.receive(0.2))
        wait_for(lambda: samples.extend(subscriber.drain()) or len(samples) >= len(scans), 10.0)  # in flight
    finally:
        link.close()
        subscriber.close()
        receiver.close()
    assert sitl.returncode == 0, err
    summary = json.loads(err.splitlines()[-1])
    kinds = Counter(m.get_type() for m in received)
    sent = {(int(round(s.deliver_s * 1e6)), int(s.sensor.sensor_id)): m for s in scans for m in s.measurements}
    print(json.dumps({"sitl": summary, "received": kinds, "zenoh_samples": len(samples)}))
    assert kinds["ADSB_VEHICLE"] == 0 and kinds["GLOBAL_POSITION_INT"] > 0
    assert summary["sensor_measurements"] == len(sent) >= 10 and summary["sensor_samples"] == len(scans)
    got = [m for m in received if m.get_type() == "DAA_SENSOR_MEASUREMENT"]
    assert len(got) >= 0.9 * len(sent)  # UDP on loopback: a datagram lost under load is not a failure here
    assert {m.sensor_id for m in got} == {0, 1}  # radar and active surveillance
    decoder_counters = Counter()
    for msg in got:
        decoded = SensorMessageDecoder(decoder_counters).decode(msg, 0.0)
        assert same(decoded, f32(sent[(msg.time_usec, msg.sensor_id)]), 0.0)
    # zenoh: the scans put once the sitl's session had reached ours (the first may precede the connection)
    assert len(samples) >= len(scans) // 2
    decoder = SensorPayloadDecoder(decoder_counters, "uav1")
    by_time = {(s.deliver_s, s.sensor.sensor_id): s for s in scans}
    for sensor_id, raw, _ in samples:
        scan = by_time[(json.loads(raw)["time_s"], sensor_id)]
        decoded = decoder.decode(raw, sensor_id, 0.0)
        assert len(decoded) == len(scan.measurements)
        assert all(same(d, m, 1e-12) and d.mount == m.mount for d, m in zip(decoded, scan.measurements))
    assert [k for k in decoder_counters if not k.startswith("rx.")] == []


def test_a_mode_c_altitude_s_declared_sigma_survives_the_wire_as_its_quantum():
    """The simulator (and DEGAS) declares a Mode C altitude's error as 100 ft / sqrt(12); after the wire's float32
    (DAA_SENSOR_MEASUREMENT) it still names the 100 ft quantum, so the tracker reads that track's vertical rate
    from its level transitions (tracking/altitude_tracker.py), on MAVLink as in the replay."""
    from dataclasses import replace

    from avionics.tracking.altitude_tracker import MODE_C_QUANTUM_M, mode_c_quantum
    from avionics_sitl.sensors import ACTIVE_MODE_C

    reply = replace(mode_s_reply(), altitude_sigma_m=ACTIVE_MODE_C.altitude_quantum_m / math.sqrt(12.0), address=None)
    (frame,) = _framed(sensor_message(reply, 3.0, 0, 1))
    got = SensorMessageDecoder(Counter(), {"1": ACTIVE}).decode(frame, 5.0)
    assert got.altitude_sigma_m != reply.altitude_sigma_m  # float32 on the wire
    assert mode_c_quantum(got.altitude_sigma_m) == MODE_C_QUANTUM_M
