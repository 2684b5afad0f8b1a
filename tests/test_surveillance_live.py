"""Traffic that does not broadcast, live over real sockets (issue 30): `sitl live head-on --sensor radar` (a child
process: the ownship's DO-365 Appendix Q radar, with its errors, and no ADSB_VEHICLE) sends its scans on MAVLink
(DAA_SENSOR_MEASUREMENT) or on zenoh (`daa/<vehicle>/sensor/<id>`); `avionics run` (another child process) tracks
the returns without identity and alerts on the radar's track, published on zenoh as `sensor-<track id>`."""

from __future__ import annotations

import json
import subprocess
import sys
import threading

import pytest

from avionics.config import ZenohConfig
from avionics.io.zenoh_bus import open_session
from tests.conftest import DEADLINE_S, wait_for
from tests.test_integration_live import _wait_for_tcp

pytestmark = pytest.mark.live
START_S, DURATION_S = 50.0, 20.0  # head-on: the radar's TA at ~55 s, RA at ~65 s (sitl replay head-on --sensor radar)


@pytest.mark.parametrize("link", ["mavlink", "zenoh"])
def test_radar_only_head_on_raises_ta_and_ra_on_the_radar_track(link, udp_port, tcp_port):
    endpoint = f"tcp/127.0.0.1:{tcp_port}"
    onboard = subprocess.Popen(
        [sys.executable, "-m", "avionics.cli", "run", "--connection", f"udpin:127.0.0.1:{udp_port}",
         "--set", f'zenoh.listen=["{endpoint}"]', "--set", "vehicle.id=testuav",
         "--duration", str(DURATION_S + 10 + 2 * DEADLINE_S)],  # ended by the test; a backstop only
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    advisories: list[dict] = []
    lock = threading.Lock()

    def on_sample(sample):
        with lock:
            advisories.append(json.loads(sample.payload.to_bytes()))

    session = sitl = None
    try:
        _wait_for_tcp(tcp_port, onboard)
        session = open_session(ZenohConfig(listen=(), connect=(endpoint,)))
        subscriber = session.declare_subscriber("daa/testuav/advisories/*", on_sample)
        sitl = subprocess.run(
            [sys.executable, "-m", "avionics_sitl.cli", "live", "head-on", "--sensor", "radar", "--sensor-link", link,
             "--zenoh-connect", endpoint, "--zenoh-vehicle", "testuav", "--start", str(START_S),
             "--duration", str(DURATION_S), "--connection", f"udpout:127.0.0.1:{udp_port}"],
            capture_output=True, text=True, timeout=DURATION_S + 2 * DEADLINE_S)
        wait_for(lambda: any(a["level"] == "RA" for a in list(advisories)))
        subscriber.undeclare()
    finally:
        onboard.terminate()
        _, err = onboard.communicate(timeout=DEADLINE_S)
        if session is not None:
            session.close()
    assert sitl is not None and sitl.returncode == 0, sitl.stderr if sitl is not None else ""
    with lock:
        levels = [(a["intruder"], a["level"], a["address_source"]) for a in advisories]
    print(json.dumps({"link": link, "advisories": levels[:6]}))
    assert levels, err
    assert all(intruder.startswith("sensor-") and source == "sensor" for intruder, _, source in levels), levels
    changes = [lv for i, (_, lv, _) in enumerate(levels) if i == 0 or levels[i - 1][1] != lv]  # (refreshes repeat)
    assert changes[:2] == ["TA", "RA"], levels
