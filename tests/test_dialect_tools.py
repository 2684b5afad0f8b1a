"""Stock MAVLink tools read our messages by name from the shipped dialect XML (docs/mavlink.md, "The dialect").

Nothing of the project's own generated module is used on the reading side: pymavlink's mavgen.py turns the XML
installed with the package into a module, and pymavlink's parser and mavlogdump.py (the installed scripts) decode
frames our encoder and our link wrote. The id block declared in the XML is checked against every public dialect
pymavlink ships.
"""

from __future__ import annotations

import math
import os
import re
import socket
import subprocess
import sys
from collections import Counter
from importlib import resources
from pathlib import Path

from avionics.base.types import AddressSource, Advisory, AdvisoryLevel, AltitudeDatum, IntruderKey
from avionics.base.units import FPM
from avionics.io import encode
from avionics.io.dialect import daa
from avionics.io.link import MavlinkLink


BIN = Path(sys.executable).parent
XML = resources.files("avionics.io.dialect") / "daa.xml"
BLOCK = range(52610, 52620)
# Every block mavlink/mavlink's message_definitions/v1.0/all.xml assigns or reserves in its comments (commit de1e078,
# 2026-07-22): (owner, first, last message id). Its "next range to allocate" is 52610 - 52619, which we declare.
ALL_XML_BLOCKS = [("ardupilotmega", 11000, 11999), ("ASLUAV", 8000, 8999), ("common", 300, 10000),
                  ("icarous", 42000, 42999), ("uAvionix", 10001, 10999), ("storm32", 60000, 60049),
                  ("AVSSUAS", 60050, 60099), ("Herelink", 50000, 50099), ("ras_a", 51000, 51999),
                  ("csAirLink", 52000, 52099), ("reserved", 52100, 52499), ("marsh", 52500, 52599),
                  ("stemstudios", 52600, 52609), ("reserved", 53000, 53999)]


def _advisory() -> Advisory:
    return Advisory(
        intruder=IntruderKey(0xA10001, AddressSource.ES1090), level=AdvisoryLevel.RA, time_s=10.0,
        reason="tau", sensitivity_level=5, range_m=2700.0, closure_rate_mps=128.6, t_cpa_s=21.0, hmd_m=12.0,
        vmd_m=-30.0, range_tau_s=21.0, mod_tau_s=19.9, vertical_tau_s=math.inf,
        altitude_datum=AltitudeDatum.PRESSURE, datum_mismatch=False, ra_sense="descend", ra_strength="corrective",
        ra_words="DESCEND", target_vertical_rate_mps=-1500 * FPM, ra_reversed=False, ra_crossing=False,
        ra_separation_m=110.0)


def _mavgen(xml: Path, output: Path) -> None:
    """What docs/mavlink.md tells a user to run (the installed mavgen.py)."""
    subprocess.run([sys.executable, str(BIN / "mavgen.py"), "--lang=Python3", "--wire-protocol=2.0",
                    f"--output={output}", str(xml)], check=True, capture_output=True, timeout=300)


def test_the_shipped_xml_and_its_includes_are_package_data():
    names = {p.name for p in resources.files("avionics.io.dialect").iterdir()}
    assert {"daa.xml", "ardupilotmega.xml", "common.xml", "standard.xml", "minimal.xml", "uAvionix.xml",
            "icarous.xml", "loweheiser.xml", "cubepilot.xml", "csAirLink.xml"} <= names
    text = XML.read_text()
    assert "<include>ardupilotmega.xml</include>" in text
    assert re.search(r"messages: 52610 - 52619", text), "the id block is declared in the XML's header comment"


def test_our_messages_are_in_our_block_and_no_public_dialect_uses_it():
    from pymavlink.generator import mavparse

    ours = mavparse.MAVXML(str(XML), mavparse.PROTOCOL_2_0)
    assert {m.name: m.id for m in ours.message} == {"DAA_ADVISORY": 52610, "DAA_BANDS": 52611,
                                                    "DAA_SENSOR_MEASUREMENT": 52612}
    assert all(m.id in BLOCK for m in ours.message)
    assert [(owner, lo, hi) for owner, lo, hi in ALL_XML_BLOCKS for m in ours.message if lo <= m.id <= hi] == []
    import pymavlink.dialects.v20 as stock

    used = {}
    for xml in sorted(Path(stock.__file__).parent.glob("*.xml")):
        for m in mavparse.MAVXML(str(xml), mavparse.PROTOCOL_2_0).message:
            used[m.id] = f"{xml.name}:{m.name}"
    assert len(used) > 300  # the scan saw the public dialects (all.xml's includes)
    assert [used[i] for i in BLOCK if i in used] == []


def test_stock_mavgen_module_decodes_our_advisory_by_name(tmp_path):
    _mavgen(Path(str(XML)), tmp_path / "daa_stock.py")
    sys.path.insert(0, str(tmp_path))
    try:
        import daa_stock  # noqa: PLC0415  (generated just now by stock mavgen)
    finally:
        sys.path.remove(str(tmp_path))

    frame = bytes(encode.daa_advisory(_advisory(), "N123AB", 0.4).pack(daa.MAVLink(None, 1, 191)))
    parser = daa_stock.MAVLink(None)
    (msg,) = parser.parse_buffer(frame)
    assert msg.get_type() == "DAA_ADVISORY" and msg.get_srcComponent() == 191
    assert (msg.id, msg.level, msg.sense, msg.strength) == (0xA10001, daa_stock.DAA_ADVISORY_LEVEL_RA,
                                                            daa_stock.DAA_RA_SENSE_DESCEND,
                                                            daa_stock.DAA_RA_STRENGTH_CORRECTIVE)
    assert msg.callsign == "N123AB" and math.isclose(msg.target_vertical_rate, -7.62, rel_tol=1e-6)
    # and the ArduPilot messages an ArduPilot link carries, from the same module
    assert daa_stock.MAVLINK_MSG_ID_AHRS2 in daa_stock.mavlink_map


def _shadow_pymavlink(root: Path) -> Path:
    """A pymavlink installation like the real one (every file a symlink to it) whose dialects/v20 directory can
    take a new module: what a user's own pymavlink is after the documented mavgen.py command."""
    import pymavlink

    real = Path(pymavlink.__file__).parent
    site = root / "site"
    for src in real.rglob("*"):
        if "__pycache__" in src.parts or src.is_dir():
            continue
        dst = site / "pymavlink" / src.relative_to(real)
        dst.parent.mkdir(parents=True, exist_ok=True)
        dst.symlink_to(src)
    return site


def _write_tlog(path: Path) -> None:
    """Our link writes the record as `avionics run --tlog-out` does: what it sends, to a peer that listens."""
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as peer:
        peer.bind(("127.0.0.1", 0))
        port = peer.getsockname()[1]
        link = MavlinkLink(f"udpout:127.0.0.1:{port}", Counter(), 1, 191, tlog_out=path)
        try:
            link.send(encode.heartbeat())
            link.send(encode.daa_advisory(_advisory(), "N123AB", 0.4))
            link.send(daa.MAVLink_daa_bands_message(  # one track band, as encode.daa_bands writes them
                time_boot_ms=10000, kind=daa.DAA_BANDS_KIND_TRACK, flags=0, part=0, parts=1, count=1,
                lower=[10.0] + [math.nan] * 9, upper=[40.0] + [math.nan] * 9,
                region=[daa.DAA_BANDS_REGION_NEAR] + [daa.DAA_BANDS_REGION_UNKNOWN] * 9))
            link.send(encode.collision(_advisory()))
        finally:
            link.close()
        peer.settimeout(10.0)
        assert len(peer.recv(4096)) > 0  # the frames went out on a real socket too


def test_mavlogdump_prints_daa_advisory_by_name_with_the_dialect_installed(tmp_path):
    tlog = tmp_path / "flight.tlog"
    _write_tlog(tlog)
    site = _shadow_pymavlink(tmp_path)
    _mavgen(Path(str(XML)), site / "pymavlink" / "dialects" / "v20" / "daa.py")
    env = {**os.environ, "PYTHONPATH": str(site)}
    env.pop("MAVLINK_DIALECT", None)
    dump = [sys.executable, str(BIN / "mavlogdump.py")]

    def run(*args):
        out = subprocess.run(dump + [*args, str(tlog)], capture_output=True, text=True, env=env, timeout=120,
                             cwd=tmp_path)
        assert out.returncode == 0, out.stderr
        return out.stdout

    stock = run()  # the default (ardupilotmega) does not know it
    assert "DAA_ADVISORY" not in stock and "HEARTBEAT" in stock
    ours = run("--dialect", "daa")
    line = next(line for line in ours.splitlines() if "DAA_ADVISORY" in line)
    assert "id : 10551297" in line and "callsign : N123AB" in line and "sense : 2" in line
    assert "COLLISION" in ours and "HEARTBEAT" in ours
    bands = next(line for line in ours.splitlines() if "DAA_BANDS" in line)
    assert "kind : 0" in bands and "count : 1" in bands
    as_json = run("--dialect", "daa", "--format", "json", "--types", "DAA_ADVISORY")
    assert '"type": "DAA_ADVISORY"' in as_json and '"level": 2' in as_json


def test_a_pymavlink_script_reads_the_tlog_with_mavlink_dialect_set(tmp_path):
    tlog = tmp_path / "flight.tlog"
    _write_tlog(tlog)
    site = _shadow_pymavlink(tmp_path)
    _mavgen(Path(str(XML)), site / "pymavlink" / "dialects" / "v20" / "daa.py")
    script = ("from pymavlink import mavutil\n"
              f"log = mavutil.mavlink_connection({str(tlog)!r})\n"
              "m = log.recv_match(type='DAA_ADVISORY')\n"
              "print(m.get_type(), m.id, m.callsign)\n")
    out = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=120, cwd=tmp_path,
                         env={**os.environ, "PYTHONPATH": str(site), "MAVLINK_DIALECT": "daa", "MAVLINK20": "1"})
    assert out.returncode == 0, out.stderr
    assert out.stdout.split() == ["DAA_ADVISORY", str(0xA10001), "N123AB"]


def _all_with_ours(tmp_path: Path, ids: tuple[int, int] | None = None) -> Path:
    """pymavlink's all.xml (every public dialect it ships) plus our daa.xml in one directory, so that the two share
    one copy of each included file; ids: our two messages renumbered (the negative control)."""
    import shutil

    import pymavlink.dialects.v20 as stock

    for xml in Path(stock.__file__).parent.glob("*.xml"):
        shutil.copy(xml, tmp_path / xml.name)
    text = XML.read_text()
    if ids is not None:
        text = text.replace('id="52610"', f'id="{ids[0]}"').replace('id="52611"', f'id="{ids[1]}"')
    (tmp_path / "daa.xml").write_text(text)
    combined = tmp_path / "all_with_daa.xml"
    combined.write_text('<?xml version="1.0"?>\n<mavlink>\n  <include>all.xml</include>\n'
                        '  <include>daa.xml</include>\n  <messages/>\n</mavlink>\n')
    return combined


def test_stock_mavgen_builds_all_xml_with_our_dialect_without_an_id_collision(tmp_path):
    # mavgen refuses a message id defined twice ("Duplicate message id"); the control proves it would see ours.
    _mavgen(_all_with_ours(tmp_path), tmp_path / "all_with_daa.py")
    assert "MAVLINK_MSG_ID_DAA_ADVISORY = 52610" in (tmp_path / "all_with_daa.py").read_text()
    control = tmp_path / "control"
    control.mkdir()
    clash = subprocess.run([sys.executable, str(BIN / "mavgen.py"), "--lang=Python3", "--wire-protocol=2.0",
                            f"--output={control / 'x.py'}", str(_all_with_ours(control, (42000, 42001)))],
                           capture_output=True, text=True, timeout=300)
    assert clash.returncode != 0 and "Duplicate message id 42000" in clash.stdout + clash.stderr
