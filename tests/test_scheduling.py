"""Hwang's conditions for conflict-detection computation: pair pre-filters and the recompute schedule."""

import numpy as np

from avionics.conflict import scheduling as sc


def test_geometric_cases_as_printed():
    r = np.array([[10.0, 0.0]])  # j is 10 east of i
    # crossing paths ahead (i north-east, j north-west): CASE I
    assert sc.hwang_geometric_filter(r, [[1.0, 1.0]], [[-1.0, 1.0]])[0]
    # i follows j eastbound and is faster: CASE II; slower: not
    assert sc.hwang_geometric_filter(r, [[2.0, 0.1]], [[1.0, 0.0]])[0]
    assert not sc.hwang_geometric_filter(r, [[1.0, 0.0]], [[2.0, 0.0]])[0]
    # j follows i (both westbound, j faster): the second alternative of CASE II ('or', not the printed 'and')
    assert sc.hwang_geometric_filter(r, [[-1.0, 0.0]], [[-2.0, 0.0]])[0]
    # diverging: neither case
    assert not sc.hwang_geometric_filter(r, [[-1.0, 0.0]], [[1.0, 0.0]])[0]
    # The printed condition rejects an exact head-on and an offset head-on: why it is not the DAA default.
    assert not sc.hwang_geometric_filter(r, [[1.0, 0.0]], [[-1.0, 0.0]])[0]
    assert not sc.hwang_geometric_filter([[10.0, 0.5]], [[1.0, 0.0]], [[-1.0, 0.0]])[0]
    assert sc.min_distance_filter(r, [[-2.0, 0.0]], 1.0, 60.0)[0]  # the default pre-filter keeps it


def test_predicted_min_distance_against_sampling():
    rng = np.random.default_rng(0)
    s = rng.uniform(-100, 100, (200, 2))
    v = rng.uniform(-10, 10, (200, 2))
    t = np.linspace(0, 30, 30001)
    brute = np.min(np.hypot(s[:, None, 0] + v[:, None, 0] * t, s[:, None, 1] + v[:, None, 1] * t), axis=1)
    assert np.allclose(sc.predicted_min_distance(s, v, 30.0), brute, atol=1e-3)
    assert np.allclose(sc.predicted_min_vertical([100.0, 100.0, -5.0], [-10.0, 1.0, 0.0], 30.0), [0.0, 100.0, 5.0])


def test_min_distance_filter_alpha_extra_and_vertical():
    s, v = np.array([[1000.0, 140.0]]), np.array([[-50.0, 0.0]])
    assert not sc.min_distance_filter(s, v, 100.0, 60.0, alpha=1.0)[0]
    assert sc.min_distance_filter(s, v, 100.0, 60.0, alpha=1.5)[0]  # alpha R = 150 > 140
    assert sc.min_distance_filter(s, v, 100.0, 60.0, alpha=1.0, extra_m=50.0)[0]
    assert not sc.min_distance_filter(s, v, 100.0, 10.0, alpha=1.5)[0]  # too far for the lookahead
    # vertical: 500 m apart and level -> out; unknown altitude (NaN) -> kept
    assert not sc.min_distance_filter(s, v, 100.0, 60.0, 1.5, 0.0, [500.0], [0.0], 100.0)[0]
    assert sc.min_distance_filter(s, v, 100.0, 60.0, 1.5, 0.0, [np.nan], [0.0], 100.0)[0]
    assert sc.hwang_prefilter(s, [[0.0, 0.0]], v, 100.0, 60.0)[0]  # i stationary, j comes towards it


def test_scheduler_rates():
    s = sc.ConflictScheduler(period_s=1.0, fast_period_s=0.2, threshold=0.5)
    keys = ["low", "high"]
    assert list(s.due(0.0, keys)) == [True, True]  # never assessed
    s.record(0.0, keys, [0.1, 0.9], ["cv", "cv"])
    assert list(s.due(0.1, keys, ["cv", "cv"])) == [False, False]
    assert list(s.due(0.2, keys, ["cv", "cv"])) == [False, True]  # 1(c): Pc >= P-bar every tau_c
    assert list(s.due(0.3, keys, ["ct", "cv"])) == [True, True]  # 1(b): mode change
    assert list(s.due(1.0, keys, ["cv", "cv"])) == [True, True]  # 1(a): every tau
    assert np.isnan(s.last_pc(["new"])[0]) and s.last_pc(["high"])[0] == 0.9
    s.forget("high")
    assert s.due(0.01, ["high"])[0]
