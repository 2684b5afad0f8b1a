"""The onboard process without transports, for tests: MAVLink messages in; the MAVLink messages and zenoh
samples it would send, in two lists. Built from the same parts as `avionics run` (avionics/runner.py): the
validating MAVLink input, the DAA facade, the MAVLink and zenoh output ports, the loop."""

from __future__ import annotations

from collections import Counter

from avionics.config import Config
from avionics.daa import Daa, DaaResult
from avionics.io.payloads import track_payload
from avionics.loop import Batch, Loop, MavlinkInput
from avionics.ports import AdvisoryAnnouncements, MavlinkOut, ZenohOut


class Harness:
    def __init__(self, config: Config, counters: Counter | None = None):
        self.config = config
        self.counters = counters if counters is not None else Counter()
        self.mavlink_out: list = []
        self.zenoh_out: list[tuple[str, dict]] = []
        self.input = MavlinkInput(config, self.counters)
        self.daa = Daa(config, self.counters)
        advisories = AdvisoryAnnouncements.of(config)  # as avionics run wires the two ports
        ports = [MavlinkOut(self.mavlink_out.append, config, advisories=advisories)]
        self.zenoh = ZenohOut(lambda suffix, payload: self.zenoh_out.append((suffix, payload)), config,
                              advisories=advisories)
        if config.zenoh.enabled:
            ports.append(self.zenoh)
        self.loop = Loop(self.daa, self.input, ports)

    @property
    def decoder(self):
        return self.input.decoder

    @property
    def core(self):
        """The core behind the facade, for white-box assertions (no shell reads it)."""
        return self.daa._core

    def handle(self, msgs, now_s: float) -> DaaResult:
        return self.loop.step(Batch(now_s, self.input.decode(msgs, now_s)))

    def shutdown(self, now_s: float) -> DaaResult:
        self.loop.now_s = now_s
        return self.loop.shutdown()

    def status(self, now_s: float) -> dict:
        return self.daa.status(now_s, self.input.status())

    def track_messages(self, now_s: float) -> list[tuple[str, dict]]:
        vehicle = self.config.vehicle.id
        return [(f"tracks/{t.key}", track_payload(vehicle, t)) for t in self.daa.tracks(now_s, self.input.status())]
