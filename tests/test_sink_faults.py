"""Every output sink fails alone (issue 25, item 1): a record (--tlog-out), the advisory CSV (--csv), the zenoh
publication or the MAVLink endpoint that cannot be written (a full disk, EIO, a dead serial port) is counted
`sink.<name>.errors`, announced once (stderr, STATUSTEXT, zenoh status `output_faults`), closed (files) or retried
(links), and the DAA goes on. The live test runs `avionics run` as a child process on loopback, its two output
files on /dev/full (every write fails with ENOSPC, as on a full SD card), during the head-on."""

import os
import pty
import signal
from collections import Counter

import pytest
import zenoh

import avionics.io  # noqa: F401
from avionics.config import ZenohConfig
from avionics.io.dialect import daa as m2
from avionics.io.encode import heartbeat
from avionics.io.link import MavlinkLink
from avionics.io.sinks import FileSink, SinkHealth
from avionics.io.zenoh_bus import ZenohBus
from tests.conftest import DEADLINE_S, wait_for
from tests.test_failsafe import HEAD_ON, Autopilot, Onboard, head_on_events

FULL = "/dev/full"  # Linux: every write fails with ENOSPC (null(4))


def _levels(autopilot) -> list[int]:
    return [m.threat_level for m in autopilot.messages("COLLISION") if m.id == HEAD_ON]


@pytest.mark.live
@pytest.mark.skipif(not os.path.exists(FULL), reason="needs /dev/full")
def test_a_full_disk_under_tlog_and_csv_costs_neither_the_ta_nor_the_ra_is_announced_and_the_stop_exits_0():
    onboard = Onboard("fulluav", args=("--tlog-out", FULL, "--csv", FULL))
    autopilot = None
    try:
        assert wait_for(lambda: zenoh.SampleKind.PUT in onboard.liveliness())
        # from 46 s: TA ~55 s, RA ~65.3 s, CPA 86.4 s (tests/test_integration_live.py)
        autopilot = Autopilot(f"udpout:127.0.0.1:{onboard.udp}", head_on_events(start_s=46.0))
        autopilot.start()
        # (today's code: the record's first failed flush ended the loop, exit 70, before the TA)
        wait_for(lambda: m2.MAV_COLLISION_THREAT_LEVEL_HIGH in _levels(autopilot) or onboard.process.poll() is not None,
                 DEADLINE_S + 20)
        assert m2.MAV_COLLISION_THREAT_LEVEL_HIGH in _levels(autopilot), f"exit code {onboard.process.poll()}"
        assert wait_for(lambda: any(set(s.get("output_faults", {})) == {"tlog", "csv"}
                                    for s in onboard.of("status")))
        assert wait_for(lambda: sum("OUTPUT" in m.text for m in autopilot.messages("STATUSTEXT")) >= 2)
        onboard.process.send_signal(signal.SIGTERM)
        assert onboard.process.wait(DEADLINE_S) == 0
    finally:
        if autopilot is not None:
            autopilot.stop()
        code, err = onboard.close()
    assert code == 0 and "Traceback" not in err, err

    # TA then RA, on time: the advisories' own times to CPA are the head-on's (TA ~31 s, RA ~21 s before CPA)
    collisions = [m for m in autopilot.messages("COLLISION") if m.id == HEAD_ON]
    ta = next(m for m in collisions if m.threat_level == m2.MAV_COLLISION_THREAT_LEVEL_LOW)
    ra = next(m for m in collisions if m.threat_level == m2.MAV_COLLISION_THREAT_LEVEL_HIGH)
    assert collisions.index(ta) < collisions.index(ra)
    assert 25 < ta.time_to_minimum_delta < 38 and 15 < ra.time_to_minimum_delta < 25, (ta, ra)
    # announced once each: STATUSTEXT (WARNING), a line on stderr, the zenoh status with its counters
    texts = [(m.severity, m.text) for m in autopilot.messages("STATUSTEXT") if m.text.startswith("OUTPUT")]
    assert sorted(texts) == [(m2.MAV_SEVERITY_WARNING, "OUTPUT CSV FAILED (ENOSPC): CLOSED"),
                             (m2.MAV_SEVERITY_WARNING, "OUTPUT TLOG FAILED (ENOSPC): CLOSED")], texts
    assert err.count("output tlog failed") == 1 and err.count("output csv failed") == 1, err
    status = onboard.of("status")[-1]
    assert status["output_faults"]["tlog"]["state"] == "closed"
    assert status["output_faults"]["tlog"]["error"].startswith("ENOSPC")
    assert status["counters"]["sink.tlog.errors"] == 1 and status["counters"]["sink.tlog.dropped"] > 0
    assert status["counters"]["sink.csv.errors"] == 1
    assert any("output tlog failed" in w for w in status["warnings"])
    assert status["daa_available"] is False  # the last one: shutdown; DAA stayed available while the sinks failed
    assert all(s["daa_available"] for s in onboard.of("status")[:-1] if s.get("output_faults"))


def test_a_file_sink_closes_at_its_first_error_counts_what_it_refuses_and_never_raises():
    counters = Counter()
    health = SinkHealth(counters)
    sink = FileSink("csv", FULL, "w", health, newline="")
    sink.write("time_s,intruder\n")  # buffered: the disk is not asked yet
    sink.flush()  # ENOSPC here: closed
    sink.write("1.00,A\n")
    sink.flush()
    sink.close()
    assert sink.closed and counters == Counter({"sink.csv.errors": 1, "sink.csv.dropped": 1})
    assert health.as_dict() == {"csv": {"state": "closed", "error": "ENOSPC No space left on device", "errors": 1}}


def test_a_dead_serial_port_is_a_counted_announced_mavlink_sink_fault_and_the_link_goes_on():
    """A USB serial adapter unplugged: the pseudo-terminal's other end closes, writes fail with EIO; pymavlink
    returns -1 from mavserial.write() (and tries to reopen the port), which no one counted."""
    master, slave = pty.openpty()
    counters = Counter()
    link = MavlinkLink(os.ttyname(slave), counters, 1, 191)
    try:
        link.send(heartbeat())
        assert os.read(master, 280)[:1] == b"\xfd"  # the port works
        os.close(master)
        for _ in range(3):
            link.send(heartbeat())
    finally:
        link.close()
        os.close(slave)
    assert counters["sink.mavlink.errors"] == 3
    fault = link.sinks.faults["mavlink"]
    assert (fault.code, fault.state, fault.errors) == ("EIO", "retrying", 3)


def test_failed_zenoh_puts_are_counted_and_announced_on_the_loop_thread():
    counters = Counter()
    health = SinkHealth(counters)
    bus = ZenohBus(ZenohConfig(listen=(), connect=()), "sinkuav", counters=counters, sinks=health)
    try:
        bus.session.close()  # every put of the publisher thread fails from now on
        for i in range(3):
            bus.publish("status", {"time_s": float(i)})
            assert wait_for(lambda: bus.stats["put_errors"] > i)
        bus.publish("status", {"time_s": 3.0})  # reports what failed so far (the loop's thread owns counters)
    finally:
        bus.close(flush_timeout_s=DEADLINE_S)
    assert counters["sink.zenoh.errors"] >= 3 and health.faults["zenoh"].state == "retrying"
