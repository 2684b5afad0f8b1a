"""Packaging: one version source (avionics.__version__, read by setuptools as the distribution's version), the
licence file and PEP 561 markers in what pip installs, and the version on the command line."""

from __future__ import annotations

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
    for package in ("avionics", "sitl", "avionics_eval"):
        assert (ROOT / package / "py.typed").is_file()


def test_avionics_version_prints_the_one_version():
    out = subprocess.run([sys.executable, "-m", "avionics_eval.cli", "--version"], capture_output=True, text=True,
                         timeout=120)
    assert out.returncode == 0 and avionics.__version__ in out.stdout + out.stderr
