"""Start-up of the onboard process (issue 13 item 5): behaviour, never timing. Each check runs in a fresh
interpreter, since this one has imported everything already."""

import json
import os
import subprocess
import sys

THREAD_VARS = ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS")


def _python(code: str, **env) -> dict:
    clean = {k: v for k, v in os.environ.items() if k not in THREAD_VARS}
    out = subprocess.run([sys.executable, "-c", code], env={**clean, **env}, capture_output=True, text=True,
                         timeout=120, check=True).stdout
    return json.loads(out.strip().splitlines()[-1])


def test_console_entry_point_pins_blas_threads_to_one_before_numpy_loads():
    got = _python(
        "import sys, os, json\n"
        "import avionics_eval.cli\n"  # the `avionics` console script's module (pyproject [project.scripts])
        "before = 'numpy' in sys.modules\n"
        f"env = {{k: os.environ.get(k) for k in {THREAD_VARS!r}}}\n"
        "import numpy\n"
        "print(json.dumps({'numpy_before': before, 'env': env}))")
    assert got["numpy_before"] is False  # numpy, hence its BLAS, loads after the variables are set
    assert got["env"] == {k: "1" for k in THREAD_VARS}


def test_an_operators_thread_setting_stands():
    got = _python("import os, json, avionics.cli\nprint(json.dumps(os.environ['OPENBLAS_NUM_THREADS']))",
                  OPENBLAS_NUM_THREADS="2")
    assert got == "2"


def test_run_help_imports_nothing_heavy():
    """`avionics run --help` (parsing, and every usage error) loads none of the numeric, MAVLink or zenoh stack:
    they are imported by the command itself."""
    got = _python(
        "import sys, json, contextlib, io\n"
        "from avionics_eval.cli import main\n"
        "with contextlib.redirect_stdout(io.StringIO()):\n"
        "    try:\n"
        "        main(['run', '--help'])\n"
        "    except SystemExit:\n"
        "        pass\n"
        "print(json.dumps(sorted(sys.modules)))")
    heavy = ("numpy", "scipy", "pymavlink", "zenoh", "filterpy", "avionics.runner", "avionics.daa", "avionics.io.link")
    assert [m for m in got if m.split(".")[0] in heavy or m in heavy] == []


def test_the_link_and_core_import_only_the_variants_they_use():
    """The onboard import set: pymavlink's parser gets one dialect, not every dialect it ships
    (avionics/io/__init__.py), and the default tcas2 profile with the IMM tracker builds without the bands engine
    or the CV tracker (avionics/compose.py)."""
    got = _python(
        "import sys, json\n"
        "from avionics.config import load_config\n"
        "from avionics.daa import Daa\n"
        "import avionics.io.link\n"
        "from collections import Counter\n"
        "Daa(load_config(overrides=['zenoh.enabled=false']), Counter())\n"
        "print(json.dumps(sorted(sys.modules)))")
    assert "avionics.tracking.imm_tracker" in got and "avionics.io.link" in got  # it did build what it needs
    for lazy in ("pymavlink.dialects.v20.all", "avionics.advisory.bands", "avionics.advisory.bands_kinematics",
                 "avionics.tracking.tracker"):
        assert lazy not in got, lazy
