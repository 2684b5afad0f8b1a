"""The monitor's picture (no sockets): TCAS symbology and geometry, absent fields, the lossless advisory log
across a snapshot resync, deltas for the page, and the terminal view."""

import math

import pytest

from avionics.base.units import FT, NM
from avionics.monitor.state import FleetState, alt_tag, derive_track, enu_offset, imm_mode, symbol_of
from avionics.monitor.tui import render_text

OWN = {"schema": 2, "vehicle": "v", "time_s": 10.0, "valid": True, "lat_deg": 47.0, "lon_deg": 8.0,
       "alt_msl_m": 1000.0, "pressure_altitude_m": 990.0, "velocity_enu_mps": [0.0, 50.0, 0.0], "track_deg": 0.0}


def track(intruder="1090es-A10001", t=10.0, north_m=NM, east_m=0.0, alt=990.0 + 500 * FT, vrate=5.2, **extra):
    lat = 47.0 + north_m / 111_229.0
    lon = 8.0 + east_m / (111_229.0 * math.cos(math.radians(47.0)))
    return {"schema": 2, "vehicle": "v", "intruder": intruder, "callsign": "HEADON", "time_s": t, "lat_deg": lat,
            "lon_deg": lon, "altitude_m": alt, "altitude_datum": "pressure", "vertical_rate_mps": vrate,
            "ground_speed_mps": 60.0, "track_deg": 180.0, "advisory": "NONE", "mod_tau_s": 25.0, **extra}


def adv(level, t, intruder="1090es-A10001", **extra):
    return {"schema": 2, "vehicle": "v", "intruder": intruder, "level": level, "time_s": t, "reason": "tau",
            "range_m": 3000.0, "mod_tau_s": 20.0, **extra}


def test_geometry_tags_and_symbols_follow_tcas_conventions():
    e, n = enu_offset(47.0, 8.0, 47.0 + 1 / 60, 8.0)
    assert e == pytest.approx(0.0, abs=1e-6) and n == pytest.approx(1853.3, abs=2.0)  # 1' of latitude ~ 1 NM
    view = derive_track(track(), OWN, None)
    assert view["range_m"] == pytest.approx(NM, rel=2e-3) and view["bearing_deg"] == pytest.approx(0.0, abs=0.1)
    assert view["rel_alt_m"] == pytest.approx(500 * FT, abs=0.01)  # pressure datum: against pressure altitude
    assert view["tag"] == "+05" and view["vs"] == "up" and view["sym"] == "PROX"
    assert alt_tag(-1200 * FT) == "-12" and alt_tag(20 * FT) == "00" and alt_tag(None) == ""
    assert symbol_of("NONE", 6.1 * NM, 0.0) == "OTHER" and symbol_of("NONE", 5 * NM, 1300 * FT) == "OTHER"
    assert symbol_of("TA", 9 * NM, None) == "TA" and symbol_of("RA", 1.0, 0.0) == "RA"
    # ownship extrapolated to the track's time: 1 s later ownship has flown 50 m north
    later = derive_track(track(t=11.0), OWN, None)
    assert later["range_m"] == pytest.approx(NM - 50.0, rel=2e-3)
    ra = derive_track(track(), OWN, adv("RA", 10.5, ra_sense="descend", ra_words="DESCEND",
                                        target_vertical_rate_mps=-7.62, pc_ta=0.9))
    assert (ra["sym"], ra["ra_sense"], ra["ra_words"], ra["target_vertical_rate_mps"], ra["pc"]) == \
        ("RA", "descend", "DESCEND", -7.62, 0.9)


def test_fields_not_in_the_payload_are_none_and_imm_mode_shows_when_present():
    bare = derive_track({"intruder": "uat-000001", "time_s": 1.0}, None, None)
    assert bare["range_m"] is None and bare["tag"] == "" and bare["imm"] is None and bare["pc"] is None
    assert bare["sym"] == "OTHER" and bare["ra_sense"] is None
    assert imm_mode({"mode_probabilities": {"cv": 0.1, "ct": 0.82, "ca": 0.08}}) == "CT 0.82"
    assert imm_mode({"most_likely_mode": "cs"}) == "CS"


def test_advisory_log_loses_nothing_across_a_link_outage_and_snapshot_resync():
    s = FleetState()
    s.set_alive("v", True)
    s.apply_snapshot("v", {"time_s": 0.0, "advisory_changes": []})  # synced
    s.apply("v", "advisories", "1090es-A10001", adv("TA", 55.0))
    s.apply("v", "advisories", "1090es-A10001", adv("TA", 56.0))  # refresh: not a change
    s.set_alive("v", False)  # router gone: during the outage TA -> RA happens
    s.set_alive("v", True)  # back: the feed asks the snapshot; meanwhile a refresh and a new change arrive
    s.apply("v", "advisories", "1090es-A10001", adv("RA", 66.0, ra_sense="descend", ra_words="DESCEND"))
    s.apply("v", "advisories", "1090es-A10001", adv("RA", 67.0, ra_sense="descend", ra_words="INCREASE DESCENT"))
    s.apply_snapshot("v", {"time_s": 66.5, "tracks": [track(t=66.5)], "advisories": [
        adv("RA", 66.5, ra_sense="descend", ra_words="DESCEND")], "advisory_changes": [
        adv("TA", 55.0), adv("RA", 65.2, ra_sense="descend", ra_words="DESCEND")]})
    s.apply("v", "advisories", "1090es-A10001", adv("NONE", 86.4))
    log = [(e["level"], e["time_s"], e["source"]) for e in s.advisory_log("v")]
    assert log == [("TA", 55.0, "live"), ("RA", 65.2, "snapshot"), ("RA", 67.0, "replay"), ("NONE", 86.4, "live")]
    assert [t["id"] for t in s.tracks("v")] == ["1090es-A10001"]


def test_deltas_carry_only_what_changed_and_expired_tracks_are_removed():
    now = [0.0]
    s = FleetState(stale_s=5.0, clock=lambda: now[0])
    s.apply("v", "ownship", "", OWN)
    s.apply("v", "tracks", "a", track("a"))
    s.apply("v", "tracks", "b", track("b", east_m=2000.0))
    full, cur = s.view("v")
    assert full["type"] == "full" and {t["id"] for t in full["tracks"]} == {"a", "b"} and full["fleet"][0]["id"] == "v"
    now[0] = 3.0
    s.apply("v", "tracks", "a", track("a", t=11.0))
    delta, cur = s.view("v", cur)
    assert delta["type"] == "delta" and [t["id"] for t in delta["tracks"]] == ["a"] and "ownship" not in delta
    now[0] = 6.0
    assert s.expire() == 1  # b not updated for 6 s
    delta, cur = s.view("v", cur)
    assert delta["removed"] == ["b"]
    other, _ = s.view("w", cur)  # another vehicle: a full view
    assert other["type"] == "full"


def test_onboard_restart_starts_a_new_epoch():
    s = FleetState()
    s.apply_snapshot("v", None)
    s.apply("v", "status", "", {"time_s": 300.0})
    s.apply("v", "advisories", "x", adv("TA", 290.0, intruder="x"))
    s.apply("v", "tracks", "x", track("x", t=300.0))
    s.apply("v", "status", "", {"time_s": 2.0})  # a new process: its clock restarted
    s.apply("v", "advisories", "x", adv("TA", 3.0, intruder="x"))
    assert [(e["epoch"], e["time_s"]) for e in s.advisory_log("v")] == [(0, 290.0), (1, 3.0)]
    assert s.tracks("v") == []


def test_terminal_view_shows_symbols_tags_ra_and_offline():
    s = FleetState()
    s.apply_snapshot("v", None)
    s.set_alive("v", True)
    s.apply("v", "ownship", "", OWN)
    s.apply("v", "status", "", {"time_s": 10.0, "sensitivity_level": 4, "advisories": {"TA": 0, "RA": 1},
                                "warnings": []})
    s.apply("v", "tracks", "1090es-A10001", track())
    s.apply("v", "advisories", "1090es-A10001", adv("RA", 10.5, callsign="HEADON", ra_sense="descend",
                                                    ra_words="DESCEND", target_vertical_rate_mps=-7.62))
    s.apply("v", "tracks", "1090es-B00002", track("1090es-B00002", north_m=-3 * NM, east_m=3 * NM, alt=990.0, vrate=0.0))
    text = render_text(s, "v", 150, 44)
    assert "■+05↑" in text and "◆00" in text  # RA square with tag and arrow; proximate diamond
    assert "RA DESCEND -1500 fpm" in text and "HEADON" in text and "1090es-B00002" in text
    assert "SL 4" in text and "—" in text  # IMM mode not in the payload
    s.set_alive("v", False)
    assert "v OFFLINE" in render_text(s, "v", 150, 44)


# -- DO-365 guidance bands, level names, cleared Pc (issue 16, item 4) ------------------------------------------------
def bands(t=12.0, **extra):
    return {"schema": 2, "vehicle": "v", "time_s": t, "alerter": "daidalus-do365b-no-sum",
            "ownship": {"track_deg": 90.0, "ground_speed_mps": 51.4, "vertical_rate_mps": 0.0, "altitude_m": 1219.2},
            "track_deg": [{"lower": 0.0, "upper": 87.0, "region": "NONE"}, {"lower": 87.0, "upper": 113.0, "region": "MID"},
                          {"lower": 113.0, "upper": 360.0, "region": "NONE"}],
            "ground_speed_mps": [{"lower": 0.0, "upper": 300.0, "region": "NONE"}],
            "vertical_rate_mps": [{"lower": -30.0, "upper": 30.0, "region": "NEAR"}], "altitude_m": [],
            "recovery": {"track_deg": False, "ground_speed_mps": False, "vertical_rate_mps": False, "altitude_m": False},
            "intruders": [{"intruder": "1090es-A1B2C3", "alert_level": 2, "alert_name": "CORRECTIVE"}], **extra}


def test_bands_latest_per_vehicle_stale_after_bands_stale_s_and_dropped_on_restart():
    now = [0.0]
    s = FleetState(clock=lambda: now[0], bands_stale_s=3.0)
    s.apply("v", "bands", "", bands(12.0))
    full, cur = s.view("v")
    assert full["bands"]["track_deg"][1] == {"lower": 87.0, "upper": 113.0, "region": "MID"}
    assert full["bands"]["stale"] is False and full["bands"]["altitude_m"] == [] and s.memory()["v"]["bands"] == 1
    s.apply("v", "bands", "", bands(11.0, alerter="older"))  # an older sample (reordered): ignored
    assert s.bands("v")["alerter"] == "daidalus-do365b-no-sum"
    now[0] = 2.9
    s.expire()
    delta, cur = s.view("v", cur)
    assert "bands" not in delta  # nothing changed yet
    now[0] = 3.1
    s.expire()  # no newer bands for 3 s: stale, and readers are told
    delta, cur = s.view("v", cur)
    assert delta["bands"]["stale"] is True and delta["bands"]["age_s"] == pytest.approx(3.1)
    assert delta["bands"]["track_deg"][1]["region"] == "MID"  # still shown (greyed), not dropped
    s.apply("v", "bands", "", bands(13.0))
    delta, cur = s.view("v", cur)
    assert delta["bands"]["stale"] is False and delta["bands"]["time_s"] == 13.0
    s.apply("v", "status", "", {"time_s": 300.0})
    s.apply("v", "status", "", {"time_s": 2.0})  # the onboard process restarted: its bands go
    assert s.bands("v") is None and s.view("v", cur)[0]["bands"] is None
    s.apply("v", "bands", "", bands(3.0))
    assert s.bands("v")["time_s"] == 3.0


def test_a_cleared_intruder_shows_no_stale_pc_and_do365_level_names_are_kept():
    s = FleetState()
    s.apply_snapshot("v", None)
    s.apply("v", "ownship", "", OWN)
    s.apply("v", "tracks", "1090es-A10001", track(t=10.0, pc_ta=0.6, advisory="RA"))
    s.apply("v", "advisories", "1090es-A10001", adv("RA", 10.5, pc_ta=1.0, alert_level=3, alert_name="WARNING"))
    [t] = s.tracks("v")
    assert (t["pc"], t["alert_name"], t["alert_level"]) == (1.0, "WARNING", 3)
    # cleared at the closest approach: the NONE advisory still carries the last alerting Pc (1.0)
    s.apply("v", "advisories", "1090es-A10001", adv("NONE", 11.0, reason="diverging", pc_ta=1.0, alert_level=0,
                                                    alert_name="NONE"))
    [t] = s.tracks("v")
    assert t["level"] == "NONE" and t["pc"] is None and t["tau_s"] is None  # not the stale 1.000
    s.apply("v", "tracks", "1090es-A10001", track(t=11.5, pc_ta=0.02, advisory="NONE"))
    [t] = s.tracks("v")
    assert t["pc"] == 0.02 and t["alert_name"] == "NONE"  # the track's own, newer assessment
    log = s.advisory_log("v")
    assert [(e["level"], e["alert_name"], e["pc"]) for e in log] == [("RA", "WARNING", 1.0), ("NONE", "NONE", None)]
    text = render_text(s, "v", 150, 44)
    assert "WARNING" in text and "1.000" in text  # the log's RA row keeps its Pc; the cleared row and track do not
    assert "0.020" in text


def test_terminal_view_shows_the_bands_as_text_with_stale_and_empty_kinds():
    now = [0.0]
    s = FleetState(clock=lambda: now[0], bands_stale_s=3.0)
    s.apply_snapshot("v", None)
    s.apply("v", "ownship", "", OWN)
    assert "GUIDANCE BANDS" not in render_text(s, "v", 150, 44)  # a TCAS vehicle: no bands panel
    s.apply("v", "bands", "", bands(12.0, recovery={"track_deg": True}))
    text = render_text(s, "v", 150, 44)
    assert "GUIDANCE BANDS daidalus-do365b-no-sum" in text and "STALE" not in text
    assert "MID 87–113" in text and "NONE 0–87" in text and "NONE 113–360" in text and "RECOVERY MID" not in text
    assert "NEAR -5906–5906" in text  # vertical rate in fpm (30 m/s)
    assert "ALT ft   no bands computed" in text and "1090es-A1B2C3 CORRECTIVE" in text
    assert "TRK °    RECOVERY" in text
    now[0] = 5.0
    s.expire()
    assert "STALE 5 s" in render_text(s, "v", 150, 44)
