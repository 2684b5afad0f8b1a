"""ROS 2 on the wire: the zenoh samples also published as ROS 2 messages, CDR-encoded, on ROS-style keys.

Why CDR over zenoh, not DDS: the process already holds a zenoh session, and `zenoh-bridge-ros2dds` (eclipse-zenoh,
the bridge ROS 2 users run to carry topics over zenoh) maps a zenoh key `K` to the ROS topic `/K` and forwards the
payload as the DDS sample it is: the CDR serialisation with its 4-byte encapsulation header. A bridge on the
ground started with `--namespace /<vehicle>` gives ROS nodes `/daa/advisories`, `/daa/traffic`, `/daa/bands` and
`/diagnostics`-style status on `/daa/status` (docs/zenoh.md, "ROS 2"). No DDS library flies with us (cyclonedds
is a native dependency a companion computer would have to carry for four topics). rmw_zenoh's own key format
(domain, type name and hash in the key, an attachment per sample) is not produced.

Messages: standard where one exists (status as `diagnostic_msgs/msg/DiagnosticArray`), else the small package
`avionics_msgs` shipped beside this module (`ros2_msgs/avionics_msgs/msg/*.msg`: Advisory, Track, TrackArray,
Bands, BandInterval), each the JSON payload of the same sample (avionics/io/payloads.py), field for field.

Encoding (OMG DDS-XTypes 1.3, 7.4.1, "CDR", plain CDR = XCDR1, little endian, as ROS 2's default RMWs write it):
the header 00 01 00 00 (CDR_LE), then the fields in order, each primitive aligned to its size counted from the
end of the header; a string is a uint32 length including its NUL, the bytes, the NUL; a sequence T[] a uint32
count then its elements; an array T[N] its N elements. The message layouts are read from the .msg files, so the
definitions a ROS user builds are the ones we write (tests/test_ros2.py decodes with `rosbags`, not with this).
"""

from __future__ import annotations

import math
import struct
from functools import lru_cache
from importlib import resources

import zenoh

from avionics.contract.bands import BAND_KIND_NAMES

# The standard definitions the messages use, as ros2/common_interfaces (std_msgs, diagnostic_msgs; Humble) and
# ros2/rcl_interfaces (builtin_interfaces) define them.
STANDARD = {
    "builtin_interfaces/msg/Time": "int32 sec\nuint32 nanosec\n",
    "std_msgs/msg/Header": "builtin_interfaces/Time stamp\nstring frame_id\n",
    "diagnostic_msgs/msg/KeyValue": "string key\nstring value\n",
    "diagnostic_msgs/msg/DiagnosticStatus": "byte OK=0\nbyte WARN=1\nbyte ERROR=2\nbyte STALE=3\nbyte level\n"
                                            "string name\nstring message\nstring hardware_id\nKeyValue[] values\n",
    "diagnostic_msgs/msg/DiagnosticArray": "std_msgs/Header header\nDiagnosticStatus[] status\n",
}
OURS = ("Advisory", "Track", "TrackArray", "BandInterval", "Bands")
PRIMITIVES = {"bool": "?", "byte": "B", "char": "B", "uint8": "B", "int8": "b", "int16": "h", "uint16": "H",
              "int32": "i", "uint32": "I", "int64": "q", "uint64": "Q", "float32": "f", "float64": "d"}
CDR_LE = b"\x00\x01\x00\x00"
# The zenoh keys under the vehicle's namespace, by the JSON topic they encode (docs/zenoh.md, "ROS 2").
TOPICS = {"advisories": "daa/advisories", "traffic": "daa/traffic", "bands": "daa/bands", "status": "daa/status"}


def definition(name: str) -> str:
    """The .msg text of a message type ("pkg/msg/Type")."""
    if name in STANDARD:
        return STANDARD[name]
    package, _, short = name.split("/")
    if package != "avionics_msgs" or short not in OURS:
        raise KeyError(name)
    return (resources.files("avionics.io") / "ros2_msgs" / package / "msg" / f"{short}.msg").read_text()


@lru_cache(maxsize=None)
def fields(name: str) -> tuple[tuple[str, str], ...]:
    """(type, field name) of a message's fields, types fully qualified; constants and comments skipped."""
    package = name.split("/")[0]
    out = []
    for line in definition(name).splitlines():
        line = line.split("#", 1)[0].strip()
        if not line or "=" in line:
            continue
        type_, field = line.split()[:2]
        base = type_.split("[", 1)[0]
        if base not in PRIMITIVES and base != "string":
            pkg, _, short = base.rpartition("/")
            full = f"{pkg or package}/msg/{short}"
            type_ = full + type_[len(base):]
        out.append((type_, field))
    return tuple(out)


class _Writer:
    def __init__(self):
        self.buf = bytearray()

    def align(self, n: int) -> None:
        self.buf += b"\x00" * (-len(self.buf) % n)

    def primitive(self, code: str, value) -> None:
        size = struct.calcsize(code)
        self.align(size)
        self.buf += struct.pack("<" + code, value)

    def string(self, value: str) -> None:
        data = value.encode("utf-8") + b"\x00"
        self.primitive("I", len(data))
        self.buf += data

    def value(self, type_: str, value) -> None:
        base, bracket, rest = type_.partition("[")
        if bracket:
            items = list(value)
            if rest == "]":  # sequence: count, then the elements
                self.primitive("I", len(items))
            elif len(items) != int(rest.rstrip("]")):
                raise ValueError(f"{type_}: {len(items)} elements")
            for item in items:
                self.value(base, item)
        elif base == "string":
            self.string(value)
        elif base in PRIMITIVES:
            self.primitive(PRIMITIVES[base], value)
        else:
            for field_type, name in fields(base):
                self.value(field_type, value[name])


def serialize(name: str, message: dict) -> bytes:
    """One message as a DDS sample: the CDR_LE encapsulation header and the plain-CDR body."""
    w = _Writer()
    w.value(name, message)
    return CDR_LE + bytes(w.buf)


# -- the JSON payloads as messages ----------------------------------------------------------------------------------
def _f(v) -> float:
    return math.nan if v is None else float(v)


def _s(v) -> str:
    return "" if v is None else str(v)


def header(time_s: float, vehicle: str) -> dict:
    sec = math.floor(time_s)
    return {"stamp": {"sec": int(sec), "nanosec": min(int(round((time_s - sec) * 1e9)), 999_999_999)},
            "frame_id": vehicle}


def advisory_message(p: dict) -> dict:
    sl = p["sensitivity_level"]
    out = {"header": header(p["time_s"], p["vehicle"]), "intruder": p["intruder"], "address": int(p["address"]),
           "callsign": _s(p["callsign"]), "level": p["level"], "alert_level": int(p["alert_level"]),
           "alert_name": _s(p["alert_name"]), "reason": _s(p["reason"]), "sensitivity_level": -1 if sl is None else int(sl),
           "ra_sense": _s(p["ra_sense"]), "ra_strength": _s(p["ra_strength"]), "ra_words": _s(p["ra_words"]),
           "ra_reversed": bool(p["ra_reversed"]), "ra_crossing": bool(p["ra_crossing"]),
           "ra_composite": bool(p["ra_composite"]), "integrity": _s(p["integrity"])}
    for key in ("range_m", "closure_rate_mps", "t_cpa_s", "hmd_m", "vmd_m", "range_tau_s", "mod_tau_s", "vertical_tau_s",
                "target_vertical_rate_mps", "ra_separation_m"):
        out[key] = _f(p[key])
    return out


def track_message(p: dict) -> dict:
    return {"intruder": p["intruder"], "address": int(p["address"]), "callsign": _s(p["callsign"]),
            "latitude_deg": _f(p["lat_deg"]), "longitude_deg": _f(p["lon_deg"]), "altitude_m": _f(p["altitude_m"]),
            "altitude_datum": _s(p["altitude_datum"]), "velocity_enu_mps": [float(v) for v in p["velocity_enu_mps"]],
            "ground_speed_mps": _f(p["ground_speed_mps"]), "track_deg": _f(p["track_deg"]),
            "position_sigma_m": _f(p["position_sigma_m"]), "velocity_sigma_mps": _f(p["velocity_sigma_mps"]),
            "age_s": _f(p["age_s"]), "advisory": p["advisory"], "integrity": _s(p["integrity"]),
            "spoof_suspected": bool(p["spoof_suspected"])}


def bands_message(p: dict) -> dict:
    out = {"header": header(p["time_s"], p["vehicle"]), "alerter": p["alerter"]}
    for kind in BAND_KIND_NAMES:
        out[kind] = [{"lower": float(b["lower"]), "upper": float(b["upper"]), "region": b["region"]} for b in p[kind]]
        out[f"recovery_{kind}"] = bool(p["recovery"][kind])
    return out


def status_message(p: dict) -> dict:
    """The status payload as one DiagnosticStatus named "daa": ERROR while DAA is unavailable, WARN with warnings,
    else OK; the message says why; values: the warnings and every counter, as strings (the diagnostics
    convention: REP 107's aggregator and rqt_runtime_monitor read them)."""
    unavailable, warnings = p.get("unavailable_reason"), list(p.get("warnings") or ())
    level = 2 if unavailable else 1 if warnings else 0
    message = f"unavailable: {unavailable}" if unavailable else "; ".join(warnings) or "ok"
    values = [{"key": f"warning{i}", "value": w} for i, w in enumerate(warnings)]
    values += [{"key": k, "value": str(v)} for k, v in (p.get("counters") or {}).items()]
    return {"header": header(p["time_s"], p["vehicle"]),
            "status": [{"level": level, "name": "daa", "message": message, "hardware_id": p["vehicle"],
                        "values": values}]}


def encode(kind: str, payload) -> tuple[str, bytes] | None:
    """(topic under the vehicle's namespace, sample) of one zenoh sample (its topic kind and payload), or None
    for the kinds with no ROS 2 topic (per-track keys: the traffic array carries them; ownship)."""
    if kind == "advisories":
        return TOPICS[kind], serialize("avionics_msgs/msg/Advisory", advisory_message(payload))
    if kind == "traffic":  # a TrafficBatch
        tracks = [track_message(p) for p in payload.payloads()]
        return TOPICS[kind], serialize("avionics_msgs/msg/TrackArray",
                                       {"header": header(payload.time_s, payload.vehicle), "tracks": tracks})
    if kind == "bands":
        return TOPICS[kind], serialize("avionics_msgs/msg/Bands", bands_message(payload))
    if kind == "status":
        return TOPICS[kind], serialize("diagnostic_msgs/msg/DiagnosticArray", status_message(payload))
    return None


class Ros2Publisher:
    """Puts the ROS 2 encoding of the zenoh bus's samples on `<namespace>/<topic>`, on the bus's publisher thread
    (avionics/io/zenoh_bus.py): advisories reliable and ahead of data, as their JSON twins."""

    def __init__(self, session: zenoh.Session, namespace: str):
        self.session = session
        self.namespace = namespace.strip("/")
        self._publishers: dict[str, zenoh.Publisher] = {}

    def put(self, kind: str, payload) -> None:
        encoded = encode(kind, payload)
        if encoded is None:
            return
        topic, sample = encoded
        pub = self._publishers.get(topic)
        if pub is None:
            advisory = kind == "advisories"
            pub = self._publishers[topic] = self.session.declare_publisher(
                f"{self.namespace}/{topic}", encoding=zenoh.Encoding.APPLICATION_CDR,
                congestion_control=zenoh.CongestionControl.BLOCK if advisory else zenoh.CongestionControl.DROP,
                priority=zenoh.Priority.INTERACTIVE_HIGH if advisory else zenoh.Priority.DATA)
        pub.put(sample)
