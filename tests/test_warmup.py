"""`avionics warmup`: every module of avionics.base.jit.KERNEL_MODULES imported, its kernels compiled into the disk
cache (AVIONICS_CACHE_DIR) the first time and loaded from it the next; nothing to do with AVIONICS_COMPILED=0."""

import os
import subprocess
import sys

from avionics.base import jit


def _warmup(tmp_path, **env):
    environment = {**os.environ, "AVIONICS_CACHE_DIR": str(tmp_path / "cache"), **env}
    environment.pop("NUMBA_CACHE_DIR", None)
    if "AVIONICS_COMPILED" not in env:
        environment.pop("AVIONICS_COMPILED", None)
    return subprocess.run([sys.executable, "-m", "avionics.cli", "warmup"], capture_output=True, text=True,
                          env=environment, timeout=600, cwd=tmp_path)


def test_warmup_compiles_every_kernel_module_into_the_cache_then_loads_it(tmp_path):
    assert "avionics.conflict.kernels" in jit.KERNEL_MODULES
    first = _warmup(tmp_path)
    assert first.returncode == 0, first.stderr
    lines = first.stdout.splitlines()
    assert any(line.startswith("compiled ") and "avionics.conflict.kernels.pc_exact_pairs" in line for line in lines)
    assert str(tmp_path / "cache") in lines[-1] and ", 0 loaded from the cache" in lines[-1]
    assert any((tmp_path / "cache").rglob("*.nbi"))
    second = _warmup(tmp_path)
    assert second.returncode == 0, second.stderr
    assert " 0 compiled now" in second.stdout.splitlines()[-1]
    assert not [line for line in second.stdout.splitlines()[:-1] if not line.startswith("cached ")]


def test_warmup_with_compiled_kernels_off_does_nothing(tmp_path):
    out = _warmup(tmp_path, AVIONICS_COMPILED="0")
    assert out.returncode == 0 and "compiled kernels are off" in out.stdout
    assert not (tmp_path / "cache").exists()
