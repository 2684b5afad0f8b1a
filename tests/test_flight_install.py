"""The flight install (issue 31 item 3): `pip install .` at the repository root is the onboard process and nothing
else. Built as a wheel and installed with the pins of constraints/flight.txt into a fresh virtual environment (no
access to this one's packages), it holds only the `avionics` package, pulls in none of the lab's or the ground's
packages, imports every flight module, names the extra a missing optional part needs, and, run from that
environment against the simulator of this one, raises the head-on's TA and RA on a real UDP link."""

from __future__ import annotations

import os
import subprocess
import sys
import threading
import venv
import zipfile

import pytest
from pymavlink.dialects.v20 import common as mavlink2

from avionics_sitl.encounters import load_encounter
from avionics_sitl.impairments import PRESETS
from avionics_sitl.live import fly
from tests.conftest import DEADLINE_S, ROOT, wait_for

pytestmark = pytest.mark.live  # a fresh venv (pip from the package index or its cache), a child process, UDP

# Not in a flight install: the lab (dask, matplotlib, filterpy), the ground monitor's terminal view (rich), the
# Beast decoder (pyModeS), serial links (pyserial), the simulator and the evaluation. pyarrow stays: the onboard
# process writes the zenoh `traffic` topic as Arrow IPC (avionics/io/traffic.py).
NOT_FLIGHT = {"dask", "distributed", "matplotlib", "filterpy", "rich", "pymodes", "pyserial", "avionics-sitl",
              "avionics-eval"}
START_S, END_S = 46.0, 72.0  # head-on: TA ~55 s, RA ~65 s (tests/test_integration_live.py)


# session, not module: a worker that runs other modules' tests between this module's would build it again
@pytest.fixture(scope="session")
def flight(tmp_path_factory):
    """(the fresh environment's python, its bin folder) with the flight wheel installed, and the wheel's path."""
    where = tmp_path_factory.mktemp("flight")
    subprocess.run([sys.executable, "-m", "pip", "wheel", "-q", "--no-deps", "-w", str(where), str(ROOT)],
                   check=True, timeout=600)
    (wheel,) = where.glob("avionics_daa-*.whl")
    venv.EnvBuilder(with_pip=True).create(where / "venv")
    bin_dir = where / "venv" / "bin"
    subprocess.run([str(bin_dir / "python"), "-m", "pip", "install", "-q", "--disable-pip-version-check",
                    "-c", str(ROOT / "constraints" / "flight.txt"), str(wheel)], check=True, timeout=900,
                   env={k: v for k, v in os.environ.items() if k != "PYTHONPATH"})
    return bin_dir, wheel


def _clean_env(**extra) -> dict:
    """This process's environment without the checkout on PYTHONPATH: the fresh environment runs its own install."""
    return {**{k: v for k, v in os.environ.items() if k != "PYTHONPATH"}, **extra}


def test_the_flight_wheel_holds_flight_code_and_installs_only_flight_packages(flight, tmp_path):
    bin_dir, wheel = flight
    assert {n.split("/")[0] for n in zipfile.ZipFile(wheel).namelist()
            if not n.split("/")[0].endswith(".dist-info")} == {"avionics"}
    listed = subprocess.run([str(bin_dir / "python"), "-m", "pip", "list", "--format=freeze"], capture_output=True,
                            text=True, timeout=120, env=_clean_env(), check=True).stdout
    installed = {line.split("==")[0].lower() for line in listed.split()}
    assert "avionics-daa" in installed and not installed & NOT_FLIGHT, installed & NOT_FLIGHT
    # every flight module imports; the two that need an extra say which, in one line, where they are used
    code = ("import importlib, pkgutil, avionics\n"
            "from avionics.extras import EXTRA_MODULES\n"
            "for m in pkgutil.walk_packages(avionics.__path__, 'avionics.'):\n"
            "    if m.name not in EXTRA_MODULES:\n"
            "        importlib.import_module(m.name)\n"
            "print('ok')\n")
    proc = subprocess.run([str(bin_dir / "python"), "-c", code], capture_output=True, text=True, timeout=300,
                          cwd=tmp_path, env=_clean_env())
    assert proc.returncode == 0 and proc.stdout.split() == ["ok"], proc.stderr
    for argv, words in ((["monitor", "--tui", "--duration", "1"], "pip install 'avionics-daa[monitor]'"),
                        (["run", "--no-zenoh", "--duration", "1", "--traffic", "beast:127.0.0.1:1"],
                         "pip install 'avionics-daa[beast]'"),
                        (["demo"], "not in the flight install: pip install ./sitl ./eval")):
        proc = subprocess.run([str(bin_dir / "avionics"), *argv], capture_output=True, text=True, timeout=300,
                              cwd=tmp_path, env=_clean_env())
        assert proc.returncode == 2 and words in proc.stderr and "Traceback" not in proc.stderr, (argv, proc.stderr)


def test_the_flight_install_raises_the_head_on_ta_and_ra_against_the_simulator(flight, tmp_path, udp_port):
    bin_dir, _ = flight
    # The numpy reference path (decisions identical to the kernels', tests/test_kernel_switch.py): a cold kernel
    # cache would compile for half a minute of CPU in a child process, which this test does not need.
    onboard = subprocess.Popen([str(bin_dir / "avionics"), "run", "--connection", f"udpin:127.0.0.1:{udp_port}",
                                "--no-zenoh", "--duration", str(END_S - START_S + 2 * DEADLINE_S)],
                               stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, cwd=tmp_path,
                               env=_clean_env(AVIONICS_COMPILED="0"))
    lines: list[str] = []
    threading.Thread(target=lambda: lines.extend(onboard.stderr), daemon=True).start()
    try:
        # the link is open once the start-up line names it
        assert wait_for(lambda: any(f"MAVLink udpin:127.0.0.1:{udp_port}" in line for line in list(lines))
                        or onboard.poll() is not None), lines
        recording = fly(load_encounter("head-on"), f"udpout:127.0.0.1:{udp_port}", PRESETS["default"], seed=3,
                        start_s=START_S, duration_s=END_S - START_S)
    finally:
        onboard.terminate()
        onboard.wait(timeout=DEADLINE_S)
    err = "".join(lines)
    levels = {r.msg.threat_level for r in recording.of_type("COLLISION")}
    assert {mavlink2.MAV_COLLISION_THREAT_LEVEL_LOW, mavlink2.MAV_COLLISION_THREAT_LEVEL_HIGH} <= levels, err
    assert "kernels: numpy reference" in err
