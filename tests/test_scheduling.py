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


def test_prefilters_as_objects_built_from_the_configuration():
    import dataclasses

    import pytest

    from avionics.compose import build_prefilter
    from avionics.config import ConflictConfig
    from avionics.conflict.params import PREFILTERS

    cfg = ConflictConfig()
    # head-on 10 km out (kept by 2(b), rejected by 2(a) as printed), receding 30 km out (rejected by both), and a
    # pair 2000 m above the slab that stays there (rejected by the vertical part of 2(b))
    rel_x = np.array([[10000.0, 0.0, 0.0, -100.0, 0.0, 0.0], [-30000.0, 0.0, 0.0, -100.0, 0.0, 0.0],
                      [3000.0, 0.0, 2000.0, -100.0, 0.0, 0.0]])
    rel_p = np.broadcast_to(np.diag([100.0, 100.0, 25.0, 1.0, 1.0, 0.25]), (3, 6, 6))
    has_alt, margin, own_vel = np.ones(3, bool), np.zeros(3), np.array([50.0, 0.0])
    kinds = {}
    for name in PREFILTERS:
        f = build_prefilter(dataclasses.replace(cfg, prefilter=name))
        kinds[name] = type(f).__name__
        keep = list(f.keep(rel_x, rel_p, has_alt, margin, own_vel))
        assert keep == {"none": [True, True, True], "min_distance": [True, False, False],
                        "hwang": [False, False, False]}[name]
    assert kinds == {"none": "NoPrefilter", "min_distance": "MinDistancePrefilter", "hwang": "HwangPrefilter"}
    # without altitude the vertical part passes
    assert list(build_prefilter(cfg).keep(rel_x, rel_p, np.zeros(3, bool), margin)) == [True, False, True]
    with pytest.raises(ValueError, match="own_vel"):
        build_prefilter(dataclasses.replace(cfg, prefilter="hwang")).keep(rel_x, rel_p, has_alt, margin)

