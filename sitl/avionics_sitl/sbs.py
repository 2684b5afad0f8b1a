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

from dataclasses import dataclass
from datetime import datetime, timedelta, timezone

from avionics.base.units import FPM, FT, KT
from avionics_sitl.autopilot import AutopilotConfig, schedule
from avionics_sitl.feed_server import FeedServer
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


class SbsServer(FeedServer):
    """SBS-1 BaseStation lines over TCP, each event at its delivery time (feed_server.py: clocks, clients, stop)."""

    name = "sbs server"
    sent_key = "sbs_lines"

    def __init__(self, events: list[SbsEvent], host: str = "127.0.0.1", port: int = 30003, **kw):
        super().__init__(events, host, port, **kw)

    @staticmethod
    def payload(event: SbsEvent) -> bytes:
        return event.data

    @staticmethod
    def units(event: SbsEvent) -> int:
        return event.data.count(b"\n")
