"""`avionics run` shell behaviours: log replay, port conflicts, ArduPilot traffic on the link, config checks."""

import json
import subprocess
import sys
from collections import Counter

import pytest
from pymavlink.dialects.v20 import ardupilotmega

from avionics.config import ConfigError, load_config
from avionics.io.framing import FrameScanner
from avionics.io.link import LinkError, MavlinkLink
from avionics_sitl.autopilot import Packer, schedule
from avionics_sitl.impairments import PRESETS
from avionics_sitl.encounters import load_encounter
from tests.conftest import DEADLINE_S


@pytest.mark.live  # `avionics run` in a process of its own
def test_tlog_replay_runs_the_encounter_and_sends_nothing(tmp_path):
    # Record a head-on as a .tlog (8-byte big-endian microsecond stamp + frame), then replay it.
    path = tmp_path / "flight.tlog"
    packer = Packer()
    with open(path, "wb") as fh:
        for event in schedule(load_encounter("head-on"), PRESETS["none"], duration_s=100.0):
            fh.write(int(event.deliver_s * 1e6 + 1_000_000).to_bytes(8, "big") + packer.pack(event.msg))
    out = subprocess.run([sys.executable, "-m", "avionics.cli", "run", "--connection", str(path), "--no-zenoh",
                          "--counters"], capture_output=True, text=True, timeout=5 * DEADLINE_S)
    assert out.returncode == 0, out.stderr
    counters = json.loads(out.stdout[out.stdout.index("{"):])
    assert counters["rx.adsb_vehicle"] == 100 and counters["rx.global_position_int"] == 501
    assert "DAA TA" in out.stderr or " TA " in out.stderr  # the advisory log lines
    assert "RA " in out.stderr


@pytest.mark.live  # binds a real UDP port
def test_a_udp_port_in_use_is_a_clear_error(udp_port):
    first = MavlinkLink(f"udpin:127.0.0.1:{udp_port}", Counter(), 1, 191)
    try:
        with pytest.raises(LinkError, match="in use"):
            MavlinkLink(f"udpin:127.0.0.1:{udp_port}", Counter(), 1, 191)
    finally:
        first.close()


def test_ardupilot_messages_are_decoded_not_counted_as_garbage():
    mav = ardupilotmega.MAVLink(None, 1, 1)
    frames = mav.ahrs2_encode(0.1, 0.2, 0.3, 100.0, 470000000, 85000000).pack(mav) + \
        mav.heartbeat_encode(2, 3, 0, 0, 4).pack(mav)
    counters = Counter()
    msgs = FrameScanner(counters).feed(frames, end_of_datagram=True)
    assert [m.get_type() for m in msgs] == ["AHRS2", "HEARTBEAT"]
    assert not counters


@pytest.mark.parametrize("override, message", [
    ('vehicle.id=""', "vehicle.id"), ('vehicle.id="a/*"', "vehicle.id"), ("mavlink.source_system=300", "1..255"),
    ("altitude.baro_offset_smoothing_s=0", "baro_offset_smoothing_s"), ("bogus.key=1", "configuration: unknown"),
])
def test_values_that_would_crash_later_are_rejected_up_front(override, message):
    with pytest.raises(ConfigError, match=message):
        load_config(overrides=[override])
