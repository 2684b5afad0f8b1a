"""`avionics bench --capacity`: the measuring instrument of issue 13 (capacity, latency, start-up, memory, and a
reference on the same machine so that results compare across machines as ratios). Prints JSON; nothing here is
asserted by a test except the shape and sanity of the JSON.

Per intruder count N (all in one process pinned to one core, the live loop's parts of avionics/bench.py, the
socket read left out, zenoh on a real loopback session with `--zenoh`, MAVLink only with `--no-zenoh`):

- `latency_us_p50/p99/max`: N intruders at 1 Hz each for `trial_s` seconds through the live loop on the wall
  clock (bench.drive_real_time, as the `real_time` run of `avionics bench`): from a report's arrival to the end
  of the step that sent its outputs, queueing included. The compiled kernels are loaded before the first trial,
  as a running `avionics run` has them (their one load is start-up: `startup_s`).
- `capacity_reports_per_s`: the highest offered load (reports per second, N intruders each reporting at
  rate / N Hz, ownship at 5 Hz) that the live loop sustains for `trial_s` seconds with no growing lag. The 1 Hz
  run above is the first trial; the rate is then doubled until a trial fails (halved until one passes when
  1 Hz already fails) and the bracket bisected until its ends are within 15 % or `max_bisections` trials.
  **No growing lag**, precisely (`sustained`): a report's lag is the time from its arrival to the end of the step
  that processed it; split the trial's reports by arrival time into quarters; the trial passes when
  (a) the 99th percentile of the lag in the last quarter is at most that of the second quarter (the first one
  holds the tracks' start) plus GROWTH_SLACK_S, and (b) the last report was processed within END_LAG_S of its
  arrival. Above capacity the backlog, hence the lag, grows in proportion to time: 2 % over capacity adds
  0.2 s of lag between the second and the last quarter of a 20 s trial, which (a) sees. A trial far over
  capacity is stopped as failed once a report waited more than max(ABORT_LAG_S, half the trial): at a constant
  offered load it could not catch up, and it would otherwise run for minutes.
- `single_report_us_p50`: one report alone through the whole path (framing, decoding, tracking, assessment,
  outputs), each datagram its own step as fast as it goes, N tracks present; reports of the first
  WARMUP_S simulated seconds (track starts) are left out.
- `tracker_update_us_per_track`: the configured tracker (compose.build_tracker, IMM by default) updating N
  established tracks with one report each per ingest_many call, per track, CPU time
  (eval/avionics_eval/tracking_bench.py `bench_tracker`, as docs/tracking.md); `tracker_vs_filterpy` is
  reference_filterpy_imm_step_us over it: how many times faster than filterpy a track update is.
- `resident_memory_mb` / `resident_memory_peak_mb`: VmRSS at the end and VmHWM of a real `avionics run` child
  fed N intruders at 1 Hz over loopback UDP for `trial_s` seconds (the same traffic), read from /proc before it
  is stopped.

Once per run: `startup_s`, the median over `startup_repeats` launches of `avionics run` as a subprocess (warm:
one launch before them fills the byte-code cache, PYTHONPYCACHEPREFIX in the temporary directory when this
environment disables byte code) from Popen to the first datagram it sends back to a sender that offers it an
ownship fix every 2 ms: it answers only a sender it has heard, in the step that decoded that sender's
message, so this is launch to first processed message (zenoh session included with `--zenoh`);
`startup_first_launch_s` is the first, unwarmed launch. `reference_filterpy_imm_step_us`: filterpy's
IMMEstimator predict + update (tracking_bench `bench_filterpy`: two KalmanFilters with the CV and CT models of
docs/tracking.md's filterpy equivalence, 6 states, 4 measured), CPU time per step, best of 5.
"""

from __future__ import annotations

import math
import os
import platform
import signal
import socket
import statistics
import subprocess
import sys
import tempfile
import time

import numpy as np

from avionics import __version__
from avionics.base import jit
from avionics_eval import bench as b
from avionics_eval import tracking_bench

GROWTH_SLACK_S = 0.1
END_LAG_S = 0.5
ABORT_LAG_S = 10.0  # a trial whose lag passes max(this, half the trial) is stopped as failed (it cannot catch up)
BRACKET = 1.15
WARMUP_S = 1.5
MIN_RATE_PER_INTRUDER_HZ = 1.0 / 16  # below this a count is reported as not sustained at all (capacity 0)
SINGLE_SECONDS = 3.0  # simulated seconds of the one-report-alone run
REASSESSMENT_STEP_S = 0.002  # the re-assessment run: a step every 2 ms (as the live loop steps under traffic) ...
REASSESSMENT_S = 2.0  # ... for this long
STARTUP_TIMEOUT_S = 30.0
FILTERPY_STEPS = 400  # tracking_bench.bench_filterpy: best of 5 runs of this many IMMEstimator steps
TRACKER_CYCLES = 10  # tracking_bench.bench_tracker: cycles of one report per track, best of 5


def sustained(run: b.LiveRun, trial_s: float) -> tuple[bool, dict]:
    """The no-growing-lag test of the module docstring, and the numbers it used."""
    if run.aborted:
        return False, {"reason": f"stopped: a report waited more than {max(ABORT_LAG_S, trial_s / 2)} s"}
    lag = run.latencies_s
    q = np.floor(run.arrived_s / (trial_s / 4.0)).clip(0, 3)
    early, late = lag[q == 1], lag[q == 3]
    if not len(early) or not len(late):
        return False, {"reason": "too few reports"}
    p99_early, p99_late = float(np.percentile(early, 99)), float(np.percentile(late, 99))
    end_lag = float(lag[np.argmax(run.arrived_s)])
    ok = p99_late <= p99_early + GROWTH_SLACK_S and end_lag <= END_LAG_S
    return ok, {"lag_p99_second_quarter_s": round(p99_early, 4), "lag_p99_last_quarter_s": round(p99_late, 4),
                "last_report_lag_s": round(end_lag, 4)}


def trial(n: int, rate: float, trial_s: float, zenoh: bool) -> tuple[dict, b.LiveRun]:
    """One trial: N intruders offering `rate` reports per second in total, through the live loop."""
    config, _counters, loop, mavlink, scanner, bus, _sent, events = b._setup(n, trial_s, b._free_port(), zenoh,
                                                                           rate_hz=rate / n)
    try:
        run = b.drive_real_time(loop, mavlink, scanner, events, 1.0 / config.advisory.assessment_hz,
                                abort_lag_s=max(ABORT_LAG_S, trial_s / 2))
    finally:
        b._close(bus)
    ok, why = sustained(run, trial_s)
    return {"offered_reports_per_s": round(rate, 1), "sustained": ok, "cpu_load": round(run.busy_s / run.wall_s, 3),
            "largest_batch": run.largest_batch, **why}, run


def _latency(lat_s: np.ndarray) -> dict:
    us = lat_s * 1e6
    return {"latency_us_p50": round(float(np.percentile(us, 50)), 1),
            "latency_us_p99": round(float(np.percentile(us, 99)), 1),
            "latency_us_max": round(float(us.max()), 1)}


def capacity(n: int, trial_s: float, zenoh: bool, max_bisections: int = 3, max_trials: int = 16, log=None) -> dict:
    """Latency at 1 Hz per intruder, then the capacity search (module docstring). At most max_trials trials: when
    they run out before a failing rate was found, the capacity is a lower bound (`capacity_bracket` [lo, null])."""
    trials = []

    def attempt(rate: float):
        result, run = trial(n, rate, trial_s, zenoh)
        trials.append(result)
        if log:
            log(f"N={n} zenoh={zenoh} {result}")
        return result["sustained"], run

    ok, run = attempt(float(n))  # 1 Hz per intruder: the latency run and the first trial
    out = {"intruders": n, **_latency(run.latencies_s), "sustained_at_1hz": ok}
    lo, hi = (float(n), None) if ok else (None, float(n))
    while (lo is None or hi is None) and len(trials) < max_trials:
        rate = (lo * 2.0) if hi is None else (hi / 2.0)
        if lo is None and rate < n * MIN_RATE_PER_INTRUDER_HZ:
            lo = 0.0
            break
        passed, _ = attempt(rate)
        if passed:
            lo = rate
        else:
            hi = rate
    lo = 0.0 if lo is None else lo
    for _ in range(max_bisections):
        if lo == 0.0 or hi is None or hi / lo <= BRACKET or len(trials) >= max_trials:
            break
        mid = math.sqrt(lo * hi)
        passed, _ = attempt(mid)
        lo, hi = (mid, hi) if passed else (lo, mid)
    out["capacity_reports_per_s"] = round(lo, 1)
    out["capacity_bracket"] = [round(lo, 1), None if hi is None else round(hi, 1)]
    out["trials"] = trials
    return out


def single_report(n: int, zenoh: bool) -> dict:
    """One report alone through the whole path, each datagram its own step (module docstring)."""
    _config, _counters, loop, mavlink, scanner, bus, _sent, events = b._setup(n, SINGLE_SECONDS, b._free_port(),
                                                                              zenoh)
    lat = []
    try:
        for t, data, is_report in events:
            t0 = time.perf_counter()
            loop.last = loop.step(b.Batch(t, mavlink.decode(scanner.feed(data, end_of_datagram=True), t)))
            if is_report and t >= WARMUP_S:
                lat.append(time.perf_counter() - t0)
    finally:
        b._close(bus)
    return {"single_report_us_p50": round(float(np.median(lat)) * 1e6, 1), "single_reports": len(lat)}


def reassessment(n: int, zenoh: bool) -> dict:
    """The re-assessment pass alone (issue 13 items 2 and 3): N tracks established by WARMUP_S of the bench's
    traffic, then no more reports, steps every REASSESSMENT_STEP_S (ownship at 5 Hz) for REASSESSMENT_S: the
    slices of the passes. `reassessment_us_per_intruder` is the CPU time of the steps that re-assessed someone over
    the number of re-assessments (prediction, geometry, TCAS tests, Pc, conflict stage, state, outputs);
    `slice_step_us_p50/p99` those steps' times."""
    _config, _counters, loop, mavlink, scanner, bus, _sent, events = b._setup(n, WARMUP_S + REASSESSMENT_S,
                                                                              b._free_port(), zenoh)
    own = [(t, data) for t, data, is_report in events if not is_report and t >= WARMUP_S]
    steps, assessed = [], []
    try:
        for t, data, _is_report in events:
            if t < WARMUP_S:
                loop.last = loop.step(b.Batch(t, mavlink.decode(scanner.feed(data, end_of_datagram=True), t)))
        for k in range(round(REASSESSMENT_S / REASSESSMENT_STEP_S)):
            t = WARMUP_S + k * REASSESSMENT_STEP_S
            msgs = []
            while own and own[0][0] <= t:
                msgs += scanner.feed(own.pop(0)[1], end_of_datagram=True)
            t0 = time.process_time()
            loop.last = loop.step(b.Batch(t, mavlink.decode(msgs, t)))
            if len(loop.last.assessed):
                steps.append(time.process_time() - t0)
                assessed.append(len(loop.last.assessed))
    finally:
        b._close(bus)
    us = np.array(steps) * 1e6
    return {"reassessment_us_per_intruder": round(float(us.sum() / max(sum(assessed), 1)), 2),
            "slice_step_us_p50": round(float(np.percentile(us, 50)), 1),
            "slice_step_us_p99": round(float(np.percentile(us, 99)), 1),
            "reassessments": int(sum(assessed))}


# --- the real process: start-up and memory ------------------------------------------------------------------


def _child_env() -> dict:
    """A warm byte-code cache even where this environment disables it (PYTHONDONTWRITEBYTECODE), kept out of the
    source tree."""
    env = dict(os.environ)
    if env.pop("PYTHONDONTWRITEBYTECODE", None) and "PYTHONPYCACHEPREFIX" not in env:
        env["PYTHONPYCACHEPREFIX"] = os.path.join(tempfile.gettempdir(), "avionics-bench-pycache")
    return env


def proc_memory_mb(pid: int) -> tuple[float, float]:
    """(VmRSS, VmHWM) of a process in MB, from /proc/PID/status."""
    fields = {}
    with open(f"/proc/{pid}/status") as f:
        for line in f:
            key, _, value = line.partition(":")
            if key in ("VmRSS", "VmHWM"):
                fields[key] = int(value.split()[0]) / 1024.0
    return fields["VmRSS"], fields["VmHWM"]


class Onboard:
    """`avionics run` as a child on loopback (MAVLink udpin on a free port, zenoh on another or off), and a UDP
    socket that talks to it as the autopilot would."""

    def __init__(self, zenoh: bool, duration_s: float = 120.0):
        self.port = b._free_port()
        zen = ["--set", f'zenoh.listen=["tcp/127.0.0.1:{b._free_port()}"]'] if zenoh else ["--no-zenoh"]
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.sock.bind(("127.0.0.1", 0))
        self.sock.setblocking(False)
        self.t0 = time.perf_counter()
        self.proc = subprocess.Popen([sys.executable, "-m", "avionics_eval.cli", "-q", "run", "--connection",
                                      f"udpin:127.0.0.1:{self.port}", "--duration", str(duration_s), "--counters",
                                      *zen], stdout=subprocess.PIPE, stderr=subprocess.PIPE, env=_child_env())

    def first_reply_s(self, fix: bytes) -> float:
        """Seconds from Popen to the first datagram back, offering `fix` every 2 ms."""
        while True:
            try:
                self.sock.recv(65536)
                return time.perf_counter() - self.t0
            except BlockingIOError:
                pass
            if self.proc.poll() is not None:
                raise RuntimeError(f"avionics run exited with {self.proc.returncode}: {self.proc.stderr.read()!r}")
            if time.perf_counter() - self.t0 > STARTUP_TIMEOUT_S:
                raise RuntimeError("avionics run did not answer within 30 s")
            self.sock.sendto(fix, ("127.0.0.1", self.port))
            time.sleep(0.002)

    def memory_mb(self) -> tuple[float, float]:
        """(VmRSS, VmHWM) of the child in MB."""
        rss, hwm = proc_memory_mb(self.proc.pid)
        return round(rss, 1), round(hwm, 1)

    def stop(self) -> dict:
        """SIGTERM (a clean shutdown); its counters."""
        import json

        if self.proc.poll() is None:
            self.proc.send_signal(signal.SIGTERM)
        try:
            out, _ = self.proc.communicate(timeout=30)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            out, _ = self.proc.communicate()
        self.sock.close()
        try:
            return json.loads(out)
        except ValueError:
            return {}


def _ownship_fix() -> bytes:
    """The first GLOBAL_POSITION_INT of the bench traffic."""
    return next(data for t, data, is_report in b._traffic(0, 1.0) if not is_report)


def startup(zenoh: bool, repeats: int) -> dict:
    fix = _ownship_fix()
    launches = []
    for _ in range(repeats + 1):
        onboard = Onboard(zenoh)
        try:
            launches.append(onboard.first_reply_s(fix))
        finally:
            onboard.stop()
    return {"startup_s": round(statistics.median(launches[1:]), 3), "startup_first_launch_s": round(launches[0], 3),
            "startup_launches_s": [round(x, 3) for x in launches[1:]]}


def memory(n: int, trial_s: float, zenoh: bool) -> dict:
    """A real `avionics run` fed N intruders at 1 Hz over loopback for trial_s; its memory at the end."""
    events = b._traffic(n, trial_s)
    onboard = Onboard(zenoh)
    try:
        onboard.first_reply_s(events[0][1])
        start = time.perf_counter()
        for t, data, _ in events:
            delay = t - (time.perf_counter() - start)
            if delay > 0:
                time.sleep(delay)
            onboard.sock.sendto(data, ("127.0.0.1", onboard.port))
        time.sleep(0.5)
        rss, peak = onboard.memory_mb()
    finally:
        counters = onboard.stop()
    return {"resident_memory_mb": rss, "resident_memory_peak_mb": peak,
            "memory_run_reports_received": counters.get("rx.adsb_vehicle", 0)}


def capacity_bench(intruder_counts: list[int], trial_s: float = 20.0, zenoh: bool = True,
                   startup_repeats: int = 5, max_bisections: int = 3, max_trials: int = 16, log=None) -> dict:
    """The whole instrument (module docstring), pinned to one core (bench.one_core); children inherit the pin."""
    with b.one_core() as pinned:
        # The compiled kernels load once per process (`avionics run` loads them in the background after its first
        # step; start-up is `startup_s`): loaded here, so that the first trial's latencies are not that one load.
        jit.load()
        reference = tracking_bench.bench_filterpy(FILTERPY_STEPS)
        out = {
            "benchmark": "avionics bench --capacity (issue 13)",
            "version": __version__, "python": platform.python_version(), "machine": platform.machine(),
            "numpy": np.__version__, "pinned_to_one_core": pinned, "zenoh": zenoh, "trial_s": trial_s,
            "load_average_at_start": [round(x, 2) for x in os.getloadavg()],
            "sustained_means": f"lag p99 of the last quarter <= second quarter + {GROWTH_SLACK_S} s and the last "
                               f"report processed within {END_LAG_S} s",
            "reference_filterpy_imm_step_us": round(reference, 1),
            **startup(zenoh, startup_repeats),
            "counts": [],
        }
        for n in intruder_counts:
            row = capacity(n, trial_s, zenoh, max_bisections, max_trials, log)
            row.update(single_report(n, zenoh))
            row.update(reassessment(n, zenoh))
            per_track = tracking_bench.bench_tracker(n, TRACKER_CYCLES)
            row["tracker_update_us_per_track"] = round(per_track, 2)
            row["tracker_vs_filterpy"] = round(reference / per_track, 1)
            row.update(memory(n, trial_s, zenoh))
            out["counts"].append(row)
            if log:
                log(f"N={n} done: {row}")
        out["load_average_at_end"] = [round(x, 2) for x in os.getloadavg()]
        return out
