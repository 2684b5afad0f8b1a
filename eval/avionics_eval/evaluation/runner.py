"""Run an encounter set on Dask and stream it to partitioned Parquet: `avionics evaluate` (docs/evaluation.md).

The set is cut into partitions of consecutive encounter indices; a partition is one task (generate and evaluate
its encounters for every profile) whose records come back to this process as an Arrow table and are written to
`<out>/part-<start>-<stop>.parquet` through a temporary name and an atomic rename. A partition file exists only
complete, so a run that is interrupted (or stopped by --max-partitions) is resumed by running the same command:
finished partitions are skipped. At most WINDOW tasks per worker are in flight and each result is written and
dropped at once, so memory does not grow with the number of encounters.

Every record depends on (source, seed, index, profile) alone (generator.generate or lincoln.LincolnSource,
evaluate.evaluate), so the scheduler
(in-process, a LocalCluster, a remote cluster) does not change a single value.
"""

from __future__ import annotations

import json
import logging
import os
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import pyarrow as pa
import pyarrow.parquet as pq

from avionics_eval.evaluation.evaluate import DEFAULT_CONDITIONS, Conditions, check_profile, evaluate, record_schema
from avionics_eval.evaluation.generator import SOURCE, generate

# Bump when the generator or the record changes: a resumed run must not mix versions. 2: the source, weight,
# conditions, pilot_responds and loss-of-well-clear columns.
MODEL_VERSION = 2
MANIFEST = "_manifest.json"  # '_' and '.' names are not read as data by pyarrow's dataset reader
RUN_LOG = "_runs.jsonl"
PARTITION_LOG = "_partitions.jsonl"
WINDOW = 2  # tasks in flight per worker: enough to keep workers busy while the client writes


class EvaluationError(ValueError):
    """A bad --scheduler, or an --out directory holding a different set."""


@dataclass(frozen=True)
class Partition:
    start: int
    stop: int

    @property
    def name(self) -> str:
        return f"part-{self.start:09d}-{self.stop:09d}.parquet"


def partitions(n: int, size: int) -> list[Partition]:
    """[0, size), [size, 2 size), ... up to n: a set extended to more encounters keeps its full partitions."""
    return [Partition(start, min(start + size, n)) for start in range(0, n, size)]


def source_name(source) -> str:
    """The manifest's and the records' name of an encounter source: None is ours (generator.py)."""
    return SOURCE if source is None else source.name


def run_partition(seed: int, part: Partition, profiles: tuple[str, ...], source=None,
                  conditions: Conditions = DEFAULT_CONDITIONS) -> tuple[pa.Table, float]:
    """The task: every encounter of the partition with every profile, and the CPU seconds it took. source: None
    for the project's generator, else an object whose encounter(seed, index) makes one (lincoln.LincolnSource);
    conditions: the surveillance and pilot models (evaluate.Conditions)."""
    cpu0 = time.process_time()
    records = []
    for index in range(part.start, part.stop):
        encounter = generate(seed, index) if source is None else source.encounter(seed, index)
        records.extend(evaluate(encounter, profile, (seed, index), conditions=conditions) for profile in profiles)
    return pa.Table.from_pylist(records, schema=record_schema(conditions)), time.process_time() - cpu0


def write_partition(out: Path, part: Partition, table: pa.Table) -> None:
    tmp = out / f".{part.name}.{os.getpid()}.tmp"
    pq.write_table(table, tmp)
    os.replace(tmp, out / part.name)  # atomic: a reader or a resume never sees half a partition


def _prepare(out: Path, seed: int, size: int, profiles: tuple[str, ...], source=None,
             conditions: Conditions = DEFAULT_CONDITIONS) -> None:
    out.mkdir(parents=True, exist_ok=True)
    manifest = {"model_version": MODEL_VERSION, "seed": seed, "partition_size": size, "profiles": list(profiles),
                "source": source_name(source), "conditions": conditions.name}
    path = out / MANIFEST
    if path.exists():
        found = json.loads(path.read_text())
        if found != manifest:
            raise EvaluationError(f"{out} holds another set ({found}); this run is {manifest}: use another --out")
    else:
        path.write_text(json.dumps(manifest) + "\n")
    for stale in out.glob(".part-*.tmp"):  # left by a killed run (one run per directory at a time)
        stale.unlink()


def _synchronous(pending, seed, profiles, source, conditions, done):
    for part in pending:
        done(part, *run_partition(seed, part, profiles, source, conditions))


def _distributed(client, pending, seed, profiles, source, conditions, done):
    from distributed import as_completed

    workers = max(1, len(client.scheduler_info(n_workers=-1)["workers"]))
    queue = list(reversed(pending))  # popped in index order: an interrupted set is close to a prefix
    in_flight = {}  # task key -> its partition

    def submit():
        part = queue.pop()
        key = f"evaluate-{seed}-{part.start}-{part.stop}"
        in_flight[key] = part
        return client.submit(run_partition, seed, part, profiles, source, conditions, key=key, pure=False)

    futures = as_completed([submit() for _ in range(min(len(queue), WINDOW * workers))], with_results=True)
    for future, (table, cpu_s) in futures:
        done(in_flight.pop(future.key), table, cpu_s)
        future.release()
        if queue:
            futures.add(submit())


def _scheduler(scheduler: str) -> tuple[str, int | str | None]:
    """--scheduler parsed: ("synchronous", None), ("local", workers) or ("tcp", address); EvaluationError
    otherwise, before anything is written or started."""
    kind, _, arg = scheduler.partition(":")
    if scheduler == "synchronous":
        return "synchronous", None
    if kind == "local":
        if not arg:
            return "local", os.cpu_count() or 1
        if arg.isdigit() and int(arg) >= 1:
            return "local", int(arg)
        raise EvaluationError(f"--scheduler {scheduler}: local:N takes a whole number of workers, at least one")
    if kind == "tcp" and arg.startswith("//"):
        return "tcp", scheduler
    raise EvaluationError(f"--scheduler {scheduler!r}: expected local[:N], synchronous or tcp://HOST:PORT")


def _client(kind: str, arg):
    """A dask.distributed Client for a parsed --scheduler (_scheduler): local, a LocalCluster of `arg` processes
    on 127.0.0.1 with no dashboard; tcp, the existing scheduler at `arg`. None for synchronous."""
    if kind == "synchronous":
        return None, None
    from distributed import Client, LocalCluster

    if kind == "tcp":
        return Client(arg), None
    logging.getLogger("distributed").setLevel(logging.WARNING)  # its INFO lines would bury the progress bar
    # Loopback only: the scheduler, the nannies and the workers bind 127.0.0.1; no dashboard, and the
    # scheduler's small HTTP server (health routes, always started) on an ephemeral loopback port.
    cluster = LocalCluster(n_workers=arg, threads_per_worker=1, processes=True, host="127.0.0.1",
                           dashboard_address=None, scheduler_port=0, silence_logs=logging.WARNING,
                           scheduler_kwargs={"dashboard_address": "127.0.0.1:0"})
    return Client(cluster), cluster


def run(n: int, seed: int, profiles: tuple[str, ...], out: str | Path, scheduler: str = "local",
        partition_size: int = 100, max_partitions: int | None = None, progress: bool | None = None,
        source=None, conditions: Conditions = DEFAULT_CONDITIONS) -> dict:
    """Evaluate encounters [0, n) of set `seed` with each profile into the Parquet directory `out`; returns a
    summary of this invocation (also appended to <out>/_runs.jsonl). source, conditions: see run_partition."""
    from avionics_sitl.progress import progress_bar

    kind, arg = _scheduler(scheduler)
    for profile in profiles:  # a bad name fails here, before a worker starts or a manifest is written
        check_profile(profile, conditions)
    out = Path(out)
    _prepare(out, seed, partition_size, profiles, source, conditions)
    todo = [p for p in partitions(n, partition_size) if not (out / p.name).exists()]
    pending = todo[:max_partitions] if max_partitions is not None else todo
    bar, task = progress_bar(progress, f"evaluating {n} encounters", n)
    if bar is not None:
        bar.update(task, completed=n - sum(p.stop - p.start for p in todo))
    stats = {"encounters": 0, "cpu_s": 0.0}

    def done(part, table, cpu_s):
        write_partition(out, part, table)
        with open(out / PARTITION_LOG, "a") as fh:  # the cost of an interrupted run is known too
            fh.write(json.dumps({"partition": part.name, "cpu_s": round(cpu_s, 2),
                                 "utc": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime())}) + "\n")
        stats["encounters"] += part.stop - part.start
        stats["cpu_s"] += cpu_s
        if bar is not None:
            bar.advance(task, part.stop - part.start)

    wall0 = time.perf_counter()
    client, cluster = _client(kind, arg)
    try:
        if client is None:
            _synchronous(pending, seed, profiles, source, conditions, done)
        else:
            _distributed(client, pending, seed, profiles, source, conditions, done)
    finally:
        if bar is not None:
            bar.stop()
        if client is not None:
            client.close()
        if cluster is not None:
            cluster.close()
    wall = time.perf_counter() - wall0
    remaining = len(todo) - len(pending)
    summary = {
        "utc": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()), "command": " ".join(sys.argv),
        "seed": seed, "source": source_name(source), "conditions": conditions.name, "encounters_in_set": n,
        "profiles": list(profiles), "scheduler": scheduler,
        "evaluated_now": stats["encounters"], "partitions_now": len(pending), "partitions_left": remaining,
        "wall_s": round(wall, 1), "cpu_s": round(stats["cpu_s"], 1),
        "encounters_per_cpu_s": round(stats["encounters"] / stats["cpu_s"], 3) if stats["cpu_s"] else None,
        "complete": remaining == 0,
    }
    with open(out / RUN_LOG, "a") as fh:
        fh.write(json.dumps(summary) + "\n")
    return summary


def read(out: str | Path) -> pa.Table:
    """Every record of a results directory, sorted by (index, profile)."""
    from avionics_eval.evaluation.evaluate import RECORD_SCHEMA

    manifest = Path(out) / MANIFEST
    guided = manifest.exists() and ",pilot=guidance" in json.loads(manifest.read_text()).get("conditions", "")
    schema = record_schema(Conditions(pilot="guidance", vehicle="multirotor")) if guided else RECORD_SCHEMA
    table = pq.read_table(out, schema=schema)
    return table.sort_by([("index", "ascending"), ("profile", "ascending")])
