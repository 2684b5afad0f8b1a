"""A drone gets told when its profile gives it no RA (issue 26 item 4): flying below the profile's RA-inhibit height
(tcas2: 1000 ft AGL) for a minute is named once as STATUSTEXT, as a WARNING line (again each minute while it lasts)
and in the status; a UAS profile (RAs at any height) and a vehicle on the ground (below 10 m AGL) never are. The
onboard chain is the harness's (the same parts as `avionics run`), fed GLOBAL_POSITION_INT framed and parsed with
pymavlink at 2 Hz on simulated time; `avionics run`'s start-up line is checked in tests/test_wiring_live.py."""

import logging

import avionics.io  # noqa: F401  (MAVLink 2)
import pytest
from pymavlink.dialects.v20 import common as mavlink2

from avionics.advisory.inhibits import RA_INHIBIT_WARN_S
from avionics.config import load_config
from avionics.ports import LogOut
from harness import Harness

TEXT = "NO RA BELOW 1000 FT AGL: PROFILE TCAS2"


def fly(profile: str, relative_alt_m: float, duration_s: float, caplog):
    """(time, STATUSTEXT text) the autopilot got, the WARNING lines, the last status."""
    config = load_config(overrides=[f"advisory.profile={profile}", "zenoh.enabled=false"])
    h = Harness(config)
    logger = logging.getLogger("avionics.test_ra_inhibit")
    h.loop.ports.append(LogOut(logger))
    mav, parser = mavlink2.MAVLink(None, 1, 1), mavlink2.MAVLink(None)
    texts = []
    with caplog.at_level(logging.INFO, logger=logger.name):
        for k in range(int(duration_s * 2) + 1):
            t = k / 2.0
            gpi = mavlink2.MAVLink_global_position_int_message(
                int(t * 1000), 473977000, 85455000, int((400.0 + relative_alt_m) * 1000), int(relative_alt_m * 1000),
                1500, 0, 0, 0)  # 15 m/s north, level
            pressure = mavlink2.MAVLink_scaled_pressure_message(int(t * 1000), 960.0, 0.0, 1500)
            msgs = parser.parse_buffer(bytes(gpi.pack(mav)) + bytes(pressure.pack(mav)))
            sent = len(h.mavlink_out)
            h.handle(msgs, t)
            texts += [(t, m.text) for m in h.mavlink_out[sent:] if m.get_type() == "STATUSTEXT"]
    warnings = [(r.getMessage()) for r in caplog.records if r.levelno == logging.WARNING]
    return texts, warnings, h.status(duration_s)


def test_tcas2_below_1000_ft_for_a_minute_is_named_once(caplog):
    texts, warnings, status = fly("tcas2", 100.0, RA_INHIBIT_WARN_S + 70.0, caplog)
    named = [t for t, text in texts if text == TEXT]
    assert len(named) == 1 and named[0] >= RA_INHIBIT_WARN_S, texts  # once, after the minute
    lines = [w for w in warnings if "below profile tcas2's RA inhibit height 1000 ft AGL" in w]
    assert len(lines) == 2, warnings  # at the onset and a minute later, while it lasts
    assert "flying 100 m AGL" in lines[0] and "no RA is possible" in lines[0]
    assert "--set advisory.profile=small-uas" in lines[0]
    assert [d["key"] for d in status["wiring"]] == ["ra_inhibited"]
    assert any("no RA is possible" in w for w in status["warnings"])


@pytest.mark.parametrize("profile, relative_alt_m", [("small-uas", 100.0), ("do365", 100.0), ("tcas2", 2.0),
                                                      ("tcas2", 400.0)])
def test_no_warning_with_ras_possible_or_on_the_ground(profile, relative_alt_m, caplog):
    texts, warnings, status = fly(profile, relative_alt_m, RA_INHIBIT_WARN_S + 10.0, caplog)
    assert not [text for _, text in texts if text.startswith("NO RA BELOW")], texts
    assert not [w for w in warnings if "RA inhibit height" in w]
    assert status["wiring"] == []
