"""`avionics run`: the live shell around the DAA facade. Owns the clock, the MAVLink link and the zenoh session.

Shutdown (SIGTERM, SIGINT, --duration, end of a log): the loop ends at its next tick, every active advisory is
sent as NONE with reason `shutdown` on MAVLink and zenoh, with "DAA UNAVAILABLE shutdown" and a last HEARTBEAT
(MAV_STATE_POWEROFF); the zenoh queues are flushed, then the liveliness token is withdrawn; exit code 0. A
second SIGINT while that runs stops it at once (KeyboardInterrupt).
"""

from __future__ import annotations

import logging
import signal
import threading
import time
from collections import Counter

from avionics import __version__
from avionics.advisory.inhibits import profile_banner
from avionics.advisory.vehicle import response_banner
from avionics.config import Config
from avionics.base import jit
from avionics.base.kernel_startup import KernelStartup
from avionics.base.params import ConfigError
from avionics.daa import Daa
from avionics.io.diagnostics import wiring_diagnostics
from avionics.io.feeds.source import FeedSet, TrafficSource
from avionics.io.link import MavlinkLink
from avionics.io.sinks import FileSink, SinkHealth
from avionics.loop import LinkSource, Loop, MavlinkInput
from avionics.ports import AdvisoryAnnouncements, CsvOut, LogOut, MavlinkOut, ZenohOut

log = logging.getLogger("avionics")
SHUTDOWN_FLUSH_S = 5.0  # how long the last zenoh samples (the shutdown NONEs first) may take to go out


class Runner:
    """The live loop's parts: the link (source and MAVLink port), the zenoh session (port), the log (port)."""

    def __init__(self, config: Config, tlog_out: str | None = None, bus=None, stop: threading.Event | None = None,
                 duration_s: float | None = None, csv_out: str | None = None, traffic: tuple[str, ...] = ()):
        """traffic: --traffic SPECs, receiver feeds beside the link (avionics/io/feeds/, docs/traffic-inputs.md)."""
        self.config = config
        self.stop = stop if stop is not None else threading.Event()
        self.counters: Counter = Counter()
        self.sinks = SinkHealth(self.counters)  # the outputs that fail alone (avionics/io/sinks.py)
        self.kernels = KernelStartup()  # which path the kernels take in run() (reference, then compiled)
        start_s = time.monotonic()  # the loop's time 0: the link's batches and the feeds' reports share it
        self.feeds = FeedSet.open(traffic, config, lambda: time.monotonic() - start_s, self.counters)
        cfg = config.mavlink
        self.link = MavlinkLink(cfg.connection, self.counters, cfg.source_system, cfg.source_component,
                                baud=cfg.baud, tlog_out=tlog_out, signing_key_file=cfg.signing_key_file,
                                signing_required=cfg.signing_required, sinks=self.sinks,
                                tcpin_idle_timeout_s=cfg.tcpin_idle_timeout_s)
        self.bus = bus
        if self.bus is None and config.zenoh.enabled:
            from avionics.io.zenoh_bus import ZenohBus

            # queued, never blocks
            self.bus = ZenohBus(config.zenoh, config.vehicle.id, counters=self.counters, sinks=self.sinks)
        advisories = AdvisoryAnnouncements.of(config)  # one refresh clock and callsign memory for both ports
        ports = [MavlinkOut(self.link.send, config, send_as=self.link.send_as, sinks=self.sinks,
                            advisories=advisories), LogOut(log)]
        if self.bus is not None:
            ports.append(ZenohOut(self.bus.publish, config, sinks=self.sinks, advisories=advisories))
        self._csv = FileSink("csv", csv_out, "w", self.sinks, newline="") if csv_out else None
        if self._csv is not None:
            ports.append(CsvOut(self._csv, guidance=config.guidance.mode != "passive"))
        if self.feeds.feeds and self.link.is_log:
            self.link.close()
            raise ConfigError("--traffic needs a live MAVLink link: a log replays its own traffic on its own time")
        source = LinkSource(self.link, self._mavlink_input(config), 1.0 / config.advisory.assessment_hz,
                            duration_s, self.stop, start_s=start_s)
        if self.feeds.feeds:
            source = TrafficSource(source, self.feeds)  # started by the loop's iteration, joined at its end
        self._sensors = None
        if self.bus is not None and getattr(self.bus, "session", None) is not None:
            from avionics.io.sensor_input import SensorInputSource, SensorPayloadDecoder, SensorSubscriber

            # the ownship's range/bearing sensors on `<prefix>/<vehicle>/sensor/*` (docs/zenoh.md, "Sensor")
            self._sensors = SensorSubscriber(self.bus.session, config.zenoh.key_prefix, config.vehicle.id,
                                             lambda: time.monotonic() - start_s)
            source = SensorInputSource(source, self._sensors, SensorPayloadDecoder(self.counters, config.vehicle.id))
        self.loop = Loop(Daa(config, self.counters), source, ports)

    def _mavlink_input(self, config: Config) -> MavlinkInput:
        """The decoder, with the wiring diagnostics on a live link (io/diagnostics.py; a log has no wiring)."""
        mavlink = MavlinkInput(config, self.counters)
        if not self.link.is_log:
            mavlink.diagnostics = wiring_diagnostics(config, self.counters, mavlink.decoder.senders)
        return mavlink

    @property
    def now(self) -> float:
        return self.loop.now_s  # the loop's last time (log time when replaying)

    def run(self) -> None:
        # The loop never waits for the compiled kernels (avionics/base/kernel_startup.py): the numpy reference
        # until they are loaded (numba's import, ~27 kernels from a warm disk cache: ~0.3 s, on a thread started
        # once the first step is out, as the import holds the GIL; a cold cache compiles in a niced child process
        # first), then the kernels, switched between two steps. The first messages (ownship fixes, HEARTBEAT)
        # need none.
        with jit.deferred():
            self.loop.run(after_step=self.kernels.after_step)

    def shutdown(self) -> None:
        """The last outputs: every active advisory as NONE (reason shutdown), DAA unavailable; sent now."""
        self.loop.shutdown()

    def close(self) -> None:
        self.kernels.close()  # a compile still running is stopped; no interpreter exit in the middle of a load
        try:
            self.feeds.close()  # the reader threads are joined (no-op when the loop's end did it)
            self.link.close()
            if self._sensors is not None:
                self._sensors.close()
            if self._csv is not None:
                self._csv.close()
        finally:
            if self.bus is not None:
                self.bus.close(flush_timeout_s=SHUTDOWN_FLUSH_S)  # the last samples, then the token goes


def run(config: Config, duration_s: float | None = None, tlog_out: str | None = None,
        csv_out: str | None = None, traffic: tuple[str, ...] = ()) -> Counter:
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
        runner = Runner(config, tlog_out=tlog_out, stop=stop, duration_s=duration_s, csv_out=csv_out,
                        traffic=tuple(traffic))
        # after the link and the zenoh session opened: a start-up error is the only line printed
        log.info("avionics %s: MAVLink %s, zenoh %s, vehicle %s", __version__, config.mavlink.connection,
                 list(config.zenoh.listen) if config.zenoh.enabled else "off", config.vehicle.id)
        # what the profile means at a drone's height (a tcas2 drone below 1000 ft AGL has no RA)
        log.info("%s", profile_banner(runner.loop.daa.profile, config.advisory.ra_enabled,
                                      "MSL - advisory.ground_elevation_m" if config.advisory.ground_elevation_m
                                      is not None else "height above home, GLOBAL_POSITION_INT relative_alt"))
        # what the RA logic assumes the vehicle flies (a default ArduCopter climbs at 2.5 m/s, not 1500 fpm)
        log.info("%s", response_banner(runner.loop.daa.profile.response, config.vehicle.profile,
                                       runner.loop.daa.profile.name))
        try:
            runner.run()
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
