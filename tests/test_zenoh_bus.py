"""ZenohBus: queued publishing that never blocks the loop, advisories never dropped, the snapshot queryable,
the liveliness token and TLS from configuration, over loopback sessions (scouting off)."""

import json
import shutil
import subprocess
import threading
import time
from collections import Counter

import pytest
import zenoh

from avionics.config import ConfigError, ZenohConfig, load_config
from avionics.io.zenoh_bus import UPDATES_PER_BATCH, ZenohBus, ZenohBusError, advisory_state, open_session, session_config
from avionics.monitor.feed import wait_for
from tests.conftest import DEADLINE_S

LOOPBACK_ONLY = dict(listen=(), connect=())


def adv(intruder, level, t, **ra):
    return {"schema": 2, "vehicle": "v", "intruder": intruder, "level": level, "time_s": t, "reason": "tau", **ra}


def track(intruder, t):
    return {"schema": 2, "vehicle": "v", "intruder": intruder, "time_s": t, "lat_deg": 47.0, "lon_deg": 8.0}


@pytest.mark.live
def test_publish_never_blocks_drops_oldest_updates_and_never_an_advisory(monkeypatch):
    cfg = ZenohConfig(queue_size=50, **LOOPBACK_ONLY)
    counters = Counter()
    bus = ZenohBus(cfg, "v", counters=counters)
    put = []
    gate = threading.Event()

    def slow_put(suffix, payload, is_advisory):  # a link that stalls (until the gate opens), then crawls
        gate.wait()
        time.sleep(0.0002)
        put.append((suffix, payload["time_s"], is_advisory))

    monkeypatch.setattr(bus, "_put", slow_put)
    calls = []

    def loop():  # the onboard loop, publishing while the link is stalled for good
        for k in range(5000):
            t0 = time.perf_counter()
            bus.publish(f"tracks/t{k % 500}", track(f"t{k % 500}", k * 0.001))
            if k % 50 == 0:
                bus.publish(f"advisories/a{k // 50 % 7}", adv(f"a{k // 50 % 7}", ("TA", "RA", "NONE")[k // 350 % 3], k * 0.001))
            calls.append(time.perf_counter() - t0)

    try:
        publisher = threading.Thread(target=loop, daemon=True)
        publisher.start()
        publisher.join(DEADLINE_S)
        # Never blocks: every publish() returned while not one sample could go out (a blocking publish() would
        # wait on the gate, which only opens below).
        finished, went_out = not publisher.is_alive(), len(put)
        depths = bus.queue_depths()
        gate.set()
        publisher.join(DEADLINE_S)
        assert finished and went_out == 0 and len(calls) == 5000
        assert bus.flush(DEADLINE_S)
    finally:
        gate.set()
        bus.close()
    calls.sort()
    advisories = [p for p in put if p[2]]
    updates = [p for p in put if not p[2]]
    assert len(advisories) == 100 and [t for _, t, _ in advisories] == sorted(t for _, t, _ in advisories)
    # Bounded while every advisory waited: at most the queue (50) plus the one batch the publisher thread took
    # before the link stalled. How much of it is which depends on scheduling.
    assert depths["updates"] <= 50 and len(updates) <= 50 + UPDATES_PER_BATCH
    assert counters["zenoh.dropped_updates"] == bus.stats["dropped_updates"] == 5000 - len(updates)
    assert updates[-1][1] == pytest.approx(4.999)  # the newest track update survived (drop-oldest)
    # The cost of a call is a measurement (docs/monitor.md), not asserted: it depends on the machine's load.
    print("benchmark " + json.dumps({"publish_while_stalled_us": {
        "p50": round(calls[len(calls) // 2] * 1e6, 1), "p99": round(calls[int(len(calls) * 0.99)] * 1e6, 1),
        "max": round(calls[-1] * 1e6, 1), "n": len(calls)}}))


@pytest.mark.live
def test_change_log_counts_changes_not_refreshes_and_prunes_gone_tracks():
    bus = ZenohBus(ZenohConfig(**LOOPBACK_ONLY), "v")
    try:
        seq = [adv("a", "TA", 1.0), adv("a", "TA", 2.0), adv("a", "RA", 3.0, ra_sense="climb", ra_words="CLIMB"),
               adv("a", "RA", 4.0, ra_sense="climb", ra_words="CLIMB"),
               adv("a", "RA", 4.5, ra_sense="climb", ra_words="INCREASE CLIMB"), adv("a", "NONE", 9.0)]
        for p in seq:
            bus.publish("advisories/a", p)
        bus.publish("tracks/a", track("a", 9.0))
        bus.publish("tracks/b", track("b", 9.0))
        snap = bus.snapshot()
        assert [(c["level"], c["time_s"]) for c in snap["advisory_changes"]] == [("TA", 1.0), ("RA", 3.0),
                                                                                ("RA", 4.5), ("NONE", 9.0)]
        assert snap["advisories"] == [] and {t["intruder"] for t in snap["tracks"]} == {"a", "b"}
        bus.publish("tracks/b", track("b", 10.5))
        bus.publish("status", {"schema": 2, "time_s": 10.5})  # a is two track periods old: gone
        assert [t["intruder"] for t in bus.snapshot()["tracks"]] == ["b"]
        assert advisory_state(seq[2]) != advisory_state(seq[4])
    finally:
        bus.close()


@pytest.mark.live
def test_snapshot_queryable_and_liveliness_token_over_loopback(tcp_port):
    endpoint = f"tcp/127.0.0.1:{tcp_port}"
    bus = ZenohBus(ZenohConfig(listen=(endpoint,), connect=()), "uav9")
    monitor = open_session(ZenohConfig(mode="client", listen=(), connect=(endpoint,)))
    events = []
    try:
        sub = monitor.liveliness().declare_subscriber("daa/*/alive", lambda s: events.append((s.kind, str(s.key_expr),
                                                                                              time.monotonic())),
                                                      history=True)
        assert wait_for(lambda: events, DEADLINE_S)
        assert events[0][:2] == (zenoh.SampleKind.PUT, "daa/uav9/alive")
        bus.publish("ownship", {"schema": 2, "vehicle": "uav9", "time_s": 5.0, "valid": True})
        bus.publish("advisories/x", adv("x", "TA", 5.0))
        bus.publish("tracks/x", track("x", 5.0))
        assert bus.flush(DEADLINE_S)
        replies = list(monitor.get("daa/uav9/snapshot", timeout=DEADLINE_S))  # ends at the reply
        snap = json.loads(replies[0].ok.payload.to_bytes())
        assert str(replies[0].ok.encoding) == "application/json"
        assert snap["vehicle"] == "uav9" and snap["ownship"]["time_s"] == 5.0
        assert [a["level"] for a in snap["advisories"]] == ["TA"] and len(snap["tracks"]) == 1
        assert [c["level"] for c in snap["advisory_changes"]] == ["TA"]
        closed = time.monotonic()
        bus.close()
        assert wait_for(lambda: len(events) == 2, DEADLINE_S)
        assert events[1][:2] == (zenoh.SampleKind.DELETE, "daa/uav9/alive")
        print("benchmark " + json.dumps({"liveliness_delete_after_close_ms": round(1e3 * (events[1][2] - closed), 1)}))
        sub.undeclare()
    finally:
        bus.close()
        monitor.close()


def test_session_config_passes_retry_and_tls_through(tmp_path):
    ca = tmp_path / "ca.pem"
    ca.write_text("x")
    cfg = ZenohConfig(connect=("tls/127.0.0.1:1",), tls_root_ca_certificate=str(ca), reconnect_max_s=0.5)
    conf = session_config(cfg)
    assert json.loads(conf.get_json("transport/link/tls/root_ca_certificate")) == str(ca)
    assert json.loads(conf.get_json("connect/retry"))["period_max_ms"] == 500


@pytest.mark.parametrize("override, message", [
    ("zenoh.queue_size=0", "queue_size"),
    ("zenoh.snapshot_changes=-1", "snapshot_changes"),
    ("zenoh.reconnect_max_s=0", "reconnect_max_s"),
    ('zenoh.listen=["tls/127.0.0.1:7447"]', "tls_listen_certificate"),
    ('zenoh.connect=["tls/127.0.0.1:7447"]', "tls_root_ca_certificate"),
    ('zenoh.tls_root_ca_certificate="/nonexistent/ca.pem"', "no such file"),
    ("zenoh.tls_enable_mtls=true", "mtls"),
])
def test_bad_zenoh_configuration_is_a_clear_error(override, message):
    with pytest.raises(ConfigError, match=message):
        load_config(overrides=[override])


@pytest.mark.live
@pytest.mark.skipif(shutil.which("openssl") is None, reason="openssl CLI not installed (needed to make test certificates)")
def test_tls_endpoints_from_configuration(tmp_path, tcp_port):
    def run(*args):
        subprocess.run(["openssl", *args], cwd=tmp_path, check=True, capture_output=True)

    run("req", "-x509", "-newkey", "rsa:2048", "-nodes", "-keyout", "ca.key", "-out", "ca.pem", "-days", "2",
        "-subj", "/CN=daa-test-ca")
    run("req", "-newkey", "rsa:2048", "-nodes", "-keyout", "srv.key", "-out", "srv.csr", "-subj", "/CN=localhost")
    (tmp_path / "ext.cnf").write_text("subjectAltName=IP:127.0.0.1,DNS:localhost\nbasicConstraints=CA:FALSE\n")
    run("x509", "-req", "-in", "srv.csr", "-CA", "ca.pem", "-CAkey", "ca.key", "-CAcreateserial", "-out", "srv.pem",
        "-days", "2", "-extfile", "ext.cnf")
    endpoint = f"tls/127.0.0.1:{tcp_port}"
    onboard = load_config(overrides=[f'zenoh.listen=["{endpoint}"]', f'zenoh.tls_listen_certificate="{tmp_path}/srv.pem"',
                                     f'zenoh.tls_listen_private_key="{tmp_path}/srv.key"'])
    ground = load_config(overrides=['zenoh.mode="client"', "zenoh.listen=[]", f'zenoh.connect=["{endpoint}"]',
                                    f'zenoh.tls_root_ca_certificate="{tmp_path}/ca.pem"'])
    bus = ZenohBus(onboard.zenoh, "tlsuav")
    monitor = open_session(ground.zenoh)
    got = []
    try:
        sub = monitor.declare_subscriber("daa/tlsuav/**", lambda s: got.append(json.loads(s.payload.to_bytes())))
        assert wait_for(lambda: (bus.publish("status", {"schema": 2, "time_s": 1.0}), bus.flush(), got)[2], DEADLINE_S, 0.2)
        sub.undeclare()
        # A client that does not trust our CA cannot connect at all.
        with pytest.raises(ZenohBusError, match="cannot open zenoh session"):
            open_session(ZenohConfig(mode="client", listen=(), connect=(endpoint,)))
    finally:
        monitor.close()
        bus.close()
