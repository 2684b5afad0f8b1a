"""Pairing Lincoln-model trajectories into importance-weighted encounters (avionics_eval.encounter_models.pairing):
the drawn HMD/VMD are the tracks' true misses at CPA, proposals equal to the nominal give importance weights of
1, and a weighted estimate of a known nominal probability is recovered within its interval. Tracks are sampled
from the package's shipped model files."""

from __future__ import annotations

import numpy as np
import pytest

from avionics_eval.encounter_models.model import packaged_model, read_model
from avionics_eval.encounter_models.pairing import (HMD_EDGES_FT, PairingError, Proposal, generate,
                                                    horizontal_cpa, relative_speed_integral)
from avionics_eval.encounter_models.tracks import sample_tracks
from avionics_eval.encounter_models.uav import mission_tracks
from avionics_eval.encounter_models.weighted import weighted_proportion

TCA = 40
MODEL = read_model(packaged_model("uncor_1200code_v2p1.txt"))


def tracks(count, rng):
    return sample_tracks(MODEL, count, 2 * TCA, rng, transition="markov")


def test_drawn_misses_are_the_tracks_true_misses_at_cpa():
    e = generate(tracks, tracks, 2000, TCA, np.random.default_rng(11))
    assert len(e) == 2000
    t_cpa, r_cpa = horizontal_cpa(e.own, e.intruder)
    assert np.allclose(r_cpa, np.abs(e.hmd_ft), atol=1.0)
    # VMD at the CPA: the altitudes at TCA; the CPA is at TCA except where the range is flat there
    assert np.allclose(e.intruder.alt_ft[:, TCA] - e.own.alt_ft[:, TCA], e.vmd_ft, atol=1.0)
    at_tca = np.abs(t_cpa - TCA) < 1e-6
    assert at_tca.mean() > 0.99
    assert np.allclose(np.hypot(e.intruder.north_ft[:, TCA] - e.own.north_ft[:, TCA],
                                e.intruder.east_ft[:, TCA] - e.own.east_ft[:, TCA]), np.abs(e.hmd_ft), atol=1.0)
    assert np.allclose(e.own.north_ft[:, 0], 0) and np.allclose(e.own.east_ft[:, 0], 0)
    assert (np.abs((e.own.heading_deg[:, TCA] + 180) % 360 - 180) < 1e-6).all()  # ownship heads north at TCA
    assert (np.abs(e.vmd_ft) < 1500).all() and (np.abs(e.hmd_ft) <= HMD_EDGES_FT[-1]).all()
    assert e.rejected_vmd > 0  # independent altitudes mostly lie > 1500 ft apart


def test_proposals_equal_to_the_nominal_give_weights_of_one():
    flat_hmd = Proposal.of((-18240.0, 0.0, 18240.0), (1.0, 1.0))
    # bin shares are what the rejection keeps (q_b = p_b / max p): equal shares keep every pair, these do not
    flat_vmd = Proposal.of((-1500.0, -100.0, 100.0, 1500.0), (1400.0, 200.0, 1400.0))
    e = generate(tracks, tracks, 500, TCA, np.random.default_rng(12), hmd=flat_hmd,
                 vmd=Proposal.of((-1500.0, 1500.0), (1.0,)))
    assert np.allclose(e.importance, 1.0)
    assert (e.weight > 0).all()
    e2 = generate(tracks, tracks, 500, TCA, np.random.default_rng(12), hmd=flat_hmd, vmd=flat_vmd)
    assert not np.allclose(e2.importance, 1.0)  # unequal bin shares: rejection and its weights at work
    # the rate weight integrates |v_rel| over the heading: against a hovering intruder it is 2 pi v1
    v = relative_speed_integral(np.array([100.0]), np.array([0.0]), np.array([0.0]), np.array([0.0]))
    assert v[0] == pytest.approx(2 * np.pi * 100.0)


def test_weighted_estimate_recovers_a_nominal_probability():
    """Under the nominal HMD (uniform on +-18240 ft) P(|HMD| < 500 ft) = 500 / 18240; the tool's proposal
    draws such encounters about 11 times as often, the weights bring the estimate back."""
    e = generate(tracks, tracks, 4000, TCA, np.random.default_rng(13))
    _, r_cpa = horizontal_cpa(e.own, e.intruder)
    close = r_cpa < 500.0
    truth = 500.0 / 18240.0
    assert close.mean() > 5 * truth  # the proposal oversamples close encounters
    est = weighted_proportion(close, e.weight)
    assert est.low <= truth <= est.high, est
    assert est.events == int(close.sum())


def test_bad_proposals_and_tca_are_errors():
    with pytest.raises(PairingError):
        Proposal.of((0.0, -1.0), (1.0,))
    rng = np.random.default_rng(1)
    with pytest.raises(PairingError, match="TCA"):
        generate(tracks, tracks, 10, 500, rng)


@pytest.mark.parametrize("mission", ["transit", "survey", "corridor", "hover"])
def test_uav_ownship_missions_pair_with_the_rotorcraft_model(mission):
    rotorcraft = read_model(packaged_model("uncor_1200exclude_rotorcraft_v1p2.txt"))
    own = mission_tracks(mission, 300, 2 * TCA, np.random.default_rng(5))
    assert ((own.alt_ft >= 50) & (own.alt_ft <= 1200)).all()
    if mission != "hover":
        step = np.hypot(np.diff(own.north_ft, axis=1), np.diff(own.east_ft, axis=1))
        assert np.allclose(step, 10.0 / 0.3048)  # WPNAV_SPEED 10 m/s
    e = generate(lambda k, rng: mission_tracks(mission, k, 2 * TCA, rng),
                 lambda k, rng: sample_tracks(rotorcraft, k, 2 * TCA, rng), 300, TCA, np.random.default_rng(6))
    _, r_cpa = horizontal_cpa(e.own, e.intruder)
    assert len(e) == 300 and np.allclose(r_cpa, np.abs(e.hmd_ft), atol=1.0)
    assert (e.weight > 0).all()
