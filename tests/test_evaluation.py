"""The encounter generator, the per-encounter evaluation and the metrics of avionics evaluate (issue 15).

References are independent of the code under test: the drawn CPA geometry against the sampled truth, the
standard pilot response's displacement computed by hand, Wilson intervals and the matched-pair risk ratio
computed by hand."""

from __future__ import annotations

import math

import numpy as np
import pyarrow as pa
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from avionics.base import jit
from avionics.contract.bands import BAND_KIND_NAMES as KINDS
from avionics.base.units import FT, KT
from avionics_eval.evaluation import evaluate as ev
from avionics_eval.evaluation import generator as gen
from avionics_eval.evaluation.lincoln import LincolnSource
from avionics_eval.evaluation.metrics import (
    markdown,
    metrics,
    paired_risk_ratio,
    wilson,
)

seeds = st.integers(0, 2**32 - 1)
indices = st.integers(0, 10**9)


@settings(max_examples=40, deadline=None)
@given(seeds, indices)
def test_an_encounter_is_a_function_of_seed_and_index_alone(seed, index):
    first = gen.generate(seed, index)
    gen.generate(seed, index + 1)  # other draws in between change nothing: no shared stream
    gen.generate(seed + 1, index)
    assert gen.generate(seed, index) == first
    assert (first.seed, first.index) == (seed, index)


@settings(max_examples=40, deadline=None)
@given(seeds, indices)
def test_the_truth_has_the_drawn_miss_at_its_closest_approach(seed, index):
    e = gen.generate(seed, index)
    _, own, intruder = e.truth()
    horizontal = np.hypot(intruder[:, 0] - own[:, 0], intruder[:, 1] - own[:, 1])
    k = int(np.argmin(horizontal))
    assert horizontal[k] == pytest.approx(e.hmd_m, abs=0.5)  # the grid's 0.5 m tolerance of the generator
    k_cpa = round(gen.T_CPA_S / gen.DT_S)
    assert horizontal[k_cpa] == pytest.approx(e.hmd_m, abs=1e-6)
    assert intruder[k_cpa, 2] - own[k_cpa, 2] == pytest.approx(e.vmd_m, abs=1e-6)
    m = gen.DEFAULT_MODEL
    assert 0 <= e.hmd_m <= m.hmd_max_ft * FT and abs(e.vmd_m) <= m.vmd_max_ft * FT
    low, high = m.layers_ft[e.layer - 1]
    assert low * FT <= own[k_cpa, 2] <= high * FT
    for x in (own, intruder):
        assert x[:, 2].min() >= m.min_agl_ft * FT
        speed = np.hypot(x[:, 3], x[:, 4])
        assert m.speed_bounds_kt[0] * KT <= speed.min() and speed.max() <= m.speed_bounds_kt[1] * KT
        # positions are the integral of the velocities (trapezoid on the grid)
        assert np.allclose(np.diff(x[:, 0]), 0.5 * (x[1:, 3] + x[:-1, 3]) * gen.DT_S, atol=1e-9)


def _level_head_on(hmd_ft: float, vmd_ft: float, alt_ft: float = 3000.0) -> gen.Encounter:
    """Both level at 150 kt, opposite headings, CPA at T_CPA_S with the given misses."""
    own = gen.Aircraft(0.0, 0.0, alt_ft * FT, 0.0, 150 * KT, 0.0)
    intruder = gen.Aircraft(hmd_ft * FT, 0.0, (alt_ft + vmd_ft) * FT, math.pi, 150 * KT, 0.0)
    return gen.Encounter(7, 0, 3, hmd_ft * FT, vmd_ft * FT, 180.0, own, intruder)


def _truth_record(e: gen.Encounter, offset_m: float = 0.0) -> dict:
    """The record of e's truth with ownship displaced by offset_m (up) all along, and no advisory."""
    from avionics.advisory.tables import load_profile

    t, own, intruder = e.truth()
    return ev._record(e, "tcas2", t, own, intruder, np.full(len(t), offset_m), [], 5.0,
                      load_profile("tcas2").response, ev._setup("tcas2")[1])


def test_nmac_is_500_ft_horizontally_and_100_ft_vertically_at_once():
    record = _truth_record(_level_head_on(400.0, 90.0))
    assert record["nmac_unequipped"] and record["nmac_equipped"] and not record["induced_nmac"]
    for hmd, vmd in ((400.0, 110.0), (520.0, 0.0)):
        record = _truth_record(_level_head_on(hmd, vmd))
        assert not record["nmac_unequipped"]
        assert record["hmd_ft"] == pytest.approx(hmd) and record["vmd_unequipped_ft"] == pytest.approx(vmd)
    # ownship 40 ft lower turns a 90 ft miss into 130 ft: no NMAC equipped; 40 ft higher, a 110 ft miss into 70 ft
    record = _truth_record(_level_head_on(400.0, 90.0), -40 * FT)
    assert record["nmac_unequipped"] and not record["nmac_equipped"]
    record = _truth_record(_level_head_on(400.0, 110.0), 40 * FT)
    assert record["induced_nmac"] and record["vmd_equipped_ft"] == pytest.approx(70.0)


def test_a_co_altitude_head_on_is_resolved_by_the_standard_response_by_hand():
    """Level head-on at 3000 ft (SL 4), 50 ft apart vertically: the RA is CLIMB or DESCEND at 1500 fpm; with the
    drawn delay d and 0.25 g, ownship is displaced by r (L - d - r / a) + r^2 / (2 a) at the CPA, L the RA's
    lead; the vertical miss flown is 50 ft plus or minus that."""
    e = _level_head_on(0.0, 50.0)
    record = ev.evaluate(e, "tcas2", 11)
    assert record["nmac_unequipped"] and not record["nmac_equipped"]
    words = record["ra_words"].split("|")
    assert words[0] in ("CLIMB", "DESCEND") and record["ra_strengthenings"] == record["ra_reversals"] == 0
    from avionics.advisory.tables import load_profile

    response = load_profile("tcas2").response
    lead, d = record["ra_lead_s"], record["response_delay_s"]
    r, a = response.rate_mps, response.accel_mps2
    assert 0.6 * response.delay_s <= d <= 1.4 * response.delay_s  # DELAY_SPREAD
    displacement = (r * (lead - d - r / a) + r * r / (2 * a)) / FT
    sign = 1.0 if words[0] == "DESCEND" else -1.0  # the intruder is 50 ft above
    assert record["vmd_equipped_ft"] == pytest.approx(abs(50.0 + sign * displacement), abs=3.0)
    assert record["ra_lead_s"] > d + r / a and not record["late_ra"]


def test_a_dont_climb_strengthens_when_ownship_levels_off_under_a_descending_intruder():
    """Seed 1, encounter 16492 of the 2026-12-03 run: ownship descending 1989 fpm gets DONT CLIMB against an intruder
    above descending 1500 fpm, then levels off (its own manoeuvre, which DONT CLIMB allows) 18 s before the CPA.
    The RA held for 37 s and the pair passed 15 ft apart (NMAC); it must strengthen to DESCEND and resolve it
    (the RA logic's unit tests in test_resolution.py compute the same strengthening by hand)."""
    record = ev.evaluate(gen.generate(1, 16492), "tcas2", (1, 16492))
    assert record["nmac_unequipped"] and not record["nmac_equipped"]
    assert record["ra_words"].split("|")[:2] == ["DONT CLIMB", "DESCEND"] and record["ra_strengthenings"] >= 1


def test_evaluate_is_pure_and_its_record_fits_the_schema():
    e = gen.generate(3, 14)
    first = ev.evaluate(e, "tcas2", (3, 14))
    assert ev.evaluate(gen.generate(3, 14), "tcas2", (3, 14)) == first
    table = pa.Table.from_pylist([first], schema=ev.RECORD_SCHEMA)
    assert table.column_names == list(first)


@pytest.mark.parametrize("profile", ["tcas2", "do365"])
def test_the_cut_display_outputs_change_no_record(monkeypatch, profile):
    """EVALUATION_OVERRIDES cut outputs that advisories do not read (the conflict zone's probabilities, a DO-365
    alerter's guidance bands): the records equal the flight defaults'."""
    cut = [ev.evaluate(gen.generate(5, i), profile, (5, i)) for i in range(6)]
    from avionics.config import load_config

    setup = ev._setup.__wrapped__

    def flight_defaults(profile, overrides=()):
        config = load_config(overrides=["zenoh.enabled=false", f'advisory.profile="{profile}"'])
        assert config.advisory.guidance_bands and config.conflict.within_samples > 0
        return config, setup(profile)[1]

    monkeypatch.setattr(ev, "_setup", flight_defaults)
    assert [ev.evaluate(gen.generate(5, i), profile, (5, i)) for i in range(6)] == cut
    assert any(r["ra"] for r in cut)  # the comparison covered RAs



def test_the_band_kinds_the_guidance_does_not_read_change_no_record(monkeypatch):
    """Flown through the guidance with the bands, an encounter computes only the kinds of bands the guidance reads
    (guidance/params.py BAND_KINDS_READ; the others are for displays): the records equal those with all four, on
    Lincoln encounters whose guidance flew the bands' resolution (commanding:recovery, commanding:warning)."""
    conditions = ev.Conditions("do365-adsb", None, "guidance", "multirotor", True)
    source = LincolnSource.of("uncor_1200exclude_rotorcraft_v1p2.txt", "uav-survey")

    def records():
        return [ev.evaluate(source.encounter(28, i), "do365", (28, i), conditions=conditions) for i in (3003, 3008)]

    cut = records()
    assert "advisory.guidance_band_kinds=[\"track_deg\"]" in conditions.overrides()
    monkeypatch.setattr(ev, "BAND_KINDS_READ", KINDS)
    assert records() == cut
    assert all(r["guidance_states"].startswith("commanding:") for r in cut)  # the bands' resolution was flown


@pytest.mark.skipif(not jit.ENABLED, reason="compiled kernels are off (AVIONICS_COMPILED=0)")
@pytest.mark.parametrize("profile, conditions, encounters", [
    ("tcas2", ev.DEFAULT_CONDITIONS, 100),
    ("do365", ev.DEFAULT_CONDITIONS, 100),
    # the guidance flies the bands' resolutions: the bands' compiled comparisons and loss intervals decide them
    ("do365", ev.Conditions("sitl", None, "guidance", "multirotor", True), 3),
])
def test_the_compiled_kernels_change_no_record(profile, conditions, encounters):
    """Issue 32: the compiled pieces of the step (tracker, geometry, alerter, Pc, the conflict stage, the bands'
    comparisons and intervals) give the records of the numpy reference (avionics.base.jit.reference()), field
    for field, on encounters with RAs among them."""
    def records():
        return [ev.evaluate(gen.generate(1, i), profile, (1, i), conditions=conditions) for i in range(encounters)]

    compiled = records()
    with jit.reference():
        reference = records()
    assert compiled == reference
    assert sum(r["ra"] for r in compiled) >= min(encounters, 20)

def test_wilson_and_the_matched_pair_risk_ratio_by_hand():
    est, lo, hi = wilson(0, 10)
    assert (est, lo) == (0.0, 0.0) and hi == pytest.approx(1.959964**2 / (10 + 1.959964**2), rel=1e-6)
    assert wilson(5, 10)[1:] == pytest.approx((0.236593, 0.763407), abs=1e-6)
    rr, lo, hi = paired_risk_ratio(2, 0, 6)  # RR = 2 / 8, se(log) = sqrt(6 / (2 * 8))
    se = math.sqrt(6 / 16)
    assert (rr, lo, hi) == pytest.approx((0.25, 0.25 * math.exp(-1.959964 * se), 0.25 * math.exp(1.959964 * se)))
    rr, lo, hi = paired_risk_ratio(0, 0, 8)  # no equipped NMAC: b = 0.5 for the upper bound
    assert (rr, lo) == (0.0, 0.0) and hi == pytest.approx(0.5 / 8 * math.exp(1.959964 * math.sqrt(8.5 / 4)))


def test_metrics_count_per_profile():
    rows = []
    for i in range(10):
        for profile, equipped in (("a", i < 1), ("b", i < 3)):
            rows.append({"seed": 1, "index": i, "profile": profile, "nmac_unequipped": i < 4,
                         "nmac_equipped": equipped, "ra": i < 6, "alerted": i < 8, "ra_reversals": int(i == 0),
                         "ra_strengthenings": int(i < 2), "nuisance_ra": i == 5, "late_ra": i == 3,
                         "ra_lead_s": 20.0 if i < 6 else None, "alert_duration_s": 30.0})
    result = metrics(pa.Table.from_pylist(rows))
    assert result["a"]["p_nmac_unequipped"][0] == 0.4 and result["a"]["p_nmac_equipped"][0] == 0.1
    assert result["a"]["risk_ratio"][0] == pytest.approx(0.25) and result["b"]["risk_ratio"][0] == 0.75
    assert result["b"]["nmac_counts"] == {"both": 3, "induced": 0, "resolved": 1}
    assert result["a"]["reversal_rate"][0] == pytest.approx(1 / 6)
    assert result["a"]["strengthening_rate"][0] == pytest.approx(2 / 6)
    assert result["a"]["late_ra_rate"][0] == pytest.approx(1 / 4)
    assert list(metrics(pa.Table.from_pylist(rows), order=("b", "z"))) == ["b", "a"]
    table = markdown(result)
    assert "| risk ratio | 0.2500 [" in table and table.count("\n") == len(table.splitlines()) - 1


def test_the_nuisance_study_truth_ra_volume_by_hand():
    """avionics_eval.reports.nuisance on the evaluation's encounters: SL 4 (RA DMOD 0.35 nm, ZTHR 600 ft, RA HMD
    0.57 nm). A level head-on passing 0 ft horizontally enters the RA volume when 500 ft apart vertically, not
    at 700 ft (> ZTHR) nor passing 0.6 nm (> RA HMD) apart."""
    from avionics.advisory.tables import load_profile
    from avionics.base.units import NM
    from avionics_eval.reports import nuisance

    level = next(lvl for lvl in load_profile("tcas2").levels if lvl.sl == 4)
    assert nuisance._truth_enters_ra_volume(_level_head_on(0.0, 500.0), level)
    assert not nuisance._truth_enters_ra_volume(_level_head_on(0.0, 700.0), level)
    assert not nuisance._truth_enters_ra_volume(_level_head_on(0.6 * NM / FT, 0.0), level)
    assert nuisance._truth_enters_ra_volume(_level_head_on(0.5 * NM / FT, 0.0), level)
    e = gen.generate(1, 3, nuisance.model(level))
    assert e.own.alt_m == pytest.approx(nuisance.ALTITUDE_FT * FT) and e.own.vrate_mps == 0.0
    assert e.hmd_m <= 2 * level.ra_hmd_m and abs(e.vmd_m) <= 900 * FT


def test_metrics_load_keeps_the_common_encounters(tmp_path):
    from avionics_eval.evaluation.metrics import load
    from avionics_eval.evaluation.runner import Partition, write_partition

    def records(profile, n):
        return pa.Table.from_pylist([{**dict.fromkeys(ev.RECORD_SCHEMA.names), "seed": 1, "index": i,
                                      "profile": profile} for i in range(n)], schema=ev.RECORD_SCHEMA)

    for name, profile, n in (("a", "p", 5), ("b", "q", 3)):
        (tmp_path / name).mkdir()
        write_partition(tmp_path / name, Partition(0, n), records(profile, n))
    dirs = [tmp_path / "a", tmp_path / "b"]
    assert load(dirs).num_rows == 8
    common = load(dirs, common=True)
    assert sorted(zip(common["profile"].to_pylist(), common["index"].to_pylist())) == \
        [(p, i) for p in "pq" for i in range(3)]
    with pytest.raises(ValueError, match="twice"):
        load([tmp_path / "a", tmp_path / "a"])
