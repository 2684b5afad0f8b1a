"""docs/integration.md's recipes, as far as they can be tested without ArduPilot, PX4, mavlink-router or MAVProxy.

The blocks the doc marks `<!-- recipe: NAME -->` are read from the doc itself, so a recipe edited there is tested as
written: every `avionics run|monitor|router` command line is parsed by the real command line and its configuration
loaded (a `--config NAME` refers to the recipe block NAME), every TOML block loads, the ports that mavlink-router,
MAVProxy and sim_vehicle.py are told to send to are the ports the DAA is told to listen on, and a pymavlink stand-in
for the autopilot reaches `avionics run` on the documented default port over real UDP (the Mission Planner /
QGroundControl recipe: the intruder comes back as a re-broadcast ADSB_VEHICLE)."""

from __future__ import annotations

import configparser
import json
import re
import shlex
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import pytest

import avionics.io  # noqa: F401  (MAVLink 2 before pymavlink)
from avionics.cli import _load, build_parser
from avionics.config import load_config
from avionics.io.dialect import daa
from avionics.io.feeds.source import parse_spec
from avionics.io.link import translate_connection
from tests.conftest import DEADLINE_S, wait_for

DOC = Path(__file__).resolve().parents[1] / "docs" / "integration.md"
RECIPE = re.compile(r"<!-- recipe: (\S+) -->\n```(\w+)\n(.*?)\n```", re.S)


def recipes() -> dict[str, tuple[str, str]]:
    found: dict[str, tuple[str, str]] = {}
    for name, lang, body in RECIPE.findall(DOC.read_text()):
        assert name not in found, f"recipe {name} twice in {DOC.name}"
        found[name] = (lang, body)
    return found


def commands(body: str) -> list[list[str]]:
    """The shell lines of a block (continuations joined, comments dropped) as argv lists."""
    return [argv for line in body.replace("\\\n", " ").splitlines()
            if (argv := shlex.split(line, comments=True))]


def avionics_lines(name: str, sub: str) -> list[list[str]]:
    return [argv[1:] for argv in commands(recipes()[name][1]) if argv[:2] == ["avionics", sub]]


def port_of(connection: str) -> int:
    return int(connection.rsplit(":", 1)[1])


def test_the_doc_has_every_recipe_it_promises():
    names = set(recipes())
    assert {"ardupilot-sitl-start", "mavproxy-output-add", "ardupilot-sitl-params", "ardupilot-sitl-run",
            "px4-sitl-run", "px4-sitl-streams", "mavlink-router.conf", "mavlink-router-run", "flight.toml",
            "mavproxy-companion", "receiver-feed-run", "monitor-local", "monitor-fleet", "gcs-rebroadcast-run",
            "gcs-rebroadcast.toml"} <= names
    assert "14550" not in recipes()["ardupilot-sitl-run"][1] + recipes()["px4-sitl-run"][1]


def test_every_toml_recipe_loads(tmp_path):
    tomls = {name: body for name, (lang, body) in recipes().items() if lang == "toml"}
    assert tomls
    for name, body in tomls.items():
        path = tmp_path / name
        path.write_text(body)
        load_config(str(path))  # a ConfigError (unknown key, bad value) fails the test


def test_every_avionics_command_line_is_accepted(tmp_path):
    """Parsed by the real argparse parser, configuration loaded with --config/--set/--connection/--no-zenoh as
    `avionics run` would, connection strings translated, --traffic specs checked: what cmd_run does before it opens
    anything."""
    for name, (lang, body) in recipes().items():
        if lang == "toml":
            (tmp_path / name).write_text(body)
    runs = 0
    for name, (lang, body) in recipes().items():
        if lang != "sh":
            continue
        for argv in commands(body):
            if argv[0] != "avionics":
                continue
            argv = list(argv[1:])
            if "--config" in argv:
                at = argv.index("--config") + 1
                argv[at] = str(tmp_path / argv[at])  # the recipe block of that name
            args = build_parser().parse_args(argv)
            if args.command != "run":
                continue
            config = _load(args)
            connection, _ = translate_connection(config.mavlink.connection, config.mavlink.baud)
            assert connection.startswith(("udpin:", "udpout:", "tcp:", "tcpin:", "/dev/")), (name, connection)
            for spec in args.traffic:
                parse_spec(spec)
            runs += 1
    assert runs >= 8


def test_the_forwarders_send_where_the_daa_listens():
    default = load_config().mavlink.connection
    assert default == "udpin:0.0.0.0:14540"
    # ArduPilot SITL: sim_vehicle.py --out and MAVProxy's `output add` point at the default port
    start = [a for argv in commands(recipes()["ardupilot-sitl-start"][1]) for a in argv if a.startswith("--out=")]
    assert [port_of(a) for a in start] == [port_of(default)]
    assert recipes()["mavproxy-output-add"][1].split() == ["output", "add", f"127.0.0.1:{port_of(default)}"]
    # ArduPilot and PX4 SITL recipes run on the default connection
    for name in ("ardupilot-sitl-run", "px4-sitl-run"):
        (run,) = avionics_lines(name, "run")
        assert "--connection" not in run
    # PX4: the extra onboard instance's remote port (-o) is where the second recipe listens
    (mav,) = commands(recipes()["px4-sitl-second-instance"][1])
    (run,) = avionics_lines("px4-sitl-second-instance-run", "run")
    assert mav[mav.index("-o") + 1] == str(port_of(run[run.index("--connection") + 1]))
    # mavlink-router: the daa endpoint is the DAA's connection, the GCS keeps 14550
    router = configparser.ConfigParser(inline_comment_prefixes=("#",))
    router.read_string(recipes()["mavlink-router.conf"][1])
    (run,) = avionics_lines("mavlink-router-run", "run")
    connection = run[run.index("--connection") + 1]
    assert router["UdpEndpoint daa"]["Mode"] == "Normal"
    assert (router["UdpEndpoint daa"]["Address"], int(router["UdpEndpoint daa"]["Port"])) == \
        (connection.split(":")[1], port_of(connection))
    assert int(router["UdpEndpoint gcs"]["Port"]) == 14550
    # MAVProxy on the companion: its first output is the DAA
    (proxy, run) = commands(recipes()["mavproxy-companion"][1])
    outs = [a.split("=", 1)[1] for a in proxy if a.startswith("--out=")]
    assert outs[0] == "udpout:" + run[run.index("--connection") + 1].split(":", 1)[1]


def _port_free(port: int) -> bool:
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        try:
            s.bind(("0.0.0.0", port))
        except OSError:
            return False
    return True


@pytest.mark.live  # `avionics run` in a process of its own, on the real default port
def test_a_pymavlink_autopilot_reaches_avionics_run_on_the_default_port():
    port = port_of(load_config().mavlink.connection)
    if not _port_free(port):
        pytest.skip(f"UDP {port} is in use on this machine (a PX4 SITL, MAVSDK, another DAA?)")
    (run,) = avionics_lines("gcs-rebroadcast-run", "run")
    proc = subprocess.Popen([sys.executable, "-m", "avionics.cli", *run, "--no-zenoh", "--counters"],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    autopilot = daa.MAVLink(None, srcSystem=1, srcComponent=1)
    receiver = daa.MAVLink(None, srcSystem=1, srcComponent=156)  # an ADS-B receiver's re-sent traffic
    parser = daa.MAVLink(None)
    parser.robust_parsing = True
    seen: list = []
    icao, t0 = 0xABC123, time.monotonic()
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as sock:
        sock.bind(("127.0.0.1", 0))
        sock.setblocking(False)

        def step() -> bool:
            if proc.poll() is not None:
                return True  # reported below
            t = time.monotonic() - t0
            lat = 47.0 + 0.018 - t * 40.0 / 111_320.0  # 2 km north, southbound at 40 m/s
            frames = [
                autopilot.global_position_int_encode(int(t * 1000), 470000000, 80000000, 500000, 50000,
                                                     0, 0, 0, 0).pack(autopilot),
                receiver.adsb_vehicle_encode(icao, int(lat * 1e7), 80000000, 1, 520000, 18000, 4000, 0,
                                             b"TEST1", 2, 0, 0x1F, 1200).pack(receiver),
            ]
            for frame in frames:
                sock.sendto(bytes(frame), ("127.0.0.1", port))
            try:
                while True:
                    seen.extend(parser.parse_buffer(sock.recv(65536)) or [])
            except BlockingIOError:
                pass
            return heartbeat() and rebroadcast()

        def heartbeat() -> bool:
            return any(m.get_type() == "HEARTBEAT" and m.get_srcComponent() == 191 for m in seen)

        def rebroadcast() -> bool:
            return any(m.get_type() == "ADSB_VEHICLE" and m.get_srcComponent() == 192 and m.ICAO_address == icao
                       for m in seen)

        try:
            wait_for(step, period_s=0.2)
            assert proc.poll() is None, proc.communicate()[1]
            assert heartbeat(), "no HEARTBEAT from component 191 came back"
            assert rebroadcast(), "the intruder was not re-broadcast as ADSB_VEHICLE from component 192"
        finally:
            if proc.poll() is None:
                proc.send_signal(signal.SIGTERM)
            out, err = proc.communicate(timeout=DEADLINE_S)
    assert proc.returncode == 0, err
    counters = json.loads(out[out.index("{"):])
    assert counters["rx.adsb_vehicle"] > 0 and counters["rx.global_position_int"] > 0
