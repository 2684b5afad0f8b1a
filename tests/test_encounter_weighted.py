"""Weighted metrics of importance-weighted encounters (avionics_eval.encounter_models.weighted): the
effective-sample-size Wilson interval and the weighted-bootstrap ratio, on data whose answer is known."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from avionics_eval.encounter_models.model import packaged_model, read_model
from avionics_eval.encounter_models.pairing import generate
from avionics_eval.encounter_models.tracks import sample_tracks
from avionics_eval.encounter_models.weighted import nmac, weighted_proportion, weighted_ratio


def test_equal_weights_give_the_ordinary_wilson_interval():
    x = np.array([True] * 10 + [False] * 90)
    est = weighted_proportion(x, np.full(100, 3.0))
    assert est.estimate == pytest.approx(0.1) and est.effective_n == pytest.approx(100)
    assert (est.low, est.high) == pytest.approx((0.0552, 0.1744), abs=1e-4)  # Wilson 95 %, 10/100
    uneven = weighted_proportion(x, np.r_[np.full(50, 1.0), np.full(50, 9.0)])
    assert uneven.effective_n < 100 and uneven.events == 10
    with pytest.raises(ValueError):
        weighted_proportion(x, np.zeros(100))


def test_weighted_ratio_covers_a_known_ratio():
    rng = np.random.default_rng(4)
    n = 20000
    w = rng.uniform(0.2, 5.0, n)
    without = rng.random(n) < 0.2
    with_daa = without & (rng.random(n) < 0.25)  # the DAA leaves a quarter of the NMACs: ratio 0.25
    r = weighted_ratio(with_daa, without, w, np.random.default_rng(5), resamples=500)
    assert r.low <= 0.25 <= r.high and r.low < r.estimate < r.high
    assert r.numerator_events == int(with_daa.sum()) and r.denominator_events == int(without.sum())
    assert np.isnan(weighted_ratio(with_daa, np.zeros(n, bool), w, rng, resamples=10).estimate)


def test_nmac_of_paired_encounters_follows_the_misses():
    model = read_model(packaged_model("uncor_1200code_v2p1.txt"))
    e = generate(lambda k, rng: sample_tracks(model, k, 80, rng), lambda k, rng: sample_tracks(model, k, 80, rng),
                 1500, 40, np.random.default_rng(9))
    hit = nmac(e.own, e.intruder)
    inside = (np.abs(e.hmd_ft) < 500) & (np.abs(e.vmd_ft) < 100)
    assert (hit[inside]).all()  # at TCA, a sample, they are inside the cylinder
    p = weighted_proportion(hit, e.weight)
    assert p.events == int(hit.sum()) > 0 and 0 < p.low <= p.estimate <= p.high < 1


def test_a_ratio_with_no_numerator_event_gets_the_wilson_bound_of_zero_events():
    """The bootstrap cannot move off 0 when no encounter has the numerator: the upper bound is then the
    effective-sample-size Wilson bound of 0 events among the denominator's encounters, z^2 / (n_eff + z^2)."""
    w = np.r_[np.full(8, 2.0), np.full(92, 1.0)]
    b = np.r_[np.ones(8, bool), np.zeros(92, bool)]
    r = weighted_ratio(np.zeros(100, bool), b, w, np.random.default_rng(1), resamples=200)
    z2 = 1.959963984540054 ** 2
    assert (r.estimate, r.low) == (0.0, 0.0) and r.high == pytest.approx(z2 / (8 + z2))
    same = weighted_ratio(b, b, w, np.random.default_rng(1), resamples=200)  # every NMAC left: ratio 1
    assert same.estimate == 1.0 and same.high == pytest.approx(1.0) and same.low == pytest.approx(8 / (8 + z2))


def test_the_weighted_ratio_is_the_ratio_of_weighted_sums():
    w = np.array([1.0, 2.0, 3.0, 4.0, 5.0])
    a = np.array([True, False, True, False, False])
    b = np.array([True, True, False, True, False])
    r = weighted_ratio(a, b, w, np.random.default_rng(2), resamples=300)
    assert r.estimate == pytest.approx((1 + 3) / (1 + 2 + 4))
    assert (r.numerator_events, r.denominator_events) == (2, 3) and r.low <= r.estimate <= r.high


@settings(max_examples=12, deadline=None, derandomize=True)
@given(p=st.floats(0.005, 0.2), oversample=st.floats(2.0, 20.0), n=st.integers(300, 1500))
def test_the_effective_sample_size_wilson_interval_covers_an_importance_sampled_probability(p, oversample, n):
    """P(U < p) for U uniform on [0, 1] estimated from draws of a proposal that puts `oversample` times the
    nominal density on [0, p] (the way the pairing oversamples small misses), weights nominal / proposal. Over
    200 replicate sets the 95 % interval covers p at least 90 % of the time (docs/evaluation.md gives the
    coverage measured on 1000 replicates: 0.91-0.97)."""
    rng = np.random.default_rng(int(p * 1e6) + n)
    replicates = 200
    inside = rng.random((replicates, n)) < oversample * p / (oversample * p + 1 - p)
    u = np.where(inside, rng.random((replicates, n)) * p, p + rng.random((replicates, n)) * (1 - p))
    density = np.where(u < p, oversample, 1.0) / (oversample * p + 1 - p)
    covered = 0
    for k in range(replicates):
        est = weighted_proportion(u[k] < p, 1.0 / density[k])
        covered += est.low <= p <= est.high
    assert covered >= 0.9 * replicates


def test_the_interval_uses_the_estimate_s_own_effective_sample_size():
    """Events carrying small weights (oversampled) make p far better known than Kish's n_eff says: n_p =
    p (1 - p) / var, var = sum(w^2 (x - p)^2) / (sum w)^2, by hand."""
    x = np.r_[np.ones(20, bool), np.zeros(80, bool)]
    w = np.r_[np.full(20, 0.1), np.full(40, 1.0), np.full(40, 3.0)]
    est = weighted_proportion(x, w)
    total = 2.0 + 40.0 + 120.0
    p = 2.0 / total
    var = (20 * 0.01 * (1 - p) ** 2 + 40 * 1.0 * p * p + 40 * 9.0 * p * p) / total ** 2
    assert est.estimate == pytest.approx(p) and est.interval_n == pytest.approx(p * (1 - p) / var)
    assert est.effective_n == pytest.approx(total ** 2 / (20 * 0.01 + 40 + 360))
    assert est.interval_n > 10 * est.effective_n  # Kish's n_eff: over ten times fewer, an interval far too wide


def test_no_event_gives_a_lower_bound_of_exactly_zero():
    est = weighted_proportion(np.zeros(50, bool), np.linspace(1.0, 3.0, 50))
    assert (est.estimate, est.low) == (0.0, 0.0) and 0 < est.high < 1
    r = weighted_ratio(np.zeros(50, bool), np.arange(50) < 7, np.linspace(1.0, 3.0, 50), np.random.default_rng(0), 50)
    assert (r.estimate, r.low) == (0.0, 0.0) and 0 < r.high < 1
