"""The Monte Carlo oracle for SUM from the tracks (issue 29 acceptance; eval/avionics_eval/reports/sum_oracle.py):
a pass 1250 m abeam (DTHR 1222 m) flown by `sitl replay` with the default ADS-B impairments through the real
MAVLink path, IMM tracker and core, advisory.sum_from_tracks on. Wherever SUM (the level's WCV_TAUMOD_SUM with the
tracks' covariances) says no conflict, the fraction of true states drawn from those covariances that are in
conflict stays within the level the z-scores imply (1 - Phi(z_min), 22.7 % inside 2.5 nmi) with its binomial
allowance. The same check on the plain detector's clear assessments fails: this pass lies on the volume's edge,
so the check can fail, and SUM is what makes it hold."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import stats

from avionics.advisory.tables import load_profile
from avionics.base.units import NM
from avionics_eval.reports.sum_oracle import Geometry, assessments, implied_level, oracle

PROFILE = "daidalus-do365b-sum"


def test_implied_level_is_the_weakest_z_score_tail():
    z = load_profile(PROFILE).alerter.sum
    assert implied_level(z, 0.0, 0.0) == pytest.approx(stats.norm.sf(0.75))  # v_pos 0.75: 22.66 %
    assert implied_level(z, 0.0, 0.0) == pytest.approx(0.2266, abs=1e-4)
    assert implied_level(z, 4.0 * NM, 0.0) == pytest.approx(stats.norm.sf(0.6))  # h_vel 1.0 - 0.5 * 4 / 5
    assert implied_level(z, 6.0 * NM, 0.0) == pytest.approx(0.3085, abs=1e-4)  # h_vel_z_score_min 0.5


def test_sum_clear_means_few_draws_in_conflict():
    rows = assessments(Geometry(180.0, 1250.0, 0.0, t_meet_s=60.0, duration_s=75.0), PROFILE, seed=1)
    assert len(rows) >= 60
    result = oracle(rows, PROFILE, draws=400, rng=np.random.default_rng(1))
    for name, res in result.items():
        s, plain = res["sum"], res["plain"]
        assert s["assessments"] >= 10, name
        assert s["over_allowance"] == 0, (name, s["worst"])
        assert s["max_fraction"] < s["worst"]["implied_level"], (name, s["worst"])
        # the pass is on the edge: without SUM, clear assessments have many draws in conflict
        assert plain["over_allowance"] > 0, (name, plain["worst"])
        assert plain["max_fraction"] > 0.3, name
