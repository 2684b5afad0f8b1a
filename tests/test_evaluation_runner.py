"""avionics evaluate on Dask (issue 15's acceptance): 200 encounters on a LocalCluster of two processes and in
process give identical Parquet records, and a set interrupted (by --max-partitions, or by killing the process)
is completed by running the command again, without duplicates."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from avionics_eval.evaluation.runner import EvaluationError, partitions, read, run

pytestmark = pytest.mark.live  # subprocesses and loopback LocalClusters

N, SEED, PROFILES = 200, 15, ("tcas2",)  # one profile keeps the test near a minute on a busy 2-core machine
CLI = [sys.executable, "-m", "avionics_eval.cli", "evaluate", "--seed", str(SEED), "--profiles", ",".join(PROFILES)]


def _in_process(tmp_path: Path, n: int, partition_size: int):
    """The reference: the set evaluated in this process (another partition size than the runs compared)."""
    out = tmp_path / "in-process"
    summary = run(n, SEED, PROFILES, out, scheduler="synchronous", partition_size=partition_size, progress=False)
    assert summary["complete"] and summary["evaluated_now"] == n
    return read(out)


def _parts(out: Path) -> list[str]:
    return sorted(p.name for p in out.glob("part-*.parquet"))


def test_local_cluster_interrupted_and_resumed_equals_in_process(tmp_path):
    reference = _in_process(tmp_path, N, 40)
    out = tmp_path / "results"
    first = subprocess.run([*CLI, "--encounters", str(N), "--out", str(out), "--scheduler", "local:2",
                            "--partition-size", "25", "--max-partitions", "3"], check=False, capture_output=True, text=True,
                           timeout=600)
    assert first.returncode == 0, first.stderr
    assert len(_parts(out)) == 3 and not json.loads(first.stdout)["complete"]
    second = subprocess.run([*CLI, "--encounters", str(N), "--out", str(out), "--scheduler", "local:2",
                             "--partition-size", "25"], check=False, capture_output=True, text=True, timeout=600)
    assert second.returncode == 0, second.stderr
    summary = json.loads(second.stdout)
    assert summary["complete"] and summary["evaluated_now"] == N - 3 * 25  # the finished partitions skipped
    assert _parts(out) == [p.name for p in partitions(N, 25)]
    records = read(out)
    assert records.num_rows == N * len(PROFILES)
    assert records.equals(reference)  # every value, whatever the scheduler and the partitioning
    runs = [json.loads(line) for line in (out / "_runs.jsonl").read_text().splitlines()]
    assert [r["evaluated_now"] for r in runs] == [75, 125]
    logged = [json.loads(line)["partition"] for line in (out / "_partitions.jsonl").read_text().splitlines()]
    assert sorted(logged) == _parts(out)  # each partition evaluated once


def test_a_killed_run_is_resumed_without_duplicates(tmp_path):
    """The process is killed while it writes partitions; the rerun completes the set: no half partition was
    visible and none is evaluated twice. Another partition size than the reference: the records do not depend
    on it."""
    out, n = tmp_path / "results", 40
    child = subprocess.Popen([*CLI, "--encounters", str(n), "--out", str(out), "--scheduler", "synchronous",
                              "--partition-size", "4"], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    deadline = time.monotonic() + 300
    try:
        while len(_parts(out)) < 2 and child.poll() is None and time.monotonic() < deadline:
            time.sleep(0.05)
    finally:
        os.kill(child.pid, signal.SIGKILL)
        child.wait(timeout=60)
    written = _parts(out)
    assert 2 <= len(written) < n // 4, "the child was to be killed before it finished"
    summary = run(n, SEED, PROFILES, out, scheduler="synchronous", partition_size=4, progress=False)
    assert summary["evaluated_now"] == n - 4 * len(written) and summary["complete"]
    assert not list(out.glob(".*.tmp"))  # a partition the kill interrupted is cleared, then made whole
    records = read(out)
    keys = list(zip(records["index"].to_pylist(), records["profile"].to_pylist()))
    assert len(keys) == len(set(keys)) == n * len(PROFILES)
    assert records.equals(_in_process(tmp_path, n, 10))


def test_an_existing_cluster_by_address_gives_the_same_records(tmp_path):
    """--scheduler tcp://HOST:PORT: a cluster started elsewhere (here a loopback LocalCluster of one worker)."""
    from distributed import LocalCluster

    with LocalCluster(n_workers=1, threads_per_worker=1, host="127.0.0.1", dashboard_address=None,
                      scheduler_kwargs={"dashboard_address": "127.0.0.1:0"}) as cluster:
        summary = run(10, SEED, PROFILES, tmp_path / "results", scheduler=cluster.scheduler_address,
                      partition_size=5, progress=False)
    assert summary["complete"] and summary["evaluated_now"] == 10
    assert read(tmp_path / "results").equals(_in_process(tmp_path, 10, 3))


def test_a_directory_of_another_set_is_refused(tmp_path):
    run(2, SEED, PROFILES, tmp_path, scheduler="synchronous", partition_size=1, progress=False)
    with pytest.raises(EvaluationError, match="another set"):
        run(2, SEED + 1, PROFILES, tmp_path, scheduler="synchronous", partition_size=1, progress=False)
    for bad in ("threads", "local:0", "local:two", "tcp:host"):
        with pytest.raises(EvaluationError, match="--scheduler"):
            run(3, SEED, PROFILES, tmp_path / "other", scheduler=bad, partition_size=1, progress=False)
    assert not (tmp_path / "other").exists()  # refused before anything is written


def test_an_unknown_profile_is_refused_before_anything_is_written(tmp_path):
    """A typo in --profiles is the configuration's clear error, and the directory stays free for the right run."""
    out = tmp_path / "set"
    result = subprocess.run([*CLI[:-2], "--profiles", "tcas2,tcas3", "--encounters", "1", "--out", str(out)],
                            capture_output=True, text=True, timeout=300)
    assert result.returncode != 0 and "unknown profile 'tcas3'" in result.stderr
    assert not out.exists()
    assert run(1, SEED, PROFILES, out, scheduler="synchronous", progress=False)["complete"]
