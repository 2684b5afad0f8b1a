import os
import socket
import sys
from pathlib import Path

import pytest
from hypothesis import HealthCheck, settings

# The three distributions' source folders (pyproject.toml, sitl/, eval/). The tests, and every process they start,
# run this checkout's code, never an installed copy of it.
ROOT = Path(__file__).resolve().parent.parent
SOURCES = {"avionics": ROOT, "avionics_sitl": ROOT / "sitl", "avionics_eval": ROOT / "eval"}
for _folder in reversed(SOURCES.values()):
    if str(_folder) not in sys.path:
        sys.path.insert(0, str(_folder))
os.environ["PYTHONPATH"] = os.pathsep.join([*map(str, SOURCES.values()),
                                            *filter(None, [os.environ.get("PYTHONPATH")])])

# Every wait in the tests polls for its condition and returns as soon as it holds: the deadline only bounds how
# long a failure takes to report. It is generous on purpose, so that a slow success on a loaded CI machine
# (2 cores, other jobs running) is never reported as a failure. Durations and latencies are printed as
# benchmark JSON, never asserted.
DEADLINE_S = float(os.environ.get("AVIONICS_TEST_DEADLINE_S", "60"))

# The same for property tests: hypothesis's per-example deadline (200 ms by default) and its too_slow health check
# (data generation timed) are wall-clock checks. Off by default for every test; a test's own @settings still wins.
settings.register_profile("load-proof", deadline=None, suppress_health_check=[HealthCheck.too_slow])
settings.load_profile("load-proof")


def wait_for(predicate, timeout_s: float = DEADLINE_S, period_s: float = 0.02) -> bool:
    """Poll predicate until it is true (returns True) or timeout_s has passed (returns its last value)."""
    from avionics.monitor.feed import wait_for as poll

    return poll(predicate, timeout_s, period_s)


class ResultCapture:
    """An output port (avionics/ports.py) that keeps every step's DaaResult: the replay's loop feeds it as it
    feeds the others."""

    def __init__(self):
        self.results = []

    def wants(self, now_s):
        from avionics.ports import NOTHING

        return NOTHING

    def publish(self, result):
        self.results.append(result)

    def close(self):
        pass


def free_port(kind=socket.SOCK_STREAM) -> int:
    with socket.socket(socket.AF_INET, kind) as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@pytest.fixture
def udp_port() -> int:
    return free_port(socket.SOCK_DGRAM)


@pytest.fixture
def tcp_port() -> int:
    return free_port(socket.SOCK_STREAM)
