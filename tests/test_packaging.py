"""Packaging: one version source (avionics.__version__, read by setuptools as the distribution's version), the
licence file and PEP 561 markers in what pip installs, and the version on the command line."""

from __future__ import annotations

import os
import subprocess
import sys
from importlib import metadata
from pathlib import Path

import avionics

ROOT = Path(__file__).resolve().parent.parent


def test_the_installed_distribution_has_the_package_version_and_the_licence():
    dist = metadata.distribution("avionics-daa")
    assert dist.version == avionics.__version__
    assert dist.metadata["License"] == "Apache-2.0" and "LICENSE" in dist.metadata.get_all("License-File")
    assert (ROOT / "LICENSE").read_text().lstrip().startswith("Apache License")
    for package in ("avionics", "avionics_sitl", "avionics_eval"):
        assert (ROOT / package / "py.typed").is_file()


def test_avionics_version_prints_the_one_version():
    out = subprocess.run([sys.executable, "-m", "avionics_eval.cli", "--version"], capture_output=True, text=True,
                         timeout=120)
    assert out.returncode == 0 and avionics.__version__ in out.stdout + out.stderr


def test_the_wheel_carries_the_licence_and_its_commands_run_from_it(tmp_path):
    """What `pip install .` installs: the wheel built from this tree, installed on its own (no editable paths),
    names no top-level `sitl` package (a PyPI project of that name exists), holds LICENSE, and its two console
    scripts run from it."""
    import zipfile

    subprocess.run([sys.executable, "-m", "pip", "wheel", "-q", "--no-deps", "-w", str(tmp_path), str(ROOT)],
                   check=True, timeout=600)
    (wheel,) = tmp_path.glob("avionics_daa-*.whl")
    names = zipfile.ZipFile(wheel).namelist()
    assert any(n.endswith(".dist-info/licenses/LICENSE") or n.endswith(".dist-info/LICENSE") for n in names)
    assert {n.split("/")[0] for n in names if not n.split("/")[0].endswith(".dist-info")} == \
        {"avionics", "avionics_eval", "avionics_sitl"}
    assert {"avionics/io/dialect/daa.xml", "avionics/io/dialect/ardupilotmega.xml"} <= set(names)  # docs/mavlink.md
    target = tmp_path / "site"
    subprocess.run([sys.executable, "-m", "pip", "install", "-q", "--no-deps", "--target", str(target), str(wheel)],
                   check=True, timeout=600)
    env = {**os.environ, "PYTHONPATH": str(target)}  # the wheel's packages before the source tree's
    version = subprocess.run([str(target / "bin" / "avionics"), "--version"], capture_output=True, text=True,
                             env=env, timeout=120, cwd=tmp_path)
    assert version.returncode == 0 and avionics.__version__ in version.stdout + version.stderr
    listing = subprocess.run([str(target / "bin" / "sitl"), "list"], capture_output=True, text=True, env=env,
                             timeout=120, cwd=tmp_path)
    assert listing.returncode == 0 and "head-on" in listing.stdout
    where = subprocess.run([sys.executable, "-c", "import avionics_sitl; print(avionics_sitl.__file__)"],
                           capture_output=True, text=True, env=env, timeout=120, cwd=tmp_path)
    assert where.stdout.startswith(str(target))
