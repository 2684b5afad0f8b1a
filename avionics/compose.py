"""The composition root: every variant of the core (tracker, motion models, gating, persistence, prefilter,
Pc method, alerter) is built here from the configuration, and nowhere else. The stages receive objects, never
strings that name a variant. `build_components` is what the core (pipeline/daa_core.py DaaCore) is made of; a shell
or a test may hand the core other objects behind the same interfaces instead."""

from __future__ import annotations

import math
from collections import Counter
from dataclasses import dataclass, replace
from collections.abc import Callable
from typing import TYPE_CHECKING

if TYPE_CHECKING:  # the parts' types; the variants themselves are imported only when built (start-up, issue 13)
    from avionics.advisory.alerting import Alerter
    from avionics.advisory.bands import BandsEngine
    from avionics.advisory.gating import AlertGate, Criterion
    from avionics.advisory.inhibits import LowAltitudeInhibits
    from avionics.advisory.params import AdvisoryConfig
    from avionics.advisory.persistence import AlertingHysteresis, NoHysteresis, Persistence
    from avionics.advisory.resolution import ResolutionLogic
    from avionics.advisory.tables import AlertProfile, LevelSelector
    from avionics.config import Config
    from avionics.conflict.assess import ConflictAssessor
    from avionics.conflict.params import ConflictConfig
    from avionics.conflict.probability import PcMethod
    from avionics.conflict.scheduling import Prefilter
    from avionics.tracking.interface import Tracker
    from avionics.tracking.params import TrackingConfig


@dataclass(frozen=True)
class Components:
    """The core's parts: the alerting profile (data) and the objects built from it and from the configuration. The
    variants sit behind the Protocols: the tracker's (Tracker, its MotionModels), the gate's (Criterion,
    Persistence), the conflict stage's (Prefilter, PcMethod) and the alerter's levels' (Detector, Continuation)."""

    profile: AlertProfile  # sensitivity levels, inhibits, response model
    levels: LevelSelector  # the sensitivity level from altitude
    alerter: Alerter  # the alert levels, each with its detector
    hysteresis: AlertingHysteresis | NoHysteresis  # a DO-365 alerter's M of N and persistence; none for tcas2
    bands: BandsEngine | None  # a DO-365 alerter's guidance; None: no bands
    gate: AlertGate  # criterion and persistence
    resolution: ResolutionLogic  # RA sense and strength
    inhibits: LowAltitudeInhibits
    conflict: ConflictAssessor  # prefilter and Pc method
    tracker: Tracker


def build_components(config: Config, counters: Counter) -> Components:
    """Every part of the core from a validated configuration (avionics/config.py)."""
    from avionics.advisory.inhibits import LowAltitudeInhibits
    from avionics.advisory.resolution import ResolutionLogic
    from avionics.advisory.tables import LevelSelector, load_profile

    profile = load_profile(config.advisory.profile, config.advisory.profile_overrides)
    if config.vehicle.profile:  # the vehicle's own performance: what the logic assumes is what it can fly
        from avionics.advisory.vehicle import load_vehicle

        vehicle = load_vehicle(config.vehicle.profile)
        profile = replace(profile, response=vehicle.response_model(),
                          bands=vehicle.bands_params(profile.bands) if profile.bands is not None else None)
    return Components(
        profile=profile, levels=LevelSelector(profile), alerter=build_alerter(config.advisory, profile),
        hysteresis=build_hysteresis(profile),
        bands=build_bands(profile, config.advisory.guidance_band_kinds) if config.advisory.guidance_bands else None,
        gate=build_gate(config.advisory), resolution=ResolutionLogic(profile), inhibits=LowAltitudeInhibits(profile),
        conflict=build_conflict_assessor(config.conflict), tracker=build_surveillance(config.tracking, counters))


def build_surveillance(tracking_params: TrackingConfig, counters: Counter) -> Tracker:
    """Every surveillance source as one tracker (tracking/surveillance.py): the ADS-B tracker (build_tracker)
    and, from the first scan on, the range/bearing sensors' tracks over the IMM motion models of [tracking]."""
    from avionics.tracking.surveillance import SurveillanceTracker

    return SurveillanceTracker(build_tracker(tracking_params, counters),
                               lambda period_s, horizontal: motion_models(tracking_params, period_s, horizontal),
                               tracking_params, counters)


def motion_models(t: TrackingConfig, period_s: float = 1.0, horizontal=None) -> tuple[list, list]:
    """The IMM's horizontal and vertical mode filters (tracking/models.py) of tracking.imm_horizontal_modes (or
    the names `horizontal`: the radar tracks' tracking.radar_horizontal_modes) and imm_vertical_modes, their
    noise from [tracking]. Those sigmas are per step and were chosen for ADS-B's 1 s
    report period; period_s: the period of the measurements the filters will take (a 10 Hz radar: 0.1 s), for
    which each per-step sigma is rescaled to put the same noise into a second of flight: a per-step velocity
    increment of sigma T (CV's piecewise-constant acceleration, Baek & Bang eq 5; CAD, eq 8) adds sigma^2 T^2
    per step, sigma^2 T per second, so sigma^2 is divided by T; a per-step acceleration or vertical-speed
    increment (CT's and CA's Wiener sequence, Hwang eq 18, Baek & Bang eq 6; CH, eq 7) adds sigma^2 per step,
    so sigma^2 is multiplied by T. Left at per-step values, a 10 Hz radar's CT mode took ten times the
    acceleration variance a second and its CV mode a tenth: tracks whose velocity wandered by 3-5 m/s at 6 km
    (issue 30's extra radar alerts)."""
    from avionics.tracking import models  # only when an IMM is configured: start-up (issue 13)

    if not (math.isfinite(period_s) and period_s > 0.0):
        raise ValueError(f"measurement period must be a positive number of seconds, got {period_s!r}")
    faster, slower = math.sqrt(1.0 / period_s), math.sqrt(period_s)  # sigma factors for 1 s -> period_s
    motion = {
        "cv": lambda: models.ConstantVelocity(t.imm_cv_sigma_mps2 * faster),  # Baek & Bang eq 5
        "ca": lambda: models.ConstantAcceleration(t.imm_ca_sigma_mps2 * slower, heading_noise=True),  # eq 6, 31
        "ct": lambda: models.CoordinatedTurn(t.imm_ct_sigma_mps2 * slower),  # Hwang eq 18
        "cs": lambda: models.CurrentStatistical(t.imm_cs_alpha_per_s, t.imm_cs_max_accel_mps2),  # Dai eqs 8-12
        # Bar-Shalom et al. eq 11.7.1-4 at +-imm_turn_rate_dps; white acceleration as CV's
        "turn_left": lambda: models.KnownRateTurn(math.radians(t.imm_turn_rate_dps), t.imm_turn_sigma_mps2 * faster),
        "turn_right": lambda: models.KnownRateTurn(-math.radians(t.imm_turn_rate_dps), t.imm_turn_sigma_mps2 * faster),
        "ch": lambda: models.ConstantHeight(t.imm_ch_sigma_mps * slower),  # Baek & Bang eq 7
        "cad": lambda: models.ConstantAltitudeChange(t.imm_cad_sigma_mps2 * faster),  # Baek & Bang eq 8
    }
    horizontal = t.imm_horizontal_modes if horizontal is None else horizontal
    return [motion[k]() for k in horizontal], [motion[k]() for k in t.imm_vertical_modes]


def build_tracker(tracking_params: TrackingConfig, counters: Counter, capacity: int = 16) -> Tracker:
    """The intruder tracker tracking.filter names (docs/tracking.md): cv, one CV Kalman filter per track
    (tracking/tracker.py); imm, rmimm (Hwang eqs 11-14's residual-mean likelihood), vb-imm, vb-rmimm (Dai eqs
    17-25's variational-Bayes measurement noise), the IMM tracker (tracking/imm_tracker.py) over the motion
    models of tracking.imm_horizontal_modes and imm_vertical_modes (tracking/models.py); capacity: the IMM
    banks' initial number of track slots (they grow as needed)."""
    t = tracking_params
    if t.filter == "cv":
        from avionics.tracking.tracker import IntruderTracker

        return IntruderTracker(t, counters)
    from avionics.tracking.imm import VbParams
    from avionics.tracking.imm_tracker import ImmTracker

    vb = VbParams(t.vb_iterations, t.vb_c1, t.vb_c2, t.vb_c3) if t.filter.startswith("vb-") else None
    h_modes, v_modes = motion_models(t)
    return ImmTracker(t, counters, h_modes, v_modes, likelihood="rmimm" if "rmimm" in t.filter else "standard",
                      vb=vb, name=t.filter, capacity=capacity)


def build_alerter(advisory_params: AdvisoryConfig, profile: AlertProfile) -> Alerter:
    """The alerter (advisory/alerting.py) of the profile: without an [alerter] table the `tcas2` alerter, levels
    1 "TA" and 2 "RA", both TCAS3D with the columns of the profile's sensitivity-level table ([B71] Table 3 for
    tcas2; the RA's HMD filter from advisory.hmd_filter, the TA's minimum duration from
    advisory.ta_min_duration_s); with one (kind "wcv": daidalus-do365b-no-sum, daidalus-do365b-sum, do365, do365-non-coop, f3442) the
    DO-365 well-clear alerter of its levels. `alerting.cd3d_alerter` is the DAIDALUS CD3D alternative, not
    selectable by configuration. The profile's sensitivity levels are not copied in: the core hands the alerter
    the level it selected at each assessment."""
    from avionics.advisory.alerting import tcas2_alerter, wcv_alerter

    if profile.alerter is not None:
        other = profile.alerter.non_cooperative
        return wcv_alerter(profile.alerter, profile.name,
                           None if other is None else non_cooperative_alerter(profile, other))
    return tcas2_alerter(hmd_filter=advisory_params.hmd_filter, ta_min_duration_s=advisory_params.ta_min_duration_s)


def non_cooperative_alerter(profile: AlertProfile, name: str) -> Alerter:
    """The alerter of profile `name` for the intruders seen only by the ownship's sensors ([alerter]
    non_cooperative; its levels and hysteresis were checked against the profile's at load,
    tables._check_non_cooperative)."""
    from avionics.advisory.alerting import wcv_alerter
    from avionics.advisory.tables import load_profile

    return wcv_alerter(load_profile(name).alerter, name)


def build_hysteresis(profile: AlertProfile) -> AlertingHysteresis | NoHysteresis:
    """A DO-365 alerter's alerting hysteresis (advisory/persistence.py AlertingHysteresis: DAIDALUS HysteresisData
    with the profile's M of N, persistence and hysteresis times); none for the tcas2 alerter."""
    from avionics.advisory.persistence import AlertingHysteresis, NoHysteresis

    spec = profile.alerter
    if spec is None:
        return NoHysteresis()
    return AlertingHysteresis(spec.hysteresis_time_s, spec.persistence_time_s, spec.alerting_m, spec.alerting_n,
                              spec.period_s)


def build_bands(profile: AlertProfile, kinds: tuple[str, ...] | None = None) -> BandsEngine | None:
    """A DO-365 alerter's guidance bands (advisory/bands.py, DAIDALUS DaidalusRealBands): the profile's [bands]
    parameters and the alerter's levels, each painting its region (a sensor-only intruder's conflicts with its
    non-cooperative alerter's, [alerter] non_cooperative); None for the tcas2 alerter. kinds: the kinds computed
    (advisory.guidance_band_kinds; None: all four)."""
    spec = profile.alerter
    if spec is None:
        return None
    from avionics.advisory.bands import BandsEngine  # not imported for tcas2: start-up (issue 13)

    from avionics.advisory.tables import load_profile

    other = None if spec.non_cooperative is None else load_profile(spec.non_cooperative).alerter.levels
    # the alerter's levels (SUM: its tests too), and the non-cooperative alerter's for the sensor-only intruders
    return BandsEngine(profile.bands, spec.levels, sum_z=spec.sum, non_cooperative_levels=other, kinds=kinds)


def build_gate(advisory_params: AdvisoryConfig) -> AlertGate:
    """The alert gate (advisory/gating.py): the criterion advisory.criterion names (tcas | tcas+pc | pc) and the
    persistence advisory.persistence names (none | m-of-n | binomial, advisory/persistence.py)."""
    from avionics.advisory import gating, persistence

    a = advisory_params
    criterion: dict[str, Callable[[], Criterion]] = {
        "tcas": lambda: gating.TcasCriterion(),
        "tcas+pc": lambda: gating.TcasPcCriterion(a.pc_ta_threshold, a.pc_ra_threshold),
        "pc": lambda: gating.PcCriterion(a.pc_ta_threshold, a.pc_ra_threshold),
    }
    persist: dict[str, Callable[[], Persistence]] = {
        "none": lambda: persistence.NoPersistence(),
        "m-of-n": lambda: persistence.MOfNPersistence(a.persistence_m, a.persistence_n),
        "binomial": lambda: persistence.BinomialPersistence(a.persistence_m, a.persistence_n,
                                                            a.persistence_confidence),
    }
    return gating.AlertGate(criterion[a.criterion](), persist[a.persistence]())


def build_prefilter(conflict_params: ConflictConfig) -> Prefilter:
    """The pair pre-filter conflict.prefilter names (conflict/scheduling.py, Hwang condition 2): min_distance
    (2(b) widened by 3 sigma), hwang (2(a) as printed and 2(b)), none."""
    from avionics.conflict import scheduling

    c = conflict_params
    if c.prefilter == "none":
        return scheduling.NoPrefilter()
    cls = {"min_distance": scheduling.MinDistancePrefilter, "hwang": scheduling.HwangPrefilter}[c.prefilter]
    return cls(c.zone_radius_m, c.zone_half_height_m, c.lookahead_s, c.step_s, c.prefilter_alpha,
               c.accel_sigma_h_mps2, c.accel_sigma_v_mps2)


def build_pc_method(conflict_params: ConflictConfig) -> PcMethod:
    """The Pc method conflict.method names (conflict/probability.py): exact, one_block, blocks (n_blocks), pe,
    mc (mc_samples)."""
    from avionics.conflict import probability

    c = conflict_params
    methods: dict[str, Callable[[], PcMethod]] = {
        "exact": lambda: probability.ExactPc(),
        "one_block": lambda: probability.OneBlockPc(),
        "blocks": lambda: probability.BlocksPc(c.n_blocks),
        "pe": lambda: probability.PaielliErzbergerPc(),
        "mc": lambda: probability.MonteCarloPc(c.mc_samples),
    }
    return methods[c.method]()


def build_conflict_assessor(conflict_params: ConflictConfig) -> ConflictAssessor:
    """The conflict stage (conflict/assess.py) with its pre-filter and Pc method."""
    from avionics.conflict.assess import ConflictAssessor

    return ConflictAssessor(conflict_params, build_prefilter(conflict_params), build_pc_method(conflict_params))
