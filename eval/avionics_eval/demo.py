"""`avionics demo`: the onboard process and the SITL encounter as two processes on loopback.

The onboard process (`avionics run`, a child process) listens for MAVLink on udpin:127.0.0.1:PORT and
publishes on zenoh at tcp/127.0.0.1:ZENOH_PORT. This process is the SITL autopilot with its ADS-B receiver:
it flies the encounter in real time, and prints the advisory timeline as it arrives, from the COLLISION
messages the autopilot receives and the advisory JSON a zenoh subscriber receives.

It fails fast, in one line: a bad scenario before anything starts (ScenarioError, exit 2), a port in use before
the onboard process starts (LinkError / ZenohBusError, exit 1), and an onboard process that exits during the
flight stops the flight at once (OnboardError, exit 1).
"""

from __future__ import annotations

import json
import math
import signal
import socket
import subprocess
import sys
import threading
import time

from avionics.config import ZenohConfig
from avionics.contract.bands import BAND_KINDS
from avionics.base.units import FT
from avionics_sitl.encounters import ScenarioError, load_scenario  # noqa: F401  (ScenarioError: exit 2, avionics_eval.cli)

DEMO_START_S = {"head-on": 40.0}  # skip the quiet minute of the head-on: TA ~15 s into the demo
THREAT = {0: "NONE", 1: "TA  ", 2: "RA  "}
START_TIMEOUT_S = 30.0  # for the onboard process to listen on its zenoh port


class OnboardError(RuntimeError):
    """The onboard process did not start, or exited before the demo stopped it."""


def check_ports_free(port: int, zenoh_port: int) -> None:
    """Bind both loopback ports once, as the onboard process will: a port in use is an error now, not after a
    flight with nobody listening (or with somebody else's process answering)."""
    from avionics.io.link import LinkError
    from avionics.io.zenoh_bus import ZenohBusError

    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as probe:  # as the link: without SO_REUSEADDR
        try:
            probe.bind(("127.0.0.1", port))
        except OSError as exc:
            raise LinkError(f"demo: MAVLink UDP port 127.0.0.1:{port} is in use ({exc.strerror}); "
                            f"pick another with --port") from exc
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as probe:
        probe.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)  # as zenoh's listener: TIME_WAIT is free
        try:
            probe.bind(("127.0.0.1", zenoh_port))
        except OSError as exc:
            raise ZenohBusError(f"demo: zenoh TCP port 127.0.0.1:{zenoh_port} is in use ({exc.strerror}); "
                                f"pick another with --zenoh-port") from exc


def _onboard_failure(returncode: int, stderr: str, when: str) -> OnboardError:
    """One line: how the onboard process ended, and its own one-line error (`avionics: ...`) if it printed one
    (its other stderr lines are log lines)."""
    errors = [line.strip() for line in stderr.splitlines() if line.startswith("avionics: ")]
    if returncode < 0:
        number = -returncode
        how = f"was killed by {signal.Signals(number).name if number in signal.valid_signals() else number}"
    else:
        how = f"exited with code {returncode}"
    reason = f": {errors[-1].removeprefix('avionics: ').replace('; traceback above', '')}" if errors else ""
    return OnboardError(f"demo: the onboard process (avionics run) {how} {when}{reason}")


def _listening(port: int) -> bool:
    with socket.socket() as probe:
        return probe.connect_ex(("127.0.0.1", port)) == 0


def _start_onboard(port: int, endpoint: str, duration_s: float, profile: str | None,
                   sets: tuple[str, ...] = ()) -> subprocess.Popen:
    return subprocess.Popen([
        sys.executable, "-m", "avionics.cli", "--quiet", "run", "--connection", f"udpin:127.0.0.1:{port}",
        "--set", f'zenoh.listen=["{endpoint}"]', "--duration", f"{duration_s + 5:.0f}", "--counters",
        *(["--set", f"advisory.profile={profile}"] if profile else []), *(a for s in sets for a in ("--set", s)),
    ], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)


def bands_text(payload: dict) -> str:
    """The conflict (and recovery) intervals of a bands sample, one kind after the other: what a pilot would have
    to keep out of (docs/zenoh.md, Bands)."""
    parts = []
    for kind in BAND_KINDS:
        unit = kind.per_display_unit
        shown = [f"{b['region']} {b['lower'] / unit:.0f}-{b['upper'] / unit:.0f}" for b in payload[kind.name]
                 if b["region"] != "NONE"]
        parts.append(f"{kind.label} [{kind.display_unit}] "
                     + (", ".join(shown) if shown else "clear" if payload[kind.name] else "--"))
    return "; ".join(parts)


def _wait_listening(onboard: subprocess.Popen, zenoh_port: int, endpoint: str) -> None:
    """The onboard process is up once its zenoh endpoint listens; OnboardError if it exits or takes too long."""
    deadline = time.monotonic() + START_TIMEOUT_S
    while not _listening(zenoh_port):
        if onboard.poll() is not None:
            raise _onboard_failure(onboard.returncode, onboard.communicate()[1], "at start-up")
        if time.monotonic() > deadline:
            raise OnboardError(f"demo: the onboard process did not listen on {endpoint} within "
                               f"{START_TIMEOUT_S:.0f} s")
        time.sleep(0.1)


def _stop(onboard: subprocess.Popen) -> tuple[str, str]:
    """SIGTERM (the onboard process then prints its counters); SIGKILL if it has not exited within 15 s."""
    if onboard.poll() is None:
        onboard.terminate()
    try:
        return onboard.communicate(timeout=15)
    except subprocess.TimeoutExpired:
        onboard.kill()
        return onboard.communicate()


def demo(scenario_name: str = "head-on", port: int = 14650, zenoh_port: int = 17447, noise: str = "default",
         profile: str | None = None) -> int:
    """profile: the onboard alerting profile (advisory.profile; default tcas2). A DO-365 one (do365, f3442, ...)
    prints its alert levels and guidance bands as they arrive over zenoh."""
    from avionics.io.zenoh_bus import open_session
    from avionics_sitl.impairments import PRESETS
    from avionics_sitl.live import fly

    scenario = load_scenario(scenario_name)
    do365 = profile_has_bands(profile)
    start = 0.0 if do365 else DEMO_START_S.get(scenario_name, 0.0)  # DO-365 alerts come a minute earlier
    duration = scenario.duration_s - start
    endpoint = f"tcp/127.0.0.1:{zenoh_port}"
    check_ports_free(port, zenoh_port)
    onboard = _start_onboard(port, endpoint, duration, profile)
    try:
        print(f"avionics demo: '{scenario.name}' from t={start:.0f} s for {duration:.0f} s of real time\n"
              f"  onboard DAA process pid {onboard.pid}: MAVLink udpin:127.0.0.1:{port}, zenoh {endpoint}\n"
              f"  SITL autopilot + ADS-B receiver (this process): ownship 5 Hz, ADS-B 1 Hz, noise '{noise}'\n"
              f"  alerting profile: {profile or 'tcas2 (default)'}\n",
              flush=True)
        _wait_listening(onboard, zenoh_port, endpoint)
        # The flight stops as soon as the onboard process exits: nothing would answer for the rest of it.
        onboard_exited = threading.Event()
        threading.Thread(target=lambda: (onboard.wait(), onboard_exited.set()), name="demo-onboard-watch",
                         daemon=True).start()
        lock = threading.Lock()
        zenoh_advisories = []
        session = open_session(ZenohConfig(listen=(), connect=(endpoint,)))

        def on_advisory(sample) -> None:
            payload = json.loads(sample.payload.to_bytes())
            with lock:
                previous = zenoh_advisories[-1] if zenoh_advisories else {}
                key = ("level", "ra_words", "alert_name")
                if [previous.get(k) for k in key] != [payload.get(k) for k in key]:
                    tau = "--" if payload["mod_tau_s"] is None else f"{payload['mod_tau_s']:4.1f} s"
                    vmd = "?" if payload["vmd_m"] is None else f"{payload['vmd_m'] / FT:+5.0f} ft"
                    ra = f" {payload['ra_words']}" if payload.get("ra_words") else ""
                    pc = "" if payload.get("pc_ra") is None else f"  Pc(RA) {payload['pc_ra']:.2f}"
                    alert = f" {payload['alert_name']}" if payload.get("alert_name") not in (None, payload["level"]) else ""
                    print(f"  zenoh      {payload['level']:4s}{alert}{ra} {payload['intruder']}  reason "
                          f"{payload['reason']:9s} mod tau {tau}  range {payload['range_m']:6.0f} m  "
                          f"CPA in {payload['t_cpa_s']:5.1f} s  HMD {payload['hmd_m']:5.0f} m  VMD {vmd}{pc}",
                          flush=True)
                zenoh_advisories.append(payload)

        bands_seen: list[str] = []

        def on_bands(sample) -> None:
            text = bands_text(json.loads(sample.payload.to_bytes()))
            shape = [word for word in text.split() if word in ("FAR", "MID", "NEAR", "RECOVERY", "clear", "--")]
            with lock:
                if not bands_seen or bands_seen[-1][0] != shape:
                    print(f"  zenoh      bands {text}", flush=True)
                bands_seen.append((shape, text))

        subscriber = session.declare_subscriber("daa/*/advisories/**", on_advisory)
        bands_subscriber = session.declare_subscriber("daa/*/bands", on_bands)
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
                            duration_s=duration, on_receive=on_receive, stop=onboard_exited)
            died = onboard_exited.is_set()  # read before we stop it ourselves
        finally:
            out, err = _stop(onboard)
            subscriber.undeclare()
            bands_subscriber.undeclare()
            session.close()
        if died:
            raise _onboard_failure(onboard.returncode, err, "during the flight")
        if onboard.returncode not in (0, -signal.SIGTERM):
            raise _onboard_failure(onboard.returncode, err, "when stopped")
    finally:
        if onboard.poll() is None:  # an error on the way (zenoh session, Ctrl-C): no orphan onboard process
            _stop(onboard)
    counters = json.loads(out) if out.strip() else {}
    collisions = recording.of_type("COLLISION")
    print(f"\nSITL sent {recording.sent} MAVLink messages; received {len(collisions)} COLLISION, "
          f"{len(recording.of_type('STATUSTEXT'))} STATUSTEXT, {len(recording.of_type('HEARTBEAT'))} HEARTBEAT; "
          f"zenoh advisories received: {len(zenoh_advisories)}")
    # what was received or accepted is not a rejection (the rest are the counted refusals and drops)
    accepted = ("rx.", "track.", "assessment.", "link.datagrams", "signing.accepted", "plane.recentred", "baro.recovered")
    rejected = {k: v for k, v in counters.items() if not k.startswith(accepted)}
    print(f"onboard input counters: { {k: v for k, v in counters.items() if k.startswith('rx.')} }; "
          f"rejections: {rejected or 'none'}")
    levels = [THREAT[r.msg.threat_level].strip() for r in collisions]
    ok = "TA" in levels and "RA" in levels and levels[-1] == "NONE"
    if not do365:
        print("result:", "TA, RA and clear received" if ok else f"unexpected advisory sequence {levels}")
        return 0 if ok else 1
    names = [p.get("alert_name") for p in zenoh_advisories]
    sequence = [n for i, n in enumerate(names) if i == 0 or n != names[i - 1]]  # the DO-365 levels in turn
    conflict_bands = any(word in ("MID", "NEAR") for shape, _ in bands_seen for word in shape)
    print(f"guidance bands received: {len(bands_seen)} ({'with' if conflict_bands else 'without'} conflict bands)")
    # the alert escalates to the warning (the levels are nested: a head-on 11 km out is preventive and corrective
    # at once, as in DAIDALUS) and ends
    ok = ok and conflict_bands and len(sequence) >= 3 and sequence[-2:] == ["WARNING", "NONE"]
    print("result:", f"DO-365 levels {' -> '.join(sequence)} received, and guidance bands" if ok
          else f"unexpected sequence: COLLISION {levels}, DO-365 levels {sequence}")
    return 0 if ok else 1


GUIDANCE_START_S = {"head-on": 50.0}  # with small-uas: TA ~55 s, RA ~65 s, CPA 86 s, clear ~91 s
GUIDANCE_END_MARGIN_S = 3.0  # the flight ends this long after the mission was given back


def demo_guidance(scenario_name: str = "head-on", port: int = 14650, zenoh_port: int = 17447,
                  noise: str = "default", profile: str | None = None, autopilot: str = "ardupilot",
                  flight: dict | None = None) -> int:
    """`avionics demo --guidance`: a multirotor on its mission (the scenario's ownship path, flown in AUTO by the
    simulated ArduCopter or PX4 of sitl/avionics_sitl/guided.py) meets the encounter; the onboard process
    (guidance.mode=execute, vehicle.profile=multirotor, advisory.profile small-uas unless given) commands the
    avoidance over MAVLink and gives the mission back. Prints the guidance's states as zenoh carries them, the
    autopilot's modes, and the truth miss without and with; exit 0 when the flown miss is outside NMAC
    (100 ft at the closest approach) and the vehicle is back on its mission. flight: a dict that receives the
    `recording` (sitl/avionics_sitl/live.py), the `copter`, the zenoh `guidance` payloads and the `misses`."""
    from avionics.advisory.vehicle import load_vehicle
    from avionics.guidance import ardupilot, px4
    from avionics.io.zenoh_bus import open_session
    from avionics_sitl.guided import SimCopter
    from avionics_sitl.impairments import PRESETS
    from avionics_sitl.live import fly_guided
    from avionics_sitl.replay import _vertical_miss

    scenario = load_scenario(scenario_name)
    start = GUIDANCE_START_S.get(scenario_name, 0.0)
    duration = scenario.duration_s - start
    endpoint = f"tcp/127.0.0.1:{zenoh_port}"
    check_ports_free(port, zenoh_port)
    profile = profile or "small-uas"
    onboard = _start_onboard(port, endpoint, duration, profile, ("vehicle.profile=multirotor",
                                                                 "guidance.mode=execute"))
    contract = px4 if autopilot == "px4" else ardupilot
    copter = SimCopter(load_vehicle("multirotor"), firmware=autopilot)
    states: list[dict] = []
    try:
        print(f"avionics demo --guidance: '{scenario.name}' from t={start:.0f} s; a multirotor on its mission, "
              f"simulated {'PX4' if autopilot == 'px4' else 'ArduCopter'} (this process) on udpin:127.0.0.1:{port}; "
              f"onboard guidance.mode=execute, profile {profile}, zenoh {endpoint}\n", flush=True)
        _wait_listening(onboard, zenoh_port, endpoint)
        onboard_exited = threading.Event()
        stop = threading.Event()  # the onboard process exited, or the mission was given back: the demo is over
        threading.Thread(target=lambda: (onboard.wait(), onboard_exited.set(), stop.set()),
                         name="demo-onboard-watch", daemon=True).start()
        lock = threading.Lock()
        session = open_session(ZenohConfig(listen=(), connect=(endpoint,)))
        resumed_at: list[float] = []

        def on_guidance(sample) -> None:
            payload = json.loads(sample.payload.to_bytes())
            with lock:
                if not states or states[-1]["state"] != payload["state"]:
                    rate = payload["target_vertical_rate_mps"]
                    print(f"  zenoh      guidance {payload['state']:10s} {payload['manoeuvre']:7s} "
                          f"{'' if rate is None else f'{rate:+.1f} m/s':9s} {payload['reason']}  "
                          f"(autopilot {payload['autopilot_mode']})", flush=True)
                states.append(payload)

        modes_seen = [copter.mode]

        def on_receive(received) -> None:
            msg = received.msg
            if msg.get_type() == "STATUSTEXT" and msg.text.startswith("DAA GUIDANCE"):
                print(f"t={received.time_s:6.1f} s  STATUSTEXT {msg.text}", flush=True)
            if copter.mode != modes_seen[-1]:
                modes_seen.append(copter.mode)
                print(f"t={received.time_s:6.1f} s  autopilot mode {contract.mode_name(copter.mode)}", flush=True)
                if len(modes_seen) >= 3 and copter.mode == modes_seen[0]:
                    resumed_at.append(received.time_s)
            if resumed_at and received.time_s > resumed_at[0] + GUIDANCE_END_MARGIN_S:
                stop.set()  # the guidance has said idle by now (HEARTBEAT, 1 Hz)

        subscriber = session.declare_subscriber("daa/*/guidance", on_guidance)
        try:
            recording = fly_guided(scenario, f"udpout:127.0.0.1:{port}", PRESETS[noise], copter, start_s=start,
                                   duration_s=duration, on_receive=on_receive, stop=stop)
            died = onboard_exited.is_set()
        finally:
            _, err = _stop(onboard)
            subscriber.undeclare()
            session.close()
        if died:
            raise _onboard_failure(onboard.returncode, err, "during the flight")
    finally:
        if onboard.poll() is None:
            _stop(onboard)
    own, intruders = scenario.trajectories()
    ok = True
    misses = []
    for spec, traj in zip(scenario.intruders, intruders):
        miss = _vertical_miss(scenario, own, traj, spec.name, recording.flown)
        misses.append(miss)
        outside = miss.vmd_with_m > 100 * FT or miss.hmd_flown_m > 500 * FT
        ok = ok and outside
        print(f"\ntruth miss with {spec.name}: without guidance HMD {miss.hmd_m:.0f} m VMD "
              f"{miss.vmd_without_m / FT:.0f} ft; flown HMD {miss.hmd_flown_m:.0f} m VMD {miss.vmd_with_m / FT:.0f} ft "
              f"({'outside' if outside else 'inside'} NMAC)")
    modes = [contract.mode_name(m) for _, m in copter.modes]
    mission = (px4.PX4 if autopilot == "px4" else ardupilot.ARDUCOPTER).return_mode
    resumed = len(copter.modes) >= 3 and copter.mode == mission  # taken and given back
    print(f"autopilot modes: {' -> '.join(modes)}")
    ok = ok and resumed
    print("result:", "avoided, and back on the mission" if ok else "NOT avoided or not back on the mission")
    if flight is not None:
        flight.update(recording=recording, copter=copter, guidance=states, misses=misses)
    return 0 if ok else 1


def profile_has_bands(profile: str | None) -> bool:
    from avionics.advisory.tables import load_profile

    return profile is not None and load_profile(profile).alerter is not None
