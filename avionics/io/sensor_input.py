"""Range/bearing sensor measurements on the wire (issue 30): the zenoh sensor payload (`<prefix>/<vehicle>/sensor/<id>`,
contract/zenoh.py SENSOR, docs/zenoh.md "Sensor") and MAVLink DAA_SENSOR_MEASUREMENT (our dialect, 52612,
contract/mavlink.py, docs/mavlink.md), each built from and decoded into tracking/measurement.py PolarMeasurement.

Decoding treats a sample as data to check, as decode.py treats ADSB_VEHICLE: every rejection is counted
(`sensor.zenoh.<reason>`, `sensor.mavlink.<reason>`) and nothing is raised. A zenoh sample that is not JSON, not an
object, or whose scan fields (time, age, kind, mount) are missing or out of the contract's range is rejected whole;
a return with a bad field is left out and counted (`sensor.zenoh.return.<field>`), the scan's other returns kept; a
return that PolarMeasurement.problem() refuses is counted `...problem`. A measurement is dated on the receiver's
clock: receipt minus the sender's `age` (the sensor's own clock is not the process's, as ADSB_VEHICLE's tslc).

The mount (field of regard, range limits, rate) comes from the zenoh payload (null: SensorMount's all-round default);
DAA_SENSOR_MEASUREMENT has no room for it, so its decoder takes the mounts from configuration (sensor instance text
-> SensorMount) and gives an unconfigured instance an all-round mount of the message's kind. The tracker uses the
mount's kind only; the field of regard is declared for whoever reads the measurements.
"""

from __future__ import annotations

import json
import math
import threading
from collections import Counter, deque
from dataclasses import replace

from avionics.contract import mavlink as contract_mavlink
from avionics.contract.fields import Field
from avionics.contract.zenoh import MAX_SENSOR_AGE_S, SCHEMA_VERSION, SENSOR, SENSOR_RETURN
from avionics.io.dialect import daa as m2
from avionics.base.types import SensorScan
from avionics.tracking.measurement import SENSOR_KINDS, PolarMeasurement, SensorMount

MAX_SAMPLE_BYTES = 64 * 1024  # a scan of MAX_SENSOR_RETURNS returns is ~60 kB of JSON
MAX_QUEUED_SAMPLES = 1024  # zenoh samples waiting for the loop (10 Hz x a few sensors, many seconds' worth)
_KIND_CODE = {kind: getattr(m2, name) for kind, name in contract_mavlink.SENSOR_KIND.items()}
_CODE_KIND = {code: kind for kind, code in _KIND_CODE.items()}
_ADDRESS_VALID = getattr(m2, contract_mavlink.SENSOR_ADDRESS_VALID)
_MOUNT_FIELDS = ("boresight_deg", "half_azimuth_deg", "elevation_min_deg", "elevation_max_deg", "min_range_m",
                 "max_range_m", "rate_hz")  # payload field -> SensorMount attribute of the same name
_SCAN_FIELDS = tuple(f for f in SENSOR if f.name != "returns")
_RETURNS = next(f for f in SENSOR if f.name == "returns")


def sensor_key(prefix: str, vehicle: str, sensor_id: str) -> str:
    return f"{prefix}/{vehicle}/sensor/{sensor_id}"


def _deg(rad: float | None) -> float | None:
    return None if rad is None else math.degrees(rad)


def sensor_payload(vehicle: str, mount: SensorMount, time_s: float, measurements, age_s: float = 0.0) -> dict:
    """One scan of one sensor as the zenoh payload (contract/zenoh.py SENSOR, in its order). time_s: the time of
    measurement on the sensor's clock; age_s: how old it is now."""
    scan = {"schema": SCHEMA_VERSION, "vehicle": vehicle, "time_s": time_s, "sensor": mount.sensor_id,
            "kind": mount.kind, "age_s": age_s}
    scan.update({name: getattr(mount, name) for name in _MOUNT_FIELDS})
    if math.isinf(mount.max_range_m):
        scan["max_range_m"] = None  # JSON has no infinity: null is unlimited
    scan["returns"] = [{
        "range_m": m.range_m, "azimuth_deg": math.degrees(m.azimuth_rad), "elevation_deg": _deg(m.elevation_rad),
        "range_rate_mps": m.range_rate_mps, "amplitude_db": None, "altitude_m": m.altitude_m, "address": m.address,
        "range_sigma_m": m.range_sigma_m, "azimuth_sigma_deg": math.degrees(m.azimuth_sigma_rad),
        "elevation_sigma_deg": _deg(m.elevation_sigma_rad), "range_rate_sigma_mps": m.range_rate_sigma_mps,
        "altitude_sigma_m": m.altitude_sigma_m} for m in measurements]
    return scan


def _value_ok(field: Field, v) -> bool:
    """v (not None) is of the field's type and within its limit (contract/fields.py)."""
    t = type(v)
    if field.type == "float":
        return (t is float or t is int) and field.limit[0] <= v <= field.limit[1]  # NaN and infinities fail
    if field.type == "int":
        return t is int and field.limit[0] <= v <= field.limit[1]
    if field.type == "string":
        return t is str and 0 < len(v) <= field.limit and v.isprintable()
    return False


def _bad_field(fields, obj: dict, required: tuple) -> str | None:
    """The first field of obj that is missing (when required) or not what the contract says, else None."""
    for f in fields:
        v = obj.get(f.name)
        if v is None:
            if f.name in required:
                return f.name
        elif not _value_ok(f, v):
            return f.name
    return None


_SCAN_REQUIRED = ("schema", "time_s", "sensor", "kind", "age_s")
_RETURN_REQUIRED = ("range_m", "azimuth_deg", "range_sigma_m", "azimuth_sigma_deg")


def _rad(v) -> float | None:
    return None if v is None else math.radians(v)


class SensorPayloadDecoder:
    """zenoh sensor samples -> PolarMeasurement; every rejection counted `sensor.zenoh.<reason>`."""

    def __init__(self, counters: Counter, vehicle: str | None = None):
        self.counters = counters
        self.vehicle = vehicle  # the payload's `vehicle` must be ours when given
        self._mounts: dict[tuple, SensorMount] = {}  # one SensorMount per distinct mount, not one per sample

    def _reject(self, reason: str) -> list:
        self.counters[f"sensor.zenoh.{reason}"] += 1
        return []

    def decode(self, raw: bytes, key_sensor: str, received_s: float) -> list[PolarMeasurement]:
        """The usable returns of one sample on `.../sensor/<key_sensor>`, received at received_s (process clock)."""
        self.counters["rx.sensor.zenoh"] += 1
        if len(raw) > MAX_SAMPLE_BYTES:
            return self._reject("size")
        try:
            scan = json.loads(raw)
        except (ValueError, RecursionError):  # UnicodeDecodeError is a ValueError
            return self._reject("json")
        if type(scan) is not dict:
            return self._reject("type")
        bad = _bad_field(_SCAN_FIELDS, scan, _SCAN_REQUIRED)
        if bad is not None:
            return self._reject(bad)
        if scan["sensor"] != key_sensor:
            return self._reject("sensor_key")  # the key and the payload name two sensors
        if self.vehicle is not None and scan.get("vehicle") not in (None, self.vehicle):
            return self._reject("vehicle")
        if scan["kind"] not in SENSOR_KINDS:
            return self._reject("kind")
        returns = scan.get("returns")
        if type(returns) is not list or len(returns) > _RETURNS.size:
            return self._reject("returns")
        mount = self._mount(scan)
        if mount is None:
            return self._reject("mount")
        time_s = received_s - scan["age_s"]
        out = []
        for item in returns:
            m = self._measurement(item, mount, time_s)
            if m is not None:
                out.append(m)
        return out

    def _mount(self, scan: dict) -> SensorMount | None:
        values = {name: scan[name] for name in _MOUNT_FIELDS if scan.get(name) is not None}
        key = (scan["sensor"], scan["kind"], *sorted(values.items()))
        mount = self._mounts.get(key)
        if mount is None:
            try:
                mount = SensorMount(scan["sensor"], scan["kind"], **values)
            except ValueError:  # a field of regard or range limits that contradict themselves
                return None
            if len(self._mounts) > 256:  # bounded under churn
                self._mounts.clear()
            self._mounts[key] = mount
        return mount

    def _measurement(self, item, mount: SensorMount, time_s: float) -> PolarMeasurement | None:
        if type(item) is not dict:
            self.counters["sensor.zenoh.return.type"] += 1
            return None
        bad = _bad_field(SENSOR_RETURN, item, _RETURN_REQUIRED)
        if bad is not None:
            self.counters[f"sensor.zenoh.return.{bad}"] += 1
            return None
        m = PolarMeasurement(
            mount=mount, time_s=time_s, range_m=item["range_m"], azimuth_rad=math.radians(item["azimuth_deg"]),
            range_sigma_m=item["range_sigma_m"], azimuth_sigma_rad=math.radians(item["azimuth_sigma_deg"]),
            elevation_rad=_rad(item.get("elevation_deg")), elevation_sigma_rad=_rad(item.get("elevation_sigma_deg")),
            altitude_m=item.get("altitude_m"), altitude_sigma_m=item.get("altitude_sigma_m"),
            range_rate_mps=item.get("range_rate_mps"), range_rate_sigma_mps=item.get("range_rate_sigma_mps"),
            address=item.get("address"))
        return _usable(m, self.counters, "sensor.zenoh")


def _usable(m: PolarMeasurement, counters: Counter, prefix: str) -> PolarMeasurement | None:
    """m, or None (counted `<prefix>.problem`) when PolarMeasurement.problem() refuses it; a range rate without its
    sigma (or the reverse) is dropped from m, counted `<prefix>.range_rate_unpaired`: the rest is still a fix."""
    if (m.range_rate_mps is None) != (m.range_rate_sigma_mps is None):
        counters[f"{prefix}.range_rate_unpaired"] += 1
        m = replace(m, range_rate_mps=None, range_rate_sigma_mps=None)
    if m.problem() is not None:
        counters[f"{prefix}.problem"] += 1
        return None
    return m


# -- MAVLink DAA_SENSOR_MEASUREMENT -------------------------------------------------------------------------------
def _nan(v: float | None) -> float:
    return math.nan if v is None else float(v)


def sensor_message(m: PolarMeasurement, time_s: float, age_s: float = 0.0, sensor_id: int = 0,
                   amplitude_db: float | None = None):
    """One detection as DAA_SENSOR_MEASUREMENT (contract/mavlink.py; absent values NaN). time_s: the time of
    measurement on the sender's clock; age_s: how old it is now (0 .. 65.535 s)."""
    address = m.address if m.address is not None else 0
    return m2.MAVLink_daa_sensor_measurement_message(
        int(round(time_s * 1e6)), min(65535, max(0, int(round(age_s * 1000)))), sensor_id, _KIND_CODE[m.mount.kind],
        _ADDRESS_VALID if m.address is not None else 0, address, m.range_m, m.azimuth_rad, _nan(m.elevation_rad),
        _nan(m.range_rate_mps), _nan(m.altitude_m), _nan(amplitude_db), m.range_sigma_m, m.azimuth_sigma_rad,
        _nan(m.elevation_sigma_rad), _nan(m.range_rate_sigma_mps), _nan(m.altitude_sigma_m))


def _present(v: float) -> float | None:
    """A float32 field: NaN is absent; an infinity stays (problem() refuses it)."""
    return None if math.isnan(v) else float(v)


class SensorMessageDecoder:
    """DAA_SENSOR_MEASUREMENT -> PolarMeasurement; every rejection counted `sensor.mavlink.<reason>`.
    mounts: sensor instance (decimal text) -> its SensorMount, from configuration."""

    def __init__(self, counters: Counter, mounts: dict[str, SensorMount] | None = None):
        self.counters = counters
        self.mounts = dict(mounts or {})
        self._scan: dict[str, tuple[int, float]] = {}  # instance -> (time_usec, time_s) of its latest scan

    def decode(self, msg, received_s: float) -> PolarMeasurement | None:
        self.counters["rx.sensor.mavlink"] += 1
        kind = _CODE_KIND.get(msg.kind)
        if kind is None:
            return self._reject("kind")
        if msg.age / 1000.0 > MAX_SENSOR_AGE_S:
            return self._reject("stale")
        name = str(msg.sensor_id)
        mount = self.mounts.get(name)
        if mount is None:
            mount = self.mounts[name] = SensorMount(name, kind)
        elif mount.kind != kind:
            return self._reject("kind_mismatch")  # the configured instance is another kind of sensor
        if msg.flags & _ADDRESS_VALID and not 0 < msg.address <= 0xFFFFFF:
            return self._reject("address")
        m = PolarMeasurement(
            mount=mount, time_s=self._time_s(name, msg, received_s), range_m=float(msg.range),
            azimuth_rad=float(msg.azimuth), range_sigma_m=float(msg.range_std),
            azimuth_sigma_rad=float(msg.azimuth_std), elevation_rad=_present(msg.elevation),
            elevation_sigma_rad=_present(msg.elevation_std), altitude_m=_present(msg.altitude),
            altitude_sigma_m=_present(msg.altitude_std), range_rate_mps=_present(msg.range_rate),
            range_rate_sigma_mps=_present(msg.range_rate_std),
            address=msg.address if msg.flags & _ADDRESS_VALID else None)
        return _usable(m, self.counters, "sensor.mavlink")

    def _time_s(self, name: str, msg, received_s: float) -> float:
        """receipt - age; the detections of one scan (one time_usec) share the first one's, though read apart, so
        the intake can group a scan by (sensor, time_s) as the zenoh sample groups it."""
        last = self._scan.get(name)
        if last is not None and last[0] == msg.time_usec:
            return last[1]
        time_s = received_s - msg.age / 1000.0
        self._scan[name] = (msg.time_usec, time_s)
        return time_s

    def _reject(self, reason: str) -> None:
        self.counters[f"sensor.mavlink.{reason}"] += 1
        return None


# -- the zenoh subscription ------------------------------------------------------------------------------------------
class SensorInputSource:
    """A loop Source (avionics/loop.py) with the zenoh sensor samples added to its batches as SensorScans: each
    sample is one scan (SensorPayloadDecoder; a rejected one is counted and adds nothing)."""

    def __init__(self, inner, subscriber: "SensorSubscriber", decoder: SensorPayloadDecoder):
        self.inner, self.subscriber, self.decoder = inner, subscriber, decoder

    def __iter__(self):
        for batch in self.inner:
            scans = []
            for sensor_id, raw, received_s in self.subscriber.drain():
                measurements = self.decoder.decode(raw, sensor_id, received_s)
                if measurements:
                    scans.append(SensorScan(measurements[0].time_s, sensor_id, tuple(measurements)))
            yield replace(batch, inputs=batch.inputs + scans) if scans else batch  # a loop.Batch

    def status(self):
        return self.inner.status()


class SensorSubscriber:
    """Subscribes to `<prefix>/<vehicle>/sensor/*` on an open session. The callback (zenoh's thread) only files
    (sensor id, payload bytes, receipt time on `clock`); the loop drains and decodes on its own thread, so the
    decoder's counters stay the loop's. More than MAX_QUEUED_SAMPLES waiting: the oldest is dropped (`dropped`)."""

    def __init__(self, session, prefix: str, vehicle: str, clock):
        self._clock = clock
        self._queue: deque = deque()
        self._lock = threading.Lock()
        self.dropped = 0
        self._subscriber = session.declare_subscriber(sensor_key(prefix, vehicle, "*"), self._on_sample)

    def _on_sample(self, sample) -> None:
        sensor_id = str(sample.key_expr).rsplit("/", 1)[-1]
        item = (sensor_id, sample.payload.to_bytes(), self._clock())
        with self._lock:
            if len(self._queue) >= MAX_QUEUED_SAMPLES:
                self._queue.popleft()
                self.dropped += 1
            self._queue.append(item)

    def drain(self) -> list[tuple[str, bytes, float]]:
        """Every sample filed since the last call, oldest first: (sensor id, payload, received_s)."""
        with self._lock:
            items = list(self._queue)
            self._queue.clear()
        return items

    def close(self) -> None:
        self._subscriber.undeclare()
