"""Alert criteria (tcas, tcas+pc, pc) and persistence (m-of-n, binomial) on noise-free encounters."""

import math
from itertools import product

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from avionics.advisory.persistence import at_least_m_of_n
from avionics.base.types import AdvisoryLevel
from avionics.base.units import FT, KT, NM
from synthetic import Encounter, Mover

ALT, V = 3000 * FT, 125 * KT  # SL 4
OWN = Mover((0.0, 0.0, ALT), (0.0, V, 0.0))


@settings(max_examples=60, deadline=None)
@given(p=st.floats(0.0, 1.0), n=st.integers(1, 8), m=st.integers(1, 8))
def test_binomial_tail_matches_enumeration(p, n, m):
    m = min(m, n)
    exact = sum(math.prod(p if hit else 1 - p for hit in outcome)
                for outcome in product((True, False), repeat=n) if sum(outcome) >= m)
    assert at_least_m_of_n(p, m, n) == pytest.approx(exact, abs=1e-12)


def first(changes, level):
    return next((t for t, c in changes if c.level is level), None)


def test_tcas_plus_pc_drops_the_ra_of_a_miss_outside_alim_but_keeps_the_ta():
    # 0.5 nm abeam (inside the 0.57 nm HMD filter) and 500 ft above (inside RA ZTHR 600 ft, outside ALIM 300 ft):
    # TCAS II issues an RA; the probability of a miss inside the RA volume (HMD x ALIM) is low.
    intruder = Mover((0.5 * NM, 6 * NM, ALT + 500 * FT), (0.0, -V, 0.0))
    _, tcas = Encounter(OWN, intruder).run(100)
    core, gated = Encounter(OWN, intruder, overrides=['advisory.criterion="tcas+pc"']).run(100)
    assert first(tcas, AdvisoryLevel.RA) is not None
    assert first(gated, AdvisoryLevel.RA) is None and first(gated, AdvisoryLevel.TA) is not None
    assert max(c.pc_ra for _, c in tcas if c.level is AdvisoryLevel.RA) < 0.3


def test_a_collision_course_keeps_its_ra_under_every_criterion():
    intruder = Mover((0.0, 6 * NM, ALT), (0.0, -V, 0.0))
    onsets = {}
    for criterion in ("tcas", "tcas+pc", "pc"):
        _, changes = Encounter(OWN, intruder, overrides=[f'advisory.criterion="{criterion}"']).run(100)
        onsets[criterion] = first(changes, AdvisoryLevel.RA)
        ra = next(c for _, c in changes if c.level is AdvisoryLevel.RA)
        # at the RA onset (about 20 s to CPA) with the conflict stage's prediction noise (2.0 / 1.0 m/s^2): ~0.3
        assert 0.25 <= ra.pc_ra <= 1.0 and 0.0 <= ra.pc_ta <= 1.0
    assert all(t is not None for t in onsets.values())
    assert onsets["tcas+pc"] >= onsets["tcas"]  # the probability can only delay an RA, never advance it
    assert onsets["pc"] <= onsets["tcas"] + 20.0


def test_m_of_n_persistence_delays_the_onset_by_whole_reports():
    intruder = Mover((0.0, 6 * NM, ALT), (0.0, -V, 0.0))
    _, plain = Encounter(OWN, intruder).run(100)
    _, persistent = Encounter(OWN, intruder, overrides=['advisory.persistence="m-of-n"', "advisory.persistence_m=3",
                                                        "advisory.persistence_n=3"]).run(100)
    delay = first(persistent, AdvisoryLevel.TA) - first(plain, AdvisoryLevel.TA)
    assert 1.0 <= delay <= 3.0  # reports at 1 Hz: the 2nd and 3rd reports after the first in-conflict one


def test_binomial_persistence_needs_confidence():
    intruder = Mover((0.0, 6 * NM, ALT), (0.0, -V, 0.0))
    _, strict = Encounter(OWN, intruder, overrides=['advisory.persistence="binomial"', "advisory.persistence_m=3",
                                                    "advisory.persistence_n=3",
                                                    "advisory.persistence_confidence=0.999"]).run(100)
    _, loose = Encounter(OWN, intruder, overrides=['advisory.persistence="binomial"', "advisory.persistence_m=1",
                                                   "advisory.persistence_n=3",
                                                   "advisory.persistence_confidence=0.5"]).run(100)
    assert first(loose, AdvisoryLevel.TA) is not None
    assert first(strict, AdvisoryLevel.RA) is None or first(strict, AdvisoryLevel.RA) > first(loose, AdvisoryLevel.RA)
