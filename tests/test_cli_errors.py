"""Every command-line error is one line on stderr, no traceback, with the README's exit code:
0 success, 1 a link, zenoh session or listening socket could not be opened, 2 configuration, scenario or file.

Each case runs the real command as a subprocess. Busy ports are real sockets bound on 127.0.0.1 first. There are
no sleeps and no timing asserts: waits poll with a generous deadline, which only bounds how long a failure takes.
"""

import os
import queue
import signal
import socket
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

pytestmark = pytest.mark.live  # subprocesses and sockets on loopback

ROOT = Path(__file__).resolve().parent.parent
TIMEOUT_S = 60.0


def free_port(kind: int) -> int:
    with socket.socket(socket.AF_INET, kind) as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


EVAL_CLI = "avionics_eval.cli"  # the `avionics` console script: the flight commands of avionics.cli plus demo, bench


def cli(*argv: str, module: str = "avionics.cli") -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", module, *argv], capture_output=True, text=True, timeout=TIMEOUT_S,
                          cwd=ROOT)


def assert_one_line_error(proc: subprocess.CompletedProcess, code: int, *names: str) -> str:
    assert "Traceback" not in proc.stderr, proc.stderr
    lines = proc.stderr.splitlines()
    assert len(lines) == 1, proc.stderr
    assert proc.returncode == code, (proc.returncode, proc.stderr)
    for name in names:
        assert name in lines[0], (name, lines[0])
    return lines[0]


@pytest.fixture
def busy_tcp_port():
    """A port with a listener on 127.0.0.1, as another program would hold it."""
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind(("127.0.0.1", 0))
        s.listen()
        yield s.getsockname()[1]


@pytest.fixture
def busy_udp_port():
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.bind(("127.0.0.1", 0))
        yield s.getsockname()[1]


# --- configuration, scenario and file errors: exit 2 --------------------------------------------------------------

def test_demo_unknown_scenario():
    line = assert_one_line_error(cli("demo", "--scenario", "no-such", module=EVAL_CLI), 2, "avionics:",
                                 "'no-such'")
    assert "unknown encounter" in line and "head-on" in line  # says what would have been accepted


def test_demo_malformed_daa_scenario(tmp_path):
    path = tmp_path / "broken.daa"
    path.write_text("NAME lat lon alt\nownship 1 2\n")
    line = assert_one_line_error(cli("demo", "--scenario", str(path), module=EVAL_CLI), 2, str(path))
    assert "header lacks" in line


def test_demo_missing_scenario_file(tmp_path):
    path = tmp_path / "absent.daa"
    assert_one_line_error(cli("demo", "--scenario", str(path), module=EVAL_CLI), 2, str(path), "No such file")


def test_run_tlog_out_into_a_missing_directory(tmp_path):
    target = tmp_path / "no-such-dir" / "flight.tlog"
    port = free_port(socket.SOCK_DGRAM)
    proc = cli("run", "--no-zenoh", "--connection", f"udpin:127.0.0.1:{port}", "--duration", "30",
               "--tlog-out", str(target))
    assert_one_line_error(proc, 2, "--tlog-out", "no such directory", str(target.parent))
    assert not target.parent.exists()


@pytest.mark.parametrize("endpoint", ["foo", "tcp/foo", "tcp/127.0.0.1:0", "tcp/127.0.0.1:99999",
                                      "bogus/127.0.0.1:7447"])
def test_monitor_connect_endpoint_is_validated_up_front(endpoint):
    # Before: `foo` was retried once a second until --duration, then exit 0.
    proc = cli("monitor", "--connect", endpoint, "--http", "127.0.0.1:0", "--duration", "30")
    assert_one_line_error(proc, 2, "configuration error", f"'{endpoint}'")


def test_monitor_tui_connect_endpoint_is_validated_up_front():
    proc = cli("monitor", "--tui", "--connect", "foo", "--duration", "30")
    assert_one_line_error(proc, 2, "zenoh connect endpoint 'foo'")


def test_router_listen_endpoint_is_validated():
    assert_one_line_error(cli("router", "--listen", "foo"), 2, "zenoh listen endpoint 'foo'")


@pytest.mark.parametrize("address", ["127.0.0.1:notaport", "nohost", "127.0.0.1:70000"])
def test_monitor_malformed_http_address(address):
    port = free_port(socket.SOCK_STREAM)
    proc = cli("monitor", "--http", address, "--connect", f"tcp/127.0.0.1:{port}", "--duration", "30")
    assert_one_line_error(proc, 2, "--http", f"'{address}'")


def test_usage_error_is_one_line():
    assert_one_line_error(cli("demo", "--port", "70000", module=EVAL_CLI), 2, "--port", "70000")
    assert_one_line_error(cli("no-such-command"), 2, "avionics: error:")


def test_sitl_unknown_encounter_and_unwritable_output(tmp_path):
    assert_one_line_error(cli("live", "no-such", module="avionics_sitl.cli"), 2, "sitl:", "'no-such'")
    out = tmp_path / "missing" / "advisories.csv"
    assert_one_line_error(cli("replay", "head-on", "--out", str(out), module="avionics_sitl.cli"), 2, "--out",
                          "no such directory")


# --- links, sessions and listening sockets that cannot be opened: exit 1 ------------------------------------------

def test_sitl_live_bad_connection_string():
    proc = cli("live", "head-on", "--connection", "bogus:foo", "--duration", "30", module="avionics_sitl.cli")
    assert_one_line_error(proc, 1, "sitl:", "cannot open MAVLink connection", "'bogus:foo'")


@pytest.mark.parametrize("port", ["99999", "0"])
def test_run_with_a_udp_port_out_of_range(port):
    """One line (no start-up banner before it), exit 1."""
    proc = cli("run", "--connection", f"udpin:127.0.0.1:{port}", "--no-zenoh", "--duration", "5")
    assert_one_line_error(proc, 1, "avionics:", "cannot open MAVLink connection", f"UDP port {port} is not in 1..65535")


def test_monitor_http_port_in_use(busy_tcp_port):
    zenoh_port = free_port(socket.SOCK_STREAM)
    proc = cli("monitor", "--http", f"127.0.0.1:{busy_tcp_port}", "--connect", f"tcp/127.0.0.1:{zenoh_port}",
               "--duration", "30")
    assert_one_line_error(proc, 1, f"127.0.0.1:{busy_tcp_port}", "in use")


def test_demo_zenoh_port_in_use_fails_before_flying(busy_tcp_port):
    # Before: the onboard process died at once, the demo flew its 80 s to nobody, then said so.
    proc = cli("demo", "--port", str(free_port(socket.SOCK_DGRAM)), "--zenoh-port", str(busy_tcp_port),
               module=EVAL_CLI)
    assert_one_line_error(proc, 1, f"zenoh TCP port 127.0.0.1:{busy_tcp_port} is in use", "--zenoh-port")
    assert "pid" not in proc.stdout  # refused before the onboard process was started


def test_demo_mavlink_port_in_use_fails_before_flying(busy_udp_port):
    proc = cli("demo", "--port", str(busy_udp_port), "--zenoh-port", str(free_port(socket.SOCK_STREAM)),
               module=EVAL_CLI)
    assert_one_line_error(proc, 1, f"MAVLink UDP port 127.0.0.1:{busy_udp_port} is in use", "--port")
    assert "pid" not in proc.stdout


def _listening(port: int) -> bool:
    with socket.socket() as probe:
        return probe.connect_ex(("127.0.0.1", port)) == 0


def test_demo_stops_at_once_when_the_onboard_process_dies():
    udp, tcp = free_port(socket.SOCK_DGRAM), free_port(socket.SOCK_STREAM)
    proc = subprocess.Popen([sys.executable, "-m", EVAL_CLI, "demo", "--port", str(udp),
                             "--zenoh-port", str(tcp)], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            cwd=ROOT)
    lines: queue.Queue = queue.Queue()
    stdout: list[str] = []

    def read() -> None:
        for line in proc.stdout:
            stdout.append(line)
            lines.put(line)
        lines.put(None)

    reader = threading.Thread(target=read, daemon=True)
    reader.start()
    try:
        deadline = time.monotonic() + TIMEOUT_S
        onboard_pid = None
        while onboard_pid is None:
            line = lines.get(timeout=max(0.0, deadline - time.monotonic()))
            assert line is not None, f"demo ended before starting the onboard process: {proc.stderr.read()}"
            if "onboard DAA process pid" in line:
                onboard_pid = int(line.split("pid")[1].split(":")[0])
        while not _listening(tcp):  # the onboard process is up: the demo starts flying
            assert time.monotonic() < deadline and proc.poll() is None, "onboard process never listened"
            time.sleep(0.05)
        os.kill(onboard_pid, signal.SIGKILL)
        # The flight is 80 s: a demo that flew on would be killed by this deadline and fail the test.
        proc.wait(timeout=TIMEOUT_S)
        stderr = proc.stderr.read()
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    reader.join(timeout=TIMEOUT_S)
    result = subprocess.CompletedProcess(proc.args, proc.returncode, "".join(stdout), stderr)
    assert_one_line_error(result, 1, "onboard process", "killed by SIGKILL")
    assert "SITL sent" not in result.stdout  # no summary of a flight that did not happen


# --- the exit-code mapping itself ----------------------------------------------------------------------------------

def test_an_unexpected_error_keeps_its_traceback_and_says_it_is_a_bug(capsys):
    from avionics.cli import EXIT_INTERNAL, call

    def broken(_args):
        raise KeyError("oops")

    assert call("avionics", broken, None) == EXIT_INTERNAL
    err = capsys.readouterr().err
    assert "Traceback" in err
    assert err.splitlines()[-1] == "avionics: internal error (a bug; traceback above): KeyError: 'oops'"


def test_expected_errors_map_to_the_documented_codes(capsys):
    from avionics.config import ConfigError
    from avionics.io.link import LinkError
    from avionics.io.zenoh_bus import ZenohBusError
    from avionics.monitor.app import HttpServerError
    from avionics_eval.cli import call  # the flight table plus the demo's errors
    from avionics_eval.demo import OnboardError
    from avionics_sitl.encounters import ScenarioError

    for exc, code in ((ConfigError("x"), 2), (ScenarioError("x"), 2), (LinkError("x"), 1), (ZenohBusError("x"), 1),
                      (HttpServerError("x"), 1), (OnboardError("x"), 1)):
        def fail(_args, exc=exc):
            raise exc

        assert call("avionics", fail, None) == code, exc
        err = capsys.readouterr().err
        assert len(err.splitlines()) == 1 and "Traceback" not in err, err
