"""The ownship's simulated range/bearing sensors served live (`sitl live --sensor radar|active|adsb[,...]`): each
sensor (sensors.py SimulatedSensor, DO-365 Appendix Q; `--noise none`: its exact_model) scans the encounter's truth
at its rate, from the ownship's position with its heading taken from its track (a stabilised sensor on an aircraft
flying its track: no crab, no attitude), and each scan goes out as the process takes sensor inputs
(avionics/io/sensor_input.py): DAA_SENSOR_MEASUREMENT on the MAVLink link, one message per detection, and/or the
zenoh sensor payload on `<prefix>/<vehicle>/sensor/<id>`, one sample per scan, both dated at their send time (age 0).

Not modelled: active surveillance's slower far period (SensorErrors.far_period_s: every 5 s while tau >= 60 s);
each sensor scans at its rate_hz.
"""

from __future__ import annotations

import math
import threading
from dataclasses import dataclass

import numpy as np

from avionics.base.jsonsafe import dumps
from avionics.io.sensor_input import sensor_key, sensor_message, sensor_payload
from avionics_sitl.autopilot import Event
from avionics_sitl.scenario import Scenario
from avionics_sitl.sensors import MODELS, SimulatedSensor

SENSOR_CHOICES = ("adsb", "radar", "active")
SENSOR_IDS = {"radar": 0, "active": 1}  # the MAVLink instance; the zenoh id is its decimal text (one name for both)
PACE_S = 0.02  # how often the zenoh publisher looks for what is due


def sensor_list(text: str) -> tuple[str, ...]:
    """`--sensor`: a comma-separated subset of SENSOR_CHOICES, in that order; ValueError names a bad one."""
    names = [n.strip() for n in text.split(",") if n.strip()]
    bad = [n for n in names if n not in SENSOR_CHOICES]
    if bad or not names:
        raise ValueError(f"{','.join(bad) or 'nothing'}: choose from {', '.join(SENSOR_CHOICES)}")
    return tuple(n for n in SENSOR_CHOICES if n in names)


@dataclass(frozen=True, slots=True)
class Scan:
    deliver_s: float  # scenario time of the scan (sent at once)
    sensor: SimulatedSensor
    measurements: list  # PolarMeasurement
    truth: list  # index of the intruder behind each, None for a false return


def simulated_sensors(kinds, seed: int, exact: bool) -> list[SimulatedSensor]:
    """One SimulatedSensor per non-ADS-B kind; exact: `--noise none` (measures exactly, sees all round)."""
    out = []
    for kind in kinds:
        if kind == "adsb":
            continue
        errors = MODELS[kind].exact_model() if exact else MODELS[kind]
        out.append(SimulatedSensor(errors, str(SENSOR_IDS[kind]), seed=(seed, SENSOR_IDS[kind])))
    return out


def _enu(traj, t: float) -> np.ndarray:
    """[east, north, alt, ve, vn, vu] in the scenario's plane (true velocity axes: the meridian convergence over
    an encounter's few km is a small fraction of a degree, below the radar's 1 deg azimuth sigma)."""
    s = traj.state_at(t)
    return np.array([*traj.enu_at(t), s.vel_east_mps, s.vel_north_mps, s.vel_up_mps])


def sensor_scans(scenario: Scenario, sensors: list[SimulatedSensor], end_s: float, start_s: float = 0.0) -> list[Scan]:
    """Every scan of every sensor from start_s up to (not at) end_s, in time order: what a live flight sends."""
    own_traj, intruder_trajs = scenario.trajectories()
    scans = []
    for sensor in sensors:
        period = 1.0 / sensor.errors.rate_hz
        for k in range(int(math.ceil(start_s / period - 1e-9)), int(math.ceil(end_s / period - 1e-9))):
            t = k * period
            own = _enu(own_traj, t)
            heading = math.atan2(own[3], own[4]) if math.hypot(own[3], own[4]) > 0.0 else 0.0
            targets = np.array([_enu(traj, t) for traj in intruder_trajs]).reshape(-1, 6)
            measurements, truth = sensor.scan(t, own, heading, targets)
            scans.append(Scan(t, sensor, measurements, truth))
    scans.sort(key=lambda s: s.deliver_s)
    return scans


def mavlink_events(scans: list[Scan]) -> list[Event]:
    """DAA_SENSOR_MEASUREMENT per detection, for the MAVLink schedule."""
    return [Event(s.deliver_s, sensor_message(m, s.deliver_s, 0.0, int(s.sensor.sensor_id)), s.deliver_s)
            for s in scans for m in s.measurements]


class ZenohSensorPublisher:
    """Puts each scan's payload on `<prefix>/<vehicle>/sensor/<id>` when the clock (scenario seconds) reaches it,
    from a thread: start() after the clock's start, stop() at the end. `sent` counts samples."""

    sent_key = "sensor_samples"

    def __init__(self, session, scans: list[Scan], clock, prefix: str = "daa", vehicle: str = "uav1"):
        self.session, self.scans, self.clock = session, scans, clock
        self.prefix, self.vehicle = prefix, vehicle
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name="sensor zenoh", daemon=True)
        self._next = 0
        self.sent = 0

    def start(self) -> "ZenohSensorPublisher":
        self._thread.start()
        return self

    def send_until(self, t: float) -> None:
        while self._next < len(self.scans) and self.scans[self._next].deliver_s <= t:
            scan = self.scans[self._next]
            if scan.deliver_s >= self.clock.start_s:  # a late start: nothing due before it is sent
                payload = sensor_payload(self.vehicle, scan.sensor.mount, scan.deliver_s, scan.measurements)
                self.session.put(sensor_key(self.prefix, self.vehicle, scan.sensor.sensor_id),
                                 dumps(payload).encode(), encoding="application/json")
                self.sent += 1
            self._next += 1

    def _run(self) -> None:
        while not self._stop.is_set():
            if self.clock.started():  # nothing before the link is open
                self.send_until(self.clock())
            self._stop.wait(PACE_S)

    def stop(self) -> None:
        self._stop.set()
        if self._thread.is_alive():
            self._thread.join(timeout=5.0)
