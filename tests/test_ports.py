"""Output ports: adding an output is one class and one line of wiring (issue 12, acceptance).

- A new output (JSON lines of the advisory changes) is written as one class in this test and added to the
  replay's loop with one argument; what it writes equals the changes `sitl replay` reports.
- The built-in CSV port run live (`avionics run --csv`, a .tlog on its own clock) writes the same rows as
  `sitl replay --out` writes for the same log's encounter.
- A second MAVLink link is one more MavlinkOut on the running loop: a real UDP socket on 127.0.0.1 receives the
  same COLLISION sequence as the first.
"""

from __future__ import annotations

import csv
import io
import json
import socket
import struct
from collections import Counter

import avionics.io  # noqa: F401  (MAVLink 2)
from avionics.config import load_config
from avionics.io.framing import FrameScanner
from avionics.io.link import MavlinkLink
from avionics.ports import NOTHING, MavlinkOut
from avionics.runner import Runner
from avionics_sitl.autopilot import Packer, schedule
from avionics_sitl.encounters import load_encounter
from avionics_sitl.impairments import PRESETS
from avionics_sitl.replay import replay


class JsonLinesOut:
    """The new output: one JSON line per advisory change."""

    def __init__(self, fh):
        self.fh = fh

    def wants(self, now_s):
        return NOTHING

    def publish(self, result):
        for a in result.changes:
            self.fh.write(json.dumps({"t": a.time_s, "intruder": str(a.intruder), "level": a.level.name,
                                      "reason": a.reason}) + "\n")

    def close(self):
        pass


def test_a_new_output_is_one_class_and_one_line_of_wiring():
    buffer = io.StringIO()
    config = load_config(overrides=["zenoh.enabled=false"])
    result = replay(load_encounter("head-on"), config, PRESETS["none"], ports=[JsonLinesOut(buffer)])
    lines = [json.loads(line) for line in buffer.getvalue().splitlines()]
    assert [(d["t"], d["intruder"], d["level"], d["reason"]) for d in lines] == \
        [(a.time_s, str(a.intruder), a.level.name, a.reason) for a in result.changes]
    levels = [d["level"] for d in lines]
    assert levels[0] == "TA" and "RA" in levels and levels[-1] == "NONE"


def _head_on_tlog(path, duration_s: float = 120.0) -> None:
    packer = Packer()
    with open(path, "wb") as fh:
        for event in schedule(load_encounter("head-on"), PRESETS["none"], duration_s=duration_s):
            fh.write(struct.pack(">Q", int((1_700_000_000.0 + event.deliver_s) * 1e6)) + packer.pack(event.msg))


def _collisions(sock: socket.socket) -> list[tuple[int, int]]:
    scanner = FrameScanner(Counter())
    out = []
    sock.settimeout(0.0)
    while True:
        try:
            data = sock.recv(65536)
        except (BlockingIOError, socket.timeout):
            return out
        out += [(m.id, m.threat_level) for m in scanner.feed(data, end_of_datagram=True)
                if m.get_type() == "COLLISION"]


def test_the_csv_port_and_a_second_link_on_the_live_loop(tmp_path):
    log = tmp_path / "head-on.tlog"
    _head_on_tlog(log)
    csv_path = tmp_path / "live.csv"
    first, second = (socket.socket(socket.AF_INET, socket.SOCK_DGRAM) for _ in range(2))
    for sock in (first, second):
        sock.bind(("127.0.0.1", 0))
        sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 1 << 22)
    config = load_config(overrides=[f'mavlink.connection="{log}"', "zenoh.enabled=false"])
    runner = Runner(config, csv_out=str(csv_path))
    # the replayed log sends nothing back on its own link: the two links under test are two UDP senders
    links = [MavlinkLink(f"udpout:127.0.0.1:{sock.getsockname()[1]}", Counter(), 1, 191) for sock in (first, second)]
    runner.loop.ports[0] = MavlinkOut(links[0].send, config)
    runner.loop.ports.append(MavlinkOut(links[1].send, config))  # the second link: one line
    try:
        runner.run()
        runner.shutdown()
    finally:
        runner.close()
        for link in links:
            link.close()
    got_first, got_second = _collisions(first), _collisions(second)
    for sock in (first, second):
        sock.close()
    assert got_first and got_first == got_second
    assert [level for _, level in got_first][:1] == [1] and max(level for _, level in got_first) == 2
    with open(csv_path, newline="") as fh:
        live = [(r["advisory"], r["reason"]) for r in csv.DictReader(fh)]
    fast = [(a.level.name, a.reason) for a in replay(load_encounter("head-on"), load_config(
        overrides=["zenoh.enabled=false"]), PRESETS["none"]).changes]
    assert live[:len(fast)] == fast and live[len(fast):] == []  # head-on ends clear: nothing at shutdown
