"""The re-assessment pass in slices and the advisory state in arrays (issue 13, items 2 and 3;
avionics/pipeline/schedule.py `AssessmentSchedule.due`, pipeline/records.py `AssessmentRows`; avionics/advisory/logic.py
`AdvisoryStates`).

Oracles: the pass's contract stated as properties over random traffic sizes, slice sizes and step rates (every
intruder re-assessed at assessment_hz; no step re-assesses more than its slice unless the pace needs it); the
unsliced core (one full pass per tick, the path the DAIDALUS golden files and the built-in scenarios' CSVs check)
for the advisories of a threat among many quiet intruders; and the TA hold of TCAS II (a TA stays 8 s) for the
array-held state.
"""

from __future__ import annotations

import math

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from avionics.advisory.logic import AdvisoryStates
from avionics.config import load_config
from avionics.base.geodesy import LocalTangentPlane
from avionics.base.types import (
    AddressSource, AdvisoryLevel, AltitudeDatum, IntruderKey, IntruderReport, OwnshipFix, OwnshipPressure,
)
from avionics.pipeline.daa_core import DaaCore
from avionics.pipeline.views import ViewRound

PLANE = LocalTangentPlane(47.0, 8.0)
ALT_M = 1500.0
PERIOD_S = 0.1  # advisory.assessment_hz = 10 (config/default.toml)
THREAT = IntruderKey(0xBAD001, AddressSource.ES1090)


def _report(key, t, east, north, ve=0.0, vn=0.0):
    lat, lon = PLANE.to_geodetic(east, north)
    return IntruderReport(key, t, t, float(lat), float(lon), ALT_M, AltitudeDatum.PRESSURE, (ve, vn), 0.0)


def _ownship(t):
    return [OwnshipFix(t, 47.0, 8.0, ALT_M, ALT_M, (0.0, 0.0, 0.0)), OwnshipPressure(t, ALT_M)]


def _quiet(n):
    """n intruders 20-40 km away, slow: never a threat."""
    rng = np.random.default_rng(n)
    bearing, dist = rng.uniform(0, 2 * math.pi, n), rng.uniform(20e3, 40e3, n)
    return [(IntruderKey(0x100000 + i, AddressSource.ES1090), dist[i] * math.sin(bearing[i]),
             dist[i] * math.cos(bearing[i])) for i in range(n)]


@settings(max_examples=12, deadline=None)
@given(n=st.integers(20, 400), slice_=st.integers(1, 80), dt=st.sampled_from([0.002, 0.005, 0.01, 0.02, 0.05]))
def test_every_intruder_is_re_assessed_at_assessment_hz_and_a_step_takes_at_most_its_slice(n, slice_, dt):
    core = DaaCore(load_config(overrides=["zenoh.enabled=false", f"advisory.assessment_slice={slice_}"]))
    quiet = _quiet(n)
    core.step(0.0, _ownship(0.0) + [_report(k, 0.0, e, nn) for k, e, nn in quiet])
    last = {}
    gaps = []
    pace = math.ceil(n * dt / (0.5 * PERIOD_S)) + 1  # more than the slice only when the pace needs it
    for k in range(1, int(round(1.5 / dt)) + 1):
        t = round(k * dt, 9)
        res = core.step(t, _ownship(t) if k % max(1, round(0.2 / dt)) == 0 else [])
        assert len(res.assessed) <= max(slice_, pace)
        for advisory in res.assessed:
            key = advisory.intruder
            if key in last:
                gaps.append(t - last[key])
            last[key] = t
    assert set(last) == {k for k, _, _ in quiet}
    assert max(gaps) <= PERIOD_S + dt + 1e-6  # at assessment_hz, late by at most the step that holds it
    assert core.counters["assessment.pass_overrun"] == 0


def _threat_run(slice_: int, n_quiet: int = 200, dt: float = 0.01, until_s: float = 33.0):
    """A head-on threat from 6 km at 100 m/s closing, reports stopping at 25 s, among n_quiet intruders reported at
    1 Hz (staggered over the second); steps every dt. The threat's advisory changes: [(t, level, reason)]."""
    core = DaaCore(load_config(overrides=["zenoh.enabled=false", f"advisory.assessment_slice={slice_}"]))
    quiet = _quiet(n_quiet)
    out = []
    steps_per_s = round(1 / dt)
    for k in range(int(round(until_s / dt)) + 1):
        t = round(k * dt, 9)
        inputs = _ownship(t) if k % round(0.2 / dt) == 0 else []
        inputs += [_report(key, t, e, nn) for j, (key, e, nn) in enumerate(quiet) if j % steps_per_s == k % steps_per_s]
        if k % steps_per_s == 0 and t <= 25.0:
            inputs.append(_report(THREAT, t, 0.0, 6000.0 - 100.0 * t, vn=-100.0))
        out += [(t, a.level, a.reason) for a in core.step(t, inputs).changes if a.intruder == THREAT]
    return core, out


def test_a_threat_among_many_quiet_intruders_alerts_as_with_one_full_pass_per_tick_and_is_lost_on_time():
    sliced_core, sliced = _threat_run(slice_=8)
    _, full = _threat_run(slice_=10**6)
    assert sliced_core.counters["assessment.pass_overrun"] == 0
    assert [(lvl, why) for _, lvl, why in sliced] == [(lvl, why) for _, lvl, why in full]
    assert AdvisoryLevel.TA in [lvl for _, lvl, _ in full] and full[-1][1:] == (AdvisoryLevel.TA, "lost")
    for (ts, _, _), (tf, _, _) in zip(sliced, full, strict=True):
        assert abs(ts - tf) <= PERIOD_S + 1e-6
    # lost: no report for more than tracking.max_coast_s (6 s) after the last one at 25 s, seen within a period
    assert 31.0 < sliced[-1][0] <= 31.0 + PERIOD_S + 0.01 + 1e-6


def test_an_advisory_read_later_is_the_one_of_its_step():
    """The advisory of a quiet intruder is built when read (`_Rows`): read after later steps, it is still the one
    of the step that assessed it (its time, its geometry at that step)."""
    core = DaaCore(load_config(overrides=["zenoh.enabled=false"]))
    key = IntruderKey(0x123456, AddressSource.ES1090)
    res = core.step(0.0, _ownship(0.0) + [_report(key, 0.0, 0.0, 30e3, vn=-50.0)])
    first = res.assessed
    core.step(1.0, _ownship(1.0) + [_report(key, 1.0, 0.0, 30e3 - 50.0, vn=-50.0)])
    (early,) = first
    assert early.time_s == 0.0 and early.level is AdvisoryLevel.NONE and early.reason == "clear"
    assert math.isclose(early.range_m, 30e3, rel_tol=1e-6)
    now = core.advisory(key)
    assert now.time_s == 1.0 and math.isclose(now.range_m, 30e3 - 50.0, rel_tol=1e-6)


@settings(max_examples=200, deadline=None)
@given(st.lists(st.tuples(st.sampled_from([0, 1, 2]), st.booleans()), min_size=1, max_size=40))
def test_the_array_state_keeps_a_ta_for_its_minimum_duration(moves):
    """TCAS II: an alert lasts at least the TA minimum (8 s) unless forced; a higher level is taken at once. The
    oracle is the rule applied by hand over a random sequence of candidates at 1 s steps."""
    states = AdvisoryStates(capacity=1)
    rows = states.rows(["a"])
    level, onset = 0, None
    for k, (candidate, force) in enumerate(moves):
        t = float(k)
        if candidate >= level or force or onset is None or t - onset >= 8.0:
            expected = candidate
        else:
            expected = 1
        onset = None if expected == 0 else (t if level == 0 else onset)
        changed = states.next(rows, t, np.array([candidate]), 8.0, force=np.array([force]))
        assert bool(changed[0]) == (expected != level)
        level = expected
        assert int(states.level[rows[0]]) == level


def _same_values(a: tuple, b: tuple) -> bool:
    return all(x is None and y is None or x is not None and y is not None and
               (x == y or (math.isnan(x) and math.isnan(y))) for x, y in zip(a, b, strict=True))


@settings(max_examples=15, deadline=None)
@given(seed=st.integers(0, 2**31 - 1), n=st.integers(1, 40))
def test_a_tracks_assessment_columns_are_its_advisorys_fields(seed, n):
    """The `traffic` publication reads each track's ASSESSMENT_FIELDS without building its advisory
    (`_Rows.assessment`): they equal the built advisory's fields, for quiet, alerting, altitude-less and stale
    intruders alike (random traffic around a hovering ownship, some converging, some without altitude)."""
    from avionics.base.types import ASSESSMENT_FIELDS
    from avionics.daa import Daa

    rng = np.random.default_rng(seed)
    daa = Daa(load_config(overrides=["zenoh.enabled=false"]))
    pos = rng.uniform(-8e3, 8e3, (n, 2))
    vel = -pos / rng.uniform(20.0, 200.0, (n, 1))  # converging, some fast
    alt = rng.choice([None, ALT_M, ALT_M + 150.0, ALT_M + 900.0], n)
    last_report = rng.uniform(5.0, 20.0, n)  # some go stale before t = 20 s
    for k in range(41):
        t = 0.5 * k
        inputs = _ownship(t)
        for i in range(n):
            if k % 2 == 0 and t <= last_report[i]:
                lat, lon = PLANE.to_geodetic(*(pos[i] + vel[i] * t))
                key = IntruderKey(0x200000 + i, AddressSource.ES1090)
                inputs.append(IntruderReport(key, t, t, float(lat), float(lon), alt[i],
                                             AltitudeDatum.PRESSURE if alt[i] is not None else None,
                                             (float(vel[i, 0]), float(vel[i, 1])), 0.0 if alt[i] is not None else None))
        result = daa.step(t, inputs, tracks=True)
        for track in result.tracks:
            advisory = track.advisory
            assert track.advisory_level is advisory.level
            assert _same_values(track.assessment, tuple(getattr(advisory, f) for f in ASSESSMENT_FIELDS))


@settings(max_examples=150, deadline=None)
@given(n=st.integers(0, 600), slice_=st.integers(1, 256), data=st.data())
def test_the_track_views_of_a_round_come_once_each_in_order_by_its_deadline_a_slice_a_step(n, slice_, data):
    """pipeline/views.py ViewRound, over random step times, demands (with their within), and tracks deleted during
    a round: a round delivers each of its starting tracks still tracked when its slice is built, once, in id
    order; it is complete at the first step at or after its deadline (start + the tightest within asked during
    it); and a step builds more than a slice only when the round's pace needs it."""
    tracks = set(range(n))
    round_ = ViewRound(slice_)
    t, start, delivered = 0.0, None, []
    for _ in range(data.draw(st.integers(1, 40))):
        t += data.draw(st.floats(0.001, 0.3))
        wanted = data.draw(st.booleans())
        within = data.draw(st.sampled_from([0.0, 0.05, 0.25, 0.5, 1.0]))
        tracks -= set(data.draw(st.lists(st.integers(0, max(n - 1, 0)), max_size=5)))
        if wanted and start is None:
            start, deadline, size, done, expected = t, t + within, len(tracks), 0, sorted(tracks)
        elif wanted:
            deadline = min(deadline, t + within)
        built: list = []

        def build(keys, built=built):
            built.extend(keys)
            kept = [k for k in keys if k in tracks]  # Daa.tracks: the keys that are still tracks
            delivered.extend(kept)
            return kept

        views = round_.step(t, wanted, within, lambda: sorted(tracks), build)
        if start is None:
            assert views is None and not built
            continue
        assert built == expected[done:done + len(built)]  # in order, each once
        paced = math.ceil(size * min(1.0, (t - start) / (deadline - start)) - 1e-6) if deadline > start else size
        assert len(built) <= slice_ or done + len(built) == paced
        done += len(built)
        if t >= deadline - 1e-9:
            assert views is not None
        if views is not None:
            assert done == size and list(views) == delivered == sorted(delivered)
            start, delivered = None, []
