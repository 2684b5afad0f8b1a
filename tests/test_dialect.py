"""The project MAVLink dialect: the committed generated module matches daa.xml, and DAA_ADVISORY
round-trips through real framing with every field."""

import math
from pathlib import Path

from avionics.base.types import AddressSource, Advisory, AdvisoryLevel, AltitudeDatum, IntruderKey
from avionics.io import encode
from avionics.io.dialect import daa
from avionics.io.dialect.generate import generate
from avionics.io.framing import FrameScanner
from avionics.base.units import FPM

HERE = Path(daa.__file__).parent


def test_generated_module_is_up_to_date(tmp_path):
    fresh = generate(tmp_path / "daa.py")
    assert fresh.read_text() == (HERE / "daa.py").read_text(), "run: python -m avionics.io.dialect.generate"


def test_daa_advisory_round_trip():
    advisory = Advisory(
        intruder=IntruderKey(0xABC123, AddressSource.UAT), level=AdvisoryLevel.RA, time_s=10.0, reason="tau",
        sensitivity_level=4, range_m=2700.0, closure_rate_mps=128.6, t_cpa_s=21.0, hmd_m=12.0, vmd_m=None,
        range_tau_s=21.0, mod_tau_s=19.9, vertical_tau_s=math.inf, altitude_datum=AltitudeDatum.PRESSURE,
        datum_mismatch=True, ra_sense="climb", ra_strength="corrective", ra_words="CLIMB",
        target_vertical_rate_mps=1500 * FPM, ra_reversed=True, ra_crossing=False, ra_separation_m=110.0)
    mav = daa.MAVLink(None, 1, 191)
    from collections import Counter

    (msg,) = FrameScanner(Counter()).feed(bytes(encode.daa_advisory(advisory, "N123AB", 0.42).pack(mav)), True)
    assert msg.get_type() == "DAA_ADVISORY" and msg.id == 0xABC123
    assert (msg.level, msg.sense, msg.strength) == (daa.DAA_ADVISORY_LEVEL_RA, daa.DAA_RA_SENSE_CLIMB,
                                                    daa.DAA_RA_STRENGTH_CORRECTIVE)
    assert msg.flags == (daa.DAA_ADVISORY_FLAGS_REVERSED | daa.DAA_ADVISORY_FLAGS_DATUM_MISMATCH
                         | daa.DAA_ADVISORY_FLAGS_ALTITUDE_UNKNOWN | daa.DAA_ADVISORY_FLAGS_UAT)
    assert math.isclose(msg.target_vertical_rate, 7.62, rel_tol=1e-6) and math.isnan(msg.vertical_miss)
    assert math.isclose(msg.pc, 0.42, rel_tol=1e-6) and msg.callsign == "N123AB" and msg.sensitivity_level == 4
