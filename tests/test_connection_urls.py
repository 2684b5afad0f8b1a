"""MAVSDK/MAVROS-style connection strings (docs/mavlink.md, The link): each form opens a real socket (or a pty for
serial) on 127.0.0.1 and exchanges a frame; malformed ones are one-line errors with exit code 2, an address that
cannot be reached exit code 1 (as tests/test_cli_errors.py checks for pymavlink's own strings)."""

from __future__ import annotations

import os
import socket
import subprocess
import sys
from collections import Counter

import pytest

import avionics.io  # noqa: F401
from avionics.config import ConfigError, load_config
from avionics.io.dialect import daa as m2
from avionics.io.encode import heartbeat
from avionics.io.link import MavlinkLink
from tests.conftest import wait_for

pytestmark = pytest.mark.live


def _frame(component: int = 1) -> bytes:
    return bytes(heartbeat().pack(m2.MAVLink(None, 1, component)))


def _received(link: MavlinkLink, poke=None) -> bool:
    got: list = []

    def step():
        if poke is not None:
            poke()
        got.extend(link.receive(0.05))
        return any(m.get_type() == "HEARTBEAT" for m in got)
    return wait_for(step)


@pytest.mark.parametrize("url", ["udp://127.0.0.1:{port}", "udpin://127.0.0.1:{port}", "udp://:{port}",
                                 "udp://:{port}@"])
def test_udp_listening_forms_receive_and_answer(url, udp_port):
    link = MavlinkLink(url.format(port=udp_port), Counter(), 1, 191)
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as peer:
        peer.settimeout(10.0)
        try:
            assert link.connection.startswith("udpin:")
            assert _received(link, lambda: peer.sendto(_frame(), ("127.0.0.1", udp_port)))
            link.send(heartbeat())  # the reply goes to the sender
            assert len(peer.recv(4096)) > 0
        finally:
            link.close()


def test_udpout_form_sends(udp_port):
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as peer:
        peer.bind(("127.0.0.1", udp_port))
        peer.settimeout(10.0)
        link = MavlinkLink(f"udpout://127.0.0.1:{udp_port}", Counter(), 1, 191)
        try:
            link.send(heartbeat())
            data, address = peer.recvfrom(4096)
            assert data[0] == 0xFD
            peer.sendto(_frame(), address)
            assert _received(link)
        finally:
            link.close()


def test_tcp_client_form(tcp_port):
    with socket.socket() as server:
        server.bind(("127.0.0.1", tcp_port))
        server.listen(1)
        server.settimeout(10.0)
        link = MavlinkLink(f"tcp://127.0.0.1:{tcp_port}", Counter(), 1, 191)
        try:
            conn, _ = server.accept()
            with conn:
                conn.sendall(_frame())
                assert _received(link)
                link.send(heartbeat())
                conn.settimeout(10.0)
                assert conn.recv(4096)[0] == 0xFD
        finally:
            link.close()


def test_tcpin_server_form(tcp_port):
    link = MavlinkLink(f"tcpin://127.0.0.1:{tcp_port}", Counter(), 1, 191)
    try:
        with socket.create_connection(("127.0.0.1", tcp_port), timeout=10.0) as client:
            assert _received(link, lambda: client.sendall(_frame()))
    finally:
        link.close()


def test_serial_form_with_baud_over_a_pty():
    pytest.importorskip("serial")
    controller, device = os.openpty()
    try:
        name = os.ttyname(device)
        link = MavlinkLink(f"serial://{name}:115200", Counter(), 1, 191)
        try:
            assert link.connection == name
            assert _received(link, lambda: os.write(controller, _frame()))
        finally:
            link.close()
    finally:
        os.close(controller)
        os.close(device)


@pytest.mark.parametrize("url", ["udp://127.0.0.1", "udp://:99999", "tcp://:5760", "zmq://127.0.0.1:5",
                                 "udp://:14540@127.0.0.1:14557", "serial://ttyUSB0"])
def test_malformed_urls_are_configuration_errors(url):
    with pytest.raises(ConfigError, match="mavlink.connection"):
        load_config(overrides=[f'mavlink.connection="{url}"'])


def _cli(*argv):
    return subprocess.run([sys.executable, "-m", "avionics.cli", "run", "--no-zenoh", "--duration", "1", *argv],
                          capture_output=True, text=True, timeout=120)


def test_cli_malformed_url_exits_2_and_unreachable_exits_1(tcp_port):
    bad = _cli("--connection", "udp://127.0.0.1")
    assert bad.returncode == 2 and bad.stderr.strip().count("\n") == 0, bad.stderr
    assert "configuration error" in bad.stderr and "udp://127.0.0.1" in bad.stderr
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as busy:
        busy.bind(("127.0.0.1", 0))
        port = busy.getsockname()[1]
        used = _cli("--connection", f"udpin://127.0.0.1:{port}")
    assert used.returncode == 1 and "in use" in used.stderr and used.stderr.strip().count("\n") == 0, used.stderr


def test_the_default_connection_listens_on_14540():
    assert load_config().mavlink.connection == "udpin:0.0.0.0:14540"
