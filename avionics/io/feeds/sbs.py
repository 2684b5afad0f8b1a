"""SBS-1 BaseStation text (dump1090/readsb --net-sbs-port, usually TCP 30003) -> Observations -> IntruderReports.

One comma-separated line per message, 22 fields (Kinetic Avionics' BaseStation port 30003 format, as dump1090 and
readsb write it; docs/traffic-inputs.md has the table):

    MSG,3,1,1,4CA2D6,1,2024/01/31,12:34:56.789,2024/01/31,12:34:56.789,,35000,,,53.123,-6.456,,,0,0,0,0
    1   2 3 4 5      6 7          8            9          10           11 12  13 14 15 16 17 18 19 20 21 22

 1 message type (only MSG carries aircraft data; SEL, ID, AIR, STA, CLK are counted `ignored`), 2 transmission
 type 1-8, 5 ICAO address (hex; dump1090 prefixes a non-ICAO address with "~": rejected), 7-8 date and time the
 message was generated (the receiver's clock, aligned by clock.py), 11 callsign, 12 altitude (ft, Mode C /
 barometric: pressure altitude), 13 ground speed (kt), 14 track (deg true), 15-16 latitude, longitude (deg),
 17 vertical rate (ft/min), 18 squawk (4 octal digits), 22 on ground (-1 / 1 true).

No field carries NACp or NACv: every report has the configured traffic.sbs_*_sigma_* accuracy. Counters
`traffic.sbs.lines`, `.ignored`, `.rejected.malformed` (not 22 fields, not a number where one is due: the whole
line), `.rejected.line_too_long`, and the merger's (aircraft.py).
"""

from __future__ import annotations

import math
from collections import Counter
from datetime import datetime, timezone

from avionics.base.types import AltitudeDatum, IntruderReport
from avionics.base.units import FPM, FT, KT
from avionics.io.feeds.aircraft import AircraftMerge, Observation
from avionics.io.feeds.clock import ReceiverClock
from avionics.io.feeds.source import parse_host_port
from avionics.io.feeds.transport import LineSplitter, tcp_chunks

FIELDS = 22
MAX_LINE_BYTES = 512  # a BaseStation line is under 200 characters


class Malformed(ValueError):
    """A line that is not BaseStation text (counted, never raised out of the parser)."""


def _float(text: str) -> float | None:
    if not text:
        return None
    try:
        value = float(text)
    except ValueError:
        raise Malformed from None
    if not math.isfinite(value):
        raise Malformed
    return value


def receiver_time_s(date: str, clock: str) -> float | None:
    """"2024/01/31", "12:34:56.789" -> seconds on the receiver's clock (its local time read as UTC: the offset is
    absorbed by the clock alignment); None when absent or malformed (the receipt time is then used)."""
    try:
        year, month, day = (int(x) for x in date.split("/"))
        hms, _, frac = clock.partition(".")
        hour, minute, second = (int(x) for x in hms.split(":"))
        stamp = datetime(year, month, day, hour, minute, second, tzinfo=timezone.utc).timestamp()
        return stamp + (float("0." + frac) if frac.isdigit() else 0.0)
    except ValueError:
        return None


class SbsParser:
    """BaseStation lines -> IntruderReports of one source (the merger keeps each aircraft's latest fields)."""

    def __init__(self, path: str, config, counters: Counter):
        self.counters = counters
        self.merge = AircraftMerge(path, config, counters)
        self.clock = ReceiverClock(config.traffic.clock_window_s)
        self.prefix = self.merge.prefix

    def line(self, raw: bytes, received_s: float) -> IntruderReport | None:
        """One line (without its end); the report it completes or None. Never raises on the line's content."""
        self.counters[self.prefix + "lines"] += 1
        text = raw.decode("ascii", errors="replace").strip()
        if not text:
            return None
        fields = text.split(",")
        if fields[0] != "MSG":
            if fields[0] in ("SEL", "ID", "AIR", "STA", "CLK"):
                self.counters[self.prefix + "ignored"] += 1
                return None
            self.counters[self.prefix + "rejected.malformed"] += 1
            return None
        try:
            obs = self._observation(fields, received_s)
        except Malformed:
            self.counters[self.prefix + "rejected.malformed"] += 1
            return None
        return None if obs is None else self.merge.observe(obs)

    def _observation(self, f: list[str], received_s: float) -> Observation | None:
        if len(f) != FIELDS or not f[1].isdigit() or not 1 <= int(f[1]) <= 8 or "\ufffd" in "".join(f):
            raise Malformed
        hex_ident = f[4].strip()
        if hex_ident.startswith("~"):
            self.counters[self.prefix + "rejected.non_icao_address"] += 1  # TIS-B / anonymous: not an ICAO address
            return None
        if len(hex_ident) != 6 or any(c not in "0123456789abcdefABCDEF" for c in hex_ident):
            raise Malformed
        receiver_s = receiver_time_s(f[6], f[7])
        time_s = self.clock.align(receiver_s, received_s)
        obs = Observation(int(hex_ident, 16), time_s, received_s)
        callsign = f[10].strip()
        if callsign:
            obs.callsign = callsign
        altitude_ft = _float(f[11])
        on_ground = f[21].strip() in ("-1", "1")
        if altitude_ft is not None and not on_ground:
            obs.altitude_m, obs.altitude_datum = altitude_ft * FT, AltitudeDatum.PRESSURE
        speed_kt, track_deg = _float(f[12]), _float(f[13])
        if speed_kt is not None and track_deg is not None:
            speed, track = speed_kt * KT, math.radians(track_deg)
            obs.velocity_en_mps = (speed * math.sin(track), speed * math.cos(track))
        lat, lon = _float(f[14]), _float(f[15])
        if lat is not None or lon is not None:
            obs.lat_deg, obs.lon_deg = lat, lon
        rate = _float(f[16])
        if rate is not None:
            obs.vertical_rate_mps = rate * FPM
        squawk = f[17].strip()
        if squawk:
            if not squawk.isdigit():
                raise Malformed
            obs.squawk = int(squawk)
        if on_ground:
            self.counters[self.prefix + "on_ground"] += 1  # tracked horizontally; a surface altitude is not sent
        return obs


def make_session(path: str, target: str, config):
    """The session of one sbs:HOST:PORT source (source.py runs it on the feed's thread, again after each failure).
    Every session has a fresh parser: the receiver's clock and its aircraft may have changed while it was down."""
    host, port = parse_host_port(path, target)

    def session(ctx) -> None:
        parser = SbsParser(path, config, ctx.counters)
        lines = LineSplitter(MAX_LINE_BYTES)
        for chunk, received_s in tcp_chunks(host, port, ctx):
            for line in lines.feed(chunk):
                report = parser.line(line, received_s)
                if report is not None:
                    ctx.emit(report)
            if lines.too_long:
                ctx.counters[parser.prefix + "rejected.line_too_long"] += lines.too_long
                lines.too_long = 0
            ctx.flush()

    return session
