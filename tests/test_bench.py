"""`avionics bench` runs end to end and accounts for every report (its numbers are measurements, not asserted)."""

import json
import os

import pytest

from avionics_eval.cli import main

pytestmark = pytest.mark.live  # a real zenoh session on loopback, the live loop on the wall clock


def test_bench_command_prints_both_modes_with_every_report_accounted_for(capsys):
    cores = os.sched_getaffinity(0)
    assert main(["bench", "--intruders", "5", "--seconds", "2"]) == 0
    assert os.sched_getaffinity(0) == cores  # pinned to one core for the run only
    out = json.loads(capsys.readouterr().out)
    assert [r["intruders"] for r in out["per_report"]] == [5] and [r["intruders"] for r in out["real_time"]] == [5]
    for run in out["per_report"] + out["real_time"]:
        assert run["reports"] == 10 and run["tracks"] == 5 and run["rejected"] == 0
        assert 0 < run["latency_us_p50"] <= run["latency_us_p99"] <= run["latency_us_max"]  # ordered, any size
    live = out["real_time"][0]
    # cpu_load is the loop's busy share of the wall time (a fraction, whatever the load); steps and the largest
    # batch depend on how promptly the loop was woken: it ran in steps, each taking what had arrived.
    assert 0 < live["cpu_load"] <= 1 and 1 <= live["steps"] and 1 <= live["largest_batch"] <= live["reports"]


def test_capacity_bench_prints_every_measure_positive_finite_and_ordered(capsys):
    """`avionics bench --capacity` with tiny parameters: the JSON's keys and sanity, never its timings."""
    import math

    cores = os.sched_getaffinity(0)
    assert main(["-q", "bench", "--capacity", "--intruders", "20", "--trial-seconds", "2", "--no-zenoh",
                 "--startup-repeats", "1", "--max-trials", "3"]) == 0
    assert os.sched_getaffinity(0) == cores
    out = json.loads(capsys.readouterr().out)
    assert out["zenoh"] is False and out["trial_s"] == 2.0
    for key in ("reference_filterpy_imm_step_us", "startup_s", "startup_first_launch_s"):
        assert 0 < out[key] < math.inf, key
    assert len(out["startup_launches_s"]) == 1
    [row] = out["counts"]
    assert row["intruders"] == 20
    for key in ("latency_us_p50", "latency_us_p99", "latency_us_max", "single_report_us_p50",
                "tracker_update_us_per_track", "tracker_vs_filterpy", "resident_memory_mb",
                "resident_memory_peak_mb"):
        assert 0 < row[key] < math.inf, key
    assert row["latency_us_p50"] <= row["latency_us_p99"] <= row["latency_us_max"]
    assert row["resident_memory_mb"] <= row["resident_memory_peak_mb"]
    assert row["memory_run_reports_received"] > 0  # the child really was fed the traffic it was measured with
    # the search: the 1 Hz run is the first trial, at most 3; the capacity is a rate that was sustained (or 0)
    trials = row["trials"]
    assert 1 <= len(trials) <= 3 and trials[0]["offered_reports_per_s"] == 20
    assert row["sustained_at_1hz"] == trials[0]["sustained"]
    passed = [t["offered_reports_per_s"] for t in trials if t["sustained"]]
    failed = [t["offered_reports_per_s"] for t in trials if not t["sustained"]]
    assert row["capacity_reports_per_s"] == (max(passed) if passed else 0.0)
    lo, hi = row["capacity_bracket"]
    assert lo == row["capacity_reports_per_s"] and (hi is None if not failed else hi == min(failed) > lo)
    for t in trials:
        assert 0 < t["cpu_load"] <= 1
        if "reason" in t:  # stopped far over capacity, or too few reports to judge: never sustained
            assert t["sustained"] is False
            continue
        growth = t["lag_p99_last_quarter_s"] - t["lag_p99_second_quarter_s"] - 0.1  # the JSON rounds to 0.1 ms
        if abs(growth) > 1e-3 and abs(t["last_report_lag_s"] - 0.5) > 1e-3:
            assert t["sustained"] == (growth <= 0 and t["last_report_lag_s"] <= 0.5)


def test_a_trial_past_its_lag_bound_stops_and_is_not_sustained():
    """The capacity search stops a trial once a report's lag passes the bound (a bound of -1 s: the first report)."""
    from avionics_eval import bench, capacity_bench

    _config, _counters, loop, mavlink, scanner, _bus, _sent, events = bench._setup(5, 2.0, 0, zenoh=False)
    run = bench.drive_real_time(loop, mavlink, scanner, events, 0.1, abort_lag_s=-1.0)
    assert run.aborted and len(run.arrived_s) < 10  # 5 intruders x 2 s: stopped before the last report
    ok, why = capacity_bench.sustained(run, 2.0)
    assert ok is False and "stopped" in why["reason"]
    full = bench.drive_real_time(*bench._setup(5, 2.0, 0, zenoh=False)[2:4], scanner, events, 0.1)
    assert not full.aborted and len(full.arrived_s) == 10


def test_soak_samples_a_real_child_and_summarizes_its_memory(capsys):
    """`avionics bench --soak` for 6 s with 20 intruders: the JSON's keys and sanity, never a time or a size."""
    import math
    from itertools import pairwise

    cores = os.sched_getaffinity(0)
    assert main(["-q", "bench", "--soak", "6", "--intruders", "20", "--sample-seconds", "1", "--no-zenoh"]) == 0
    assert os.sched_getaffinity(0) == cores
    out = json.loads(capsys.readouterr().out)
    assert out["intruders"] == 20 and out["soak_s"] == 6.0 and out["zenoh"] is False
    samples = out["samples"]
    times = [s["t_s"] for s in samples]
    assert times[0] == 0 and all(a < b for a, b in pairwise(times)) and times[-1] >= 6.0
    assert len(samples) >= 7  # one a second from 0 to 6 s, then one after the last datagram
    for s in samples:
        assert 0 < s["rss_mb"] <= s["hwm_mb"] < math.inf and 0 <= s["cpu_s"] < math.inf
    assert all(a["cpu_s"] <= b["cpu_s"] for a, b in pairwise(samples))
    rss = [s["rss_mb"] for s in samples]
    for key in ("rss_first_quarter_mb", "rss_last_quarter_mb"):
        assert min(rss) <= out[key] <= max(rss), key
    assert out["rss_min_mb"] == min(rss) and out["rss_max_mb"] == max(rss)
    assert out["rss_peak_mb"] == max(s["hwm_mb"] for s in samples) >= max(rss)  # VmHWM as read can fall back
    assert out["rss_growth_fit_samples"] == sum(t >= 3.0 for t in times) >= 2
    assert math.isfinite(out["rss_growth_mb_per_min"])
    # 6 s of 20 intruders at 1 Hz, all sent; the child's own count says how many it decoded
    assert out["reports_sent"] == 120
    assert 0 < out["reports_received"] <= out["reports_sent"] == 120
    assert out["kept_up"] == (out["reports_received"] == 120)
    assert out["child_counters"]["rx.adsb_vehicle"] == out["reports_received"]
    assert 0 < out["child_cpu_load"] < math.inf and 0 <= out["send_lag_max_s"] < math.inf


def test_soak_growth_is_the_second_half_least_squares_slope_per_minute():
    """summarize: the fit ignores the first half's warm-up and gives MB per minute; the quarters are means."""
    from avionics_eval.soak_bench import summarize

    samples = [{"t_s": t, "rss_mb": 100.0 + (50.0 if t < 60 else 0.5 * t / 60.0)} for t in range(0, 241, 10)]
    out = summarize(samples, 240.0)
    assert out["rss_growth_mb_per_min"] == 0.5 and out["rss_growth_fit_samples"] == 13
    assert out["rss_first_quarter_mb"] == 150.0  # t < 60: the warm-up's level
    assert out["rss_last_quarter_mb"] == round(100.0 + 0.5 * 210.0 / 60.0, 2)  # mean of t = 180..240
