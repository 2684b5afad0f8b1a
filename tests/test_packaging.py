"""Packaging: three distributions (the flight install at the root, the simulator in sitl/, the lab in eval/; issue
31) with one version (avionics.__version__, read by setuptools; sitl/ and eval/ state it and are held equal here),
the licence file and PEP 561 markers in what pip installs, and the version on the command line."""

from __future__ import annotations

import os
import subprocess
import sys
from importlib import metadata
import avionics
from tests.conftest import ROOT


DISTRIBUTIONS = {"avionics-daa": ("avionics", ROOT), "avionics-sitl": ("avionics_sitl", ROOT / "sitl"),
                 "avionics-eval": ("avionics_eval", ROOT / "eval")}  # name -> (its package, its folder)


def test_the_installed_distributions_have_the_package_version_and_the_licence():
    for name, (package, folder) in DISTRIBUTIONS.items():
        dist = metadata.distribution(name)
        assert dist.version == avionics.__version__, name  # one version for the three (sitl/, eval/ pyproject.toml)
        assert dist.metadata["License"] == "Apache-2.0", name
        assert (folder / "LICENSE").read_text().lstrip().startswith("Apache License")
        assert (folder / package / "py.typed").is_file()


def test_avionics_version_prints_the_one_version():
    out = subprocess.run([sys.executable, "-m", "avionics.cli", "--version"], capture_output=True, text=True,
                         timeout=120)
    assert out.returncode == 0 and avionics.__version__ in out.stdout + out.stderr


def test_the_wheels_carry_their_own_package_and_licence_and_their_commands_run_from_them(tmp_path):
    """What `pip install . ./sitl ./eval` installs: three wheels built from this tree, installed on their own (no
    editable paths). Each holds its one package and LICENSE; none names a top-level `sitl` package (a PyPI project
    of that name exists); the flight wheel's `avionics` finds the lab's commands through the eval wheel's entry
    point, and `sitl` runs from its wheel."""
    import zipfile

    for name, (package, folder) in DISTRIBUTIONS.items():
        subprocess.run([sys.executable, "-m", "pip", "wheel", "-q", "--no-deps", "-w", str(tmp_path), str(folder)],
                       check=True, timeout=600)
        (wheel,) = tmp_path.glob(f"{name.replace('-', '_')}-*.whl")
        names = zipfile.ZipFile(wheel).namelist()
        assert any(n.endswith(".dist-info/licenses/LICENSE") or n.endswith(".dist-info/LICENSE") for n in names)
        assert {n.split("/")[0] for n in names if not n.split("/")[0].endswith(".dist-info")} == {package}
        if package == "avionics":  # docs/mavlink.md: the dialect XML stock MAVLink tools are pointed at
            assert {"avionics/io/dialect/daa.xml", "avionics/io/dialect/ardupilotmega.xml"} <= set(names)
    target = tmp_path / "site"  # one pip call: a second --target install skips the folders the first made (bin/)
    subprocess.run([sys.executable, "-m", "pip", "install", "-q", "--no-deps", "--target", str(target),
                    *map(str, sorted(tmp_path.glob("*.whl")))], check=True, timeout=600)
    env = {**os.environ, "PYTHONPATH": str(target)}  # the wheels' packages, not the source tree's
    version = subprocess.run([str(target / "bin" / "avionics"), "--version"], capture_output=True, text=True,
                             env=env, timeout=120, cwd=tmp_path)
    assert version.returncode == 0 and avionics.__version__ in version.stdout + version.stderr
    demo = subprocess.run([str(target / "bin" / "avionics"), "demo", "--help"], capture_output=True, text=True,
                          env=env, timeout=120, cwd=tmp_path)
    assert demo.returncode == 0 and "--scenario" in demo.stdout, demo.stderr
    listing = subprocess.run([str(target / "bin" / "sitl"), "list"], capture_output=True, text=True, env=env,
                             timeout=120, cwd=tmp_path)
    assert listing.returncode == 0 and "head-on" in listing.stdout
    for package in ("avionics", "avionics_sitl", "avionics_eval"):
        where = subprocess.run([sys.executable, "-c", f"import {package}; print({package}.__file__)"],
                               capture_output=True, text=True, env=env, timeout=120, cwd=tmp_path)
        assert where.stdout.startswith(str(target)), (package, where.stdout, where.stderr)
