"""A simulated ADS-B receiver's SBS-1 BaseStation output (dump1090/readsb's TCP port 30003): a scenario's intruders
as BaseStation text lines, served over TCP on a clock (real time, or fast time for tests).

The reports are exactly those the simulated autopilot sends as ADSB_VEHICLE (avionics_sitl.autopilot.schedule:
the same trajectories, impairments, seeds, 1 Hz phases and latencies), so that the SBS path and the MAVLink path
can be compared report for report. Each report becomes the lines a receiver writes for the messages it heard:

    MSG,3  airborne position: altitude (ft), latitude, longitude                   (DF17 TC 9-18)
    MSG,4  airborne velocity: ground speed (kt), track (deg), vertical rate (ft/min) (DF17 TC 19)
    MSG,1  identification: callsign, every CALLSIGN_EVERY-th report             (DF17 TC 1-4, every ~5 s)

22 comma-separated fields (avionics/io/feeds/sbs.py has the field list). Fields 7-8, "date/time message
generated", carry the report's time of applicability on the receiver's clock (EPOCH + scenario time, which
need not be our clock: the reader aligns it); fields 9-10 the time it was logged (its delivery).
"""

from __future__ import annotations

import socket
import threading
import time
from dataclasses import dataclass
from datetime import datetime, timedelta, timezone

from avionics.core.units import FPM, FT, KT
from avionics_sitl.autopilot import AutopilotConfig, schedule
from avionics_sitl.impairments import AdsbImpairments
from avionics_sitl.scenario import Scenario

EPOCH = datetime(2024, 6, 1, 12, 0, 0, tzinfo=timezone.utc)  # the receiver's clock at scenario time 0
CALLSIGN_EVERY = 5  # DO-260B: identification every 5 s; position and velocity 2 Hz (here: each report)


@dataclass(frozen=True, slots=True)
class SbsEvent:
    deliver_s: float  # scenario time when the receiver writes the lines
    data: bytes  # one or more "\r\n"-terminated lines


def _stamp(t_s: float) -> tuple[str, str]:
    when = EPOCH + timedelta(seconds=t_s)
    return when.strftime("%Y/%m/%d"), when.strftime("%H:%M:%S.") + f"{when.microsecond // 1000:03d}"


def sbs_line(kind: int, icao: int, generated_s: float, logged_s: float, callsign: str = "", altitude: str = "",
             speed: str = "", track: str = "", lat: str = "", lon: str = "", rate: str = "", squawk: str = "") -> str:
    gen_date, gen_time = _stamp(generated_s)
    log_date, log_time = _stamp(logged_s)
    return ",".join(["MSG", str(kind), "1", "1", f"{icao:06X}", "1", gen_date, gen_time, log_date, log_time,
                     callsign, altitude, speed, track, lat, lon, rate, squawk, "0", "0", "0", "0"])


def adsb_vehicle_lines(msg, truth_s: float, deliver_s: float, count: int) -> list[str]:
    """The BaseStation lines of one simulated ADSB_VEHICLE report (its values exactly, in SBS units)."""
    icao = msg.ICAO_address
    alt_ft = msg.altitude * 1e-3 / FT
    speed_kt = msg.hor_velocity * 1e-2 / KT
    lines = [
        sbs_line(3, icao, truth_s, deliver_s, altitude=f"{alt_ft:.0f}", lat=f"{msg.lat * 1e-7:.7f}",
                 lon=f"{msg.lon * 1e-7:.7f}"),
        sbs_line(4, icao, truth_s, deliver_s, speed=f"{speed_kt:.3f}", track=f"{msg.heading * 1e-2:.2f}",
                 rate=f"{msg.ver_velocity * 1e-2 / FPM:.0f}"),
    ]
    callsign = msg.callsign.decode("ascii", "replace") if isinstance(msg.callsign, bytes) else str(msg.callsign)
    callsign = callsign.split("\0", 1)[0].strip()
    if callsign and count % CALLSIGN_EVERY == 0:
        lines.append(sbs_line(1, icao, truth_s, deliver_s, callsign=callsign))
    return lines


def sbs_schedule(scenario: Scenario, impairments: AdsbImpairments, seed: int = 0,
                 duration_s: float | None = None, config: AutopilotConfig = AutopilotConfig()) -> list[SbsEvent]:
    """Every intruder report of the encounter as BaseStation lines, in delivery order (the velocity line before
    the position line, as the fields of a report are all known when it is delivered). config.adsb_hz: the
    report rate (1 Hz as the autopilot's ADSB_VEHICLE; a receiver hears positions at 2 Hz)."""
    events = []
    counts: dict[int, int] = {}
    for e in schedule(scenario, impairments, seed, config=config, duration_s=duration_s, ownship=False):
        if e.msg.get_type() != "ADSB_VEHICLE":
            continue
        count = counts[e.msg.ICAO_address] = counts.get(e.msg.ICAO_address, -1) + 1
        position, velocity, *rest = adsb_vehicle_lines(e.msg, e.truth_s, e.deliver_s, count)
        text = "".join(line + "\r\n" for line in [*rest, velocity, position])
        events.append(SbsEvent(e.deliver_s, text.encode("ascii")))
    return events


class SbsServer:
    """Serves events over TCP to every client connected, each line at its delivery time on `clock` (scenario
    seconds; default: real time from start(), times `speed`, from `start_s`). Loopback by default."""

    def __init__(self, events: list[SbsEvent], host: str = "127.0.0.1", port: int = 30003, speed: float = 1.0,
                 start_s: float = 0.0, clock=None):
        self.events = sorted(events, key=lambda e: e.deliver_s)
        self.host, self.speed, self.start_s = host, speed, start_s
        self._clock = clock
        self._listener = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
        self._listener.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        self._listener.bind((host, port))
        self._listener.listen(8)
        self._listener.settimeout(0.05)
        self.port = self._listener.getsockname()[1]
        self._clients: list[socket.socket] = []
        self._lock = threading.Lock()
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._next = 0
        self._t0 = None
        self.sent_lines = 0

    def scenario_time(self) -> float:
        if self._clock is not None:
            return self._clock()
        return self.start_s + (time.monotonic() - self._t0) * self.speed

    def start(self) -> "SbsServer":
        self._t0 = time.monotonic()
        while self._next < len(self.events) and self.events[self._next].deliver_s < self.start_s:
            self._next += 1  # a late start: what was due before it is not sent
        self._thread = threading.Thread(target=self._run, name=f"sbs server {self.port}", daemon=True)
        self._thread.start()
        return self

    @property
    def clients(self) -> int:
        with self._lock:
            return len(self._clients)

    @property
    def done(self) -> bool:
        return self._next >= len(self.events)

    def send_raw(self, data: bytes) -> None:
        """Bytes to every client now (garbage, partial lines: tests)."""
        with self._lock:
            self._send(data)

    def _send(self, data: bytes) -> None:
        for client in list(self._clients):
            try:
                client.sendall(data)
            except OSError:
                self._clients.remove(client)
                client.close()

    def _run(self) -> None:
        while not self._stop.is_set():
            try:
                client, _ = self._listener.accept()
                client.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
                with self._lock:
                    self._clients.append(client)
            except (socket.timeout, TimeoutError):
                pass
            except OSError:
                if self._stop.is_set():
                    return
            now = self.scenario_time()
            chunk = []
            while self._next < len(self.events) and self.events[self._next].deliver_s <= now:
                chunk.append(self.events[self._next].data)
                self._next += 1
            if chunk:
                data = b"".join(chunk)
                with self._lock:
                    self._send(data)
                self.sent_lines += data.count(b"\n")

    def stop(self) -> None:
        """Close the listener and every connection (the clients see the connection end), join the thread."""
        self._stop.set()
        if self._thread is not None:
            self._thread.join(5.0)
        self._listener.close()
        with self._lock:
            for client in self._clients:
                try:
                    client.shutdown(socket.SHUT_RDWR)
                except OSError:
                    pass
                client.close()
            self._clients.clear()

    def __enter__(self) -> "SbsServer":
        return self.start()

    def __exit__(self, *exc) -> None:
        self.stop()
