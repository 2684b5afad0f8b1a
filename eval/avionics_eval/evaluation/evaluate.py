"""One encounter through the onboard core, open and closed loop: `evaluate(encounter, profile, seed) -> record`.

Pure: the record (a flat dict of scalars, RECORD_SCHEMA) depends only on the encounter, the alerting profile and
the seed, which draws the ADS-B noise and the pilot's delay. Nothing is shared between calls but the parsed
configuration, which is read-only.

The core (avionics.daa.Daa) is stepped once a second, the TCAS II surveillance and logic cycle (and DAIDALUS's,
the do365 alerter's `period_s`): each step gets ownship's fix and pressure altitude and the intruder's ADS-B
reports received since the last step (1 Hz, through an avionics_sitl.impairments model, by default DEFAULT:
noise, quantisation, 0.2-0.5 s latency, 5 % lost), stamped on receipt as the MAVLink path stamps them (tslc 0).
Ownship flies the RAs it gets with the SITL response model (avionics_sitl.response.RaResponder, fed the
DAA_ADVISORY the MAVLink port would send), integrated every 0.1 s; by default its delay is drawn per encounter
around the profile's standard delay. Conditions choose other standard surveillance and pilot models.

NMAC: horizontal separation < 500 ft and vertical separation < 100 ft at the same time (Kochenderfer et al.,
ATC-344/345 and the 2010 JGCD paper; Kuchar and Drumm, Lincoln Laboratory Journal 16(2), 2007), on the 0.1 s
truth grid.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, replace
from functools import cache

import numpy as np
import pyarrow as pa

from avionics.advisory.tables import load_profile
from avionics.advisory.wcv import wcv_violation
from avionics.config import load_config
from avionics.base.geodesy import LocalTangentPlane
from avionics.base.types import (
    AddressSource,
    AdvisoryLevel,
    AltitudeDatum,
    IntruderKey,
    IntruderReport,
    OwnshipFix,
    OwnshipPressure,
)
from avionics.base.units import FT
from avionics.daa import Daa
from avionics.guidance.params import BAND_KINDS_READ
from avionics.io.encode import daa_advisory
from avionics_eval.evaluation.generator import DT_S, DURATION_S, T_CPA_S, Encounter
from avionics_sitl.impairments import DEFAULT, DO365_ADSB
from avionics_sitl.response import RaResponder
from avionics_sitl.trajectory import KinematicState

NMAC_HORIZONTAL_M = 500 * FT
NMAC_VERTICAL_M = 100 * FT
STEP_S = 1.0  # the core's logic cycle
REPORT_PERIOD_S = 1.0  # ADS-B position reports
DELAY_SPREAD = 0.4  # pilot delay uniform in standard x [1 - this, 1 + this] (docs/evaluation.md)
SURVEILLANCE = {"sitl": DEFAULT, "do365-adsb": DO365_ADSB}  # avionics_sitl.impairments presets
# guidance: no pilot; the vehicle's autopilot flies the RAs through the guidance port (guided.py)
PILOTS = ("spread", "standard", "trams", "guidance")
# The share of RAs pilots follow in the TRAMS data (issue 28, citing it; the primary report is not verified here)
TRAMS_RESPONSE_PROBABILITY = 0.62


@dataclass(frozen=True)
class Conditions:
    """The surveillance and pilot models of a set (docs/evaluation.md, "Surveillance and pilot models"):
    surveillance, an avionics_sitl.impairments preset (sitl: DEFAULT; do365-adsb: DO-365 Appendix Q as DEGAS);
    altitude_quantum_ft, None for the preset's (25 ft, ADS-B) or e.g. 100 (Mode C); pilot, spread (the profile's
    response, its delay uniform in standard x [0.6, 1.4]), standard (the TCAS standard pilot of DO-185B, the
    tcas2 profile's: 5 s, 0.25 g; strengthening and reversal 2.5 s, 0.35 g; the profile's rates) or trams
    (responds with TRAMS_RESPONSE_PROBABILITY, delay as spread) or guidance (no pilot: the autopilot of the
    vehicle profile `vehicle` flies the RAs through the guidance port, guided.py; the RA logic's response model is
    the vehicle's). guidance_bands (guidance only): the guidance also flies a DO-365 alerter's horizontal
    resolutions from its guidance bands, as the default configuration does; off, the evaluation's default
    (EVALUATION_OVERRIDES), it flies the RAs vertically only, at about half the cost."""

    surveillance: str = "sitl"
    altitude_quantum_ft: float | None = None
    pilot: str = "spread"
    vehicle: str | None = None  # vehicle.profile of the guidance path (pilot "guidance" only)
    guidance_bands: bool = False  # advisory.guidance_bands of the guidance path (pilot "guidance" only)

    def __post_init__(self) -> None:
        if self.surveillance not in SURVEILLANCE:
            raise ValueError(f"surveillance {self.surveillance!r}: one of {', '.join(SURVEILLANCE)}")
        if self.pilot not in PILOTS:
            raise ValueError(f"pilot {self.pilot!r}: one of {', '.join(PILOTS)}")
        if (self.vehicle is not None) != (self.pilot == "guidance"):
            raise ValueError("a vehicle profile goes with the guidance path and the guidance path needs one "
                             f"(pilot {self.pilot!r}, vehicle {self.vehicle!r})")
        if self.guidance_bands and self.pilot != "guidance":
            raise ValueError(f"the guidance bands are flown by the guidance path only (pilot {self.pilot!r})")
        if self.vehicle is not None:
            from avionics_eval.evaluation.guided import check_vehicle

            check_vehicle(self.vehicle)
        q = self.altitude_quantum_ft
        if q is not None and not (isinstance(q, (int, float)) and math.isfinite(q) and q > 0):
            raise ValueError(f"altitude quantum must be a number of feet > 0, got {q!r}")

    @property
    def name(self) -> str:
        quantum = "" if self.altitude_quantum_ft is None else f",altitude_quantum_ft={self.altitude_quantum_ft:g}"
        vehicle = "" if self.vehicle is None else f",vehicle={self.vehicle}"
        bands = ",guidance_bands=on" if self.guidance_bands else ""
        return f"surveillance={self.surveillance}{quantum},pilot={self.pilot}{vehicle}{bands}"

    @property
    def guided(self) -> bool:
        return self.pilot == "guidance"

    def overrides(self) -> tuple[str, ...]:
        """The configuration these conditions add to a profile's (the guidance path's)."""
        if not self.guided:
            return ()
        from avionics_eval.evaluation.guided import overrides

        # the bands the guidance reads; the other kinds are for displays (tests/test_evaluation.py: same records)
        bands = ("advisory.guidance_bands=true",
                 f"advisory.guidance_band_kinds={json.dumps(list(BAND_KINDS_READ))}") if self.guidance_bands else ()
        return (*overrides(self.vehicle), *bands)

    def impairments(self):
        preset = SURVEILLANCE[self.surveillance]
        if self.altitude_quantum_ft is None:
            return preset
        return replace(preset, altitude_quantum_m=self.altitude_quantum_ft * FT)


DEFAULT_CONDITIONS = Conditions()
PLANE = LocalTangentPlane(47.4, 8.5)  # where the encounters are flown (any mid-latitude point)
KEY = IntruderKey(0xC0FFEE, AddressSource.ES1090)
STRENGTH_RANK = {"preventive": 0, "level_off": 1, "corrective": 2, "increase": 3}
REPORT_SUBSTEPS = round(REPORT_PERIOD_S / DT_S)
# Outputs for displays and the autopilot that no advisory reads are cut; tests/test_evaluation.py checks that
# the records are unchanged. The [conflict] zone's probabilities (pc_now, pc_max, pc_within; the default
# criterion, tcas, never reads them): their Monte Carlo and 60 s curve were a third of a tcas2 encounter's cost.
# A DO-365 alerter's guidance bands: four fifths of a do365 encounter's cost (0.63 -> 0.12 CPU-s).
EVALUATION_OVERRIDES = ("zenoh.enabled=false", "conflict.within_samples=0", "conflict.lookahead_s=1.0",
                        "advisory.guidance_bands=false")

RECORD_SCHEMA = pa.schema([
    ("seed", pa.int64()), ("index", pa.int64()), ("profile", pa.string()), ("conditions", pa.string()),
    # the encounter generator (generator.SOURCE, or lincoln.LincolnSource.name) and the encounter's importance
    # weight under it (1 for ours; weighted metrics in metrics.py)
    ("source", pa.string()), ("weight", pa.float64()),
    # the drawn geometry (layer and manoeuvre counts: ours only)
    ("layer", pa.int8()), ("alt_ft", pa.float64()), ("hmd_drawn_ft", pa.float64()), ("vmd_drawn_ft", pa.float64()),
    ("rel_heading_deg", pa.float64()), ("own_speed_kt", pa.float64()), ("int_speed_kt", pa.float64()),
    ("own_vrate_fpm", pa.float64()), ("int_vrate_fpm", pa.float64()),
    ("own_manoeuvres", pa.int8()), ("int_manoeuvres", pa.int8()),
    # truth without ownship flying RAs (unequipped) and with (equipped, closed loop)
    ("t_cpa_s", pa.float64()), ("hmd_ft", pa.float64()), ("vmd_unequipped_ft", pa.float64()),
    ("vmd_equipped_ft", pa.float64()), ("min_vsep_within_nmac_hmd_equipped_ft", pa.float64()),
    ("nmac_unequipped", pa.bool_()), ("nmac_equipped", pa.bool_()), ("induced_nmac", pa.bool_()),
    # loss of DO-365 well clear at any truth sample, without and with the RAs flown
    ("lowc_unequipped", pa.bool_()), ("lowc_equipped", pa.bool_()),
    # alerts
    ("alerted", pa.bool_()), ("first_alert_s", pa.float64()), ("alert_lead_s", pa.float64()),
    ("alert_duration_s", pa.float64()),
    ("ra", pa.bool_()), ("first_ra_s", pa.float64()), ("ra_lead_s", pa.float64()), ("ra_duration_s", pa.float64()),
    ("ra_sl", pa.int8()), ("ra_words", pa.string()), ("ra_episodes", pa.int16()),
    ("ra_reversals", pa.int16()), ("ra_strengthenings", pa.int16()),
    ("response_delay_s", pa.float64()), ("pilot_responds", pa.bool_()), ("late_ra", pa.bool_()),
    ("outside_protection", pa.bool_()),
    ("nuisance_ra", pa.bool_()),
])


def record_schema(conditions: "Conditions | None" = None) -> pa.Schema:
    """The records' schema: RECORD_SCHEMA, and guided.GUIDANCE_FIELDS after it on the guidance path."""
    if conditions is None or not conditions.guided:
        return RECORD_SCHEMA
    from avionics_eval.evaluation.guided import GUIDANCE_FIELDS

    return pa.schema([*RECORD_SCHEMA, *(pa.field(name, kind) for name, kind in GUIDANCE_FIELDS)])


@cache
def _setup(profile: str, overrides: tuple[str, ...] = ()):
    """The parsed configuration and profile (read-only) and the first level row of each sensitivity level."""
    config = load_config(overrides=[*EVALUATION_OVERRIDES, f'advisory.profile="{profile}"', *overrides])
    levels = {}
    for level in load_profile(profile).levels:
        levels.setdefault(level.sl, level)
    return config, levels


def check_profile(profile: str, conditions: "Conditions | None" = None) -> None:
    """Raise the configuration's ConfigError when the profile does not load (an unknown name, a bad file) or, on
    the guidance path, when the configuration refuses the vehicle (e.g. a fixed-wing with guidance.mode execute)."""
    _setup(profile, conditions.overrides() if conditions is not None else ())


def _reports(t, intruder, rng, step_s: float, impairments=DEFAULT) -> dict[int, list[IntruderReport]]:
    """The intruder's ADS-B reports (1 Hz at a random phase on the truth grid) by the step that receives them."""
    impair = impairments.with_seed(int(rng.integers(2**63)))
    phase = int(rng.integers(REPORT_SUBSTEPS))
    idx = np.arange(phase, len(t), REPORT_SUBSTEPS)
    lat, lon = PLANE.to_geodetic(intruder[idx, 0], intruder[idx, 1])
    by_step: dict[int, list] = {}
    for j, k in enumerate(idx):
        x = intruder[k]
        rep = impair.impair(KinematicState(float(t[k]), float(lat[j]), float(lon[j]), float(x[2]), float(x[3]),
                                           float(x[4]), float(x[5])))
        if rep is None:
            continue
        received = float(t[k]) + rep.latency_s
        s = rep.state
        by_step.setdefault(math.ceil(received / step_s - 1e-9), []).append(IntruderReport(
            KEY, received, received, s.lat_deg, s.lon_deg, s.alt_msl_m, AltitudeDatum.PRESSURE,
            (s.vel_east_mps, s.vel_north_mps), s.vel_up_mps))
    return by_step


def _fly(responder, own, t, offsets, rates, j0, j1) -> None:
    """Ownship's response on the truth grid from index j0 to j1 inclusive."""
    for j in range(j0, j1 + 1):
        state = responder.fly(KinematicState(float(t[j]), 0.0, 0.0, float(own[j, 2]), 0.0, 0.0, float(own[j, 5])))
        offsets[j] = responder.offset_m
        rates[j] = state.vel_up_mps - own[j, 5]


def evaluate(encounter: Encounter, profile: str, seed, overrides: tuple[str, ...] = (), *,
             step_s: float = STEP_S, conditions: Conditions = DEFAULT_CONDITIONS) -> dict:
    """The record of one encounter (generator.Encounter or lincoln.LincolnEncounter: truth() and geometry())
    flown with one alerting profile; seed (an int or a sequence of ints) draws the
    ADS-B noise and the pilot's delay. Use the same seed for every profile: the profiles then see the same reports
    (common random numbers), and their differences are the logic's. overrides: more configuration key=value
    (e.g. advisory.criterion), for studies of a profile's variants. step_s: the core's step (and ownship's fix)
    period, a multiple of DT_S (docs/evaluation.md compares 1 s with 0.1 s). conditions: the surveillance and
    pilot models (Conditions)."""
    if conditions.guided:
        return _evaluate_guided(encounter, profile, seed, tuple(overrides), conditions)
    config, levels = _setup(profile, tuple(overrides))
    rng = np.random.default_rng(seed)
    t, own, intruder = encounter.truth()
    substeps = round(step_s / DT_S)
    by_step = _reports(t, intruder, rng, step_s, conditions.impairments())
    daa = Daa(config)
    standard = daa.response_model
    delay = standard.delay_s * rng.uniform(1 - DELAY_SPREAD, 1 + DELAY_SPREAD)
    response, responds = replace(standard, delay_s=delay), True
    if conditions.pilot == "standard":
        response = _tcas_standard_pilot(standard)
        delay = response.delay_s
    elif conditions.pilot == "trams":
        responds = bool(rng.random() < TRAMS_RESPONSE_PROBABILITY)
    own_lat, own_lon = PLANE.to_geodetic(own[::substeps, 0], own[::substeps, 1])
    offsets, rates = np.zeros(len(t)), np.zeros(len(t))
    responder, flown_to = None, -1
    changes = []
    for k in range(round(DURATION_S / step_s) + 1):
        j = k * substeps
        if responder is not None:
            _fly(responder, own, t, offsets, rates, flown_to + 1, j)
            flown_to = j
        alt, vup = float(own[j, 2] + offsets[j]), float(own[j, 5] + rates[j])
        now = float(t[j])
        inputs = [OwnshipFix(now, float(own_lat[k]), float(own_lon[k]), alt, alt, (float(own[j, 4]),
                                                                                   float(own[j, 3]), -vup)),
                  OwnshipPressure(now, alt), *by_step.get(k, ())]
        for change in daa.step(now, inputs).changes:
            changes.append(change)
            if responder is None and responds and change.level is AdvisoryLevel.RA:
                responder = RaResponder(response)
                responder.fly(KinematicState(now, 0.0, 0.0, float(own[j, 2]), 0.0, 0.0, float(own[j, 5])))
                flown_to = j
            if responder is not None:
                responder.receive(daa_advisory(change), now)
    if responder is not None:
        _fly(responder, own, t, offsets, rates, flown_to + 1, len(t) - 1)
    return _record(encounter, profile, t, own, intruder, offsets, changes, delay, standard, levels,
                   conditions=conditions, responds=responds)


def _evaluate_guided(encounter, profile, seed, overrides, conditions) -> dict:
    """The record of an encounter flown through the guidance port (guided.py) instead of a pilot model."""
    from avionics_eval.evaluation.guided import fly

    config, levels = _setup(profile, (*overrides, *conditions.overrides()))
    flown = fly(encounter, PLANE, config, conditions.impairments(), seed, conditions.vehicle)
    t, own, intruder = encounter.truth()
    record = _record(encounter, profile, t, own, intruder, flown.offsets, flown.changes, flown.delay_s,
                     flown.response, levels, conditions=conditions, responds=True)
    record.update(flown.fields)
    return record


@cache
def _tcas_standard_pilot(profile_response):
    """The profile's response model with the TCAS standard pilot's delays and accelerations (DO-185B, as the
    tcas2 profile states them) and the profile's own target rates."""
    tcas = load_profile("tcas2").response
    return replace(profile_response, delay_s=tcas.delay_s, accel_mps2=tcas.accel_mps2,
                   strengthen_delay_s=tcas.strengthen_delay_s, strengthen_accel_mps2=tcas.strengthen_accel_mps2)


def _record(encounter, profile, t, own, intruder, offsets, changes, delay, standard, levels, *,
            conditions: Conditions = DEFAULT_CONDITIONS, responds: bool = True) -> dict:
    """offsets: ownship's flown offset from its path on the truth grid, up (a pilot model: vertical only) or
    (east, north, up) columns (the guidance path)."""
    dh = np.hypot(intruder[:, 0] - own[:, 0], intruder[:, 1] - own[:, 1])
    dz = intruder[:, 2] - own[:, 2]
    if offsets.ndim == 1:
        dz_flown, near_flown = dz - offsets, None
    else:
        dz_flown = dz - offsets[:, 2]
        near_flown = np.hypot(intruder[:, 0] - own[:, 0] - offsets[:, 0],
                              intruder[:, 1] - own[:, 1] - offsets[:, 1]) < NMAC_HORIZONTAL_M
    k = int(np.argmin(dh))
    near = dh < NMAC_HORIZONTAL_M
    if near_flown is None:
        near_flown = near
    nmac_u = bool(np.any(near & (np.abs(dz) < NMAC_VERTICAL_M)))
    nmac_e = bool(np.any(near_flown & (np.abs(dz_flown) < NMAC_VERTICAL_M)))
    t_cpa = float(t[k])
    alert_on, ra_on = _durations(changes)
    alerts = [c for c in changes if c.level is not AdvisoryLevel.NONE]
    ras = [c for c in changes if c.level is AdvisoryLevel.RA]
    first_alert = alerts[0].time_s if alerts else None  # None (null in Parquet): no alert
    first_ra = ras[0].time_s if ras else None
    reversals, strengthenings, episodes = _ra_sequence(changes)
    level = levels.get(ras[0].sensitivity_level) if ras else None
    protection_hmd = level.ra_hmd_m or level.ra_dmod_m if level is not None and level.ra_dmod_m else None
    outside = level is not None and protection_hmd is not None and level.alim_m is not None and (
        dh[k] > protection_hmd or abs(dz[k]) > level.alim_m)
    # An RA is late when it leaves less time than the standard response needs to reach its rate.
    needed = standard.delay_s + standard.rate_mps / standard.accel_mps2
    lowc_u, lowc_e = _loss_of_well_clear(t, own, intruder, offsets)
    return {
        "seed": encounter.seed, "index": encounter.index, "profile": profile, "conditions": conditions.name,
        **encounter.geometry(),
        "t_cpa_s": t_cpa, "hmd_ft": float(dh[k]) / FT, "vmd_unequipped_ft": abs(float(dz[k])) / FT,
        "vmd_equipped_ft": abs(float(dz_flown[k])) / FT,
        "min_vsep_within_nmac_hmd_equipped_ft": float(np.abs(dz_flown[near_flown]).min()) / FT
        if near_flown.any() else None,
        "nmac_unequipped": nmac_u, "nmac_equipped": nmac_e, "induced_nmac": nmac_e and not nmac_u,
        "lowc_unequipped": lowc_u, "lowc_equipped": lowc_e,
        "alerted": bool(alerts), "first_alert_s": first_alert, "alert_lead_s": _lead(t_cpa, first_alert),
        "alert_duration_s": alert_on,
        "ra": bool(ras), "first_ra_s": first_ra, "ra_lead_s": _lead(t_cpa, first_ra), "ra_duration_s": ra_on,
        "ra_sl": ras[0].sensitivity_level if ras else None,
        "ra_words": "|".join(c.ra_words or "" for c in ras), "ra_episodes": episodes,
        "ra_reversals": reversals, "ra_strengthenings": strengthenings,
        "response_delay_s": float(delay) if delay is not None else None, "pilot_responds": responds,
        "late_ra": nmac_u and (first_ra is None or t_cpa - first_ra < needed),
        "outside_protection": bool(outside), "nuisance_ra": bool(ras) and bool(outside),
    }


DO365_PHASE_I = load_profile("daidalus-do365b-no-sum").alerter.levels[-1].thresholds  # DWC_Phase_I det_3, the data


def _lead(t_cpa: float, first: float | None) -> float | None:
    return None if first is None else t_cpa - first


def _loss_of_well_clear(t, own, intruder, offsets) -> tuple[bool, bool]:
    """Whether the DO-365 well-clear volume (Phase I: DTHR 4000 ft, ZTHR 450 ft, modified tau 35 s, as the profile
    daidalus-do365b-no-sum states them; avionics.advisory.wcv) is violated at any truth sample, without and with ownship's flown offset (vertical,
    or east, north and up: see _record)."""
    s_xy = intruder[:, 0:2] - own[:, 0:2]
    v_xy = intruder[:, 3:5] - own[:, 3:5]
    sz, vz = intruder[:, 2] - own[:, 2], intruder[:, 5] - own[:, 5]
    offset_rate = np.gradient(offsets, t, axis=0)
    unequipped = wcv_violation(s_xy, v_xy, sz, vz, DO365_PHASE_I)
    if offsets.ndim == 1:
        equipped = wcv_violation(s_xy, v_xy, sz - offsets, vz - offset_rate, DO365_PHASE_I)
    else:
        equipped = wcv_violation(s_xy - offsets[:, 0:2], v_xy - offset_rate[:, 0:2], sz - offsets[:, 2],
                                 vz - offset_rate[:, 2], DO365_PHASE_I)
    return bool(unequipped.any()), bool(equipped.any())


def _durations(changes) -> tuple[float, float]:
    """Seconds with an alert (TA or RA) and with an RA; one still on at the end counts to DURATION_S."""
    alert = ra = 0.0
    level, since = AdvisoryLevel.NONE, 0.0
    for c in [*changes, None]:
        now = DURATION_S if c is None else c.time_s
        alert += (now - since) if level is not AdvisoryLevel.NONE else 0.0
        ra += (now - since) if level is AdvisoryLevel.RA else 0.0
        if c is not None:
            level, since = c.level, now
    return alert, ra


def _ra_sequence(changes) -> tuple[int, int, int]:
    """(reversals, strengthenings, RA episodes): a reversal is a sense change within an RA; a strengthening keeps
    the sense and raises the strength (preventive < level off < corrective < increase)."""
    reversals = strengthenings = episodes = 0
    previous = None
    for c in changes:
        if c.level is not AdvisoryLevel.RA:
            previous = None
            continue
        if previous is None:
            episodes += 1
        elif c.ra_sense != previous.ra_sense:
            reversals += 1
        elif STRENGTH_RANK.get(c.ra_strength, 0) > STRENGTH_RANK.get(previous.ra_strength, 0):
            strengthenings += 1
        previous = c
    return reversals, strengthenings, episodes


__all__ = ["NMAC_HORIZONTAL_M", "NMAC_VERTICAL_M", "RECORD_SCHEMA", "T_CPA_S", "check_profile", "evaluate",
           "record_schema"]
