"""The functional core's alerting behaviour against hand-computed TCAS II thresholds."""

import math

import pytest

from avionics.base.types import AddressSource, AdvisoryLevel, AltitudeDatum, IntruderKey, IntruderReport
from avionics.base.units import FT, KT, NM
from synthetic import PLANE, Encounter, Mover, Reversal

ALT = 3000 * FT  # SL 4: TA tau 30 s, DMOD 0.48 nm; RA tau 20 s, DMOD 0.35 nm, HMD 0.57 nm
V = 125 * KT  # each, closing 250 kt
R0 = 6 * NM


def onset(range0, closing, tau, dmod):
    """Time at which modified tau (r^2 - DMOD^2) / (r * closing) falls to tau."""
    r = (tau * closing + math.sqrt((tau * closing) ** 2 + 4 * dmod**2)) / 2
    return (range0 - r) / closing


def head_on(**kw):
    return Encounter(Mover((0, 0, ALT), (0, V, 0)), Mover((0, R0, ALT), (0, -V, 0)), **kw)


def levels(changes):
    """(time, level) at each level change; RA sense/strength changes within an RA are folded."""
    out = []
    for t, c in changes:
        if not out or out[-1][1] is not c.level:
            out.append((round(t, 2), c.level))
    return out


def level_sequence(changes):
    return [lvl for _, lvl in levels(changes)]


def test_head_on_ta_ra_clear_at_hand_computed_times():
    core, changes = head_on().run(110)
    seq = levels(changes)
    assert [lvl for _, lvl in seq] == [AdvisoryLevel.TA, AdvisoryLevel.RA, AdvisoryLevel.TA, AdvisoryLevel.NONE]
    t_ta, t_ra, t_ra_end, t_clear = (t for t, _ in seq)
    assert t_ta == pytest.approx(onset(R0, 2 * V, 30, 0.48 * NM), abs=0.11)
    assert t_ra == pytest.approx(onset(R0, 2 * V, 20, 0.35 * NM), abs=0.11)
    # Diverging but inside DMOD is still a threat (DAIDALUS TCAS2D.horizontal_RA: range <= DMOD alerts,
    # closing or not): the RA holds until the range passes the RA DMOD, the TA until it passes the TA DMOD.
    assert t_ra_end == pytest.approx((R0 + 0.35 * NM) / (2 * V), abs=0.11)
    assert t_clear == pytest.approx((R0 + 0.48 * NM) / (2 * V), abs=0.11)
    assert changes[-1][1].reason == "diverging"
    assert all(c.sensitivity_level == 4 for _, c in changes)


def test_intruder_without_altitude_gets_a_ta_and_never_an_ra():
    _, changes = head_on(datum=None).run(110)
    assert level_sequence(changes) == [AdvisoryLevel.TA, AdvisoryLevel.NONE]
    assert changes[0][1].vmd_m is None


def test_vertical_separation_beyond_zthr_gives_nothing():
    enc = Encounter(Mover((0, 0, ALT), (0, V, 0)), Mover((0, R0, ALT + 900 * FT), (0, -V, 0)))
    _, changes = enc.run(110)
    assert changes == []


def test_mismatched_datums_widen_the_vertical_test_and_say_so():
    # 900 ft above: outside TA ZTHR 850 ft with matching datums; with no ownship pressure altitude the
    # pressure-altitude intruder is compared with GNSS altitude and the 200 ft margin makes it a TA (not RA:
    # 700 ft > RA ZTHR 600 ft).
    enc = Encounter(Mover((0, 0, ALT), (0, V, 0)), Mover((0, R0, ALT + 900 * FT), (0, -V, 0)), pressure=False)
    core, changes = enc.run(110)
    assert level_sequence(changes) == [AdvisoryLevel.TA, AdvisoryLevel.NONE]
    assert changes[0][1].datum_mismatch
    assert core.counters["assessment.datum_mismatch"] > 0


def test_geometric_intruder_needs_no_pressure_altitude():
    _, changes = head_on(datum=AltitudeDatum.GEOMETRIC, pressure=False).run(110)
    assert level_sequence(changes) == [AdvisoryLevel.TA, AdvisoryLevel.RA, AdvisoryLevel.TA, AdvisoryLevel.NONE]
    assert not any(c.datum_mismatch for _, c in changes)


def test_ta_stays_at_least_8_s():
    # The intruder turns away 2 s after the TA onset: diverging at once, but the TA holds for 8 s.
    turn = math.ceil(onset(R0, 2 * V, 30, 0.48 * NM)) + 2.0
    enc = head_on()
    enc.intruder = Reversal(enc.intruder, turn)
    _, changes = enc.run(110)
    assert level_sequence(changes) == [AdvisoryLevel.TA, AdvisoryLevel.NONE]
    (t_ta, _), (t_none, none) = changes
    assert 8.0 <= t_none - t_ta <= 8.0 + 0.11
    assert none.reason in ("diverging", "clear")


def test_stale_alerting_track_is_a_lost_threat_never_a_clear_one():
    # (tests/test_lost_threat.py has the rule: held on the coasted track, then ended as lost)
    t_ta = onset(R0, 2 * V, 30, 0.48 * NM)
    last = math.ceil(t_ta) + 1  # reports stop just after the TA onset
    _, changes = head_on(report_until_s=last).run(110)
    t_lost, lost = changes[1]
    assert (lost.level, lost.reason) == (AdvisoryLevel.TA, "lost")
    assert t_lost == pytest.approx(last + 6.0, abs=0.11)  # tracking.max_coast_s
    assert not any(c.reason in ("stale", "clear", "diverging") for _, c in changes)


def test_lost_ownship_ends_advisories():
    t_ta = onset(R0, 2 * V, 30, 0.48 * NM)
    _, changes = head_on(ownship_until_s=math.ceil(t_ta) + 1).run(110)
    assert level_sequence(changes) == [AdvisoryLevel.TA, AdvisoryLevel.NONE]
    assert changes[1][1].reason == "no_ownship"


def test_same_address_from_1090es_and_uat_are_two_tracks():
    core, _ = head_on().run(5)
    lat, lon = PLANE.to_geodetic(5000.0, 5000.0)
    uat = IntruderKey(0xABC123, AddressSource.UAT)
    core.step(5.5, [IntruderReport(uat, 5.5, 5.5, float(lat), float(lon), ALT, AltitudeDatum.PRESSURE, (0, 0), 0)])
    assert set(core.tracker.tracks) == {IntruderKey(0xABC123, AddressSource.ES1090), uat}


def test_report_from_another_aircraft_under_the_same_address_is_not_merged():
    core, _ = head_on().run(5)
    key = IntruderKey(0xABC123, AddressSource.ES1090)
    before = core.tracker.tracks[key].kf.x.copy()
    far = PLANE.to_geodetic(80000.0, 0.0)  # 80 km away one second later: not the same aircraft
    for i, t in enumerate((5.5, 6.5)):
        core.step(t, [IntruderReport(key, t, t, float(far[0]), float(far[1]), ALT, AltitudeDatum.PRESSURE,
                                     (0, 0), 0)])
        assert core.counters["track.implausible_jump"] == i + 1
    assert abs(core.tracker.tracks[key].kf.x[0] - before[0]) < 100  # the tracked aircraft is untouched
    core.step(7.5, [IntruderReport(key, 7.5, 7.5, float(far[0]), float(far[1]), ALT, AltitudeDatum.PRESSURE,
                                   (0, 0), 0)])
    assert core.counters["track.restarted"] == 1  # three in a row: the track follows the new reports


def test_out_of_order_and_duplicate_reports_are_counted_and_dropped():
    core, _ = head_on().run(5)
    key = IntruderKey(0xABC123, AddressSource.ES1090)
    x = core.tracker.tracks[key].kf.x.copy()
    lat, lon = PLANE.to_geodetic(0.0, R0)
    for t in (5.0, 3.0):
        core.step(5.2, [IntruderReport(key, t, 5.2, float(lat), float(lon), ALT, AltitudeDatum.PRESSURE, (0, 0), 0)])
    assert core.counters["report.duplicate"] == 1 and core.counters["report.out_of_order"] == 1
    assert (core.tracker.tracks[key].kf.x == x).all()


def test_a_backlog_ingested_in_one_step_gives_what_one_step_per_report_gives():
    """The live link hands a backlog over at once (one vectorised tracker call); the tracks and advisories must
    be those of one report per step."""
    import numpy as np

    from avionics.config import load_config
    from avionics.base.types import OwnshipFix, OwnshipPressure
    from avionics.pipeline.daa_core import DaaCore

    own = Mover((0, 0, ALT), (0, V, 0))
    intruders = {IntruderKey(0xA00001 + i, AddressSource.ES1090): m for i, m in enumerate([
        Mover((0, R0, ALT), (0, -V, 0)), Mover((-R0, R0, ALT + 200 * FT), (V, 0, 0)),
        Mover((300, R0, ALT - 100 * FT), (0, -V, 2.0))])}

    def inputs(t):
        e, n, alt = own.at(t)
        lat, lon = PLANE.to_geodetic(e, n)
        fixes = [OwnshipFix(t, float(lat), float(lon), alt, alt, (V, 0.0, 0.0)), OwnshipPressure(t, alt)]
        reports = []
        for key, m in intruders.items():
            e, n, alt = m.at(t)
            lat, lon = PLANE.to_geodetic(e, n)
            reports.append(IntruderReport(key, t, t, float(lat), float(lon), alt, AltitudeDatum.PRESSURE,
                                          m.v[:2], m.v[2]))
        return fixes, reports

    batched, single = DaaCore(load_config()), DaaCore(load_config())
    seen = {id(batched): [], id(single): []}
    for k in range(0, 1101):
        t = round(k * 0.1, 6)
        if k % 10:
            for core in (batched, single):
                seen[id(core)] += [(t, c.intruder, c.level, c.ra_words) for c in core.step(t).changes]
            continue
        fixes, reports = inputs(t)
        seen[id(batched)] += [(t, c.intruder, c.level, c.ra_words) for c in batched.step(t, fixes + reports).changes]
        for item in fixes + reports:
            seen[id(single)] += [(t, c.intruder, c.level, c.ra_words) for c in single.step(t, [item]).changes]
    assert seen[id(batched)] == seen[id(single)] and len(seen[id(single)]) >= 6
    keys = sorted(intruders)
    xb, pb = batched.tracker.predict(keys, 110.0)
    xs, ps = single.tracker.predict(keys, 110.0)
    np.testing.assert_allclose(xb, xs, rtol=0, atol=1e-9)
    np.testing.assert_allclose(pb, ps, rtol=1e-9, atol=1e-12)


def test_advisories_carry_the_conflict_stage_probabilities_and_their_age():
    _, changes = head_on().run(110)
    ra = next(c for _, c in changes if c.level is AdvisoryLevel.RA)
    assert 0.0 <= ra.pc_now <= ra.pc_max <= 1.0 and 0.0 <= ra.t_pc_max_s <= 60.0
    assert ra.pc_within >= ra.pc_max - 0.1  # any time within the lookahead >= at the likeliest time (MC noise)
    assert 0.0 <= ra.pc_within_age_s <= 1.0 + 1e-9  # one pair: the Monte Carlo's budget never binds


def test_an_older_report_after_a_newer_one_in_the_same_step_is_out_of_order_as_in_separate_steps():
    from avionics.config import load_config
    from avionics.pipeline.daa_core import DaaCore

    key = IntruderKey(0xABC123, AddressSource.ES1090)
    mover = Mover((0, R0, ALT), (0, -V, 0))

    def rep(t):
        e, n, alt = mover.at(t)
        lat, lon = PLANE.to_geodetic(e, n)
        return IntruderReport(key, t, t, float(lat), float(lon), alt, AltitudeDatum.PRESSURE, (0.0, -V), 0.0)

    together, apart = DaaCore(load_config()), DaaCore(load_config())
    for core in (together, apart):
        for t in range(6):
            core.step(float(t), [rep(float(t))])
    together.step(6.0, [rep(5.3), rep(5.2)])  # the late one arrives after the newer one, in one datagram batch
    apart.step(6.0, [rep(5.3)])
    apart.step(6.0, [rep(5.2)])
    for core in (together, apart):
        assert core.counters["report.out_of_order"] == 1 and core.tracker.tracks[key].n_updates == 7


def test_the_hwang_prefilter_runs_through_full_assessments():
    # conflict.prefilter = "hwang" validated, then crashed the first full assessment (the ownship velocity
    # never reached the conflict stage). A 90-degree crossing meeting at (0, d): Hwang condition 2(a) CASE I
    # keeps it (r.v_own = dV >= 0, r.v_intruder = -dV <= 0, r x v_own = dV and -r x v_intruder = -dV of
    # opposite signs): the same advisories as the default pre-filter, with a Pc.
    d = R0 / math.sqrt(2)

    def crossing(**kw):
        return Encounter(Mover((0, 0, ALT), (0, V, 0)), Mover((d, d, ALT), (-V, 0, 0)), **kw)

    _, default = crossing().run(110)
    _, hwang = crossing(overrides=["conflict.prefilter=hwang"]).run(110)
    assert AdvisoryLevel.RA in level_sequence(default)
    assert level_sequence(hwang) == level_sequence(default)
    ra = next(c for _, c in hwang if c.level is AdvisoryLevel.RA)
    assert ra.pc_max > 0.5


def test_the_way_back_check_reads_the_ra_thresholds_at_a_displaced_ownship():
    """DaaCore.ra_threatened_if (the guidance's check before it gives the mission back) against the booklet's SL 4
    RA thresholds by hand: inside RA tau (20 s), an intruder co-altitude with ownship raises an RA; ownship 150 m
    (492 ft) above it is still inside RA ZTHR (600 ft); 250 m (820 ft) above, level, it is outside ZTHR with no
    vertical closure; 250 m above descending at 10 m/s, its time to co-altitude (25 s) is over the RA's 20 s, so
    no RA; at 20 m/s (12.5 s) an RA (DAIDALUS TCAS3D: the vertical test's time to co-altitude, TCOA = TAU)."""
    encounter = head_on()
    t_ra = onset(R0, 2 * V, 20, 0.35 * NM)
    core, _ = encounter.run(t_ra + 1.0)
    now = t_ra + 1.0
    assert core.ra_threatened_if(now, [(0.0, 0.0)])
    assert core.ra_threatened_if(now, [(150.0, 0.0)])
    assert not core.ra_threatened_if(now, [(250.0, 0.0)])
    assert not core.ra_threatened_if(now, [(250.0, -10.0)])
    assert core.ra_threatened_if(now, [(250.0, -10.0), (0.0, 0.0)])  # any of the moves
    assert core.ra_threatened_if(now, [(250.0, -20.0)])
    early, _ = encounter.run(t_ra - 5.0)  # outside RA tau: no geometry raises one
    assert not early.ra_threatened_if(t_ra - 5.0, [(0.0, 0.0)])
