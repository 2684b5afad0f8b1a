"""The live loop's switch from the numpy reference to the compiled kernels (avionics/base/jit.py `deferred`, `switch`;
issue 26 item 1): a replay that starts on the reference and switches in the middle of the encounter, with its
tracks already in the IMM banks, decides as a replay on either path alone."""

import math

import pytest

from avionics.config import load_config
from avionics.base import jit
from avionics.ports import NOTHING
from avionics_sitl.encounters import load_encounter
from avionics_sitl.impairments import PRESETS
from avionics_sitl.replay import replay

SWITCH_S = 60.0  # head-on: TA ~55 s, RA ~65 s, clear ~93 s: tracks and a TA exist when the path changes


class SwitchAt:
    """An output port that switches to the compiled kernels after the first step at or after `at_s` (between two
    steps, on the loop's thread, as avionics/base/kernel_startup.py does) and records the path of every step."""

    def __init__(self, at_s: float | None):
        self.at_s = at_s
        self.paths: list[tuple[float, bool]] = []

    def wants(self, now_s):
        return NOTHING

    def publish(self, result):
        self.paths.append((result.time_s, jit.ready()))
        if self.at_s is not None and result.time_s >= self.at_s:
            assert jit.switch()

    def close(self):
        pass


def _decisions(result) -> list[dict]:
    return result.rows()


def _same(a: list[dict], b: list[dict]) -> None:
    """The same advisory changes: every text field equal, every number to its printed resolution (0.001)."""
    assert [(r["time_s"], r["intruder"], r["advisory"], r["ra_sense"]) for r in a] == \
           [(r["time_s"], r["intruder"], r["advisory"], r["ra_sense"]) for r in b]
    for ra, rb in zip(a, b):
        for key, va in ra.items():
            vb = rb[key]
            try:
                fa, fb = float(va), float(vb)
            except ValueError:
                assert va == vb, key
            else:
                assert math.isclose(fa, fb, abs_tol=1.5e-3), (key, va, vb)


@pytest.mark.skipif(not jit.ENABLED, reason="compiled kernels are off (AVIONICS_COMPILED=0)")
def test_a_replay_switched_to_the_kernels_mid_encounter_decides_as_either_path(monkeypatch):
    config = load_config()
    scenario = load_encounter("head-on")
    jit.load()  # loaded (warm cache, or compiled here): the switch below finds them
    runs = {}
    for name, start_compiled, switch_at in (("compiled", True, None), ("reference", False, None),
                                            ("switched", False, SWITCH_S)):
        monkeypatch.setattr(jit, "_ready", start_compiled)  # restored after the test
        port = SwitchAt(switch_at)
        with jit.deferred():  # as `avionics run`: ready() is what was switched, never a load
            result = replay(scenario, config, PRESETS["default"], seed=3, ports=[port])
        runs[name] = (_decisions(result), port.paths, dict(result.counters))
    decisions, paths, counters = runs["switched"]
    # the switched run really ran both paths: the reference until SWITCH_S, the kernels after it
    k = next(i for i, (t, _) in enumerate(paths) if t >= SWITCH_S)  # the step after which it switched
    assert not any(p for _, p in paths[:k + 1]) and all(p for _, p in paths[k + 1:])
    assert all(p for _, p in runs["compiled"][1]) and not any(p for _, p in runs["reference"][1])
    assert [r["advisory"] for r in decisions if r["advisory"] != "NONE"][:2] == ["TA", "RA"]
    assert any(float(r["time_s"]) < SWITCH_S for r in decisions) and any(float(r["time_s"]) > SWITCH_S
                                                                         for r in decisions)
    for other in ("compiled", "reference"):
        _same(decisions, runs[other][0])
        assert counters == runs[other][2]
