"""Compiled IMM kernels (avionics/tracking/kernels.py) against the numpy reference (avionics/tracking/imm.py): the
same results to 1e-9 on random inputs (states, covariances, dt including 0 and large, masked components, mode
probabilities near 0 and 1, the gate), the same tracker run with kernels on and off, and the coverage rules.

Both paths run in this process: a bank or tracker built with compiled=False runs the reference, compiled=True the
kernels (numba-compiled when AVIONICS_COMPILED is not 0, else the same functions as plain Python)."""

import dataclasses
from collections import Counter

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from avionics.compose import build_tracker
from avionics.config import load_config
from avionics.base import jit
from avionics.base.types import AddressSource, AltitudeDatum, IntruderKey, IntruderReport
from avionics.tracking import imm, imm_tracker, kernels, models
from avionics.tracking.imm import ImmBank, VbParams

H_MODES = {"cv": models.ConstantVelocity(0.3), "ca": models.ConstantAcceleration(3.0),
           "ca-iso": models.ConstantAcceleration(3.0, heading_noise=False), "ct": models.CoordinatedTurn(2.0)}
V_MODES = {"ch": models.ConstantHeight(0.1), "cad": models.ConstantAltitudeChange(1.0)}
# dt of an update or a prediction: 0, tiny, an ADS-B interval, long coasts (a track is deleted after 20 s without
# a report), and negative (a prediction to a time before the last report). Predictions are also compared an hour
# ahead; updates up to 120 s: after longer coasts P - K H P is a difference of priors > 1e9 m^2 and both paths
# keep only as many digits as that cancellation leaves (at 600 s, 1e-4 relative: a property of the equations).
DTS = st.one_of(st.sampled_from([0.0, 1e-9, 1.0, 20.0, 120.0]), st.floats(0.0, 120.0), st.floats(-5.0, 0.0))


def close(a, b, tol=1e-9, computed_from=0.0):
    """Equal to tol relative to the array's scale (entries near zero are compared at that scale), or to 1e-12 of
    the magnitude they were computed from: a posterior covariance is a difference of priors (P - K H P), ~1e10 m^2
    after a 100 s coast, where either path keeps ~1e-13 of it (at the tracker's dt <= 20 s the priors are
    ~1e6 m^2, and 1e-12 of them is no looser than tol)."""
    a, b = np.asarray(a, float), np.asarray(b, float)
    scale = max(1.0, float(np.nanmax(np.abs(b)))) if b.size else 1.0
    np.testing.assert_array_equal(np.isnan(a), np.isnan(b))
    np.testing.assert_allclose(a, b, rtol=tol, atol=max(tol * scale, 1e-12 * computed_from), equal_nan=True)


def random_bank_pair(rng, names, horizontal, b, extreme_mu):
    """Two banks (reference, compiled) holding the same random states of b slots (every other slot of 2b)."""
    table = H_MODES if horizontal else V_MODES
    modes = [table[n] for n in names]
    d = 4 if horizontal else 2
    # (some p with 4 modes make models.MarkovChain's eigenvector matrix singular, e.g. 0.23: not these)
    switch = models.switching_matrix(len(modes), rng.choice([0.01, 0.05, 0.1, 0.2, 0.3, 0.45]))
    banks = [ImmBank(modes, d, switch, capacity=2 * b, compiled=c) for c in (False, True)]
    m, n = len(modes), modes[0].dim
    scale = np.array([3000.0, 3000.0, 150.0, 150.0, 5.0, 5.0][:n] if horizontal else [2000.0, 10.0])
    x = rng.normal(size=(2 * b, m, n)) * scale
    x[:, :, :2] += rng.uniform(-1e5, 1e5, (2 * b, 1, 1)) if horizontal else 0.0  # large coordinates, small spread
    a = rng.normal(size=(2 * b, m, n, n)) * (scale[:, None] * rng.uniform(0.001, 0.3, (2 * b, m, 1, 1)))
    p = a @ np.swapaxes(a, -1, -2) + np.eye(n) * 1e-3
    if extreme_mu:
        mu = np.full((2 * b, m), 1e-14)
        mu[np.arange(2 * b), rng.integers(0, m, 2 * b)] = 1.0
    else:
        mu = rng.dirichlet(np.ones(m), 2 * b)
    mu /= mu.sum(axis=1, keepdims=True)
    for bank in banks:
        bank.x[:], bank.p[:], bank.mu[:] = x, p, mu
    return banks, np.arange(0, 2 * b, 2)


@settings(max_examples=120)
@given(seed=st.integers(0, 2**32 - 1), horizontal=st.booleans(), modes=st.integers(0, 15), b=st.integers(1, 6),
       dt=DTS, extreme_mu=st.booleans(), masks=st.lists(st.lists(st.booleans(), min_size=4, max_size=4),
                                                           min_size=6, max_size=6), far=st.booleans())
def test_bank_update_predict_posterior_equal_the_reference(seed, horizontal, modes, b, dt, extreme_mu, masks, far):
    rng = np.random.default_rng(seed)
    pool = list(H_MODES) if horizontal else list(V_MODES)
    names = [k for i, k in enumerate(pool) if modes >> i & 1] or [pool[modes % len(pool)]]
    (ref, comp), slots = random_bank_pair(rng, names, horizontal, b, extreme_mu)
    assert comp.compiled and not ref.compiled
    d = ref.d
    mask = np.array(masks, bool)[:b, :d]
    z = ref.posterior(slots)[0][:, :d] + rng.normal(size=(b, d)) * (1e4 if far else 30.0)  # far: a gate miss
    r_var = rng.uniform(1.0, 900.0, (b, d))
    dts = np.full(b, dt)
    dts[::2] = rng.uniform(0.0, 10.0, len(dts[::2]))  # every track its own interval
    # A mode of probability 1e-14 mixed over dt ~ 0 is ill-conditioned in both paths: M(0)'s off-diagonal is
    # rounding noise (1e-17 from numpy's BLAS, 0 in the kernel); divided by c_j ~ 1e-14 it blends 1e-3 of the
    # other mode into that mode's state, and a far report's likelihood can then favour that mode. The tracker
    # never updates there (a report within DUPLICATE_WINDOW_S = 1e-6 s of the last is a duplicate); the
    # prediction there is well-conditioned (the combination weighs that mode by 1e-14) and compared below.
    if not (extreme_mu and abs(dt) < 1e-6):
        pr, pc = ref.update(slots, dts, z, mask, r_var), comp.update(slots, dts, z, mask, r_var)
        prior_scale = float(np.abs(ref.predict(slots, dts)[1]).max())
        for name in ("x", "p", "mu", "d2", "loglik"):
            close(getattr(pc, name), getattr(pr, name), computed_from=prior_scale if name == "p" else 0.0)
        for name in ("x_prior", "var_prior"):
            close(pc.extra[name], pr.extra[name])
        np.testing.assert_array_equal(pc.dof, pr.dof)
        close(pc.mu.sum(axis=1), 1.0)
    for horizon in (dts, dts + 3600.0):  # and an hour ahead
        for got, want in zip(comp.predict(slots, horizon), ref.predict(slots, horizon)):
            close(got, want)
    for got, want in zip(comp.posterior(slots), ref.posterior(slots)):
        close(got, want)


@given(p=st.floats(0.001, 0.45), k=st.integers(1, 4), dt=DTS)
def test_the_markov_chain_for_any_interval_equals_the_reference(p, k, dt):
    try:
        chain = models.MarkovChain(models.switching_matrix(k, p))
    except (ValueError, np.linalg.LinAlgError):  # no continuous-time chain samples to this M1
        assume(False)
    spec = kernels.BankSpec([V_MODES["ch"]] * k, chain)
    out = np.empty((k, k))
    kernels.transition(dt, spec.v, spec.vinv, spec.lam, out)
    np.testing.assert_allclose(out, chain.at(dt)[0], rtol=0, atol=1e-14)


def test_a_not_positive_definite_innovation_covariance_raises_on_both_paths():
    rng = np.random.default_rng(3)
    (ref, comp), slots = random_bank_pair(rng, ["cv", "ct"], True, 2, False)
    for bank in (ref, comp):
        bank.p[slots[1], :, 0, 0] = -1e6  # a broken covariance: S_00 < 0
        with pytest.raises(np.linalg.LinAlgError):
            bank.update(slots, 1.0, np.zeros((2, 4)), np.ones((2, 4), bool), np.ones((2, 4)))


def test_coverage_default_configuration_compiled_others_on_the_reference():
    chain = models.MarkovChain(models.switching_matrix(2, 0.05))
    assert kernels.BankSpec([H_MODES["cv"], H_MODES["ct"]], chain).covered
    assert kernels.BankSpec([V_MODES["ch"], V_MODES["cad"]], chain).covered
    assert not kernels.BankSpec([H_MODES["cv"], models.CurrentStatistical(0.1, 20.0)], chain).covered
    assert not kernels.BankSpec([H_MODES["cv"], H_MODES["ct"]], chain, likelihood="rmimm").covered
    assert not kernels.BankSpec([H_MODES["cv"], H_MODES["ct"]], chain, vb=VbParams()).covered
    with pytest.raises(ValueError, match="no compiled kernels"):
        ImmBank([H_MODES["cv"], H_MODES["ct"]], 4, np.eye(2) * 0.9 + 0.05, likelihood="rmimm", compiled=True)
    default = build_tracker(load_config().tracking, Counter())
    assert default.compiled == jit.ENABLED  # the default configuration runs compiled whenever kernels are on
    for f in ("rmimm", "vb-imm", "vb-rmimm"):
        assert not build_tracker(load_config(overrides=[f"tracking.filter={f}"]).tracking, Counter()).compiled
    cs = build_tracker(load_config(overrides=['tracking.imm_horizontal_modes=["cv","cs"]']).tracking, Counter())
    assert not cs.compiled and cs.bank_v.compiled == jit.ENABLED


@pytest.mark.skipif(not jit.ENABLED, reason="compiled kernels are off (AVIONICS_COMPILED=0)")
def test_every_kernel_is_compiled_at_import_and_none_compiles_again_in_a_run():
    names = [k for k in dir(kernels) if isinstance(getattr(kernels, k), type(kernels.tracker_update))]
    assert len(names) >= 9 and all(getattr(kernels, k) in jit.KERNELS for k in names)
    before = {k: len(getattr(kernels, k).signatures) for k in names}
    misses = {k: sum(getattr(kernels, k)._cache_misses.values()) for k in names}  # compilations, at import
    assert all(before.values())
    run_tracker(True, steps=5)
    # the run called these dispatchers (the trackers' stand-ins gave way to this module, avionics/base/jit.py)
    assert imm.kernels is kernels and imm_tracker.kernels is kernels and jit.loaded()
    assert {k: len(getattr(kernels, k).signatures) for k in names} == before
    assert {k: sum(getattr(kernels, k)._cache_misses.values()) for k in names} == misses  # none compiled in it


def run_tracker(compiled: bool, steps: int = 60, n: int = 12, seed: int = 11):
    """A batch of reports per second for n aircraft, straight and turning, some climbing, with missing velocities
    and altitudes, irregular times, a position jump (gate misses, a competitor and a restart), a datum change,
    and an out-of-order report; predictions each step. Returns what to compare."""
    rng = np.random.default_rng(seed)
    tr = build_tracker(load_config().tracking, Counter(), capacity=4)  # grows during the run
    tr.compiled = compiled
    keys = [IntruderKey(0xA00000 + i, AddressSource.UAT if i % 3 == 0 else AddressSource.ES1090) for i in range(n)]
    pos = rng.uniform(-2e4, 2e4, (n, 2))
    psi = rng.uniform(0, 2 * np.pi, n)
    speed = rng.uniform(40, 250, n)
    alt = rng.uniform(300, 3000, n)
    rate = np.where(np.arange(n) % 4 == 1, 5.0, 0.0)
    turn = np.where(np.arange(n) % 2 == 0, np.radians(3.0), 0.0)
    out = {"ingest": [], "x": [], "p": [], "mu": [], "pred": [], "modes": []}
    for k in range(steps):
        reps, es, ns = [], [], []
        for i in range(n):
            if rng.uniform() < 0.05:
                continue  # dropout
            psi[i] += turn[i] if 20 <= k < 40 else 0.0
            pos[i] += speed[i] * np.array([np.sin(psi[i]), np.cos(psi[i])])
            alt[i] += rate[i]
            t = k + rng.uniform(0.0, 0.4)
            vel = None if rng.uniform() < 0.15 else (speed[i] * np.sin(psi[i]) + rng.normal(0, 1),
                                                     speed[i] * np.cos(psi[i]) + rng.normal(0, 1))
            a = None if rng.uniform() < 0.1 else alt[i] + rng.normal(0, 5)
            datum = AltitudeDatum.GEOMETRIC if (i == 5 and k > 30) else AltitudeDatum.PRESSURE
            e, no = pos[i] + rng.normal(0, 30, 2)
            if i == 3 and 25 <= k < 31:
                e += 5000.0  # a second aircraft under this address: gate misses, then a restart
            if i == 7 and k % 10 == 9:
                e += 600.0  # one outlier: a gate miss
            reps.append(IntruderReport(keys[i], t, t, 0.0, 0.0, a, datum if a is not None else None, vel,
                                       None if rng.uniform() < 0.1 else rate[i] + rng.normal(0, 0.3),
                                       position_sigma_m=15.0 if i == 2 else None))  # a feed's own NACp
            es.append(e)
            ns.append(no)
        if k == 40:  # an old report after a newer one
            reps.append(dataclasses.replace(reps[0], time_s=reps[0].time_s - 3.0))
            es.append(es[0])
            ns.append(ns[0])
        out["ingest"].append(tr.ingest_many(reps, es, ns).tolist())
        live = sorted(tr.tracks)
        xs, ps = tr.predict(live, k + 0.5)
        out["pred"].append((xs, ps))
        out["modes"].append([(m["mode_probabilities"], m["turn_rate_dps"]) for m in tr.mode_infos(live, k + 0.5)])
        tr.prune(k + 0.5)
    slots = np.array(sorted(t.slot for t in tr.tracks.values()))
    for bank in (tr.bank_h, tr.bank_v):
        out["x"].append(bank.x[slots])
        out["p"].append(bank.p[slots])
        out["mu"].append(bank.mu[slots])
    out["yaw"] = tr.bank_h.yaw[slots]
    out["counters"] = dict(tr.counters)
    out["tracks"] = {k: (t.n_updates, t.last_report_s, t.slot) for k, t in tr.tracks.items()}
    return out


def test_the_tracker_with_kernels_on_and_off_gives_the_same_run():
    ref, comp = run_tracker(False), run_tracker(True)
    assert comp["ingest"] == ref["ingest"]  # the same gate decisions, report by report
    assert comp["counters"] == ref["counters"] and comp["tracks"] == ref["tracks"]
    assert ref["counters"].get("track.gate_miss", 0) + ref["counters"].get("track.implausible_jump", 0) >= 5
    assert ref["counters"].get("track.restarted", 0) >= 1 and ref["counters"].get("track.datum_change", 0) >= 1
    for name in ("x", "p", "mu"):
        for got, want in zip(comp[name], ref[name]):
            close(got, want)
    close(comp["yaw"], ref["yaw"])
    for (xc, pc), (xr, pr) in zip(comp["pred"], ref["pred"]):
        close(xc, xr)
        close(pc, pr)
    for mc, mr in zip(comp["modes"], ref["modes"]):
        for (pc, tc), (pr, tr_) in zip(mc, mr):
            close(list(pc.values()), list(pr.values()))
            close(tc, tr_)
