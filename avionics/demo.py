"""`avionics demo`: the onboard process and the SITL encounter as two processes on loopback.

The onboard process (`avionics run`, a child process) listens for MAVLink on udpin:127.0.0.1:PORT and
publishes on zenoh at tcp/127.0.0.1:ZENOH_PORT. This process is the SITL autopilot with its ADS-B receiver:
it flies the encounter in real time, and prints the advisory timeline as it arrives, from the COLLISION
messages the autopilot receives and the advisory JSON a zenoh subscriber receives.
"""

from __future__ import annotations

import json
import math
import socket
import subprocess
import sys
import threading
import time

from avionics.config import ZenohConfig
from avionics.core.units import FT

DEMO_START_S = {"head-on": 40.0}  # skip the quiet minute of the head-on: TA ~15 s into the demo
THREAT = {0: "NONE", 1: "TA  ", 2: "RA  "}


def _listening(port: int) -> bool:
    with socket.socket() as probe:
        return probe.connect_ex(("127.0.0.1", port)) == 0


def demo(scenario_name: str = "head-on", port: int = 14650, zenoh_port: int = 17447, noise: str = "default") -> int:
    from avionics.io.zenoh_bus import open_session
    from sitl.impairments import PRESETS
    from sitl.live import fly
    from sitl.scenario import load_encounter

    scenario = load_encounter(scenario_name)
    start = DEMO_START_S.get(scenario_name, 0.0)
    duration = scenario.duration_s - start
    endpoint = f"tcp/127.0.0.1:{zenoh_port}"
    onboard = subprocess.Popen([
        sys.executable, "-m", "avionics.cli", "--quiet", "run", "--connection", f"udpin:127.0.0.1:{port}",
        "--set", f'zenoh.listen=["{endpoint}"]', "--duration", f"{duration + 5:.0f}", "--counters",
    ], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    print(f"avionics demo: '{scenario.name}' from t={start:.0f} s for {duration:.0f} s of real time\n"
          f"  onboard DAA process pid {onboard.pid}: MAVLink udpin:127.0.0.1:{port}, zenoh {endpoint}\n"
          f"  SITL autopilot + ADS-B receiver (this process): ownship 5 Hz, ADS-B 1 Hz, noise '{noise}'\n")
    deadline = time.monotonic() + 30.0
    while not _listening(zenoh_port):  # the onboard process is up once its zenoh endpoint listens
        if onboard.poll() is not None or time.monotonic() > deadline:
            onboard.kill()
            print(f"onboard process did not start:\n{onboard.communicate()[1]}", file=sys.stderr)
            return 1
        time.sleep(0.1)
    lock = threading.Lock()
    zenoh_advisories = []
    session = open_session(ZenohConfig(listen=(), connect=(endpoint,)))

    def on_advisory(sample) -> None:
        payload = json.loads(sample.payload.to_bytes())
        with lock:
            previous = zenoh_advisories[-1] if zenoh_advisories else {}
            if (previous.get("level"), previous.get("ra_words")) != (payload["level"], payload.get("ra_words")):
                tau = "--" if payload["mod_tau_s"] is None else f"{payload['mod_tau_s']:4.1f} s"
                vmd = "?" if payload["vmd_m"] is None else f"{payload['vmd_m'] / FT:+5.0f} ft"
                ra = f" {payload['ra_words']}" if payload.get("ra_words") else ""
                pc = "" if payload.get("pc_ra") is None else f"  Pc(RA) {payload['pc_ra']:.2f}"
                print(f"  zenoh      {payload['level']:4s}{ra} {payload['intruder']}  reason {payload['reason']:9s} "
                      f"mod tau {tau}  range {payload['range_m']:6.0f} m  CPA in {payload['t_cpa_s']:5.1f} s  "
                      f"HMD {payload['hmd_m']:5.0f} m  VMD {vmd}{pc}", flush=True)
            zenoh_advisories.append(payload)

    subscriber = session.declare_subscriber("daa/*/advisories/**", on_advisory)
    last_level: dict[int, int] = {}

    def on_receive(received) -> None:
        msg = received.msg
        if msg.get_type() == "COLLISION" and last_level.get(msg.id) != msg.threat_level:
            last_level[msg.id] = msg.threat_level
            alt = "?" if math.isnan(msg.altitude_minimum_delta) else f"{msg.altitude_minimum_delta:+.0f} m"
            with lock:
                print(f"t={received.time_s:6.1f} s  COLLISION {THREAT[msg.threat_level]} id {msg.id:06X} "
                      f"action {msg.action}  CPA in {msg.time_to_minimum_delta:5.1f} s  "
                      f"horizontal {msg.horizontal_minimum_delta:5.0f} m  vertical {alt}", flush=True)

    try:
        recording = fly(scenario, f"udpout:127.0.0.1:{port}", PRESETS[noise], start_s=start,
                        duration_s=duration, on_receive=on_receive)
    finally:
        onboard.terminate()
        out, err = onboard.communicate(timeout=15)
        subscriber.undeclare()
        session.close()
    if onboard.returncode not in (0, -15):
        print(f"onboard process failed ({onboard.returncode}):\n{err}", file=sys.stderr)
    counters = json.loads(out) if out.strip() else {}
    collisions = recording.of_type("COLLISION")
    print(f"\nSITL sent {recording.sent} MAVLink messages; received {len(collisions)} COLLISION, "
          f"{len(recording.of_type('STATUSTEXT'))} STATUSTEXT, {len(recording.of_type('HEARTBEAT'))} HEARTBEAT; "
          f"zenoh advisories received: {len(zenoh_advisories)}")
    rejected = {k: v for k, v in counters.items() if not k.startswith(("rx.", "track.", "assessment."))}
    print(f"onboard input counters: { {k: v for k, v in counters.items() if k.startswith('rx.')} }; "
          f"rejections: {rejected or 'none'}")
    levels = [THREAT[r.msg.threat_level].strip() for r in collisions]
    ok = "TA" in levels and "RA" in levels and levels[-1] == "NONE"
    print("result:", "TA, RA and clear received" if ok else f"unexpected advisory sequence {levels}")
    return 0 if ok else 1
