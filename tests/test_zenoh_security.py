"""zenoh security, live: `avionics router` (a child process) with mutual TLS, user-password authentication and an
access-control list from a zenoh config file; the onboard bus logs in with [zenoh] keys. Peers without a
certificate, without a password or with a wrong one can neither publish into daa/** nor read it; a monitor user
may read but its writes are dropped by the router; an authenticated subscriber receives the advisories."""

import json
import shutil
import subprocess
import sys
import threading
import time

import pytest

from avionics.config import load_config
from avionics.io.zenoh_bus import ZenohBus, open_session
from avionics.monitor.feed import monitor_zenoh_config
from tests.conftest import DEADLINE_S, wait_for

pytestmark = [pytest.mark.live,
              pytest.mark.skipif(shutil.which("openssl") is None, reason="openssl CLI needed to make certificates")]

ACL = """{ access_control: { enabled: true, default_permission: "allow",
    rules: [ { id: "read-only", permission: "deny", flows: ["ingress"], key_exprs: ["daa/**"],
               messages: ["put", "delete", "declare_queryable", "liveliness_token"] } ],
    subjects: [ { id: "monitors", usernames: ["monitor"] } ],
    policies: [ { rules: ["read-only"], subjects: ["monitors"] } ] } }"""


def make_pki(d):
    def run(*args):
        subprocess.run(["openssl", *args], cwd=d, check=True, capture_output=True)

    run("req", "-x509", "-newkey", "rsa:2048", "-nodes", "-keyout", "ca.key", "-out", "ca.pem", "-days", "2",
        "-subj", "/CN=daa-test-ca")
    (d / "ext.cnf").write_text("subjectAltName=IP:127.0.0.1,DNS:localhost\nbasicConstraints=CA:FALSE\n")
    for name in ("router", "uav1", "monitor", "stolen"):  # "stolen": a certificate of ours without a password
        run("req", "-newkey", "rsa:2048", "-nodes", "-keyout", f"{name}.key", "-out", f"{name}.csr",
            "-subj", f"/CN={name}")
        run("x509", "-req", "-in", f"{name}.csr", "-CA", "ca.pem", "-CAkey", "ca.key", "-CAcreateserial",
            "-out", f"{name}.pem", "-days", "2", "-extfile", "ext.cnf")
    (d / "users.txt").write_text("uav1:uav1-secret\nmonitor:monitor-secret\n")
    for user in ("uav1", "monitor"):
        (d / f"{user}.password").write_text(f"{user}-secret\n")
    (d / "wrong.password").write_text("guess\n")
    (d / "acl.json5").write_text(ACL)


def client(d, endpoint, cert=None, user=None, password=None):
    """A session of a peer that connects to the router (peer mode: it keeps trying and never fails to open)."""
    keys = {"tls_root_ca_certificate": str(d / "ca.pem")}
    if cert:
        keys |= {"tls_connect_certificate": str(d / f"{cert}.pem"), "tls_connect_private_key": str(d / f"{cert}.key"),
                 "tls_enable_mtls": True}
    if user:
        keys |= {"auth_user": user, "auth_password_file": str(d / f"{password}.password")}
    return open_session(monitor_zenoh_config([endpoint], mode="peer", **keys))


def test_unauthenticated_peers_can_neither_publish_nor_read_daa(tmp_path, tcp_port):
    make_pki(tmp_path)
    endpoint = f"tls/127.0.0.1:{tcp_port}"
    router = subprocess.Popen(
        [sys.executable, "-m", "avionics.cli", "router", "--listen", endpoint,
         "--tls-root-ca", str(tmp_path / "ca.pem"), "--tls-cert", str(tmp_path / "router.pem"), "--tls-key", str(tmp_path / "router.key"), "--mtls",
         "--auth-dictionary", str(tmp_path / "users.txt"), "--zenoh-config", str(tmp_path / "acl.json5")],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    onboard = load_config(overrides=[
        'zenoh.mode="client"', "zenoh.listen=[]", f'zenoh.connect=["{endpoint}"]',
        f'zenoh.tls_root_ca_certificate="{tmp_path}/ca.pem"', f'zenoh.tls_connect_certificate="{tmp_path}/uav1.pem"',
        f'zenoh.tls_connect_private_key="{tmp_path}/uav1.key"', "zenoh.tls_enable_mtls=true",
        'zenoh.auth_user="uav1"', f'zenoh.auth_password_file="{tmp_path}/uav1.password"']).zenoh
    received: dict[str, list[str]] = {}
    lock = threading.Lock()
    arrived = threading.Event()  # a sample reached the authenticated subscriber
    sessions, bus = {}, None

    def listen(name, session):
        sessions[name] = session
        received[name] = []

        def on_sample(sample):
            with lock:
                received[name].append(str(sample.key_expr))
            if name == "subscriber":
                arrived.set()
        session.declare_subscriber("daa/**", on_sample)

    def log_in():  # the router is up once the onboard client can log in
        nonlocal bus
        assert router.poll() is None, router.communicate()[1]
        try:
            bus = ZenohBus(onboard, "uav1")
        except Exception:  # noqa: BLE001  (ZenohBusError while the router starts)
            return False
        return True

    try:
        assert wait_for(log_in, DEADLINE_S, 0.2), "the onboard bus never logged in to the router"
        listen("subscriber", client(tmp_path, endpoint, cert="monitor", user="monitor", password="monitor"))
        listen("read_only", client(tmp_path, endpoint, cert="monitor", user="monitor", password="monitor"))
        listen("no_certificate", client(tmp_path, endpoint, user="monitor", password="monitor"))
        listen("no_password", client(tmp_path, endpoint, cert="stolen"))
        listen("wrong_password", client(tmp_path, endpoint, cert="stolen", user="monitor", password="wrong"))
        writers = ("read_only", "no_certificate", "no_password", "wrong_password")
        real = "daa/uav1/advisories/1090es-A10001"

        def count(name, key):
            with lock:
                return received[name].count(key)

        n, deadline = 0, time.monotonic() + 2 * DEADLINE_S
        # Until the subscriber and the read-only monitor have 30 advisories each (3 s of them at 10 Hz): the
        # attackers' links are re-dialled every 0.25-1 s meanwhile (zenoh.reconnect_max_s).
        while min(count("subscriber", real), count("read_only", real)) < 30 and time.monotonic() < deadline:
            bus.publish("advisories/1090es-A10001", {"schema": 2, "vehicle": "uav1", "intruder": "1090es-A10001",
                                                     "level": "RA", "time_s": float(n), "reason": "tau"})
            for name in writers:
                sessions[name].put(f"daa/uav1/advisories/1090es-{name}", b'{"level": "RA"}')
                sessions[name].put(f"daa/fake-{name}/status", b"{}")
            n += 1
            arrived.wait(1.0)  # the next round once this one reached the subscriber (or a second went by)
            arrived.clear()
        with lock:
            got = {name: set(keys) for name, keys in received.items()}
    finally:
        if bus is not None:
            bus.close()
        for session in sessions.values():
            session.close()
        router.terminate()
        router.communicate(timeout=DEADLINE_S)
    assert count("subscriber", real) >= 30 and count("read_only", real) >= 30
    assert got["subscriber"] == {real}  # not one fake sample from any writer
    for name in ("no_certificate", "no_password", "wrong_password"):  # nothing but their own puts, locally
        assert got[name] <= {f"daa/uav1/advisories/1090es-{name}", f"daa/fake-{name}/status"}, (name, got[name])
