"""The output contract (avionics/contract/, issue 31): every output declared once, and what must agree with it.

- docs/zenoh.md's field tables (advisory, track, status, ownship, bands, and the sensor input) name the contract's
  fields with its types and units, and docs/mavlink.md's DAA_ADVISORY, DAA_BANDS and DAA_SENSOR_MEASUREMENT tables
  its message fields: docs and code cannot drift.
- The generated dialect has those messages' contract fields with their types, and every enum entry the contract
  names.
- What the ports publish, from a real run, has the contract's fields in its order; the traffic batch's Arrow
  columns have the contract's types.
- Both advisory ports name an intruder alike: after its track is dropped, the zenoh advisory carries the callsign
  that DAA_ADVISORY carries (one callsign memory, one refresh clock: ports.AdvisoryAnnouncements).
"""

from __future__ import annotations

import re

import pytest

import avionics.io  # noqa: F401  (MAVLink 2)
from avionics.config import load_config
from avionics.contract import bands as contract_bands, mavlink as contract_mavlink, zenoh as contract
from avionics.contract.fields import Field
from avionics.base.types import Advisory, AddressSource, IntruderKey
from avionics.io.dialect import daa as m2
from avionics.io.traffic import TrafficBatch
from avionics.ports import ZenohOut
from avionics_sitl.autopilot import schedule
from avionics_sitl.encounters import load_encounter, load_scenario
from avionics_sitl.impairments import PRESETS
from avionics_sitl.replay import replay
from harness import Harness
from tests.conftest import ROOT
from tests.test_mavlink_out import _framed, _from_sitl

HEADON = IntruderKey(0xA10001, AddressSource.ES1090)


# -- the docs' tables -----------------------------------------------------------------------------------------------

def doc_table(doc: str, heading: str) -> list[list[str]]:
    """The cells of the first table under `heading` (a line of the doc), its header and rule left out."""
    lines = (ROOT / "docs" / doc).read_text().splitlines()
    i = lines.index(heading) + 1
    while not lines[i].startswith("|"):
        i += 1
    rows = []
    while i < len(lines) and lines[i].startswith("|"):
        rows.append([c.strip() for c in re.split(r"(?<!\\)\|", lines[i].strip())[1:-1]])
        i += 1
    return rows[2:]


def flat(fields, prefix: str = "") -> dict[str, Field]:
    """Name -> field, an object's fields as `name.sub` and a list of objects' as `name[].sub` (as the docs write)."""
    out = {}
    for f in fields:
        out[prefix + f.name] = f
        if f.fields and f.type == "object":
            out.update(flat(f.fields, f"{prefix}{f.name}."))
        elif f.fields and f.name not in contract_bands.BAND_KIND_NAMES:
            out.update(flat(f.fields, f"{prefix}{f.name}[]."))
    return out


DOC_TYPES = {"[float, float, float]": "float[3]", "[float ×3]": "float[3]"}


def doc_type(field: Field) -> str:
    """The field's type as the docs write it: a map is an object."""
    return "object" if field.type.startswith("{") else field.type


ZENOH_TABLES = [("## Advisory", contract.ADVISORY, False), ("## Track", contract.TRACK, False),
                ("## Status", contract.STATUS, True), ("### Ownship", contract.OWNSHIP, False),
                ("## Bands", contract.BANDS, False), ("## Sensor", contract.SENSOR, True)]


@pytest.mark.parametrize("heading, fields, nested", ZENOH_TABLES, ids=[h for h, _, _ in ZENOH_TABLES])
def test_docs_zenoh_field_tables_are_the_contract(heading, fields, nested):
    declared = flat(fields) if nested else {f.name: f for f in fields}
    documented = {}
    for cells in doc_table("zenoh.md", heading):
        names = re.findall(r"`([^`]+)`", cells[0])
        kind = DOC_TYPES.get(cells[1], cells[1])
        units = {u.strip() for u in cells[2].split(",")} if cells[2] else set()
        for name in names:
            documented[name] = (kind, units)
    assert sorted(set(documented) - set(declared)) == [], "documented, not in the contract"
    assert sorted(set(declared) - set(documented)) == [], "in the contract, not documented"
    for name, (kind, units) in documented.items():
        field = declared[name]
        assert not kind or kind == doc_type(field), (name, kind, field.type)
        assert not units or field.unit in units, (name, units, field.unit)


def test_docs_zenoh_key_expressions_are_the_contracts():
    documented = {re.fullmatch(r"`<prefix>/<vehicle>/(.+)`", cells[0]).group(1)
                  for heading in ("## Key expressions", "### More key expressions")
                  for cells in doc_table("zenoh.md", heading)}
    assert documented == set(contract.KEYS)


MAVLINK_TABLES = [("### DAA_ADVISORY", contract_mavlink.DAA_ADVISORY, "daa_advisory"),
                  ("### DAA_BANDS", contract_mavlink.DAA_BANDS, "daa_bands"),
                  ("### DAA_SENSOR_MEASUREMENT", contract_mavlink.DAA_SENSOR_MEASUREMENT, "daa_sensor_measurement")]


def _heading(doc: str, start: str) -> str:
    return next(line for line in (ROOT / "docs" / doc).read_text().splitlines() if line.startswith(start))


@pytest.mark.parametrize("heading, fields, message", MAVLINK_TABLES, ids=[m for _, _, m in MAVLINK_TABLES])
def test_docs_mavlink_tables_and_the_dialect_are_the_contract(heading, fields, message):
    documented = {}
    for cells in doc_table("mavlink.md", _heading("mavlink.md", heading)):
        kind = cells[1].split()[0]
        for name in re.findall(r"`([^`]+)`", cells[0]):
            base, _, length = name.partition("[")
            documented[base] = (f"{kind}[{length}" if length else kind, cells[2])
    assert documented == {f.name: (f.type, f.unit) for f in fields}
    cls = getattr(m2, f"MAVLink_{message}_message")
    lengths = dict(zip(cls.ordered_fieldnames, cls.array_lengths))  # pymavlink: in wire order
    generated = {name: f"{kind}[{lengths[name]}]" if lengths[name] else kind
                 for name, kind in zip(cls.fieldnames, cls.fieldtypes)}
    assert generated == {f.name: re.sub(r"^(u?int\d+)", r"\1_t", f.type) for f in fields}


def test_every_dialect_name_the_contract_uses_exists():
    tables = (contract_mavlink.THREAT_LEVEL, contract_mavlink.DO365_THREAT_LEVEL, contract_mavlink.ACTION,
              contract_mavlink.ACTION_REQUEST, contract_mavlink.SENSE, contract_mavlink.STRENGTH,
              contract_mavlink.INTEGRITY, contract_mavlink.SEVERITY, contract_bands.BAND_REGIONS)
    names = [name for table in tables for name in table.values()]
    names += [k.mavlink for k in contract_bands.BAND_KINDS] + [contract_bands.BAND_REGION_UNKNOWN]
    names += [*contract_mavlink.SENSOR_KIND.values(), contract_mavlink.SENSOR_ADDRESS_VALID]
    assert [n for n in names if not isinstance(getattr(m2, n, None), int)] == []
    assert m2.MAVLink_statustext_message.array_lengths[m2.MAVLink_statustext_message.fieldnames.index("text")] \
        == contract_mavlink.STATUSTEXT_LEN


def test_every_advisory_field_not_made_by_the_builder_is_an_advisory_attribute():
    from avionics.io.payloads import _ADVISORY_MADE

    attributes = set(Advisory.__dataclass_fields__)
    assert [f.name for f in contract.ADVISORY if f.name not in _ADVISORY_MADE and f.name not in attributes] == []


# -- what the ports publish -----------------------------------------------------------------------------------------

@pytest.fixture(scope="module")
def published():
    """Every zenoh sample of the head-on under a DO-365 alerter (advisories, tracks, traffic, ownship, status,
    bands), by kind."""
    config = load_config(overrides=["advisory.profile=do365"])
    samples: dict = {}
    port = ZenohOut(lambda suffix, payload: samples.setdefault(suffix.split("/")[0], []).append(payload), config)
    replay(load_scenario("head-on"), config, PRESETS["none"], ports=[port])
    return samples


@pytest.mark.parametrize("kind", ["advisories", "tracks", "ownship", "status", "bands"])
def test_published_payloads_have_the_contracts_fields_in_its_order(published, kind):
    order = [f.name for f in contract.PAYLOADS[kind]]
    assert published[kind]
    for payload in published[kind]:
        if kind == "ownship" and not payload["valid"]:
            assert list(payload) == order[:4]
            continue
        assert [k for k in payload if k not in order] == [], "not in the contract"
        assert list(payload) == [name for name in order if name in payload], "not in the contract's order"
        optional = {f.name for f in contract.IMM} if kind == "tracks" else set()
        assert [name for name in order if name not in payload and name not in optional] == [], "missing"


def test_the_traffic_batch_has_the_contracts_arrow_types(published):
    import pyarrow as pa

    batches = published["traffic"]
    batch = next(b for b in batches if b.tracks)
    batch_table = pa.ipc.open_stream(pa.py_buffer(batch.encode())).read_all()
    schema = batch_table.schema
    arrow = {"str": pa.string(), "i32": pa.int32(), "i64": pa.int64(), "bool": pa.bool_(), "f64": pa.float64(),
             "f64[3]": pa.list_(pa.float64(), 3)}
    assert schema.names == [name for name in contract.TRAFFIC_COLUMNS if name in schema.names]
    for field in schema:
        want = contract.TRAFFIC_COLUMNS[field.name]
        column = batch_table.column(field.name)
        if want == "f64[k]" and column.null_count == len(column):  # vb_noise without a vb-* filter: nulls
            assert field.type == pa.float64(), field
        elif want == "f64[k]":
            assert pa.types.is_fixed_size_list(field.type) and field.type.value_type == pa.float64(), field
        else:
            assert field.type == arrow[want], field
    assert isinstance(batch, TrafficBatch)
    assert schema.metadata[b"schema"] == str(contract.SCHEMA_VERSION).encode()


# -- one callsign memory for both ports -----------------------------------------------------------------------------

def test_after_its_track_is_dropped_the_zenoh_advisory_names_the_intruder_as_daa_advisory_does():
    """The head-on's reports stop 2 s into its TA: the TA is held as lost, and ends when the track is deleted. The
    end's zenoh advisory and its DAA_ADVISORY both carry the callsign HEADON, though the facade no longer knows it
    (the track is gone)."""
    node = Harness(load_config())
    events = [e for e in schedule(load_encounter("head-on"), PRESETS["none"], duration_s=100.0)
              if not (e.msg.get_type() == "ADSB_VEHICLE" and e.deliver_s >= 57.0)]
    mavlink, i, t, results = [], 0, 0.0, []
    while t <= 100.0:
        batch = []
        while i < len(events) and events[i].deliver_s <= t + 1e-9:
            batch.append(events[i].msg)
            i += 1
        results.append(node.handle(_from_sitl(batch), t))
        mavlink += _framed(node.mavlink_out)
        node.mavlink_out.clear()
        t = round(t + 0.1, 6)
    end = next(r for r in results for a in r.changes if a.intruder == HEADON and a.reason == "lost" and not a.level)
    assert end.callsigns.get(HEADON) is None  # the track is gone: the facade has no callsign for it
    zenoh = [p for suffix, p in node.zenoh_out if suffix == f"advisories/{HEADON}"]
    daa = [m for m in mavlink if m.get_type() == "DAA_ADVISORY" and m.id == HEADON.address]
    assert zenoh and len(zenoh) == len(daa)  # one refresh clock: the same advisories at the same steps
    assert [p["callsign"] for p in zenoh] == [m.callsign for m in daa]
    assert zenoh[-1]["reason"] == "lost" and zenoh[-1]["level"] == "NONE" and zenoh[-1]["callsign"] == "HEADON"
