"""The DO-365 well-clear detector (advisory/wcv.py, DAIDALUS WCV_TAUMOD) against independent references: the
loss interval equals the set of times at which the violation test itself holds along the straight-line motion
(sampled finely, hypothesis over random geometries), and a head-on computed by hand from the modified-tau
definition of DO-365 (Munoz et al. 2015 eq. for taumod)."""

from __future__ import annotations

import math

import numpy as np
from hypothesis import given, settings, strategies as st

from avionics.advisory.wcv import WcvThresholds, conflict, wcv_interval, wcv_violation
from avionics.advisory.tables import load_profile
from avionics.base.units import FT, KT, NM

DO365_PHASE_I = load_profile("daidalus-do365b-no-sum").alerter.levels[-1].thresholds  # DWC_Phase_I det_3, the data
DO365_NON_COOP = load_profile("do365-non-coop").alerter.levels[-1].thresholds  # DWC_Non_Coop

coord = st.floats(-10_000.0, 10_000.0)
speed = st.floats(-200.0, 200.0)
vert = st.floats(-600.0, 600.0)
vrate = st.one_of(st.just(0.0), st.floats(-20.0, 20.0))


@settings(max_examples=300, deadline=None)
@given(sx=coord, sy=coord, vx=speed, vy=speed, sz=vert, vz=vrate, horizon=st.floats(1.0, 180.0),
       table=st.sampled_from([DO365_PHASE_I, DO365_NON_COOP, WcvThresholds(0.66 * NM, 700 * FT, 35.0, 20.0)]))
def test_the_loss_interval_is_where_the_violation_test_holds(sx, sy, vx, vy, sz, vz, horizon, table):
    s, v = np.array([[sx, sy]]), np.array([[vx, vy]])
    t_in, t_out = wcv_interval(s, v, np.array([sz]), np.array([vz]), table, 0.0, horizon)
    ts = np.linspace(0.0, horizon, 3001)
    inside = wcv_violation(s + ts[:, None] * v, np.broadcast_to(v, (len(ts), 2)), sz + vz * ts,
                           np.full(len(ts), vz), table)
    step = horizon / 3000
    if conflict(t_in, t_out)[0]:
        assert inside.any() or t_out[0] - t_in[0] < 2 * step
        if inside.any():
            assert abs(ts[inside][0] - t_in[0]) <= 1.5 * step and abs(ts[inside][-1] - t_out[0]) <= 1.5 * step
            assert inside[(ts > t_in[0] + step) & (ts < t_out[0] - step)].all()  # one interval
    else:
        assert inside.sum() <= 2  # at most a grazing touch the sampling happens to hit


def test_a_head_on_alerts_when_modified_tau_reaches_35_s_by_hand():
    # co-altitude head-on, 300 kt each (closure 600 kt), 200 m lateral offset, 20 nmi apart: the horizontal test
    # first holds when taumod = (r^2 - DTHR^2) / (r rdot) ~ 35 s, with rdot the range rate (DO-365, Munoz 2015)
    closure = 600 * KT
    s0 = np.array([200.0, 20 * NM])
    v = np.array([0.0, -closure])
    d = DO365_PHASE_I.dthr_m
    # solve (r^2 - D^2) / (r * rdot) = 35 along the straight line r(t) (sampled every 0.1 ms on the exact geometry)
    ts = np.linspace(0.0, 200.0, 2_000_001)
    pos = s0 + ts[:, None] * v
    r = np.hypot(pos[:, 0], pos[:, 1])
    sdotv = pos @ v
    with np.errstate(divide="ignore"):
        taumod = np.where(sdotv < 0, (d * d - r * r) / sdotv, -1.0)
    expected = ts[np.argmax((r <= d) | ((taumod >= 0) & (taumod <= 35.0)))]
    t_in, t_out = wcv_interval(s0[None], v[None], np.zeros(1), np.zeros(1), DO365_PHASE_I, 0.0, 180.0)
    assert math.isclose(t_in[0], expected, abs_tol=1e-3)
    # the exit is when the range opens past DTHR again: |s0 + v t| = D
    exit_t = (s0[1] + math.sqrt(d * d - 200.0**2)) / closure
    assert math.isclose(t_out[0], exit_t, abs_tol=1e-6)
    # 200 ft above: inside ZTHR, the same; 500 ft above and level: never
    assert conflict(*wcv_interval(s0[None], v[None], np.array([200 * FT]), np.zeros(1), DO365_PHASE_I, 0, 180))[0]
    assert not conflict(*wcv_interval(s0[None], v[None], np.array([500 * FT]), np.zeros(1), DO365_PHASE_I, 0, 180))[0]


def test_diverging_inside_dthr_is_a_violation_and_outside_is_not():
    v = np.array([[0.0, 50.0]])
    assert wcv_violation(np.array([[0.0, 1000.0]]), v, np.zeros(1), np.zeros(1), DO365_PHASE_I)[0]
    assert not wcv_violation(np.array([[0.0, 1300.0]]), v, np.zeros(1), np.zeros(1), DO365_PHASE_I)[0]
