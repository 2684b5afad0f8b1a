"""Radosavljevic's binomial persistence (eqs 19-24), its Poisson-binomial form, M-of-N: against enumeration."""

import itertools
import math

import numpy as np
import pytest

from avionics.conflict import persistence as ps


def enumerate_at_least(l, probs):
    """P(at least l successes) by summing over all 2^n outcomes."""
    total = 0.0
    for outcome in itertools.product((0, 1), repeat=len(probs)):
        if sum(outcome) >= l:
            total += math.prod(p if o else 1.0 - p for o, p in zip(outcome, probs))
    return total


@pytest.mark.parametrize("n", [1, 3, 5, 8])
@pytest.mark.parametrize("p", [0.0, 0.05, 0.25, 0.5, 0.75, 1.0])
def test_binomial_tail_against_enumeration(n, p):
    for l in range(0, n + 2):
        assert ps.binomial_at_least(l, n, p) == pytest.approx(enumerate_at_least(l, [p] * n), abs=1e-14)
    pmf = [ps.binomial_pmf(l, n, p) for l in range(n + 1)]  # eq 22
    assert sum(pmf) == pytest.approx(1.0)  # the total probability theorem below eq 22
    mean, var = ps.binomial_mean_var(n, p)  # eqs 23-24
    assert mean == pytest.approx(sum(l * q for l, q in enumerate(pmf)))
    assert var == pytest.approx(sum((l - mean) ** 2 * q for l, q in enumerate(pmf)), abs=1e-12)


def test_paper_example_third_order():
    # Radosavljevic eq 31-32: n = 3, pi = 0.5 -> 1/8, 3/8, 3/8, 1/8
    assert [ps.binomial_pmf(l, 3, 0.5) for l in range(4)] == pytest.approx([0.125, 0.375, 0.375, 0.125])


def test_poisson_binomial_against_enumeration():
    rng = np.random.default_rng(0)
    probs = rng.uniform(0, 1, (20, 7))
    for l in range(0, 9):
        got = ps.poisson_binomial_at_least(l, probs)
        want = [enumerate_at_least(l, row) for row in probs]
        assert np.allclose(got, want, atol=1e-14)
    # equal probabilities: the binomial
    assert ps.poisson_binomial_at_least(3, np.full((1, 5), 0.3))[0] == pytest.approx(ps.binomial_at_least(3, 5, 0.3))
    dist = ps.count_distribution(probs)
    assert np.allclose(dist.sum(axis=1), 1.0)


def test_m_of_n():
    flags = np.array([[1, 0, 1, 1], [1, 0, 0, 0], [0, 0, 0, 0]], bool)
    assert list(ps.m_of_n(flags, 3)) == [True, False, False]
    assert list(ps.m_of_n(flags, 1)) == [True, True, False]


def test_filter_over_assessments():
    f = ps.PersistenceFilter("poisson_binomial", l=2, n=3, confidence=0.5)
    keys = ["a", "b"]
    alert, score = f.update(keys, [0.9, 0.1])
    assert list(alert) == [False, False]  # one assessment cannot hold 2 conflicts
    alert, score = f.update(keys, [0.9, 0.1])
    assert list(alert) == [True, False] and score[0] == pytest.approx(0.81)
    alert, score = f.update(keys, [0.0, 0.1])
    assert score[0] == pytest.approx(enumerate_at_least(2, [0.9, 0.9, 0.0]))
    alert, _ = f.update(keys, [0.0, 0.1])  # the window [0.9, 0, 0]: at most one conflict
    assert not alert[0]
    f.forget("a")
    assert np.all(f.window(["a"]) == 0.0)
    # binomial with pi = the window mean; m_of_n with a Pc threshold
    fb = ps.PersistenceFilter("binomial", l=2, n=3, confidence=0.5)
    for pc in (0.6, 0.6, 0.6):
        alert, score = fb.update(["x"], [pc])
    assert score[0] == pytest.approx(ps.binomial_at_least(2, 3, 0.6)) and alert[0]
    fm = ps.PersistenceFilter("m_of_n", l=2, n=3, pc_threshold=0.5)
    out = [bool(fm.update(["x"], [pc])[0][0]) for pc in (0.6, 0.1, 0.7, 0.1, 0.1)]
    assert out == [False, False, True, False, False]
    with pytest.raises(ValueError):
        ps.PersistenceFilter("nope")
    with pytest.raises(ValueError):
        ps.PersistenceFilter(l=4, n=3)
