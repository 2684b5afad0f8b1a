"""The alerter (advisory/alerting.py): the tcas2 alerter against the TCAS logic as it was before issue 12, the
CD3D cylinder detector against hand computations and DAIDALUS's CD3D.cd3d / CD2D.cd2d semantics, and the alerter's
level order."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from avionics.advisory.alerting import (
    CD3D, CD3D_D_M, CD3D_H_M, CD3D_LOOKAHEAD_S, TCAS3D, AlertLevel, Alerter, CylinderThresholds, Encounter,
    cd3d_alerter, ra_thresholds, ta_thresholds, tcas2_alerter,
)
from avionics.advisory.tables import load_profile
from avionics.compose import build_alerter
from avionics.config import AdvisoryConfig
from avionics.conflict.cpa import PairGeometry, pair_geometry
from avionics.base.types import AdvisoryLevel
from avionics.base.units import FT, NM

PROFILES = {name: load_profile(name) for name in ("tcas2", "small-uas", "do365", "daidalus-tcas3d")}


# --- the TCAS logic as it was (advisory/logic.py before issue 12), frozen here as the oracle -----------------

def _old_horizontal(g, dmod_m, tau_s):
    return (g.range_m <= dmod_m) | ((g.s_dot_v < 0.0) & (g.mod_tau(dmod_m) <= tau_s))


def _old_vertical(sz_m, vz_mps, zthr_m, tau_s):
    converging = sz_m * vz_mps < 0.0
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        t_coalt = np.where(converging, -sz_m / np.where(converging, vz_mps, 1.0), np.inf)
    return (np.abs(sz_m) <= zthr_m) | (converging & (t_coalt <= tau_s))


def old_detect(g, level, has_altitude, vertical_margin_m, ra_enabled=True, hmd_filter=True, threat_eligible=True):
    sz = np.sign(g.sz_m) * np.maximum(np.abs(g.sz_m) - vertical_margin_m, 0.0)
    ta = _old_horizontal(g, level.ta_dmod_m, level.ta_tau_s)
    ta &= ~has_altitude | _old_vertical(sz, g.vz_mps, level.ta_zthr_m, level.ta_tau_s)
    out = np.where(ta, int(AdvisoryLevel.TA), int(AdvisoryLevel.NONE))
    if ra_enabled and level.ra_tau_s is not None:
        ra = has_altitude & threat_eligible
        ra &= _old_horizontal(g, level.ra_dmod_m, level.ra_tau_s)
        ra &= _old_vertical(sz, g.vz_mps, level.ra_zthr_m, level.ra_tau_s)
        if hmd_filter:
            ra &= g.hmd_m <= level.ra_hmd_m
        out = np.where(ra, int(AdvisoryLevel.RA), out)
    return out


def old_continues(g, level, was_ra, hmd_filter=True):
    keep = was_ra & (g.s_dot_v < 0.0)
    if hmd_filter and level.ra_hmd_m is not None:
        keep &= g.hmd_m <= level.ra_hmd_m
    return keep


N = 12
coord = st.floats(-15000.0, 15000.0, allow_nan=False)
speed = st.floats(-300.0, 300.0, allow_nan=False)
alt = st.floats(-1500.0, 1500.0, allow_nan=False)
vrate = st.floats(-60.0, 60.0, allow_nan=False)
pairs = st.lists(st.tuples(coord, coord, speed, speed, alt, vrate, st.booleans(), st.booleans(),
                           st.sampled_from([0.0, 0.0, 30.0, 60.0]), st.sampled_from([0, 1, 2])),
                 min_size=1, max_size=N)


def encounter_of(rows):
    a = np.array([r[:6] for r in rows], float)
    g = pair_geometry(a[:, 0:2], a[:, 2:4], a[:, 4], a[:, 5])
    has_alt = np.array([r[6] for r in rows], bool)
    eligible = np.array([r[7] for r in rows], bool)
    margin = np.array([r[8] for r in rows], float)
    previous = np.array([r[9] for r in rows], int)
    return g, has_alt, eligible, margin, previous


@settings(max_examples=300, deadline=None)
@given(rows=pairs, profile=st.sampled_from(sorted(PROFILES)), index=st.integers(0, 20), ra_enabled=st.booleans(),
       hmd_filter=st.booleans())
def test_the_tcas2_alerter_is_the_old_tcas_logic(rows, profile, index, ra_enabled, hmd_filter):
    levels = PROFILES[profile].levels
    level = levels[index % len(levels)]
    g, has_alt, eligible, margin, previous = encounter_of(rows)
    alerter = tcas2_alerter(hmd_filter=hmd_filter)
    enc = Encounter(g, has_alt, margin, eligible)
    max_level = None if ra_enabled else int(AdvisoryLevel.TA)
    got = alerter.alert(enc, level, max_level)
    want = old_detect(g, level, has_alt, margin, ra_enabled, hmd_filter, eligible)
    np.testing.assert_array_equal(got, want)
    # the RA continuation of the core's _decided, as it was
    held, continued = alerter.hold(enc, level, previous, got.copy(), max_level)
    old = np.zeros(len(rows), bool)
    if ra_enabled and level.ra_tau_s is not None:
        old = old_continues(g, level, previous == int(AdvisoryLevel.RA), hmd_filter) & has_alt & eligible
        old &= want < int(AdvisoryLevel.RA)
    np.testing.assert_array_equal(continued, old)
    np.testing.assert_array_equal(held, np.where(old, int(AdvisoryLevel.RA), want))
    # DAIDALUS Alerter's assumption detection(i + 1) => detection(i) holds for the TCAS-style tables: an RA
    # (altitude known) is always also a TA
    ra = got == int(AdvisoryLevel.RA)
    ta_alone = tcas2_alerter(hmd_filter).alert(enc, level, int(AdvisoryLevel.TA)) == int(AdvisoryLevel.TA)
    assert np.all(ta_alone[ra])


def test_the_tcas2_alerter_names_its_levels_as_the_advisory_levels():
    alerter = build_alerter(AdvisoryConfig(), PROFILES["tcas2"])
    assert alerter.name == "tcas2" and alerter.most_severe == 2
    assert alerter.names() == {int(v): v.name for v in AdvisoryLevel} == {0: "NONE", 1: "TA", 2: "RA"}
    assert alerter.level(1).min_duration_s == AdvisoryConfig().ta_min_duration_s
    assert alerter.level(2).continuation is not None and alerter.level(1).continuation is None
    sl2 = PROFILES["tcas2"].levels[0]
    assert sl2.sl == 2 and ra_thresholds(sl2) is None and ta_thresholds(sl2).tau_s == 20.0  # [B71] Table 3
    with pytest.raises(ValueError):
        Alerter("bad", (AlertLevel(2, "X", CD3D(), lambda _: None),))


def test_the_tcas3d_violation_is_inside_dmod_and_zthr():
    sl5 = next(lv for lv in PROFILES["tcas2"].levels if lv.sl == 5)
    thr = ta_thresholds(sl5)  # 0.55 nm, 850 ft
    g = pair_geometry([[thr.dmod_m - 1.0, 0.0], [thr.dmod_m + 1.0, 0.0]], [[50.0, 0.0], [-50.0, 0.0]],
                      [800 * FT, 0.0], [0.0, 0.0])
    enc = Encounter(g, np.ones(2, bool))
    assert list(TCAS3D().violation(enc, thr)) == [True, False]  # the second is closing (a TA by tau), not inside


# --- CD3D ---------------------------------------------------------------------------------------------------

def one(s_xy, v_xy, sz, vz, has_alt=True) -> Encounter:
    return Encounter(pair_geometry([s_xy], [v_xy], [sz], [vz]), np.array([has_alt]))


def cd3d(enc, d, h, t):
    return bool(CD3D().conflict(enc, CylinderThresholds(d, h, t), t)[0])


def test_cd3d_by_hand():
    # head-on 10 km out at 100 m/s closing, co-altitude, D = 1000 m: inside the disk for 90 < t < 110
    head_on = one((10000.0, 0.0), (-100.0, 0.0), 0.0, 0.0)
    assert not cd3d(head_on, 1000.0, 100.0, 90.0)  # the cylinder is open: at t = 90 the range is D, not < D
    assert cd3d(head_on, 1000.0, 100.0, 90.5)
    assert cd3d(head_on, 1000.0, 100.0, 1e9)
    assert not cd3d(head_on, 999.0, 100.0, 89.0)
    # no horizontal motion inside the disk; 500 m below, closing at 10 m/s, H = 100 m: inside for 40 < t < 60
    overhead = one((100.0, 0.0), (0.0, 0.0), 500.0, -10.0)
    assert not cd3d(overhead, 1000.0, 100.0, 40.0) and cd3d(overhead, 1000.0, 100.0, 41.0)
    assert not cd3d(one((1000.0, 0.0), (0.0, 0.0), 0.0, 0.0), 1000.0, 100.0, 100.0)  # on the wall, not inside
    # the disk for 90 < t < 110, the slab (1150 - 10 t in (-100, 100)) for 105 < t < 125: both for 105 < t < 110
    both = one((10000.0, 0.0), (-100.0, 0.0), 1150.0, -10.0)
    assert not cd3d(both, 1000.0, 100.0, 105.0) and cd3d(both, 1000.0, 100.0, 106.0)
    # the disk for 90 < t < 110, the slab for 120 < t < 140: never both, whatever the lookahead
    apart = one((10000.0, 0.0), (-100.0, 0.0), 1300.0, -10.0)
    assert not cd3d(apart, 1000.0, 100.0, 1e9)
    # a pair that already lost separation is in conflict for any lookahead, and in violation
    inside = one((999.0, 0.0), (100.0, 0.0), 99.0, 0.0)
    assert cd3d(inside, 1000.0, 100.0, 0.1)
    thr = CylinderThresholds(1000.0, 100.0, 10.0)
    assert CD3D().violation(inside, thr)[0] and not CD3D().violation(one((1000.0, 0.0), (0, 0), 0.0, 0.0), thr)[0]
    # unknown altitude: the horizontal test alone, or no conflict with altitude_required
    blind = one((10000.0, 0.0), (-100.0, 0.0), 5000.0, 0.0, has_alt=False)
    assert cd3d(blind, 1000.0, 100.0, 100.0)
    assert not CD3D(altitude_required=True).conflict(blind, CylinderThresholds(1000.0, 100.0, 100.0), 100.0)[0]


def test_the_cd3d_alerter_is_daidalus_alerter_cd3d():
    alerter = cd3d_alerter()
    assert (CD3D_D_M, CD3D_H_M, CD3D_LOOKAHEAD_S) == (5 * NM, 1000 * FT, 180.0)  # Alerter.CD3D(): 5 nmi, 1000 ft
    sl = PROFILES["tcas2"].levels[3]
    # 20 nm out, closing at 400 kt (205.8 m/s): the 5 nm disk is reached after 15 nm, 135 s < 180 s
    speed = 400 * 1852.0 / 3600.0
    enc = Encounter(pair_geometry([[20 * NM, 0.0], [40 * NM, 0.0]], [[-speed, 0.0], [-speed, 0.0]], [0.0, 0.0],
                                  [0.0, 0.0]), np.ones(2, bool))
    assert list(alerter.alert(enc, sl)) == [1, 0]  # the second reaches it after 35 nm, 315 s
    assert alerter.names() == {0: "NONE", 1: "CD3D"}


def _cd2d_reference(s, v, d, b, t):
    """DAIDALUS CD2D.cd2d(s, vo, vi, D, B, T) with v = vo - vi (exact comparisons instead of almost_equals)."""
    if b < 0 or b >= t:
        return False
    sx, sy = s[0] + b * v[0], s[1] + b * v[1]
    if sx * sx + sy * sy < d * d:
        return True
    v2 = v[0] * v[0] + v[1] * v[1]
    sv = s[0] * v[0] + s[1] * v[1]
    s2 = s[0] * s[0] + s[1] * s[1]
    tau = min(max(b * v2, -sv), t * v2)  # tau_vv: tau times |v|^2, continuous everywhere
    return v2 * s2 + 2 * tau * sv + tau * tau - d * d * v2 < 0.0  # omega_vv < 0


def cd3d_reference(s, v, sz, vz, d, h, t):
    """DAIDALUS CD3D.cd3d(s, vo, vi, D, H, 0, T): the vertical interval folded into the time bounds of cd2d by
    scaling time with |vz|. As DAIDALUS (Util.almost_equals(vo.z, vi.z)), a negligible vz is none: scaling by a
    denormal |vz| would underflow."""
    if abs(vz) < 1e-9:
        return abs(sz) < h and _cd2d_reference(s, v, d, 0.0, t)
    m1 = max(-h - math.copysign(1.0, vz) * sz, 0.0)
    m2 = min(h - math.copysign(1.0, vz) * sz, t * abs(vz))
    return m1 < m2 and _cd2d_reference((s[0] * abs(vz), s[1] * abs(vz)), v, d * abs(vz), m1, m2)


@settings(max_examples=400, deadline=None)
@given(sx=coord, sy=coord, vx=speed, vy=speed, sz=alt, vz=st.one_of(st.just(0.0), vrate),
       d=st.floats(50.0, 10000.0), h=st.floats(10.0, 500.0), t=st.floats(1.0, 300.0))
def test_cd3d_matches_daidalus_cd3d(sx, sy, vx, vy, sz, vz, d, h, t):
    eps = 1e-7  # away from the boundary, where the rounding of either formulation may decide
    lo = cd3d_reference((sx, sy), (vx, vy), sz, vz, d * (1 - eps), h * (1 - eps), t * (1 - eps))
    hi = cd3d_reference((sx, sy), (vx, vy), sz, vz, d * (1 + eps), h * (1 + eps), t * (1 + eps))
    assume(lo == hi)
    enc = one((sx, sy), (vx, vy), sz, vz)
    assert cd3d(enc, d, h, t) == lo
    # a violation now is a conflict for any lookahead
    if CD3D().violation(enc, CylinderThresholds(d, h, t))[0]:
        assert cd3d(enc, d, h, t)
    # a sampled time inside the (slightly shrunk) cylinder is a conflict
    times = np.linspace(0.0, t, 4001)
    x, y, z = sx + vx * times, sy + vy * times, sz + vz * times
    if ((x * x + y * y < (d * (1 - 1e-6)) ** 2) & (np.abs(z) < h * (1 - 1e-6))).any():
        assert lo


def test_encounter_take_keeps_the_rows():
    g = pair_geometry([[1.0, 2.0], [3.0, 4.0], [5.0, 6.0]], [[0.0, 1.0]] * 3, [1.0, 2.0, 3.0], [0.0, 0.0, 0.0])
    enc = Encounter(g, np.array([True, False, True]), np.array([0.0, 1.0, 2.0]), np.array([True, True, False]))
    sub = enc.take(np.array([2, 0]))
    assert isinstance(sub.geometry, PairGeometry) and list(sub.geometry.sz_m) == [3.0, 1.0]
    assert list(sub.has_altitude) == [True, True] and list(sub.vertical_margin_m) == [2.0, 0.0]
    assert list(sub.threat_eligible) == [False, True] and sub.geometry.s_xy_m.shape == (2, 2)
