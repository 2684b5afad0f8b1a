"""Weighted metrics of importance-weighted encounters (avionics_eval.encounter_models.weighted): the
effective-sample-size Wilson interval and the weighted-bootstrap ratio, on data whose answer is known."""

from __future__ import annotations

import numpy as np
import pytest

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
