"""readsb / dump1090 `aircraft.json` (polled from a file or an http:// URL) -> Observations -> IntruderReports.

Field names as readsb's README-json.md documents them (dump1090-fa's README-json.md has the same names):
top level `now` (POSIX seconds of the document) and `aircraft` (a list); per aircraft `hex` (24-bit address; "~"
prefix: not an ICAO address, rejected), `flight` (callsign), `alt_baro` (ft, pressure altitude, or "ground"),
`gs` (kt), `track` (deg true), `baro_rate` / `geom_rate` (ft/min), `lat`, `lon` (deg), `squawk` (4 octal digits),
`category` (DO-260B emitter category "A3"), `nac_p`, `nac_v`, `nic`, `seen_pos` (s before `now` the position
was last updated), `seen` (s before `now` of the last message). `alt_geom` is height above the WGS-84 ellipsoid,
not above mean sea level: it is not used (the tracker's geometric datum is MSL).

Times: the position is applicable at `now - seen_pos`, the other fields at `now - seen`, on the receiver's clock,
aligned to ours by clock.py. A position already delivered (the same lat/lon at the same receiver time, within
readsb's 0.1 s resolution of seen_pos) is counted `unchanged`, not reported again. A document that does not
parse is counted `rejected.malformed_json`, an entry that is not an aircraft object `rejected.malformed`; the next
poll goes on. Each entry is the entry's own: a value of any JSON type or size in any field is counted and dropped
with its field (an integer of 400 digits is not a float, "²" is not a squawk), never costing the other aircraft of
the document; an entry whose decoding raises anyway is counted `decode_errors` (a bug, logged once). A document
whose `now` has not advanced for STALE_AFTER_S is a dead source (readsb stopped: its
last file stays behind): the session ends and is retried, and the status warns.
"""

from __future__ import annotations

import json
import logging
import math
from collections import Counter

from avionics.base.types import AltitudeDatum, IntruderReport
from avionics.base.units import FPM, FT, KT
from avionics.io.feeds.aircraft import AircraftMerge, Observation, emitter_type_of_category
from avionics.io.feeds.clock import ReceiverClock
from avionics.io.feeds.transport import DocumentTooLarge, read_document

log = logging.getLogger("avionics.traffic")
SEEN_POS_RESOLUTION_S = 0.15  # readsb writes seen_pos with one decimal (0.1 s), `now` with more: 0.1 s + margin
STALE_AFTER_S = 10.0  # readsb rewrites aircraft.json every second (--write-json-every 1): ten missed writes
FETCH_TIMEOUT_S = 2.0  # each connect or read of an HTTP fetch (a socket timeout)


def _num(value) -> float | None:
    """A JSON number as a finite float; None for anything else (a string, a bool, an integer beyond a float's
    range: float() and math.isfinite() raise OverflowError on one of 400 digits)."""
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        return None
    try:
        number = float(value)
    except OverflowError:
        return None
    return number if math.isfinite(number) else None


def _squawk(value) -> int:
    """readsb's squawk ("7700", four octal digits) as the int the merge checks; -1 (counted `squawk_invalid` by the
    merge) for anything else. ASCII digits only: str.isdigit() also accepts "²" and other Unicode digits, which
    int() refuses."""
    if isinstance(value, str) and 1 <= len(value) <= 4 and value.isascii() and value.isdigit():
        return int(value)
    return -1


class ReadsbParser:
    """aircraft.json documents -> IntruderReports of one source."""

    def __init__(self, path: str, config, counters: Counter):
        self.counters = counters
        self.merge = AircraftMerge(path, config, counters)
        self.clock = ReceiverClock(config.traffic.clock_window_s)
        self.prefix = self.merge.prefix
        self._last_position: dict[str, tuple[float, float, float]] = {}  # hex -> (receiver time, lat, lon)
        self.document_now: float | None = None  # the last document's `now`
        self._logged = False  # the first entry that raised is logged with its traceback, the others counted

    def document(self, data: bytes, received_s: float) -> list[IntruderReport]:
        """One aircraft.json; the reports it completes. Never raises on the document's content."""
        p = self.prefix
        self.counters[p + "documents"] += 1
        try:
            doc = json.loads(data)
        except (ValueError, RecursionError):  # UnicodeDecodeError is a ValueError
            self.counters[p + "rejected.malformed_json"] += 1
            return []
        now = _num(doc.get("now")) if isinstance(doc, dict) else None
        aircraft = doc.get("aircraft") if isinstance(doc, dict) else None
        if not isinstance(aircraft, list):
            self.counters[p + "rejected.malformed_json"] += 1
            return []
        self.document_now = now
        out = []
        for entry in aircraft:
            self.counters[p + "lines"] += 1  # one aircraft entry
            if not isinstance(entry, dict) or not isinstance(entry.get("hex"), str):
                self.counters[p + "rejected.malformed"] += 1
                continue
            try:
                report = self._entry(entry, now, received_s)
            except Exception:  # noqa: BLE001  (one entry's fault: counted and logged; the other aircraft go on)
                self.counters[p + "decode_errors"] += 1
                if not self._logged:
                    self._logged = True
                    log.exception("readsb-json: an aircraft entry could not be decoded: %.200r", entry)
                continue
            if report is not None:
                out.append(report)
        return out

    def _time(self, now: float | None, seen, received_s: float) -> tuple[float, float | None]:
        age = _num(seen)
        receiver_s = now - age if now is not None and age is not None and age >= 0.0 else None
        return self.clock.align(receiver_s, received_s), receiver_s

    def _entry(self, e: dict, now: float | None, received_s: float) -> IntruderReport | None:
        p = self.prefix
        hex_ident = e["hex"].strip()
        if hex_ident.startswith("~"):
            self.counters[p + "rejected.non_icao_address"] += 1
            return None
        if len(hex_ident) != 6 or any(c not in "0123456789abcdefABCDEF" for c in hex_ident):
            self.counters[p + "rejected.malformed"] += 1
            return None
        address = int(hex_ident, 16)
        seen_s, _ = self._time(now, e.get("seen", 0.0), received_s)
        fields = Observation(address, seen_s, received_s)
        if isinstance(e.get("flight"), str) and e["flight"].strip():
            fields.callsign = e["flight"]
        alt = e.get("alt_baro")
        if alt == "ground":
            self.counters[p + "on_ground"] += 1
        elif alt is not None:
            feet = _num(alt)
            fields.altitude_m = feet * FT if feet is not None else math.nan  # NaN: counted by the merger
            fields.altitude_datum = AltitudeDatum.PRESSURE
        gs, track = _num(e.get("gs")), _num(e.get("track"))
        if gs is not None and track is not None:
            speed, heading = gs * KT, math.radians(track)
            fields.velocity_en_mps = (speed * math.sin(heading), speed * math.cos(heading))
        elif e.get("gs") is not None and e.get("track") is not None:
            self.counters[p + "rejected.velocity_invalid"] += 1
        rate = e.get("baro_rate", e.get("geom_rate"))
        if rate is not None:
            fpm = _num(rate)
            fields.vertical_rate_mps = fpm * FPM if fpm is not None else math.nan
        squawk = e.get("squawk")
        if squawk is not None:
            fields.squawk = _squawk(squawk)
        category = e.get("category")
        if category is not None:
            emitter = emitter_type_of_category(category)
            fields.emitter_type = 0 if emitter is None else emitter  # unknown categories: NO_INFO
        for name, key in (("nacp", "nac_p"), ("nacv", "nac_v"), ("nic", "nic")):
            value = e.get(key)
            if value is not None:
                setattr(fields, name, value if isinstance(value, int) and not isinstance(value, bool) else -1)
        self.merge.observe(fields)  # the fields (no position): stored, nothing reported

        if "lat" not in e and "lon" not in e:
            return None
        lat, lon = _num(e.get("lat")), _num(e.get("lon"))
        if lat is None or lon is None:
            self.counters[p + "rejected.position_invalid"] += 1
            return None
        time_s, receiver_s = self._time(now, e.get("seen_pos"), received_s)
        if receiver_s is not None:
            last = self._last_position.get(hex_ident)
            if last is not None and (lat, lon) == last[1:] and abs(receiver_s - last[0]) <= SEEN_POS_RESOLUTION_S:
                self.counters[p + "unchanged"] += 1
                return None
            self._last_position[hex_ident] = (receiver_s, lat, lon)
        else:
            self.counters[p + "no_position_time"] += 1  # seen_pos or now missing: the position's receipt time
        return self.merge.observe(Observation(address, time_s, received_s, lat_deg=lat, lon_deg=lon))


def make_session(path: str, target: str, config):
    """The session of one readsb-json:PATH_OR_URL source: poll every traffic.readsb_poll_s until a read fails or
    the document goes stale (source.py retries it). A fetch must complete within input.max_report_age_s: a document
    that takes longer is older on arrival than a report may be (the age at which the MAVLink path and the merge
    reject a report as stale), and a source that keeps the connection alive without completing one (a byte a second) delivers
    nothing while it would look connected. Such a fetch, or a document above transport.MAX_DOCUMENT_BYTES, fails
    the session: the status warns that the source is down, and it is retried."""
    poll_s, deadline_s = config.traffic.readsb_poll_s, config.input.max_report_age_s

    def session(ctx) -> None:
        parser = ReadsbParser(path, config, ctx.counters)
        last_now, advanced_s = None, ctx.clock()
        while not ctx.stop.is_set():
            try:
                data = read_document(target, FETCH_TIMEOUT_S, deadline_s)
            except DocumentTooLarge:
                ctx.counters[parser.prefix + "rejected.document_too_large"] += 1
                raise
            except TimeoutError:
                ctx.counters[parser.prefix + "document_timeouts"] += 1
                raise
            received_s = ctx.clock()
            ctx.connected()
            for report in parser.document(data, received_s):
                ctx.emit(report)
            ctx.flush()
            if parser.document_now != last_now:
                last_now, advanced_s = parser.document_now, received_s
            elif received_s - advanced_s > STALE_AFTER_S:
                raise TimeoutError(f"aircraft.json not updated for {received_s - advanced_s:.0f} s")
            ctx.stop.wait(poll_s)

    return session
