"""Fault containment (issue 11, deliverable 3): an exception or a non-finite number while processing one intruder
fails that intruder alone, at the stage boundary: counted `fault.<stage>`, logged once with its traceback, its
advisory ends in the failed state (level NONE, reason `fault`), announced once on MAVLink and zenoh, and the
other intruders go on alerting. A step that fails outside those boundaries ends every advisory with reason
`fault` and the next steps go on. A .tlog with corrupted timestamps does not crash `avionics run`.

The core tests drive DaaCore with straight-line encounters; the live ones run `avionics run` (in-process, for
the injected fault; a child process for the .tlog) over real UDP sockets, pymavlink framing and zenoh."""

import json
import logging
import math
import subprocess
import sys
import threading
from collections import Counter

import numpy as np
import pytest

import avionics.io  # noqa: F401
from avionics.config import ZenohConfig, load_config
from avionics.base.types import AddressSource, AdvisoryLevel, AltitudeDatum, IntruderKey, IntruderReport, OwnshipFix
from avionics.base.types import OwnshipPressure
from avionics.base.units import FT, KT, NM
from avionics.io.zenoh_bus import open_session
from avionics.pipeline.daa_core import DaaCore
from avionics.runner import Runner
from synthetic import PLANE, Mover
from tests.conftest import DEADLINE_S, free_port, wait_for
from tests.test_failsafe import Autopilot, head_on_events

ALT = 3000 * FT
V = 125 * KT
A = IntruderKey(0xA00001, AddressSource.ES1090)
B = IntruderKey(0xB00002, AddressSource.ES1090)


def two_intruders(core: DaaCore, until_s: float, on_step=None, b_offset_m: float = 300.0):
    """Ownship north at V; A and B head-on from 6 NM, B 300 m to the east: both alert (TA, then RA). Ownship
    5 Hz, reports 1 Hz, steps at 0.1 s; returns [(t, advisory)] of every change."""
    own = Mover((0, 0, ALT), (0, V, 0))
    movers = {A: Mover((0, 6 * NM, ALT), (0, -V, 0)), B: Mover((b_offset_m, 6 * NM, ALT), (0, -V, 0))}
    changes = []
    for k in range(int(round(until_s * 10)) + 1):
        t = round(k * 0.1, 6)
        if on_step is not None:
            on_step(t)
        inputs = []
        if abs(t * 5 - round(t * 5)) < 1e-6:
            e, n, alt = own.at(t)
            lat, lon = PLANE.to_geodetic(e, n)
            inputs += [OwnshipFix(t, float(lat), float(lon), alt, alt, (V, 0.0, 0.0)), OwnshipPressure(t, alt)]
        if abs(t - round(t)) < 1e-6:
            for key, mover in movers.items():
                e, n, alt = mover.at(t)
                lat, lon = PLANE.to_geodetic(e, n)
                inputs.append(IntruderReport(key, t, t, float(lat), float(lon), alt, AltitudeDatum.PRESSURE,
                                             mover.v[:2], 0.0))
        changes += [(t, c) for c in core.step(t, inputs).changes]
    return changes


def levels_of(changes, key):
    out = []
    for t, c in changes:
        if c.intruder == key and (not out or out[-1][1] != (c.level, c.reason == "fault")):
            out.append((t, (c.level, c.reason == "fault")))
    return [lvl for _, lvl in out]


TA, RA, NONE = AdvisoryLevel.TA, AdvisoryLevel.RA, AdvisoryLevel.NONE
FAIL_AFTER_S = 58.0  # both intruders are TA by then (TA ~55 s, RA ~65 s in this geometry)


def _raise_for_b_after(now):
    return lambda keys: now[0] > FAIL_AFTER_S and B in keys


# stage -> (the object and method the stage calls, how to find the intruder keys among its arguments)
_STAGE_CALLS = {
    "track": (lambda core: core.tracker, "ingest_many", lambda args: [r.key for r in args[0]]),
    "predict": (lambda core: core.tracker, "predict", lambda args: args[0]),
    "conflict": (lambda core: core.conflict, "within_age", lambda args: args[1]),
    "advisory": (lambda core: core.gate, "persist", lambda args: args[0]),
}


def _inject(core: DaaCore, stage: str, now: list):
    """Make `stage` raise numpy's LinAlgError whenever B is among the intruders it is called for (after
    FAIL_AFTER_S), as a singular covariance does inside the vectorised filters."""
    hit = _raise_for_b_after(now)
    boom = np.linalg.LinAlgError("injected: matrix is not positive definite")
    owner_of, name, keys_of = _STAGE_CALLS[stage]
    owner = owner_of(core)
    real = getattr(owner, name)

    def failing(*args):
        if hit(keys_of(args)):
            raise boom
        return real(*args)
    setattr(owner, name, failing)


@pytest.mark.parametrize("stage", ["track", "predict", "conflict", "advisory"])
def test_an_exception_for_one_intruder_fails_it_alone_and_the_other_goes_on(stage, caplog):
    core = DaaCore(load_config())
    now = [0.0]
    _inject(core, stage, now)
    with caplog.at_level(logging.WARNING, logger="avionics.pipeline"):
        changes = two_intruders(core, 110.0, on_step=lambda t: now.__setitem__(0, t))
    a, b = levels_of(changes, A), levels_of(changes, B)
    # A: the whole encounter as if B were not failing; it is the RA threat after B failed
    assert a[:2] == [(TA, False), (RA, False)] and a[-1] == (NONE, False), a
    assert [t for t, c in changes if c.intruder == A and c.level is RA][0] > FAIL_AFTER_S
    # B: alerting, then its failed state, announced once although it fails at each of its reports
    assert b == [(TA, False), (NONE, True)], b
    failed = [c for _, c in changes if c.intruder == B and c.reason == "fault"]
    assert len(failed) == 1 and failed[0].time_s > FAIL_AFTER_S
    assert math.isfinite(failed[0].range_m)  # the failed advisory keeps B's last geometry
    assert core.counters[f"fault.{stage}"] > 10  # every report of B after FAIL_AFTER_S fails again, counted
    assert B in core.faults and core.faults[B].stage == stage and A not in core.faults
    assert B not in core.tracker.tracks or core.tracker.tracks[B].n_updates <= 1  # its track was dropped
    errors = [r for r in caplog.records if r.levelno == logging.ERROR and "failed in the" in r.getMessage()]
    assert len(errors) == 1 and str(B) in errors[0].getMessage() and errors[0].exc_info is not None
    assert "LinAlgError" in errors[0].getMessage()


def test_a_non_finite_state_in_one_track_fails_that_track_alone():
    """B's filter state becomes NaN (as from a corrupted covariance): the vectorised bank update of the next
    batch raises LinAlgError for every intruder in it; retried per intruder, only B fails."""
    core = DaaCore(load_config())

    def corrupt(t):
        if abs(t - FAIL_AFTER_S) < 1e-6:
            slot = core.tracker.tracks[B].slot
            core.tracker.adsb.bank_h.x[slot] = np.nan
            core.tracker.adsb.bank_h.p[slot] = np.nan
    changes = two_intruders(core, 110.0, on_step=corrupt)
    a, b = levels_of(changes, A), levels_of(changes, B)
    assert a[:2] == [(TA, False), (RA, False)], a
    assert b[:2] == [(TA, False), (NONE, True)], b
    assert core.counters["fault.track.batch"] + core.counters["fault.predict"] >= 1
    # B's next reports start a new, healthy track: it is assessed again and alerts again
    assert core.counters["fault.recovered"] == 1 and B not in core.faults
    assert (RA, False) in b[2:] or (TA, False) in b[2:]


def test_non_finite_input_is_rejected_and_counted_not_tracked():
    core = DaaCore(load_config())
    lat, lon = PLANE.to_geodetic(0.0, 1000.0)
    core.step(0.0, [OwnshipFix(0.0, 47.0, 8.0, ALT, ALT, (0.0, 0.0, 0.0))])
    bad = [IntruderReport(A, 0.1, 0.1, float(lat), float(lon), ALT, AltitudeDatum.PRESSURE, (math.nan, 0.0), 0.0),
           IntruderReport(B, math.inf, 0.1, float(lat), float(lon), ALT, AltitudeDatum.PRESSURE, None, None),
           OwnshipFix(0.2, math.nan, 8.0, ALT, ALT, (0.0, 0.0, 0.0))]
    core.step(0.2, bad)
    assert core.counters["input.non_finite"] == 3 and not core.tracker.tracks and not core.faults


def test_a_failed_step_ends_every_advisory_with_reason_fault_and_the_next_steps_go_on(caplog):
    """Outside the per-intruder boundaries (here the sensitivity-level selection, shared by all): the step
    fails, every active advisory ends with reason fault (announced once), DAA stays down while it keeps
    failing, and alerting resumes once the steps go through again."""
    core = DaaCore(load_config())
    real = core.levels.select
    window = (FAIL_AFTER_S, FAIL_AFTER_S + 3.0)
    now = [0.0]

    def select(*args):
        if window[0] < now[0] < window[1]:
            raise ZeroDivisionError("injected")
        return real(*args)
    core.levels.select = select
    with caplog.at_level(logging.WARNING, logger="avionics.pipeline"):
        changes = two_intruders(core, 110.0, on_step=lambda t: now.__setitem__(0, t))
    for key in (A, B):
        seq = levels_of(changes, key)
        assert seq[:2] == [(TA, False), (NONE, True)] and (RA, False) in seq[2:], seq
    assert core.counters["fault.step"] == 29 and core.step_fault is None
    errors = [r for r in caplog.records if r.levelno == logging.ERROR]
    assert len(errors) == 1 and errors[0].exc_info is not None and "step failed" in errors[0].getMessage()


def test_a_failing_ownship_filter_restarts_and_ownship_is_unknown_until_the_next_fix(monkeypatch, caplog):
    from avionics.tracking.ownship import OwnshipFilter

    real = OwnshipFilter.update_fix

    def update_fix(self, fix, east, north):
        if FAIL_AFTER_S <= fix.time_s <= FAIL_AFTER_S + 0.2:
            raise np.linalg.LinAlgError("injected: singular innovation covariance")
        return real(self, fix, east, north)
    monkeypatch.setattr(OwnshipFilter, "update_fix", update_fix)
    core = DaaCore(load_config())
    with caplog.at_level(logging.WARNING, logger="avionics.pipeline"):
        changes = two_intruders(core, 80.0)
    for key in (A, B):
        ends = [(t, c.reason) for t, c in changes if c.intruder == key and c.level is NONE]
        assert ends[0] == (FAIL_AFTER_S, "no_ownship"), ends
        assert (RA, False) in levels_of([(t, c) for t, c in changes if t > FAIL_AFTER_S], key)
    assert core.counters["fault.ownship"] == 2 and not core.faults and core.step_fault is None
    errors = [r for r in caplog.records if r.levelno == logging.ERROR]
    assert len(errors) == 1 and errors[0].exc_info is not None  # once, with the traceback


# -- live: `avionics run` over UDP and zenoh ------------------------------------------------------------------

FAILING = 0xA10002  # a second head-on intruder, on A10001's track: its prediction raises in every step


@pytest.mark.live
def test_live_an_injected_fault_in_one_intruder_is_announced_and_the_other_gets_its_ra(monkeypatch):
    """`avionics run` (in this process, so that one stage can be patched) on a real UDP socket with zenoh:
    the prediction raises whenever intruder A10002 is among the intruders. A10001 gets its TA and RA on
    MAVLink and zenoh; A10002 is announced once as failed (DAA_ADVISORY level 0, STATUSTEXT "DAA UNAVAILABLE
    ... (fault)" at WARNING, zenoh reason fault), HEARTBEAT goes MAV_STATE_CRITICAL, status names it."""
    from avionics.io.dialect import daa as m2
    from avionics.tracking.imm_tracker import ImmTracker

    real = ImmTracker.predict

    def predict(self, keys, t_s):
        if any(k.address == FAILING for k in keys):
            raise np.linalg.LinAlgError("injected: matrix is not positive definite")
        return real(self, keys, t_s)
    monkeypatch.setattr(ImmTracker, "predict", predict)

    udp, tcp = free_port(__import__("socket").SOCK_DGRAM), free_port()
    endpoint = f"tcp/127.0.0.1:{tcp}"
    config = load_config(overrides=[f'mavlink.connection="udpin:127.0.0.1:{udp}"', f'zenoh.listen=["{endpoint}"]',
                                    "vehicle.id=faultuav"])
    runner = Runner(config)
    worker = threading.Thread(target=runner.run, daemon=True)
    worker.start()
    session = open_session(ZenohConfig(listen=(), connect=(endpoint,)))
    got, lock = [], threading.Lock()

    def on_sample(sample):
        with lock:
            got.append((str(sample.key_expr), json.loads(sample.payload.to_bytes())))
    subs = [session.declare_subscriber("daa/faultuav/advisories/*", on_sample),
            session.declare_subscriber("daa/faultuav/status", on_sample)]
    autopilot = Autopilot(f"udpout:127.0.0.1:{udp}", head_on_events(start_s=56.0, extra_icao=FAILING))
    try:
        autopilot.start()
        assert wait_for(lambda: any(m.get_type() == "COLLISION" and m.id == 0xA10001 and
                                    m.threat_level == m2.MAV_COLLISION_THREAT_LEVEL_HIGH for m in autopilot.messages()))
        assert wait_for(lambda: any(p.get("failed_intruders") and p["advisories"]["RA"] == 1
                                    for k, p in list(got) if k.endswith("/status")))
    finally:
        autopilot.stop()
        for sub in subs:
            sub.undeclare()
        runner.stop.set()
        worker.join(DEADLINE_S)
        runner.close()
        session.close()

    msgs = autopilot.messages()
    failed_daa = [m for m in msgs if m.get_type() == "DAA_ADVISORY" and m.id == FAILING]
    assert failed_daa and {m.level for m in failed_daa} == {0}  # never alerting: it never got an assessment
    texts = [(m.severity, m.text) for m in msgs if m.get_type() == "STATUSTEXT"]
    assert (m2.MAV_SEVERITY_WARNING, "DAA UNAVAILABLE 1090es-A10002 (fault)") in texts, texts
    assert (m2.MAV_SEVERITY_WARNING, "DAA UNAVAILABLE fault predict 1090es-A10002") in texts, texts
    assert sum(t == "DAA UNAVAILABLE 1090es-A10002 (fault)" for _, t in texts) == 1  # announced once
    assert any(t.startswith("RA ") and t.endswith("HEADON") for _, t in texts)  # A10001 alerts on
    assert m2.MAV_STATE_CRITICAL in {m.system_status for m in msgs if m.get_type() == "HEARTBEAT"}
    with lock:
        advisories = [p for k, p in got if "/advisories/" in k]
        status = [p for k, p in got if k.endswith("/status") and p["advisories"]["RA"] == 1][-1]
    assert [(p["level"], p["reason"]) for p in advisories if p["intruder"] == "1090es-A10002"] == [("NONE", "fault")]
    assert "RA" in [p["level"] for p in advisories if p["intruder"] == "1090es-A10001"]
    assert status["daa_available"] is False and status["unavailable_reason"] == "fault"
    assert status["failed_intruders"] == {"1090es-A10002": "predict"}
    assert status["counters"]["fault.predict"] >= 1 and status["advisories"]["RA"] == 1


@pytest.mark.live
def test_a_tlog_with_corrupted_timestamps_runs_through_the_cli(tmp_path):
    """Non-finite-like (2^64 - 1 us), zero, far-backwards and far-ahead stamps in a recorded head-on: `avionics
    run --connection FILE.tlog` exits 0, counts them as bad input and still gives the TA and the RA."""
    from avionics_sitl.autopilot import Packer, schedule
    from avionics_sitl.impairments import PRESETS
    from avionics_sitl.encounters import load_encounter

    path = tmp_path / "corrupted.tlog"
    base_us = 1_700_000_000 * 10**6  # a plausible UNIX time
    corrupt = {0: 2**64 - 1, 5: 0, 120: base_us - 3600 * 10**6, 300: base_us + 10**15, 301: 2**63,
               302: base_us + 40 * 10**6 + 10**13}
    packer = Packer()
    with open(path, "wb") as fh:
        for i, event in enumerate(schedule(load_encounter("head-on"), PRESETS["none"], duration_s=100.0)):
            stamp = corrupt.get(i, base_us + int(event.deliver_s * 1e6))
            fh.write(stamp.to_bytes(8, "big") + packer.pack(event.msg))
    out = subprocess.run([sys.executable, "-m", "avionics.cli", "run", "--connection", str(path), "--no-zenoh",
                          "--counters"], capture_output=True, text=True, timeout=3 * DEADLINE_S)
    assert out.returncode == 0, out.stderr
    counters = Counter(json.loads(out.stdout[out.stdout.index("{"):]))
    assert counters["tlog.bad_timestamp"] >= len(corrupt) - 1, counters
    assert " TA " in out.stderr and "RA " in out.stderr, out.stderr
    assert "Traceback" not in out.stderr
    assert not any(k.startswith("fault.") for k in counters), counters
