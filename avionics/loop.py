"""The one loop every shell runs: a source of time-stamped input batches, the DAA facade, the output ports.

    for batch in source:  result = daa.step(batch.now_s, batch.inputs, ...);  every port publishes result
    then:                 final = daa.shutdown(now);                         every port publishes final, closes

Live (`avionics run`), fast time (`sitl replay`), the bench, the demo and the monitor's simulated vehicle differ
only in their source (a MAVLink link on the monotonic clock, a log on its timestamps, a scenario's schedule on
simulated time) and their ports. The clock belongs to the source: the core never reads one.
"""

from __future__ import annotations

import math
import threading
import time
from collections import Counter
from dataclasses import dataclass, replace
from typing import Iterable, Iterator, Protocol

from avionics.config import Config
from avionics.base.faults import FaultLog
from avionics.base.types import Input, IntruderReport, SensorScan
from avionics.tracking.measurement import PolarMeasurement
from avionics.daa import Daa, DaaResult, SourceStatus
from avionics.io.decode import MessageDecoder
from avionics.ports import NOTHING, OutputPort


@dataclass(frozen=True, slots=True)
class Batch:
    now_s: float  # the loop's time of this step (monotonic since start, log time or scenario time)
    inputs: list[Input]  # decoded and validated since the last batch


class Source(Protocol):
    def __iter__(self) -> Iterator[Batch]:
        """Batches in time order; the iteration ends at the end of a log, a scenario or a duration."""

    def status(self) -> SourceStatus:
        """What the source knows that the core cannot (intruders reported by a second sender, ...)."""


class MavlinkInput:
    """pymavlink messages -> core inputs through the validating decoder (io/decode.py). A message whose
    decoding raises is dropped and counted (`fault.decode`); the others go on."""

    def __init__(self, config: Config, counters: Counter, diagnostics=None):
        """diagnostics: io/diagnostics.py WiringDiagnostics over this decoder's senders (the live `avionics run`)."""
        self.decoder = MessageDecoder(config, counters)
        self.diagnostics = diagnostics
        self._fault = FaultLog(counters)
        self._now_s = 0.0  # the last batch's time: how long ownship fixes have been rejected is judged at it
        self.traffic = False  # an accepted ADSB_VEHICLE since start: MAVLink is a traffic source (daa.py traffic_down)

    def decode(self, msgs: Iterable, now_s: float) -> list[Input]:
        self._now_s = now_s
        if self.diagnostics is not None:
            self.diagnostics.observe(msgs, now_s)
        inputs, detections = [], {}
        for m in msgs:
            try:
                item = self.decoder.decode(m, now_s)
            except Exception as exc:  # noqa: BLE001  (one message's fault: it is dropped, the rest go on)
                self._fault("decode", exc)
                continue
            if type(item) is PolarMeasurement:  # DAA_SENSOR_MEASUREMENT: one detection of a scan
                detections.setdefault((item.mount.sensor_id, item.time_s), []).append(item)
            elif item is not None:
                inputs.append(item)
                self.traffic = self.traffic or type(item) is IntruderReport
        # a scan is the detections of one sensor at one time (their time_usec); one split across two batches is
        # two scans at one time, each detection applied once (sensor_tracker.py)
        inputs += [SensorScan(t, sensor, tuple(ms)) for (sensor, t), ms in detections.items()]
        return inputs

    def status(self) -> SourceStatus:
        decoder = self.decoder
        return SourceStatus(frozenset(decoder.spoof_suspected), decoder.pressure_rejection is not None,
                            rejected_senders=decoder.senders.active_suspects(self._now_s),
                            ownship_inconsistent=decoder.ownship_check.failing(self._now_s),
                            mavlink_traffic=self.traffic,
                            wiring=self.diagnostics.conditions(self._now_s) if self.diagnostics is not None else ())


class LinkSource:
    """A MAVLink link (io/link.py): live, a batch per wake-up on the monotonic clock since start (at least one per
    assessment tick); a log, a batch per record on the log's own timestamps, ending with the log."""

    def __init__(self, link, mavlink: MavlinkInput, tick_s: float, duration_s: float | None = None,
                 stop: threading.Event | None = None, clock=time.monotonic, start_s: float | None = None):
        """start_s: the clock's reading that is time 0 (default: when the iteration starts); the receiver feeds
        (avionics/io/feeds/) stamp their reports on the same origin."""
        self.link, self.mavlink, self.tick_s, self._clock = link, mavlink, tick_s, clock
        self.start_s = start_s
        self.end_s = math.inf if duration_s is None else duration_s
        self.stop = stop if stop is not None else threading.Event()

    def __iter__(self) -> Iterator[Batch]:
        start = self._clock() if self.start_s is None else self.start_s
        log_t0 = None
        now = 0.0
        while not self.stop.is_set() and now < self.end_s:
            if self.link.is_log:
                msgs = self.link.receive(0.0)
                if not msgs:
                    return  # end of the log
                stamp = getattr(msgs[0], "_timestamp", 0.0)
                log_t0 = stamp if log_t0 is None else log_t0
                now = stamp - log_t0
            else:
                msgs = self.link.receive(self.tick_s)
                now = self._clock() - start
            yield Batch(now, self.mavlink.decode(msgs, now))

    def status(self) -> SourceStatus:
        status = self.mavlink.status()
        return replace(status, link_authenticated=True) if self.link.authenticated else status


class Loop:
    """Drives a Daa from a source into ports. run() until the source ends; shutdown() publishes the final result
    (every advisory NONE with reason shutdown, DAA unavailable, a last status) and closes the ports."""

    def __init__(self, daa: Daa, source: Source, ports: list[OutputPort]):
        self.daa, self.source, self.ports = daa, source, list(ports)
        self.now_s = 0.0  # the last batch's time
        self.last: DaaResult | None = None
        self._fault = FaultLog(daa.counters)

    def step(self, batch: Batch) -> DaaResult:
        """One batch through the core and out of every port (also for shells that make their own batches)."""
        demand = NOTHING
        for port in self.ports:
            demand |= port.wants(batch.now_s)
        self.now_s = batch.now_s
        result = self.daa.step(batch.now_s, batch.inputs, sources=self.source.status(), tracks=demand.tracks,
                               status=demand.status, tracks_within_s=demand.tracks_within_s)
        self._publish(result)
        return result

    def run(self, after_step=None) -> DaaResult | None:
        """after_step: called after every step, once its outputs are out (avionics/runner.py starts loading the
        compiled kernels after the first, off the path to the first message, and switches to them between two
        steps)."""
        for batch in self.source:
            self.last = self.step(batch)
            if after_step is not None:
                after_step()
        return self.last

    def shutdown(self) -> DaaResult:
        final = self.daa.shutdown(self.now_s, self.source.status())
        self._publish(final)
        for port in self.ports:
            try:
                port.close()
            except Exception as exc:  # noqa: BLE001
                self._fault("output", exc)
        return final

    def _publish(self, result: DaaResult) -> None:
        for port in self.ports:
            try:
                port.publish(result)
            except Exception as exc:  # noqa: BLE001  (a port's fault never silences the others)
                self._fault("output", exc)
