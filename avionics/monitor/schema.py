"""What the monitor accepts from zenoh: a schema check on every sample and snapshot before it reaches the
picture (state.py), the page or the terminal view.

Anyone who can reach the zenoh network can publish under `daa/**` (no credentials without TLS), so a sample is
data to check, not to trust. Each payload kind has a table of the fields the monitor knows, made from the
contract's (avionics/contract/zenoh.py, docs/zenoh.md): type, range and string length. A sample with a known field of the wrong type, out of range, not finite, too long,
or a string with control or bidi-override characters is *rejected* whole (clean_sample raises Rejected, whose
`reason` names the field: the feed counts it in `/api/stats` and drops it). Fields the monitor does not know
are kept only when they are short scalars or short lists of them (at most MAX_UNKNOWN_FIELDS, so a newer schema's
extra fields and the benchmark's tags pass) and otherwise dropped, which bounds what a sample can make the monitor
hold.

Every known field is optional and may be null (older schemas lack fields; the contract uses null for unknown
and infinite values). Enumerations (`level`, `advisory`, `ra_sense`, ...) are checked as bounded strings, not
against their current values: a future level is shown as text rather than losing the sample, and the page and
the terminal view render every payload string as text, never as markup. The status fields the monitor does not
display (e.g. `daa_available`, `wiring`) are not in its table, so a change to their form never costs a status.

Traffic (`<prefix>/<vehicle>/traffic`, an Arrow IPC stream of every track, io/traffic.py): the stream is decoded
and fully validated first; a batch that is not a stream, too big, with a header that is not the contract's (schema,
layout, vehicle, time_s, keys) or a column of a type outside it is rejected whole (`rejected.traffic.<reason>`).
Each row is then checked as a per-track sample is, with the same table (TRACK): a bad row is left out and counted
(`rejected.traffic.row.<field>`), and the good rows of the batch are applied.

Bands (`<prefix>/<vehicle>/bands`, DO-365 alerters): each kind's intervals must be objects with `lower` <=
`upper` within the kind's range (track 0-360 deg, ...), in increasing order, each with a `region` (a bounded
string: DAIDALUS's NONE/FAR/MID/NEAR/RECOVERY, or a newer one, which the page draws as UNKNOWN); only those
three fields of an interval are kept. An empty list (no bands computed) is accepted.
"""

from __future__ import annotations

import re

from avionics.contract import fields as contract_fields, zenoh as contract
from avionics.contract.bands import BAND_KIND_NAMES
from avionics.contract.fields import Field

MAX_SAMPLE_BYTES = 256 * 1024  # one track is ~1.2 kB, a status with every counter a few kB
MAX_SNAPSHOT_BYTES = 32 * 1024 * 1024  # a vehicle's whole picture: thousands of tracks and the change log
MAX_TRAFFIC_BYTES = 32 * 1024 * 1024  # one traffic batch (Arrow): ~320 bytes a track
MAX_TRAFFIC_ROWS = 20_000  # tracks in one traffic batch
MAX_ID_LEN = contract_fields.ID_LEN  # vehicle and intruder ids (key expression chunks), callsigns, enumerations
MAX_TEXT_LEN = contract_fields.TEXT_LEN  # reasons, RA words, warnings
MAX_LIST = 10_000  # list fields (datum_mismatch_intruders) and snapshot lists
MAX_UNKNOWN_FIELDS = 32
MAX_UNKNOWN_LIST = 64
# C0/C1 controls (terminal escapes, newlines), and bidi overrides / isolates (text that displays reversed)
_BAD_CHARS = re.compile("[\x00-\x1f\x7f-\x9f\u061c\u200e\u200f\u202a-\u202e\u2066-\u2069]")


class Rejected(ValueError):
    """A sample the monitor does not accept; `reason` is a short, bounded name (a field, `json`, `size`, ...)."""

    def __init__(self, reason: str):
        super().__init__(reason)
        self.reason = reason


class _Bad(Exception):
    pass


def text_ok(value, max_len: int = MAX_ID_LEN) -> bool:
    return type(value) is str and len(value) <= max_len and not _BAD_CHARS.search(value)


def check_id(value) -> str:
    """A vehicle or intruder id taken from a key expression: 1..MAX_ID_LEN printable characters."""
    if not value or not text_ok(value, MAX_ID_LEN):
        raise Rejected("key")
    return value


# -- field checks: each returns the value (None allowed) or raises _Bad --------------------------------------------
# The common checks also carry a spec, (code, a, b), which _clean runs inline (the feed checks every sample).
def _num(lo: float, hi: float):
    def check(x):
        if x is None:
            return None
        t = type(x)
        if (t is float or t is int) and lo <= x <= hi:  # NaN and infinities fail the comparison
            return x
        raise _Bad

    check.spec = ("n", lo, hi)
    return check


def _int(lo: int, hi: int):
    def check(x):
        if x is None:
            return None
        if type(x) is int and lo <= x <= hi:
            return x
        raise _Bad

    check.spec = ("i", lo, hi)
    return check


def _bool(x):
    if x is None or type(x) is bool:
        return x
    raise _Bad


_bool.spec = ("b", 0, 0)


def _str(max_len: int = MAX_ID_LEN):
    def check(x):
        if x is None or text_ok(x, max_len):
            return x
        raise _Bad

    check.spec = ("s", max_len, 0)
    return check


def _vec3(limit: float):
    def check(x):
        if x is None:
            return None
        if type(x) is list and len(x) == 3:
            for c in x:
                t = type(c)
                if not ((t is float or t is int) and -limit <= c <= limit):
                    raise _Bad
            return x
        raise _Bad

    return check


def _map(value_check, max_items: int, key_len: int = MAX_ID_LEN):
    def check(x):
        if x is None:
            return None
        if type(x) is not dict or len(x) > max_items:
            raise _Bad
        for k, v in x.items():
            if not text_ok(k, key_len):
                raise _Bad
            value_check(v)
        return x

    return check


def _list(item_check, max_items: int = MAX_LIST):
    def check(x):
        if x is None:
            return None
        if type(x) is not list or len(x) > max_items:
            raise _Bad
        for v in x:
            if v is None:
                raise _Bad
            item_check(v)
        return x

    return check


def _object(fields: dict):
    fields = _compile(fields)

    def check(x):
        if x is None:
            return None
        if type(x) is not dict:
            raise _Bad
        return _clean(fields, x)

    return check


def _scalar_ok(v) -> bool:
    t = type(v)
    if v is None or t is bool or t is int:
        return True
    if t is float:
        return v == v and v not in (float("inf"), float("-inf"))
    return t is str and text_ok(v, MAX_TEXT_LEN)


def _unknown_ok(v) -> bool:
    if type(v) is list:
        return len(v) <= MAX_UNKNOWN_LIST and all(_scalar_ok(x) for x in v)
    return _scalar_ok(v)


def _compile(fields: dict) -> dict:
    """name -> (code, a, b, check): code n/i/b/s is checked inline by _clean, f calls check."""
    return {k: (*getattr(check, "spec", ("f", 0, 0)), check) for k, check in fields.items()}


def _clean(fields: dict, payload: dict) -> dict:
    out = {}
    unknown = 0
    bad = _BAD_CHARS.search
    for k, v in payload.items():
        spec = fields.get(k)
        if spec is not None:
            if v is None:
                out[k] = None
                continue
            code, a, b, check = spec
            t = type(v)
            if code == "n":
                if (t is float or t is int) and a <= v <= b:
                    out[k] = v
                    continue
            elif code == "s":
                if t is str and len(v) <= a and not bad(v):
                    out[k] = v
                    continue
            elif code == "i":
                if t is int and a <= v <= b:
                    out[k] = v
                    continue
            elif code == "b":
                if t is bool:
                    out[k] = v
                    continue
            else:
                try:
                    out[k] = check(v)
                    continue
                except _Bad:
                    pass
                except Rejected as exc:  # a nested object's field
                    raise Rejected(f"{k}.{exc.reason}") from None
            raise Rejected(k)
        elif unknown < MAX_UNKNOWN_FIELDS and text_ok(k) and _unknown_ok(v):
            out[k] = v
            unknown += 1
    return out


# -- the checks of the contract's fields (avionics/contract/zenoh.py: type and limit) ----------------------------------
def check_of(field: Field):
    """The check of one contract field: its type, within its limit (a bands kind: ordered intervals)."""
    t, limit = field.type, field.limit
    if t == "float":
        return _num(*limit)
    if t == "int":
        return _int(*limit)
    if t == "bool":
        return _bool
    if t == "string":
        return _str(limit)
    if t == "float[3]":
        return _vec3(limit)
    if t == "[string]":
        return _list(_str(limit), field.size or MAX_LIST)
    if t == "{string: float}":
        return _map(_num(*limit), field.size, field.key_len)
    if t == "{string: int}":
        return _map(_int(*limit), field.size)
    if t == "{string: bool}":
        return _map(_bool, field.size)
    if t == "{string: [string]}":
        return _map(_list(_str(limit), MAX_UNKNOWN_LIST), field.size)
    if t == "object":
        return _object(table(field.fields))
    if t == "[object]" and field.name in BAND_KIND_NAMES:
        return _intervals(*limit, field.size)
    if t == "[object]":
        return _objects(table(field.fields), field.size)
    raise ValueError(f"no check for {field.name}: {t}")


def table(fields, only=None) -> dict:
    """name -> check of the contract's fields (only: of those names, the ones the monitor shows)."""
    return {f.name: check_of(f) for f in fields if only is None or f.name in only}


BAND_EPS = 1e-6  # order tolerance between consecutive intervals (their bounds are the same numbers)


def _intervals(lo: float, hi: float, max_items: int):
    """A kind's bands: [{lower, upper, region}] in increasing order within [lo, hi]; [] = no bands computed.
    An interval with a bad field is Rejected naming it (`<kind>.region`); out of order or range raises _Bad."""
    items = _objects({"lower": _num(lo, hi), "upper": _num(lo, hi), "region": _str(MAX_ID_LEN)}, max_items)

    def check(x):
        bands = items(x)
        if bands is None:
            return None
        previous = lo
        for band in bands:
            lower, upper, region = band.get("lower"), band.get("upper"), band.get("region")
            if lower is None or upper is None or region is None or lower > upper or lower < previous - BAND_EPS:
                raise _Bad  # an interval must say where it is and what it is, in increasing order
            previous = upper
        return [{"lower": b["lower"], "upper": b["upper"], "region": b["region"]} for b in bands]  # nothing else

    return check


def _objects(fields: dict, max_items: int):
    """A list of objects, each cleaned by fields (a bad one rejects the sample, naming its field)."""
    fields = _compile(fields)

    def check(x):
        if x is None:
            return None
        if type(x) is not list or len(x) > max_items:
            raise _Bad
        out = []
        for item in x:
            if type(item) is not dict:
                raise _Bad
            out.append(_clean(fields, item))
        return out

    return check


# The monitor checks every field of the contract's payloads, but the status's fields it does not show: a change to
# their form never costs a status (its ownship is the status's, checked whole). Older schemas' names it still reads
# (monitor/state.py): a track's `imm_mode`, an advisory's `pc`.
STATUS_SHOWN = ("schema", "vehicle", "time_s", "version", "ownship", "ownship_valid", "pressure_altitude_available",
                "datum_mismatch_intruders", "sensitivity_level", "tracks", "advisories", "warnings", "counters")
OLDER = {"tracks": {"imm_mode": _str(MAX_ID_LEN)}, "advisories": {"pc": _num(*contract_fields.PROBABILITY)}}
KIND_FIELDS = {
    "tracks": _compile({**table(contract.TRACK), **OLDER["tracks"]}),
    "advisories": _compile({**table(contract.ADVISORY), **OLDER["advisories"]}),
    "ownship": _compile(table(contract.OWNSHIP)),
    "status": _compile(table(contract.STATUS, STATUS_SHOWN)),
    "bands": _compile(table(contract.BANDS)),
    "traffic": _compile(table(contract.TRAFFIC_HEADER)),
}
COMMON = table(contract.COMMON)


def clean_sample(kind: str, payload, name: str | None = None) -> dict:
    """The checked payload of one sample of `kind` (tracks | advisories | ownship | status | bands), or Rejected.
    name: the intruder id from the key expression; the payload's `intruder` must match it (or is set to it)."""
    if type(payload) is not dict:
        raise Rejected("type")
    out = _clean(KIND_FIELDS[kind], payload)
    if name is not None:
        intruder = out.get("intruder")
        if intruder is None:
            out["intruder"] = name
        elif intruder != name:
            raise Rejected("intruder_key")  # the page would show one id and remove another
    return out


def clean_snapshot(snap, rejected: dict | None = None) -> dict:
    """A snapshot reply checked element by element: a bad track, advisory or change is left out (and counted in
    `rejected`, reason -> n); a snapshot that is not an object, or whose ownship or status is bad, is Rejected."""
    if type(snap) is not dict:
        raise Rejected("type")
    out = {}
    for key in ("schema", "time_s"):
        try:
            out[key] = COMMON[key](snap.get(key))
        except _Bad:
            raise Rejected(key) from None
    for key, kind in (("ownship", "ownship"), ("status", "status")):
        value = snap.get(key)
        out[key] = None if value is None else clean_sample(kind, value)
    bands = snap.get("bands")  # not in the snapshot contract (yet): taken when present, left out when bad
    if bands is not None:
        try:
            out["bands"] = clean_sample("bands", bands)
        except Rejected as exc:
            if rejected is not None:
                reason = f"bands.{exc.reason}"
                rejected[reason] = rejected.get(reason, 0) + 1
    for key, kind in (("tracks", "tracks"), ("advisories", "advisories"), ("advisory_changes", "advisories")):
        items = snap.get(key)
        if items is None:
            out[key] = []
            continue
        if type(items) is not list or len(items) > MAX_LIST:
            raise Rejected(key)
        good = []
        for item in items:
            try:
                p = clean_sample(kind, item)
                check_id(p.get("intruder"))  # a snapshot element names its intruder
                good.append(p)
            except Rejected as exc:
                if rejected is not None:
                    reason = f"{key}.{exc.reason}"
                    rejected[reason] = rejected.get(reason, 0) + 1
        out[key] = good
    return out


def clean_traffic(raw: bytes, vehicle: str, rejected: dict | None = None) -> list[dict]:
    """The good rows of a traffic batch (io/traffic.py), each a checked per-track payload; a bad row is left out
    and counted in `rejected` (`row.<field>` -> n). Rejected when the batch as a whole is not the contract's:
    `size`, `arrow` (not a valid Arrow IPC stream), `rows`, `header`, `keys`, `type.<column>`, `columns`,
    `vehicle_key` (the header names another vehicle than the key expression)."""
    from avionics.io.traffic import TrafficError, decode_traffic

    if len(raw) > MAX_TRAFFIC_BYTES:
        raise Rejected("size")
    try:
        header, rows = decode_traffic(raw, MAX_TRAFFIC_ROWS)
    except TrafficError as exc:
        raise Rejected(exc.reason) from None
    try:
        header_ok = _clean(KIND_FIELDS["traffic"], header)
    except Rejected as exc:
        raise Rejected(f"header.{exc.reason}") from None
    if header_ok.get("vehicle") != vehicle:
        raise Rejected("vehicle_key")
    good = []
    for row in rows:
        try:
            p = clean_sample("tracks", row)
            check_id(p.get("intruder"))  # a row names its intruder
            good.append(p)
        except Rejected as exc:
            if rejected is not None:
                reason = f"row.{exc.reason}"
                rejected[reason] = rejected.get(reason, 0) + 1
    return good
