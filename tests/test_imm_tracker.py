"""ImmTracker: the Tracker interface, lifecycle (initiation, ordering, chi-square gate with competing
tracks, deletion), vectorised batches, outputs, and the pipeline/payload wiring."""

import math
from collections import Counter

import numpy as np
import pytest

from avionics.compose import build_tracker
from avionics.config import ConfigError, load_config
from avionics.base.types import AddressSource, AltitudeDatum, IntruderKey, IntruderReport, TrackView
from avionics.io.payloads import track_payload
from avionics_eval.reports.tracking import noisy_reports, track_reports
from avionics.tracking.imm_tracker import ImmTracker
from avionics.tracking.interface import Tracker
from avionics.tracking.record import UNKNOWN_SPEED_SIGMA_MPS
from avionics.tracking.tracker import IntruderTracker

KEY = IntruderKey(0xABC123, AddressSource.ES1090)
V = 100.0


def tracker(filter_name="imm", *extra):
    tr = build_tracker(load_config(overrides=[f"tracking.filter={filter_name}", *extra]).tracking, Counter())
    assert isinstance(tr, ImmTracker)
    return tr


def report(t, key=KEY, alt=1000.0, vel=(V, 0.0), vrate=0.0, datum=AltitudeDatum.PRESSURE):
    return IntruderReport(key, t, t, 0.0, 0.0, alt, datum if alt is not None else None, vel, vrate)


def fly(tr, t_end, key=KEY, north=0.0, start=0.0):
    for t in np.arange(start, t_end + 1e-9, 1.0):
        tr.ingest(report(float(t), key), V * t, north)


def test_config_selects_the_tracker_and_validates_the_imm_keys():
    default = build_tracker(load_config().tracking, Counter())
    assert isinstance(default, ImmTracker) and default.model == "imm"  # docs/tracking.md "Default filter"
    assert isinstance(build_tracker(load_config(overrides=["tracking.filter=cv"]).tracking, Counter()),
                      IntruderTracker)
    for f in ("imm", "rmimm", "vb-imm", "vb-rmimm"):
        assert build_tracker(load_config(overrides=[f"tracking.filter={f}"]).tracking, Counter()).model == f
    for bad, msg in (("tracking.filter=ukf", "tracking.filter"), ('tracking.imm_horizontal_modes=["cv","zz"]',
                                                                 "imm_horizontal_modes"),
                     ("tracking.gate_probability=1.0", "gate_probability"), ("tracking.vb_iterations=0", "vb_iter")):
        with pytest.raises(ConfigError, match=msg):
            load_config(overrides=[bad])


def test_interface_attributes_and_mode_info():
    tr = tracker("vb-imm")
    fly(tr, 10)
    track = tr.tracks[KEY]
    assert (track.key, track.datum, track.last_report_s, track.n_updates) == (KEY, AltitudeDatum.PRESSURE, 10.0, 11)
    assert track.altitude_valid(15.0, 6.0) and not track.altitude_valid(17.0, 6.0)
    xs, ps = tr.predict([KEY], 12.0)
    assert xs.shape == (1, 6) and ps.shape == (1, 6, 6)
    np.testing.assert_allclose(xs[0], [V * 12, 0, 1000, V, 0, 0], atol=5.0)
    info = tr.mode_info(KEY)
    assert set(info["mode_probabilities"]) == {"cv", "ct"} and math.isclose(sum(info["mode_probabilities"].values()), 1)
    assert info["most_likely_mode"] == "cv" and info["vertical_mode"] in ("ch", "cad")
    assert abs(info["turn_rate_dps"]) < 0.5
    assert set(info["vb_noise"]) == {"position_sigma_m", "velocity_sigma_mps", "altitude_sigma_m",
                                     "vertical_rate_sigma_mps"}


def test_initiation_is_honest_about_what_the_report_did_not_carry():
    tr = tracker()
    tr.ingest(IntruderReport(KEY, 0.0, 0.0, 0.0, 0.0, None, None, None, None), 500.0, 200.0)
    x, p = tr.predict([KEY], 0.0)
    assert x[0, :2] == pytest.approx([500.0, 200.0])
    assert p[0, 3, 3] == pytest.approx(UNKNOWN_SPEED_SIGMA_MPS**2, rel=0.01)
    assert p[0, 0, 0] == pytest.approx(30.0**2, rel=0.01)
    assert not tr.tracks[KEY].altitude_valid(0.0, 6.0)


def test_out_of_order_and_duplicate_reports_are_counted_and_change_nothing():
    tr = tracker()
    fly(tr, 5)
    x = tr.tracks[KEY].kf.x.copy()
    assert not tr.ingest(report(5.0), 9999.0, 0.0)
    assert not tr.ingest(report(3.0), 9999.0, 0.0)
    assert tr.counters["report.duplicate"] == 1 and tr.counters["report.out_of_order"] == 1
    assert np.array_equal(tr.tracks[KEY].kf.x, x)


def test_both_trackers_are_trackers_and_drop_forgets_the_key():
    for name in ("cv", "imm"):
        tr = build_tracker(load_config(overrides=[f"tracking.filter={name}"]).tracking, Counter())
        assert isinstance(tr, Tracker)
        fly(tr, 5)
        tr.ingest(report(6.0), 80000.0, 0.0)  # not this aircraft: the IMM tracker starts a competitor
        assert KEY in tr.competitors if name == "imm" else not tr.competitors
        tr.drop(KEY)
        assert not tr.tracks and not tr.competitors and tr.counters["track.deleted"] == 0
        if name == "imm":
            tr._check_slots()  # both slots are free again
        assert tr.ingest(report(7.0), V * 7, 0.0) and tr.tracks[KEY].n_updates == 1
        assert tr.counters["track.initiated"] == 2


def test_a_report_outside_the_gate_is_never_merged_and_three_in_a_row_restart_the_track():
    tr = tracker()
    fly(tr, 10)
    before = tr.tracks[KEY].kf.x.copy()
    for i, t in enumerate((11.0, 12.0)):
        assert not tr.ingest(report(t), 80000.0 + V * t, 0.0)  # 80 km away: not this aircraft
        assert tr.counters["track.implausible_jump"] == i + 1
        assert np.array_equal(tr.tracks[KEY].kf.x, before)
    assert tr.competitors[KEY].n_updates == 2  # the new reports are tracked apart
    assert tr.ingest(report(13.0), 80000.0 + V * 13, 0.0)
    assert tr.counters["track.restarted"] == 1
    assert tr.tracks[KEY].kf.x[0] == pytest.approx(80000.0 + V * 13, abs=100)


def test_a_plausible_but_statistically_inconsistent_report_is_a_gate_miss():
    tr = tracker()
    fly(tr, 10)
    before = tr.tracks[KEY].kf.x.copy()
    assert not tr.ingest(report(11.0), V * 11 + 600.0, 0.0)  # 600 m off with 30 m noise: 20 sigma
    assert tr.counters["track.gate_miss"] == 1 and tr.counters["track.implausible_jump"] == 0
    assert np.array_equal(tr.tracks[KEY].kf.x, before)
    assert tr.ingest(report(12.0), V * 12 + 10.0, 0.0)  # back on track: accepted
    assert tr.tracks[KEY].consecutive_rejects == 0


def test_two_aircraft_under_one_address_are_never_averaged():
    tr = tracker()
    for t in np.arange(0.0, 40.0):
        north_b = 3000.0  # B flies 3 km north of A, same address, alternate reports
        if t % 2 == 0:
            tr.ingest(report(float(t)), V * t, 0.0)
        else:
            tr.ingest(report(float(t)), V * t, north_b)
        x = tr.tracks[KEY].kf.x
        assert min(abs(x[1]), abs(x[1] - north_b)) < 100.0  # on one of them, never in between
    assert tr.counters["track.restarted"] == 0
    assert tr.counters["track.implausible_jump"] + tr.counters["track.gate_miss"] >= 19  # every B report
    assert tr.competitors[KEY].n_updates >= 10  # B is tracked on its own, out of the published tracks
    tr._check_slots()
    for t in np.arange(40.0, 60.0):  # now random far-off reports: every one replaces the competitor
        tr.ingest(report(float(t)), V * t + 1e5 * (t % 3 + 1), -1e5 * (t % 2))
    tr._check_slots()
    assert tr.counters["track.competitor_replaced"] > 5


def test_deletion_after_silence_and_a_report_updates_only_its_track():
    tr = tracker()
    other = IntruderKey(0x111111, AddressSource.UAT)
    fly(tr, 5, other, north=5000.0)
    snapshot = tr.tracks[other].kf.x.copy(), tr.tracks[other].kf.p.copy()
    fly(tr, 20, KEY, start=6.0)
    assert np.array_equal(tr.tracks[other].kf.x, snapshot[0]) and np.array_equal(tr.tracks[other].kf.p, snapshot[1])
    assert tr.prune(25.0) == []
    assert tr.prune(25.5) == [other] and set(tr.tracks) == {KEY}
    assert tr.counters["track.deleted"] == 1


def test_ingest_many_equals_one_report_at_a_time_and_predict_is_vectorised():
    rng = np.random.default_rng(0)
    keys = [IntruderKey(0x200000 + i, AddressSource.ES1090) for i in range(30)]
    batches = []
    for t in range(8):
        reps = [report(t + rng.uniform(-0.3, 0.3), k) for k in keys]
        batches.append((reps, rng.normal(V * t, 20, 30) + 2000.0 * np.arange(30), rng.normal(0, 20, 30)))
    a, b = tracker(), tracker()
    for reps, e, n in batches:
        out = a.ingest_many(reps + reps[:2], np.r_[e, e[:2]], np.r_[n, n[:2]])  # with two duplicates
        assert out[:30].all() and not out[30:].any()
        for r, ee, nn in zip(reps, e, n):
            b.ingest(r, ee, nn)
    xa, pa = a.predict(keys, 9.0)
    xb, pb = b.predict(keys, 9.0)
    np.testing.assert_allclose(xa, xb, rtol=1e-10, atol=1e-8)
    np.testing.assert_allclose(pa, pb, rtol=1e-10, atol=1e-8)
    for i, k in enumerate(keys[:3]):
        x1, p1 = a.predict([k], 9.0)
        np.testing.assert_allclose(x1[0], xa[i], rtol=1e-12)


def test_datum_change_restarts_the_vertical_axis():
    tr = tracker()
    fly(tr, 5)
    tr.ingest(report(6.0, alt=1300.0, datum=AltitudeDatum.GEOMETRIC), V * 6, 0.0)
    assert tr.counters["track.datum_change"] == 1 and tr.tracks[KEY].datum is AltitudeDatum.GEOMETRIC
    x, _ = tr.predict([KEY], 6.0)
    assert x[0, 2] == pytest.approx(1300.0, abs=1.0)  # not dragged towards the old datum's 1000 m


def test_vb_imm_tracker_stays_stable_when_the_noise_steps_up_5x():
    level = np.where(np.arange(301.0) < 150, 15.0, 75.0)
    reps, truth = noisy_reports(level, seed=3)
    err_vb, est, c_vb = track_reports("vb-imm", reps, truth)
    err_imm, _, c_imm = track_reports("imm", reps, truth)
    assert c_vb["track.restarted"] == 0 and c_vb["track.gate_miss"] <= 3
    assert np.sqrt(np.mean(err_vb[170:] ** 2)) < 25.0 and err_vb.max() < 80.0
    assert est[250:].mean() == pytest.approx(75.0, rel=0.25)
    assert c_imm["track.gate_miss"] > 5 * max(c_vb["track.gate_miss"], 1)  # fixed R: reports fall outside


def test_track_payload_carries_the_imm_outputs():
    tr = tracker("vb-rmimm")
    fly(tr, 5)
    track = tr.tracks[KEY]
    xs, ps = tr.predict([KEY], 6.0)
    payload = track_payload("uav1", TrackView.of(track, 6.0, xs[0], ps[0], 47.0, 8.0, True, None,
                                                 tr.mode_infos([KEY], 6.0)[0]))
    assert tr.mode_infos([KEY], 6.0)[0] == tr.mode_info(KEY, 6.0)
    assert payload["model"] == "vb-rmimm" and payload["most_likely_mode"] in ("cv", "ct")
    assert set(payload["mode_probabilities"]) == {"cv", "ct"} and payload["vb_noise"]["position_sigma_m"] > 0
    assert "turn_rate_dps" in payload and payload["vertical_mode"] in ("ch", "cad")
    cv = build_tracker(load_config(overrides=["tracking.filter=cv"]).tracking, Counter())
    cv.ingest(report(0.0), 0.0, 0.0)
    xs, ps = cv.predict([KEY], 1.0)
    assert track_payload("uav1", TrackView.of(cv.tracks[KEY], 1.0, xs[0], ps[0], 47.0, 8.0, True, None,
                                              cv.mode_infos([KEY], 1.0)[0]))["model"] == "cv-kalman"


def test_pipeline_alerts_at_the_hand_computed_onsets_with_the_imm():
    from synthetic import Encounter, Mover

    from avionics.base.types import AdvisoryLevel
    from avionics.base.units import FT, KT, NM

    alt, v, r0 = 3000 * FT, 125 * KT, 6 * NM
    enc = Encounter(Mover((0, 0, alt), (0, v, 0)), Mover((0, r0, alt), (0, -v, 0)), overrides=["tracking.filter=imm"])
    core, changes = enc.run(90)
    first = {}
    for t, c in changes:
        first.setdefault(c.level, t)

    def onset(tau, dmod):
        r = (tau * 2 * v + math.sqrt((tau * 2 * v) ** 2 + 4 * dmod**2)) / 2
        return (r0 - r) / (2 * v)

    assert first[AdvisoryLevel.TA] == pytest.approx(onset(30, 0.48 * NM), abs=0.11)
    assert first[AdvisoryLevel.RA] == pytest.approx(onset(20, 0.35 * NM), abs=0.11)
    assert isinstance(core.tracker.adsb, ImmTracker)
