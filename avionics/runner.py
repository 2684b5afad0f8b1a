"""`avionics run`: the live shell around DaaNode. Owns the clock, the MAVLink link and the zenoh session.

Shutdown (SIGTERM, SIGINT, --duration, end of a log): the loop ends at its next tick, every active advisory is
sent as NONE with reason `shutdown` on MAVLink and zenoh, with "DAA UNAVAILABLE shutdown" and a last HEARTBEAT
(MAV_STATE_POWEROFF); the zenoh queues are flushed, then the liveliness token is withdrawn; exit code 0. A
second SIGINT while that runs stops it at once (KeyboardInterrupt).
"""

from __future__ import annotations

import logging
import math
import signal
import threading
import time
from collections import Counter

from avionics import __version__
from avionics.config import Config
from avionics.core.types import AdvisoryLevel
from avionics.io.encode import UNAVAILABLE_REASONS, advisory_text
from avionics.io.link import MavlinkLink
from avionics.node import DaaNode

log = logging.getLogger("avionics")
SHUTDOWN_FLUSH_S = 5.0  # how long the last zenoh samples (the shutdown NONEs first) may take to go out


class Runner:
    def __init__(self, config: Config, tlog_out: str | None = None, bus=None, stop: threading.Event | None = None):
        self.config = config
        self.stop = stop if stop is not None else threading.Event()
        self.now = 0.0  # the loop's last time (log time when replaying)
        self.counters: Counter = Counter()
        self.node = DaaNode(config, self.counters)
        cfg = config.mavlink
        self.link = MavlinkLink(cfg.connection, self.counters, cfg.source_system, cfg.source_component,
                                baud=cfg.baud, tlog_out=tlog_out, signing_key_file=cfg.signing_key_file,
                                signing_required=cfg.signing_required)
        self.bus = bus
        if self.bus is None and config.zenoh.enabled:
            from avionics.io.zenoh_bus import ZenohBus

            self.bus = ZenohBus(config.zenoh, config.vehicle.id, counters=self.counters)  # queued, never blocks

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
            self.now = now
            result = self.node.handle(msgs, now)
            self._log_changes(result.changes, now)
            self._flush()

    @staticmethod
    def _log_changes(changes, now: float) -> None:
        for advisory in changes:
            alert = advisory.level is not AdvisoryLevel.NONE or advisory.reason in UNAVAILABLE_REASONS
            log.log(logging.WARNING if alert else logging.INFO, "t=%7.2f %s", now, advisory_text(advisory))

    def shutdown(self) -> None:
        """The last outputs: every active advisory as NONE (reason shutdown), DAA unavailable; sent now."""
        ended = self.node.shutdown(self.now)
        self._log_changes(ended, self.now)
        self._flush()

    def close(self) -> None:
        try:
            self.link.close()
        finally:
            if self.bus is not None:
                self.bus.close(flush_timeout_s=SHUTDOWN_FLUSH_S)  # the last samples, then the token goes


def run(config: Config, duration_s: float | None = None, tlog_out: str | None = None) -> Counter:
    """Run until SIGTERM/SIGINT, duration_s or the end of a log; then shut down cleanly (module docstring)."""
    stop = threading.Event()
    signals: list[int] = []

    def on_signal(signum, _frame):  # no logging here: it may interrupt a logging call on this thread
        if stop.is_set() and signum == signal.SIGINT:
            raise KeyboardInterrupt  # a second Ctrl-C: do not wait for the shutdown
        signals.append(signum)
        stop.set()

    main = threading.current_thread() is threading.main_thread()
    previous = {}
    if main:  # installed before the link and zenoh open: a signal during start-up stops cleanly too
        for signum in (signal.SIGTERM, signal.SIGINT):
            previous[signum] = signal.signal(signum, on_signal)
    try:
        runner = Runner(config, tlog_out=tlog_out, stop=stop)
        # after the link and the zenoh session opened: a start-up error is the only line printed
        log.info("avionics %s: MAVLink %s, zenoh %s, vehicle %s", __version__, config.mavlink.connection,
                 list(config.zenoh.listen) if config.zenoh.enabled else "off", config.vehicle.id)
        try:
            runner.run(duration_s)
        except KeyboardInterrupt:
            pass
        finally:
            if signals:
                log.info("%s: stopping", signal.Signals(signals[0]).name)
            try:
                runner.shutdown()
            except KeyboardInterrupt:
                pass
            except Exception:  # noqa: BLE001  (a broken state must not keep the token and the link open)
                log.exception("shutdown messages could not all be sent")
            finally:
                runner.close()
    finally:
        for signum, handler in previous.items():
            signal.signal(signum, handler)
    return runner.counters
