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

# subprocesses and a loopback LocalCluster; one worker builds the in-process reference once for both tests
pytestmark = [pytest.mark.live, pytest.mark.xdist_group("evaluation")]

N, SEED, PROFILES = 200, 15, ("tcas2",)  # one profile keeps the test near a minute on a busy 2-core machine
CLI = [sys.executable, "-m", "avionics_eval.cli", "evaluate", "--seed", str(SEED), "--profiles", ",".join(PROFILES)]


@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    out = tmp_path_factory.mktemp("sync") / "results"
    summary = run(N, SEED, PROFILES, out, scheduler="synchronous", partition_size=25, progress=False)
    assert summary["complete"] and summary["evaluated_now"] == N
    return read(out)


def _parts(out: Path) -> list[str]:
    return sorted(p.name for p in out.glob("part-*.parquet"))


def test_local_cluster_interrupted_and_resumed_equals_in_process(reference, tmp_path):
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


def test_a_killed_run_is_resumed_without_duplicates(reference, tmp_path):
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
    assert records.equals(reference.filter(reference["index"].to_numpy() < n))


def test_a_directory_of_another_set_is_refused(tmp_path):
    run(2, SEED, PROFILES, tmp_path, scheduler="synchronous", partition_size=1, progress=False)
    with pytest.raises(EvaluationError, match="another set"):
        run(2, SEED + 1, PROFILES, tmp_path, scheduler="synchronous", partition_size=1, progress=False)
    with pytest.raises(EvaluationError, match="--scheduler"):
        run(3, SEED, PROFILES, tmp_path, scheduler="threads", partition_size=1, progress=False)
