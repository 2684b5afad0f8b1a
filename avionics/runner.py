"""`avionics run`: the live shell around DaaNode. Owns the clock, the MAVLink link and the zenoh session."""

from __future__ import annotations

import logging
import math
import signal
import threading
import time
from collections import Counter

from avionics.config import Config
from avionics.core.types import AdvisoryLevel
from avionics.io.encode import advisory_text
from avionics.io.link import MavlinkLink
from avionics.node import DaaNode

log = logging.getLogger("avionics")


class Runner:
    def __init__(self, config: Config, tlog_out: str | None = None, bus=None):
        self.config = config
        self.counters: Counter = Counter()
        self.node = DaaNode(config, self.counters)
        cfg = config.mavlink
        self.link = MavlinkLink(cfg.connection, self.counters, cfg.source_system, cfg.source_component,
                                baud=cfg.baud, tlog_out=tlog_out)
        self.bus = bus
        if self.bus is None and config.zenoh.enabled:
            from avionics.io.zenoh_bus import ZenohBus

            self.bus = ZenohBus(config.zenoh, config.vehicle.id, counters=self.counters)  # queued, never blocks
        self.stop = threading.Event()

    def _flush(self) -> None:
        for msg in self.node.mavlink_out:
            self.link.send(msg)
        self.node.mavlink_out.clear()
        if self.bus is not None:
            for suffix, payload in self.node.zenoh_out:
                self.bus.publish(suffix, payload)
        self.node.zenoh_out.clear()

    def run(self, duration_s: float | None = None) -> None:
        tick = 1.0 / self.config.advisory.assessment_hz
        start = time.monotonic()
        log_t0 = None
        end = math.inf if duration_s is None else duration_s
        now = 0.0
        while not self.stop.is_set() and now < end:
            if self.link.is_log:
                msgs = self.link.receive(0.0)
                if not msgs:
                    break  # end of the log
                stamp = getattr(msgs[0], "_timestamp", 0.0)
                log_t0 = stamp if log_t0 is None else log_t0
                now = stamp - log_t0
            else:
                msgs = self.link.receive(tick)
                now = time.monotonic() - start
            result = self.node.handle(msgs, now)
            for advisory in result.changes:
                level = logging.WARNING if advisory.level is not AdvisoryLevel.NONE else logging.INFO
                log.log(level, "t=%7.2f %s", now, advisory_text(advisory))
            self._flush()

    def close(self) -> None:
        self.link.close()
        if self.bus is not None:
            self.bus.close()


def run(config: Config, duration_s: float | None = None, tlog_out: str | None = None) -> Counter:
    runner = Runner(config, tlog_out=tlog_out)
    previous = signal.getsignal(signal.SIGTERM)
    if threading.current_thread() is threading.main_thread():
        signal.signal(signal.SIGTERM, lambda *_: runner.stop.set())
    try:
        runner.run(duration_s)
    except KeyboardInterrupt:
        pass
    finally:
        runner.close()
        if threading.current_thread() is threading.main_thread():
            signal.signal(signal.SIGTERM, previous)
    return runner.counters
