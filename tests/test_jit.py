"""The compiled-kernel switch (avionics/base/jit.py): numba when on, the plain function when off; in a subprocess so
that the environment is read at import as in a real process."""

import os
import subprocess
import sys

import pytest

PROBE = """
from avionics.base import jit

@jit.kernel("float64(float64, float64)")
def hyp(a, b):
    return (a * a + b * b) ** 0.5

print(jit.ENABLED, type(hyp).__name__, hyp(3.0, 4.0), len(jit.KERNELS))
"""


@pytest.mark.parametrize("env, enabled, kind", [({}, "True", "CPUDispatcher"),
                                                ({"AVIONICS_COMPILED": "0"}, "False", "function")])
def test_kernels_compile_with_numba_unless_switched_off(tmp_path, env, enabled, kind):
    environment = {**os.environ, "AVIONICS_CACHE_DIR": str(tmp_path / "cache"), **env}
    environment.pop("NUMBA_CACHE_DIR", None)
    if not env:
        environment.pop("AVIONICS_COMPILED", None)
    probe = tmp_path / "probe.py"  # numba caches kernels of a source file
    probe.write_text(PROBE)
    out = subprocess.run([sys.executable, str(probe)], capture_output=True, text=True, env=environment,
                         timeout=300, cwd=tmp_path)
    assert out.returncode == 0, out.stderr
    assert out.stdout.split() == [enabled, kind, "5.0", "1" if enabled == "True" else "0"]
    assert any((tmp_path / "cache").rglob("*.nbi")) == (enabled == "True")  # compiled into AVIONICS_CACHE_DIR
    assert not (tmp_path / "__pycache__").exists()
