"""When the compiled kernels load (avionics/base/jit.py, issue 13 item 5): not on the path to the first processed
message, and never waited for (issue 26 item 1: the loop runs the numpy reference until they are loaded, then
switches). `avionics run`'s parts are built and run in a fresh interpreter (this one has loaded everything already)
on a loopback link fed as an autopilot would: ownship fixes until the first step is out, then an intruder's ADS-B
reports. Behaviour only, never timing."""

import json
import os
import subprocess
import sys

import pytest

from avionics.base import jit

RUN = r"""
import json, socket, sys, threading, time
import avionics.cli  # the console entry point's module, as `avionics run`
from avionics.config import load_config
from avionics.base import jit
from avionics.ports import NOTHING
from avionics.runner import Runner
from avionics_eval.bench import _traffic

probe = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
probe.bind(("127.0.0.1", 0))
port = probe.getsockname()[1]
probe.close()
runner = Runner(load_config(overrides=[f'mavlink.connection="udpin:127.0.0.1:{port}"', "zenoh.enabled=false"]),
                duration_s=60.0)
out = {"numba_after_building": "numba" in sys.modules}
first, done = threading.Event(), threading.Event()

class Probe:  # an output port: sees every step's result once the step is done
    def wants(self, now_s):
        return NOTHING
    def publish(self, result):
        if not first.is_set():
            out["first"] = {"numba": "numba" in sys.modules, "loaded": jit.loaded(),
                            "kernel_modules": sorted(m for m in jit.KERNEL_MODULES if m in sys.modules)}
            first.set()
        elif result.assessed and not done.is_set():
            out.setdefault("assessed", {"intruders": len(result.assessed)})
            if jit.ready() or not jit.ENABLED:  # the first intruder's re-assessments go on until the switch
                out["assessed_compiled"] = {"ready": jit.ready(), "loaded": jit.loaded()}
                done.set()
                runner.stop.set()
    def close(self):
        pass

runner.loop.ports.append(Probe())
events = _traffic(1, 5.0)

def autopilot():
    s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    fix = next(data for t, data, is_report in events if not is_report)
    while not first.wait(0.002):
        s.sendto(fix, ("127.0.0.1", port))
    for t, data, is_report in events:  # the rest at once: the first report reaches a step early
        if done.is_set():
            break
        s.sendto(data, ("127.0.0.1", port))
        time.sleep(0.01)  # pacing the autopilot's traffic, not a synchronisation (the test waits on `done`)

threading.Thread(target=autopilot, daemon=True).start()
try:
    runner.run()
finally:
    runner.close()
out["end"] = {"numba": "numba" in sys.modules, "loaded": jit.loaded(),
              "compiled": sum(sum(k._cache_misses.values()) for k in jit.KERNELS), "kernels": len(jit.KERNELS)}
from avionics.conflict import cpa
from avionics.tracking import imm_tracker
out["end"]["holders"] = [type(cpa.kernels).__name__, type(imm_tracker.kernels).__name__]
print(json.dumps(out))
"""


def _python(code: str, **env) -> dict:
    environment = {**os.environ, **env}
    out = subprocess.run([sys.executable, "-c", code], env=environment, capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stderr
    return json.loads(out.stdout.strip().splitlines()[-1])


@pytest.mark.skipif(not jit.ENABLED, reason="compiled kernels are off (AVIONICS_COMPILED=0)")
def test_run_processes_its_first_message_before_numba_loads_and_its_first_intruder_with_the_cached_kernels():
    warm = subprocess.run([sys.executable, "-m", "avionics.cli", "warmup"], capture_output=True, text=True,
                          timeout=600)  # the cache this environment uses (README: installed warm)
    assert warm.returncode == 0, warm.stderr
    got = _python(RUN)
    assert got["numba_after_building"] is False
    assert got["first"] == {"numba": False, "loaded": False, "kernel_modules": []}  # the first step had none
    assert got["assessed"]["intruders"] == 1  # on whichever path was in use: the step did not wait for a load
    assert got["assessed_compiled"] == {"ready": True, "loaded": True}  # then the loop switched to the kernels
    end = got["end"]
    assert end["numba"] and end["loaded"] and end["kernels"] >= 27
    assert end["compiled"] == 0  # warm cache: every kernel was loaded, none compiled in the run
    assert end["holders"] == ["module", "module"]  # the stand-ins were replaced by the modules


def test_with_compiled_kernels_off_the_run_never_loads_numba_or_the_kernels():
    got = _python(RUN, AVIONICS_COMPILED="0")
    assert got["first"] == {"numba": False, "loaded": False, "kernel_modules": []}
    assert got["assessed"] == {"intruders": 1}
    assert got["assessed_compiled"] == {"ready": False, "loaded": False}  # the numpy reference assessed it
    assert got["end"]["numba"] is False and got["end"]["kernels"] == 0 and got["end"]["holders"] == ["_Lazy"] * 2


def test_a_stand_in_loads_every_kernel_module_at_its_first_use_then_gives_way_to_the_module():
    got = _python(
        "import sys, json\n"
        "import numpy as np\n"
        "from avionics.base import jit\n"
        "from avionics.conflict import cpa, probability\n"
        "from avionics.tracking import imm\n"
        "before = ['numba' in sys.modules, jit.loaded(), type(cpa.kernels).__name__]\n"
        "p = probability.pc_exact(np.array([[0.3, 0.2]]), np.eye(2)[None], 1.0)\n"  # the first use: a kernel
        "import avionics.conflict.kernels as ck, avionics.tracking.kernels as tk\n"
        "after = ['numba' in sys.modules, jit.loaded(), cpa.kernels is ck, probability.kernels is ck,\n"
        "         imm.kernels is tk, type(ck.pc_exact_pairs).__name__]\n"
        "print(json.dumps({'before': before, 'after': after, 'p': float(p[0])}))")
    assert got["before"] == [False, False, "_Lazy"]
    assert got["after"] == [True, True, True, True, True, "CPUDispatcher" if jit.ENABLED else "function"]
    assert 0.0 < got["p"] < 1.0
