"""The head-on encounter with the intruder heard as Beast binary (the simulator's DF17 encoder, sitl/avionics_sitl/beast.py)
and the ownship over MAVLink gives the TA and RA of the ADSB_VEHICLE path.

Fast time: every byte goes through the real deframer, decoder, clock alignment and merger (BeastParser) on a 0.1 s
grid, as avionics_sitl.replay runs the MAVLink path. Real time: the same frames from a TCP server on 127.0.0.1,
read by the feed framework's reader thread (avionics/io/feeds/source.py), the server killed and restarted."""

from __future__ import annotations

import json

import avionics.io  # noqa: F401  (MAVLink 2 before pymavlink is imported)
import pytest

from avionics.config import load_config
from avionics.io.feeds.beast import BeastParser
from avionics.io.framing import FrameScanner
from avionics.loop import Batch
from avionics_sitl.autopilot import Packer, schedule
from avionics_sitl.beast import beast_schedule
from avionics_sitl.encounters import load_encounter
from avionics_sitl.impairments import PRESETS
from harness import Harness

SCENARIO = load_encounter("head-on")
DURATION_S = 75.0  # TA ~55 s, RA ~65 s


def onsets(changes) -> dict[str, float]:
    """The first time of each level (TA, RA)."""
    first: dict[str, float] = {}
    for t, a in changes:
        first.setdefault(a.level.name, t)
    return first


def fly(config, noise: str, beast: bool, seed: int = 0):
    """The head-on on a 0.1 s grid: ownship over MAVLink; the intruder as ADSB_VEHICLE or as Beast frames."""
    node = Harness(config)
    scanner, packer = FrameScanner(node.counters), Packer()
    events = schedule(SCENARIO, PRESETS[noise], seed=seed, duration_s=DURATION_S)
    parser = None
    frames = []
    if beast:
        events = [e for e in events if e.msg.get_type() != "ADSB_VEHICLE"]
        parser = BeastParser("beast:127.0.0.1:30005", config, node.counters)
        frames = beast_schedule(SCENARIO, PRESETS[noise], seed=seed, duration_s=DURATION_S)
    changes, reports, i, j = [], [], 0, 0
    for k in range(int(DURATION_S * 10) + 1):
        t = k / 10
        datagram = b""
        while i < len(events) and events[i].deliver_s <= t + 1e-9:
            datagram += packer.pack(events[i].msg)
            i += 1
        stream = b""
        while j < len(frames) and frames[j].deliver_s <= t + 1e-9:
            stream += frames[j].frame
            j += 1
        inputs = node.input.decode(scanner.feed(datagram, end_of_datagram=True), t)
        if parser is not None:
            new = parser.feed(stream, t)
            reports += new
            inputs += new
        result = node.loop.step(Batch(t, inputs))
        changes.extend((t, a) for a in result.changes)
        node.mavlink_out.clear()
        node.zenoh_out.clear()
    return node, changes, reports


@pytest.mark.parametrize("noise", ["none", "default"])
def test_head_on_over_beast_gives_the_ta_and_ra_of_adsb_vehicle_within_1_s(noise):
    config = load_config()
    _, reference, _ = fly(config, noise, beast=False)
    node, changes, reports = fly(config, noise, beast=True)
    ref, got = onsets(reference), onsets(changes)
    print(json.dumps({"noise": noise, "adsb_vehicle": ref, "beast": got}))
    assert list(ref)[:2] == ["TA", "RA"] and list(got)[:2] == ["TA", "RA"]
    assert abs(got["TA"] - ref["TA"]) <= 1.0 and abs(got["RA"] - ref["RA"]) <= 1.0
    intruder = SCENARIO.intruders[0]
    assert {r.key.address for r in reports} == {intruder.icao_address}
    last = reports[-1]
    assert last.path == "beast:127.0.0.1:30005" and last.callsign == (intruder.callsign or None)
    assert last.position_sigma_m == pytest.approx(30.0 / 2.4477, rel=1e-3)  # the NACp 9 the simulator sends
    assert last.velocity_sigma_mps == pytest.approx(3.0 / 2.4477, rel=1e-3)  # NACv 2
    assert last.altitude_datum.value == "pressure" and last.vertical_rate_mps is not None
    # about two positions a second (5 % lost with the default noise), each decoded: no pair needed after the first
    positions = node.counters["traffic.beast.cpr_global"] + node.counters["traffic.beast.cpr_local"]
    assert node.counters["traffic.beast.cpr_global"] == 1 and len(reports) == positions > 1.8 * DURATION_S * 0.9
    assert not node.counters["traffic.beast.crc_failed"] and not node.counters["traffic.beast.bad_frame"]
