"""The DO-365 alerter's compiled kernels (avionics/advisory/kernels.py) against their numpy references (advisory/
wcv.py, wcv_sum.py, base/almost.py, alerting.py): every decision identical, every interval to 1e-9 s.

Both paths run in one process: the public `Alerter.alert` takes the kernel when avionics.base.jit.ready(), the
numpy reference inside jit.reference(). Geometries are random and at the ties DAIDALUS decides with almost-equals:
vertical separations on the 25 ft grid of ADS-B altitudes (450 and 700 ft among them), ranges exactly at DTHR, no
relative motion, level flight; uncertainties none, zero, one axis or all. Under AVIONICS_COMPILED=0 there is
nothing compiled to compare: the tests skip.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st

from avionics.advisory import kernels
from avionics.advisory.alerting import Encounter, wcv_alerter
from avionics.advisory.bands_kinematics import Cylinder, cylinder_lines, level_out_times
from avionics.advisory.tables import load_profile
from avionics.advisory.wcv import _horizontal_interval, conflict, wcv_interval
from avionics.advisory.wcv_sum import MIN_ERROR, wcv_uncertain_intervals
from avionics.conflict.cpa import pair_geometry
from avionics.base import jit
from avionics.base.almost import almost_equals
from avionics.base.units import FPM, FT, KT, NM

pytestmark = pytest.mark.skipif(not jit.ENABLED, reason="compiled kernels are off (AVIONICS_COMPILED=0)")
SETTINGS = settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.too_slow])
PROFILES = ("do365", "daidalus-do365b-no-sum", "daidalus-do365b-sum", "do365-non-coop", "f3442")
ALERTERS = {name: (wcv_alerter(load_profile(name).alerter, name), load_profile(name).levels[0]) for name in PROFILES}
DTHR = 0.66 * NM

horizontal = st.one_of(
    st.tuples(st.floats(-12 * NM, 12 * NM), st.floats(-12 * NM, 12 * NM)),
    st.tuples(st.floats(-3 * NM, 3 * NM), st.floats(-3 * NM, 3 * NM)),
    st.sampled_from([(DTHR, 0.0), (0.0, -DTHR), (2200 * FT, 0.0), (0.0, 0.0), (DTHR + 1e-9, 0.0)]))
velocity = st.one_of(
    st.tuples(st.floats(-300 * KT, 300 * KT), st.floats(-300 * KT, 300 * KT)),
    st.sampled_from([(0.0, 0.0), (-100.0, 0.0), (0.0, 50.0), (1e-14, 0.0)]))
vertical = st.one_of(st.floats(-3000 * FT, 3000 * FT), st.integers(-40, 40).map(lambda k: 25.0 * k * FT))
vertical_rate = st.one_of(st.floats(-3000 * FPM, 3000 * FPM), st.integers(-6, 6).map(lambda k: 500.0 * k * FPM),
                          st.sampled_from([0.0, 1e-14, -1e-14]))
error_sums = st.one_of(
    st.none(), st.just((0.0, 0.0, 0.0, 0.0)),
    st.tuples(st.floats(0, 300), st.floats(0, 60), st.floats(0, 10), st.floats(0, 3)),
    st.sampled_from([(15.0, 0.0, 0.0, 0.0), (0.0, 4.0, 0.0, 0.0), (0.0, 0.0, 1.5, 0.0), (0.0, 0.0, 0.0, 0.5)]))
pair = st.tuples(horizontal, velocity, vertical, vertical_rate, st.booleans(), st.sampled_from([0.0, 0.0, 30.0]),
                 st.integers(0, 3))


def _encounter(pairs, errors):
    s = np.array([p[0] for p in pairs], float)
    v = np.array([p[1] for p in pairs], float)
    has_alt = np.array([p[4] for p in pairs], bool)
    sz = np.where(has_alt, [p[2] for p in pairs], 0.0)
    vz = np.where(has_alt, [p[3] for p in pairs], 0.0)
    g = pair_geometry(s, v, sz, vz)
    margin = np.array([p[5] for p in pairs], float)
    unc = None if errors is None else np.tile(np.asarray(errors, float), (len(pairs), 1))
    return Encounter(g, has_alt, margin, True, unc), np.array([p[6] for p in pairs], int)


@SETTINGS
@given(st.sampled_from(PROFILES), st.lists(pair, min_size=1, max_size=6), error_sums,
       st.sampled_from([None, 0, 1, 2, 3]), st.booleans())
@example("do365", [((DTHR, 0.0), (-100.0, 0.0), 450 * FT, 0.0, True, 0.0, 0)], None, None, True)
@example("daidalus-do365b-sum", [((5000.0, 0.0), (-100.0, 0.0), 450 * FT, -1000 * FPM, True, 0.0, 2)],
         (15.0, 4.0, 1.5, 0.5), None, True)
@example("do365", [((0.0, 0.0), (0.0, 0.0), 700 * FT, 0.0, True, 0.0, 1)], None, 2, False)
def test_compiled_alerter_is_the_numpy_alerter(profile, pairs, errors, max_level, with_previous):
    """Alerter.alert with the kernel = Alerter.alert with the numpy detectors, level for level."""
    alerter, level = ALERTERS[profile]
    assert alerter._compiled is not None
    enc, previous = _encounter(pairs, errors)
    prev = previous if with_previous else None
    got = alerter.alert(enc, level, max_level, previous=prev)
    with jit.reference():
        want = alerter.alert(enc, level, max_level, previous=prev)
    assert got.dtype == want.dtype and got.tolist() == want.tolist(), (got, want)


def _same(got, want, tol=1e-9):
    got, want = np.asarray(got, float), np.asarray(want, float)
    both_inf = np.isinf(got) & np.isinf(want) & (np.sign(got) == np.sign(want))
    with np.errstate(invalid="ignore"):  # inf - inf where both_inf
        close = np.abs(got - want) <= tol * np.maximum(1.0, np.abs(want))
    assert np.all(both_inf | close), (got, want)


@SETTINGS
@given(st.lists(pair, min_size=1, max_size=6), st.sampled_from(PROFILES), st.sampled_from([0.0, 10.0]),
       st.sampled_from([0.0, 25.0, 55.0, 180.0]))
def test_well_clear_intervals_and_ties(pairs, profile, b, t):
    """The kernels' WCV_TAUMOD intervals = wcv.py's to 1e-9 s, and their conflict decisions identical; almost_equals
    is base/almost.py's on the same numbers."""
    thr = load_profile(profile).alerter.levels[-1].thresholds
    d2 = thr.dthr_m**2
    for (sx, sy), (vx, vy), sz, vz, *_ in pairs:
        with jit.reference():
            t_in, t_out = wcv_interval(np.array([sx, sy]), np.array([vx, vy]), sz, vz, thr, b, t)
        k_in, k_out = kernels.wcv_interval(sx, sy, vx, vy, sz, vz, d2, thr.zthr_m, thr.tthr_s, thr.tcoa_s, b, t)
        _same([k_in, k_out], [t_in, t_out])
        assert kernels.almost_less(k_in, k_out) == bool(conflict(t_in, t_out))
        h_in, h_out = _horizontal_interval(np.array([sx, sy]), np.array([vx, vy]), thr, t)
        _same(kernels.horizontal_interval(sx, sy, vx, vy, d2, thr.tthr_s, t), [h_in, h_out])
        for a, c in ((sz, thr.zthr_m), (vz, 0.0), (float(t_in), float(t_out)), (sz, sz * (1 + 1e-13)), (sz, -0.0)):
            assert kernels.almost_equals(a, c) == bool(almost_equals(a, c)), (a, c)
    # every pair at once, as the guidance bands ask (lines (M, 1) against their vertical state, broadcast)
    s_xy, v_xy = np.array([p[0] for p in pairs], float), np.array([p[1] for p in pairs], float)
    sz, vz = np.array([p[2] for p in pairs], float), np.array([p[3] for p in pairs], float)
    lines = s_xy[:, None, :], v_xy[:, None, :], sz[:, None], np.broadcast_to(vz, (1, len(pairs)))
    got = wcv_interval(*lines, thr, b, t)
    with jit.reference():
        want = wcv_interval(*lines, thr, b, t)
    assert got[0].shape == want[0].shape == (len(pairs), len(pairs))
    _same(got, want)
    np.testing.assert_array_equal(conflict(*got), conflict(*want))


relative = st.tuples(st.floats(MIN_ERROR, 1500.0), st.floats(MIN_ERROR, 200.0), st.floats(MIN_ERROR, 200.0),
                     st.floats(MIN_ERROR, 15.0))


@SETTINGS
@given(st.lists(st.tuples(pair, relative), min_size=1, max_size=6), st.sampled_from([0.0, 10.0]),
       st.sampled_from([25.0, 180.0]))
def test_uncertain_interval_is_the_vectorised_one(rows, b, t):
    """WCV_taumod_uncertain_interval: the kernel = wcv_sum.wcv_uncertain_intervals to 1e-9 s, (inf, -inf) alike."""
    thr = load_profile("daidalus-do365b-sum").alerter.levels[-1].thresholds
    s = np.array([p[0] for p, _ in rows], float)
    v = np.array([p[1] for p, _ in rows], float)
    sz = np.array([p[2] for p, _ in rows], float)
    vz = np.array([p[3] for p, _ in rows], float)
    err = np.array([e for _, e in rows], float)
    want_in, want_out = wcv_uncertain_intervals(b, t, s, v, sz, vz, *err.T, thr)
    for i in range(len(rows)):
        got = kernels.wcv_uncertain_interval(b, t, s[i, 0], s[i, 1], v[i, 0], v[i, 1], sz[i], vz[i], *err[i],
                                             thr.dthr_m, thr.dthr_m**2, thr.zthr_m, thr.tthr_s, thr.tcoa_s)
        _same(got, [want_in[i], want_out[i]])


def test_seeded_encounters_near_the_volume_every_profile():
    """2,000 seeded pairs within 3 nmi and 1000 ft on the 25 ft grid, with and without ADS-B-like errors, every
    well-clear profile: the same levels; enough alert that every level is exercised."""
    rng = np.random.default_rng(29)
    n = 2000
    s, v = rng.uniform(-3 * NM, 3 * NM, (n, 2)), rng.uniform(-150.0, 150.0, (n, 2))
    sz, vz = 25.0 * FT * rng.integers(-40, 41, n), rng.choice([0.0, 1000 * FPM, -1000 * FPM, 3.0], n)
    g = pair_geometry(s, v, sz, vz)
    previous = rng.integers(0, 4, n)
    seen = set()
    for name, (alerter, level) in ALERTERS.items():
        for errors in (None, rng.uniform(0.0, 1.0, (n, 4)) * np.array([40.0, 10.0, 3.0, 1.0])):
            enc = Encounter(g, rng.random(n) < 0.9, 0.0, True, errors)
            got = alerter.alert(enc, level, previous=previous)
            with jit.reference():
                want = alerter.alert(enc, level, previous=previous)
            assert np.array_equal(got, want), (name, np.flatnonzero(got != want)[:5])
            seen |= set(got.tolist())
    assert seen == {0, 1, 2, 3}


def test_almost_equals_edges():
    """base/almost.py's zero special case, infinities, NaN, opposite signs and the 16348-ULP bound."""
    x = 450 * FT
    cases = [(0.0, 1e-14), (0.0, -1e-14), (1e-14, 2e-14), (math.inf, math.inf), (math.inf, -math.inf),
             (math.nan, math.nan), (-0.0, 0.0), (1.0, -1.0), (x, np.nextafter(x, 0.0)), (1e308, -1e308),
             (x, x + 16348 * np.spacing(x)), (x, x + 16349 * np.spacing(x)), (-x, -x - 10 * np.spacing(x))]
    for a, b in cases:
        assert kernels.almost_equals(a, b) == bool(almost_equals(a, b)), (a, b)


# --- the altitude bands' level-out times (bands_kinematics.level_out_times) ---------------------------------------

@SETTINGS
@given(st.floats(-500.0, 15000.0), st.one_of(st.floats(-60.0, 60.0), st.sampled_from([0.0, -0.0, 1e-6, -1e-6, 5.0])),
       st.sampled_from([0.5, 2.5, 10.0]), st.sampled_from([0.5, 1.63, 9.8]), st.sampled_from([50.0, 100.0, 250.0]))
def test_level_out_times_kernel_equals_reference(s0z, v0z, climb_rate, accel, step):
    """Every target altitude of an altitude band (climbing, descending, level within Util's 1e-5, overshooting
    targets close below or above), the kernel's (T1, T2, T3, a1, a2) are the numpy code's, bit for bit."""
    targets = np.arange(-300.0, 15300.0, step)
    got = level_out_times(s0z, v0z, climb_rate, targets, accel)
    with jit.reference():
        want = level_out_times(s0z, v0z, climb_rate, targets, accel)
    for g, w in zip(got, want):
        np.testing.assert_array_equal(g, w)


# --- the bands' recovery and NMAC cylinders (bands_kinematics.cylinder_lines) -----------------------------------

CYLINDERS = st.sampled_from([Cylinder(500 * FT, 100 * FT), Cylinder(0.66 * NM, 450 * FT), Cylinder(1.0, 1.0)])


@SETTINGS
@given(st.lists(st.tuples(horizontal, velocity, vertical, vertical_rate), min_size=1, max_size=8), CYLINDERS,
       st.sampled_from([1.0, 60.0, 180.0]))
@example([((500 * FT, 0.0), (0.0, 0.0), 100 * FT, 0.0)], Cylinder(500 * FT, 100 * FT), 180.0)  # on both edges
@example([((0.0, 0.0), (1e-14, 0.0), 0.0, 1e-14)], Cylinder(1.0, 1.0), 1.0)  # still within Util's 1e-13
def test_cylinder_lines_kernel_equals_reference(pairs, cyl, t_end):
    """The loss interval of a recovery or NMAC cylinder (CD3D.detection), inside and outside, on its edges and
    with motion below almost-equal, is the numpy code's bit for bit, on lines broadcast as the bands ask them."""
    s = np.array([(*p[0], p[2]) for p in pairs], float)
    v = np.array([(*p[1], p[3]) for p in pairs], float)
    lines = s[:, None, :], np.concatenate([v, v[::-1]])[None]  # (M, 1, 3) against (1, 2M, 3): (M, 2M)
    got = cylinder_lines(*lines, cyl, t_end)
    with jit.reference():
        want = cylinder_lines(*lines, cyl, t_end)
    for g, w in zip(got, want):
        assert g.shape == w.shape
        np.testing.assert_array_equal(g, w)
