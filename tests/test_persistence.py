"""Persistence (advisory/persistence.py): Radosavljevic's binomial model (eqs 19-24) against enumeration, and the
m-of-n and binomial filters over assessments."""

import itertools
import math

import numpy as np
import pytest

from avionics.advisory import persistence as ps
from avionics.base.types import AdvisoryLevel

TA, RA, NONE = int(AdvisoryLevel.TA), int(AdvisoryLevel.RA), int(AdvisoryLevel.NONE)


def enumerate_at_least(m, probs):
    """P(at least m successes) by summing over all 2^n outcomes."""
    total = 0.0
    for outcome in itertools.product((0, 1), repeat=len(probs)):
        if sum(outcome) >= m:
            total += math.prod(p if o else 1.0 - p for o, p in zip(outcome, probs))
    return total


@pytest.mark.parametrize("n", [1, 3, 5, 8])
@pytest.mark.parametrize("p", [0.0, 0.05, 0.25, 0.5, 0.75, 1.0])
def test_binomial_tail_against_enumeration(n, p):
    for m in range(1, n + 2):
        assert ps.at_least_m_of_n(p, m, n) == pytest.approx(enumerate_at_least(m, [p] * n), abs=1e-14)
    pmf = [ps.binomial_pmf(k, n, p) for k in range(n + 1)]  # eq 22
    assert sum(pmf) == pytest.approx(1.0)  # the total probability theorem below eq 22
    mean = sum(k * q for k, q in enumerate(pmf))
    assert mean == pytest.approx(n * p)  # eq 23
    assert sum((k - mean) ** 2 * q for k, q in enumerate(pmf)) == pytest.approx(n * p * (1 - p), abs=1e-12)  # eq 24


def test_paper_example_third_order():
    # Radosavljevic eqs 31-32: n = 3, pi = 0.5 -> 1/8, 3/8, 3/8, 1/8
    assert [ps.binomial_pmf(k, 3, 0.5) for k in range(4)] == pytest.approx([0.125, 0.375, 0.375, 0.125])


def run(filt, keys, candidates, pc_ta, pc_ra, updated=None):
    updated = set(keys) if updated is None else updated
    return list(filt.persist(keys, np.array(candidates), np.array(pc_ta, float), np.array(pc_ra, float), updated))


def test_no_persistence_lets_everything_through():
    f = ps.NoPersistence()
    assert run(f, ["a", "b"], [RA, TA], [0.0, 0.0], [0.0, 0.0]) == [RA, TA]


def test_m_of_n_counts_new_reports_only_and_never_delays_a_drop():
    f = ps.MOfNPersistence(m=2, n=3)
    keys = ["a", "b"]
    assert run(f, keys, [RA, TA], [0, 0], [0, 0]) == [NONE, NONE]  # one report cannot hold 2 of 3
    assert run(f, keys, [RA, TA], [0, 0], [0, 0], updated=set()) == [NONE, NONE]  # no new report: no count
    assert run(f, keys, [RA, NONE], [0, 0], [0, 0]) == [RA, NONE]  # 2 of 3 RA; b's candidate dropped at once
    assert run(f, keys, [TA, TA], [0, 0], [0, 0]) == [TA, TA]  # a: [RA, RA, TA] -> RA allowed, TA asked
    assert run(f, keys, [NONE, NONE], [0, 0], [0, 0]) == [NONE, NONE]
    f.forget("a")
    assert run(f, ["a"], [RA], [0], [0]) == [NONE]  # history gone with the intruder
    with pytest.raises(ValueError):
        ps.MOfNPersistence(m=4, n=3)


def test_binomial_uses_the_mean_pc_of_each_volume():
    f = ps.BinomialPersistence(m=2, n=3, confidence=0.5)
    for pc in (0.6, 0.6):
        out = run(f, ["x"], [RA], [0.9], [pc])
    assert out == [RA]  # mean Pc(RA) 0.6 over 2 reports: P(at least 2 of 3) = 0.648 >= 0.5
    assert ps.at_least_m_of_n(0.6, 2, 3) == pytest.approx(enumerate_at_least(2, [0.6] * 3))
    strict = ps.BinomialPersistence(m=2, n=3, confidence=0.7)
    for pc in (0.6, 0.6, 0.6):
        out = run(strict, ["x"], [RA], [0.9], [pc])
    assert out == [TA]  # the RA volume's 0.648 < 0.7; the TA volume's P(2 of 3 | 0.9) = 0.972 passes
    with pytest.raises(ValueError):
        ps.BinomialPersistence(m=1, n=3, confidence=1.5)


# --- DAIDALUS alerting hysteresis (a DO-365 alerter's) ----------------------------------------------------------


def _hysteresis():
    from avionics.advisory.persistence import AlertingHysteresis

    return AlertingHysteresis(hysteresis_time_s=5.0, persistence_time_s=4.0, m=2, n=4, period_s=1.0)  # DO_365B


def test_alerting_hysteresis_follows_daidalus_hysteresisdata_by_hand():
    # Worked by hand from HysteresisData.applyHysteresisLogic and MofN.m_of_n (DAIDALUS v2.0.4), 2 of 4,
    # persistence 4 s: the first evaluation resets the queue to [0, 0, -1, -1]; a level needs two of the last
    # four raw levels at or above it; once up at t = 4 it stays until 4 + 4 s although the raw level drops at 5.
    h = _hysteresis()
    raw = [0, 0, 0, 2, 2, 0, 0, 0, 0]
    out = [int(h.apply(float(t), ["a"], np.array([r]))[0]) for t, r in enumerate(raw)]
    assert out == [0, 0, 0, 0, 2, 2, 2, 2, 0]
    # more than hysteresis_time_s without an evaluation: reset, and the reset queue holds m copies of the level
    assert int(h.apply(15.0, ["a"], np.array([3]))[0]) == 3
    # the first evaluation of a new intruder alerts at once (MofN.reset(val))
    assert int(h.apply(15.0, ["b"], np.array([2]))[0]) == 2


def test_alerting_hysteresis_evaluates_once_a_second_whatever_the_assessment_rate():
    h = _hysteresis()
    out = []
    for k in range(40):  # 10 Hz assessments, raw 2 from t = 1.0 s on
        t = k / 10
        out.append(int(h.apply(t, ["a"], np.array([2 if t >= 1.0 else 0]))[0]))
    # evaluations at 0, 1, 2, 3 s: raw 0, 2, 2, 2 -> the alert comes at the second evaluation of 2 (t = 2.0 s)
    assert out.index(2) == 20
    assert list(h.last(["a", "nobody"])) == [2, 0]
