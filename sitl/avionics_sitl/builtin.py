"""Built-in encounters: canonical DAA geometries and the encounters of the seed papers.

Every encounter is authored in east/north metres on the tangent plane at REFERENCE (near Zürich, ground
at 0 ft MSL unless stated) and the Scenario integrates its leg programs in that same plane, so the
geometry below is exact. Where a paper is silent, the choice is stated in the description and in
docs/scenarios.md. Collision courses are built backwards: an aircraft's start is its meeting point minus
the displacement its leg program flies until the meeting time.
"""

from __future__ import annotations

import math
from typing import Callable

from avionics.base.geodesy import LocalTangentPlane
from avionics.base.units import FPM, FT, G0, KT, NM
from avionics_sitl.aircraft import AircraftSpec, Leg
from avionics_sitl.scenario import Scenario
from avionics_sitl.trajectory import LegKinematics, plane_velocity_to_true

REFERENCE = (47.4, 8.5)  # lat, lon of the plane every built-in encounter is authored in
_PLANE = LocalTangentPlane(*REFERENCE)

EMITTER_LIGHT = 1  # MAVLink ADSB_EMITTER_TYPE_LIGHT
EMITTER_LARGE = 3
EMITTER_HIGHLY_MANUV = 6
EMITTER_UAV = 14
OWNSHIP_ICAO = 0xC0FFEE  # any address; the DAA must not track itself


def _aircraft(name: str, icao: int, east_m: float, north_m: float, alt_m: float, heading_deg: float,
              speed_mps: float, legs: tuple[Leg, ...] = (), emitter_type: int = EMITTER_LIGHT,
              callsign: str = "") -> AircraftSpec:
    """An aircraft authored on the plane: position, heading and speed along the plane's axes. The spec gets
    the true heading and speed at that point, which LegTrajectory turns back into exactly these."""
    lat_a, lon_a = _PLANE.to_geodetic(east_m, north_m)
    lat, lon = float(lat_a), float(lon_a)
    psi = math.radians(heading_deg)
    ue, un = plane_velocity_to_true(_PLANE, lat, lon, math.sin(psi), math.cos(psi))
    true_heading = math.degrees(math.atan2(ue, un)) % 360.0
    return AircraftSpec(
        name=name, icao_address=icao, lat_deg=lat, lon_deg=lon, alt_msl_m=alt_m,
        heading_deg=true_heading if true_heading < 360.0 else 0.0, speed_mps=speed_mps * math.hypot(ue, un),
        legs=legs, callsign=callsign, emitter_type=emitter_type,
    )


def _displacement(heading_deg: float, speed_mps: float, legs: tuple[Leg, ...], t_s: float) -> tuple[float, float]:
    """East/north flown in t_s by a leg program started at the plane origin."""
    east, north, *_ = LegKinematics(0.0, 0.0, 0.0, heading_deg, speed_mps, 0.0, legs).at(t_s)
    return east, north


def _start_to_reach(point_en: tuple[float, float], t_s: float, heading_deg: float, speed_mps: float,
                    legs: tuple[Leg, ...] = ()) -> tuple[float, float]:
    """Start position from which the leg program is at point_en at time t_s."""
    de, dn = _displacement(heading_deg, speed_mps, legs, t_s)
    return point_en[0] - de, point_en[1] - dn


def _scenario(name: str, description: str, ownship: AircraftSpec, intruders: tuple[AircraftSpec, ...],
              duration_s: float) -> Scenario:
    return Scenario(name, description, ownship, intruders, duration_s, ground_elevation_m=0.0, origin=REFERENCE)


# --- canonical geometries ----------------------------------------------------------------------------------


def head_on() -> Scenario:
    speed = 125 * KT
    alt = 3000 * FT
    range0 = 6 * NM
    t_cpa = range0 / (2 * speed)  # 86.4 s
    # On one meridian, so the true tracks are exactly 000 and 180 (tests/data/head_on_3000ft.daa is the same).
    own = _aircraft("ownship", OWNSHIP_ICAO, 0.0, 0.0, alt, 0.0, speed, emitter_type=EMITTER_UAV, callsign="OWNSHIP")
    intr = _aircraft("intruder", 0xA10001, 0.0, range0, alt, 180.0, speed, callsign="HEADON")
    return _scenario(
        "head-on",
        "Exact head-on, co-altitude at 3000 ft MSL (TCAS SL4 over 0 ft ground), 125 kt each (250 kt closing), "
        f"6 nm apart at t=0 on one meridian (ownship northbound, intruder southbound); collision (CPA 0 m) at "
        f"t={t_cpa:.1f} s. Modified tau reaches the SL4 TA threshold (30 s, DMOD 0.48 nm) at 2.19 nm range, "
        "about 55 s into the run. Canonical DAA test geometry.",
        own, (intr,), duration_s=120.0,
    )


def crossing_90() -> Scenario:
    alt = 2500 * FT
    own_speed, intr_speed, t_cpa = 80 * KT, 120 * KT, 90.0
    own = _aircraft("ownship", OWNSHIP_ICAO, 0.0, 0.0, alt, 0.0, own_speed, emitter_type=EMITTER_UAV,
                    callsign="OWNSHIP")
    meet = _displacement(0.0, own_speed, (), t_cpa)
    e, n = _start_to_reach(meet, t_cpa, 270.0, intr_speed)
    intr = _aircraft("intruder", 0xA10002, e, n, alt, 270.0, intr_speed, callsign="CROSS")
    return _scenario(
        "crossing-90",
        "90-degree crossing on a collision course, co-altitude at 2500 ft MSL: ownship UAV northbound at 80 kt, "
        f"intruder westbound at 120 kt from the right; both reach the crossing point at t={t_cpa:.0f} s "
        "(CPA 0 m).",
        own, (intr,), duration_s=150.0,
    )


def overtaking() -> Scenario:
    alt = 2000 * FT
    own_speed, intr_speed = 70 * KT, 140 * KT
    gap0, offset = 1.5 * NM, 100.0
    t_abeam = gap0 / (intr_speed - own_speed)  # 77.1 s
    own = _aircraft("ownship", OWNSHIP_ICAO, 0.0, 0.0, alt, 90.0, own_speed, emitter_type=EMITTER_UAV,
                    callsign="OWNSHIP")
    intr = _aircraft("intruder", 0xA10003, -gap0, offset, alt, 90.0, intr_speed, callsign="OVERTAKE")
    return _scenario(
        "overtaking",
        "Overtake from behind on the same track (090), co-altitude at 2000 ft MSL: ownship UAV at 70 kt, intruder "
        f"at 140 kt starting 1.5 nm behind with its track 100 m left (north) of ownship's; abeam (CPA 100 m) at "
        f"t={t_abeam:.1f} s.",
        own, (intr,), duration_s=120.0,
    )


def climbing_intruder() -> Scenario:
    own_alt = 3000 * FT
    own_speed, intr_speed, t_cpa = 90 * KT, 110 * KT, 60.0
    climb = 1500 * FPM
    own = _aircraft("ownship", OWNSHIP_ICAO, 0.0, 0.0, own_alt, 0.0, own_speed, emitter_type=EMITTER_UAV,
                    callsign="OWNSHIP")
    legs = (Leg(120.0, vertical_rate_mps=climb),)  # then levels off at 4500 ft
    meet = _displacement(0.0, own_speed, (), t_cpa)
    e, n = _start_to_reach(meet, t_cpa, 225.0, intr_speed, legs)
    intr = _aircraft("intruder", 0xA10004, e, n, own_alt - climb * t_cpa, 225.0, intr_speed, legs,
                     callsign="CLIMB")
    return _scenario(
        "climbing-intruder",
        "Intruder climbing through ownship's altitude: ownship UAV level at 3000 ft MSL northbound at 90 kt; "
        "intruder from ahead-right on track 225 at 110 kt, starting 1500 ft below and climbing at 1500 fpm for "
        f"120 s (levels at 4500 ft). Horizontal CPA 0 m at t={t_cpa:.0f} s, exactly when it crosses ownship's "
        "altitude.",
        own, (intr,), duration_s=120.0,
    )


# --- seed-paper encounters ---------------------------------------------------------------------------------


def baek_bang_1() -> Scenario:
    alt = 3000 * FT
    speed = 360 * KT  # not given in the paper (Sec. 5); 0.1 nm/s keeps the turn clear of B's 2 nm zone
    legs = (Leg(50.0), Leg(60.0, turn_rate_dps=-1.5))  # left turn 090 -> 000 at 1.5 deg/s from t=50 s
    a = _aircraft("aircraft-A", 0xA20001, 0.0, 0.0, alt, 90.0, speed, legs, emitter_type=EMITTER_LARGE,
                  callsign="ACFTA")
    b = _aircraft("aircraft-B", OWNSHIP_ICAO, 7 * NM, -2 * NM, alt, 0.0, 0.0, emitter_type=EMITTER_UAV,
                  callsign="ACFTB")
    return _scenario(
        "baek-bang-1",
        "Baek & Bang (IJASS 2012) Sec. 5, scenario 1 (Fig. 5): aircraft A starts at (0, 0) nm heading +x (east), "
        "turns left at 1.5 deg/s from t=50 s until heading +y (north, t=110 s), constant speed; aircraft B is "
        "stationary at (7, -2) nm; total 130 s. Ownship is B (a hovering UAV): the paper estimates A from ADS-B "
        "with the IMM, B is the reference. Chosen (paper silent): speed of A 360 kt (0.1 nm/s), both at "
        "3000 ft MSL (the paper is horizontal only). Closest approach 2.33 nm at t~63 s; straight on, A would "
        "pass B at exactly 2 nm (the paper's conflict radius) at t=70 s.",
        b, (a,), duration_s=130.0,
    )


def baek_bang_2() -> Scenario:
    alt = 3000 * FT
    speed_a, speed_b = 240 * KT, 120 * KT  # not given in the paper (text lost); A must be the faster
    a = _aircraft("aircraft-A", 0xA20002, -10 * NM, 0.0, alt, 90.0, speed_a, emitter_type=EMITTER_LARGE,
                  callsign="ACFTA")
    b = _aircraft("aircraft-B", OWNSHIP_ICAO, -5 * NM, -2 * NM, alt, 90.0, speed_b, emitter_type=EMITTER_UAV,
                  callsign="ACFTB")
    t_abeam = 5 * NM / (speed_a - speed_b)  # 150 s
    return _scenario(
        "baek-bang-2",
        "Baek & Bang (IJASS 2012) Sec. 5, scenario 2 (Fig. 8): A starts at (-10, 0) nm and B at (-5, -2) nm, both "
        "heading +x (east) at constant velocity; A is faster and overtakes B with 2 nm lateral clearance. Ownship "
        "is B (the overtaken aircraft); intruder is A. Chosen (speeds are missing from the paper's text): A 240 kt, "
        f"B 120 kt, so A is abeam B at t={t_abeam:.0f} s; both at 3000 ft MSL; duration 300 s (A ends 5 nm ahead).",
        b, (a,), duration_s=300.0,
    )


def hwang_tracking() -> Scenario:
    alt = 12000 * FT
    speed = 480 * KT
    # Hwang, Hwang & Tomlin (AIAA GNC 2003) Sec. 3 example: their omega is counter-clockwise positive (Eq. 20,
    # sign of x'y'' - x''y'), ours clockwise positive, so the signs flip: +3 and +1.5 deg/s are left turns.
    legs = (Leg(30.0), Leg(20.0, -3.0), Leg(20.0), Leg(20.0, -1.5), Leg(20.0), Leg(20.0, 4.5), Leg(20.0))
    intr = _aircraft("tracked", 0xA30001, 0.0, 0.0, alt, 90.0, speed, legs, emitter_type=EMITTER_LARGE,
                     callsign="HWANG")
    own_speed, t_meet = 100 * KT, 170.0
    meet = _displacement(90.0, speed, legs, t_meet)  # on the final eastbound straight
    e, n = _start_to_reach(meet, t_meet, 270.0, own_speed)
    own = _aircraft("ownship", OWNSHIP_ICAO, e, n, alt, 270.0, own_speed, emitter_type=EMITTER_UAV,
                    callsign="OWNSHIP")
    return _scenario(
        "hwang-tracking",
        "Hwang, Hwang & Tomlin (AIAA GNC 2003) Sec. 3 tracking example: intruder at 480 kn, straight 0-30 s, "
        "3 deg/s turn 30-50 s, straight 50-70 s, 1.5 deg/s 70-90 s, straight 90-110 s, -4.5 deg/s 110-130 s, "
        "straight to 150 s and on (the paper's 'from 31 to 50 s' read as 20 one-second steps). Paper's omega is "
        "counter-clockwise positive (Eq. 20): the first two turns are left, the last right; net heading change 0. "
        "Chosen (paper has no second aircraft): initial heading east, both at 12000 ft MSL; ownship is a MALE UAV "
        "westbound at 100 kt on the intruder's final track, meeting it head-on (CPA 0 m) at t=170 s, so the "
        "maneuvers are tracked at 6-23 nm and the last turn rolls out pointing at ownship.",
        own, (intr,), duration_s=200.0,
    )


_RADOSAVLJEVIC_SPEED = 311.0  # m/s, both aircraft (Sec. 'Simulation results')
_RADOSAVLJEVIC_ALT = 25000 * FT  # chosen: the paper is horizontal, 'flying at the same altitude'


def _turn_dps(load_g: float) -> float:
    """Turn rate of a level turn of lateral acceleration load_g * g at the papers' 311 m/s: omega = a / v."""
    return math.degrees(load_g * G0 / _RADOSAVLJEVIC_SPEED)


def radosavljevic_1() -> Scenario:
    v, scan = _RADOSAVLJEVIC_SPEED, 5.0
    # Conflict aircraft: turns of g, 2g, g, 3g during scans 10-28, 37-45, 55-58, 65-73 (T = 5 s); directions
    # chosen alternating left, right, left, right (the paper does not say).
    legs = (
        Leg(10 * scan),
        Leg(18 * scan, -_turn_dps(1)),
        Leg(9 * scan),
        Leg(8 * scan, _turn_dps(2)),
        Leg(10 * scan),
        Leg(3 * scan, -_turn_dps(1)),
        Leg(7 * scan),
        Leg(8 * scan, _turn_dps(3)),
    )
    t_meet = 32 * scan  # 'the trajectories from test scenario 1 intersected during scan 32'
    first_turn_deg = 18 * scan * _turn_dps(1)
    heading0 = (315.0 + first_turn_deg) % 360.0  # after the first (left) turn it crosses ownship's track at 90 deg
    own = _aircraft("reference", OWNSHIP_ICAO, 0.0, 0.0, _RADOSAVLJEVIC_ALT, 45.0, v, emitter_type=EMITTER_LARGE,
                    callsign="REF")
    meet = _displacement(45.0, v, (), t_meet)
    e, n = _start_to_reach(meet, t_meet, heading0, v, legs)
    intr = _aircraft("conflict", 0xA40001, e, n, _RADOSAVLJEVIC_ALT, heading0, v, legs,
                     emitter_type=EMITTER_HIGHLY_MANUV, callsign="CONFLICT")
    return _scenario(
        "radosavljevic-1",
        "Radosavljevic, Kovacevic & Ivkovic (VTG 2020) Sec. 'Simulation results', test scenario 1 (Fig. 3a): both "
        "at 311 m/s, scans of T=5 s; the reference aircraft (ownship) flies straight on track 045; the conflict "
        "aircraft turns at g, 2g, g, 3g (omega = n*g/v: 1.81, 3.61, 1.81, 5.42 deg/s) during scans 10-28, 37-45, "
        "55-58, 65-73. Chosen (paper silent or figure-only): turn directions left/right/left/right; conflict "
        "aircraft's initial heading so that after its first turn it crosses ownship's track at 90 deg; both at "
        "the ownship's position at scan 32 (t=160 s, CPA 0 m: the paper's 'intersected during scan 32'); "
        "co-altitude at 25000 ft; duration 73 scans (365 s) so that the last turn completes (the paper says 72).",
        own, (intr,), duration_s=73 * scan,
    )


def radosavljevic_2() -> Scenario:
    v, scan = _RADOSAVLJEVIC_SPEED, 5.0
    t_turn, turn_scans, t_meet = 34 * scan, 8, 44 * scan
    omega = _turn_dps(1)
    legs_ref = (Leg(t_turn), Leg(turn_scans * scan, omega))  # right, toward the mirrored aircraft
    legs_conf = (Leg(t_turn), Leg(turn_scans * scan, -omega))
    # Mirror images about the north axis through the radar (the origin): they meet on that axis at t_meet.
    de, dn = _displacement(45.0, v, legs_ref, t_meet)
    s = de  # reference starts at (-s, -s) on the 45-degree line, so its east coordinate is 0 at t_meet
    own = _aircraft("reference", OWNSHIP_ICAO, -s, -s, _RADOSAVLJEVIC_ALT, 45.0, v, legs_ref,
                    emitter_type=EMITTER_LARGE, callsign="REF")
    intr = _aircraft("conflict", 0xA40002, s, -s, _RADOSAVLJEVIC_ALT, 315.0, v, legs_conf,
                     emitter_type=EMITTER_HIGHLY_MANUV, callsign="CONFLICT")
    return _scenario(
        "radosavljevic-2",
        "Radosavljevic, Kovacevic & Ivkovic (VTG 2020) Sec. 'Simulation results', test scenario 2 (Fig. 3b): both "
        "at 311 m/s; the reference aircraft (ownship) flies along the 45-degree line toward the radar at the "
        "origin, the conflict aircraft mirrors it (about the north axis); at scan 34 (t=170 s) both turn at 1 g "
        "(1.81 deg/s) for 8 scans (72 deg), toward each other; their trajectories meet at scan 44 (t=220 s, "
        f"CPA 0 m) on the north axis. Chosen: start {s / 1000:.1f} km west/east and south of the radar, "
        "turn directions, co-altitude at 25000 ft; duration 72 scans (360 s).",
        own, (intr,), duration_s=72 * scan,
    )


BUILTIN: dict[str, Callable[[], Scenario]] = {
    "head-on": head_on,
    "crossing-90": crossing_90,
    "overtaking": overtaking,
    "climbing-intruder": climbing_intruder,
    "baek-bang-1": baek_bang_1,
    "baek-bang-2": baek_bang_2,
    "hwang-tracking": hwang_tracking,
    "radosavljevic-1": radosavljevic_1,
    "radosavljevic-2": radosavljevic_2,
}
