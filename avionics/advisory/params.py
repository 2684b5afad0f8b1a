"""Parameters of the advisory stage: [advisory] (avionics/advisory/gating.py, logic.py; the alerting profile of
avionics/advisory/tables.py). docs/configuration.md and config/default.toml document them."""

from __future__ import annotations

from dataclasses import dataclass

from avionics.base.params import ConfigError, require_positive

CRITERIA = ("tcas", "tcas+pc", "pc")
# The re-assessment rate: at least the 1 Hz of the TCAS II logic cycle (RTCA DO-185B: threats are assessed every
# surveillance second), at most 100 Hz (the main loop's tick is 1/assessment_hz; faster only burns the core, as
# reports arrive at a few Hz).
ASSESSMENT_HZ_MIN, ASSESSMENT_HZ_MAX = 1.0, 100.0
PERSISTENCE = ("none", "m-of-n", "binomial")


@dataclass(frozen=True)
class AdvisoryConfig:
    assessment_hz: float = 10.0
    assessment_slice: int = 128  # re-assessments per step beyond fresh reports, while the pass keeps its pace
    ta_min_duration_s: float = 8.0  # TCAS II: a TA stays at least 8 s
    ra_enabled: bool = True
    guidance_bands: bool = True  # a DO-365 alerter's guidance bands; false: its alerts only (they never read them)
    # which of them: DAIDALUS computes all four; the others cost CPU for a display only (the guidance turns by
    # the track bands: guidance/params.py BAND_KINDS_READ). = contract/bands.py BAND_KIND_NAMES, written out: that
    # module imports numpy, which `avionics --help` must not (tests/test_startup.py; test_bands.py holds them equal)
    guidance_band_kinds: tuple[str, ...] = ("track_deg", "ground_speed_mps", "vertical_rate_mps", "altitude_m")
    hmd_filter: bool = True  # TCAS II v7.1 RA horizontal miss distance filter
    # a SUM detector's uncertainties from the tracks' covariances where the surveillance states none
    # (base/uncertainty.py errors_from_covariance); false: stated ones only (conformance runs)
    sum_from_tracks: bool = False
    profile: str = "tcas2"  # built-in profile (tcas2, small-uas, do365) or a profile .toml path
    profile_overrides: tuple[str, ...] = ()  # e.g. ("sl4.ra_tau_s=25", "response.delay_s=3")
    criterion: str = "tcas"  # tcas | tcas+pc | pc (docs/advisories.md, "Probabilistic gating")
    pc_ta_threshold: float = 0.1  # Pc of the TA volume needed by tcas+pc and pc
    pc_ra_threshold: float = 0.3  # Pc of the RA volume needed by tcas+pc and pc
    persistence: str = "none"  # none | m-of-n | binomial (Radosavljevic eqs 19-24)
    persistence_m: int = 2
    persistence_n: int = 3
    persistence_confidence: float = 0.5  # binomial: P(at least m of n in conflict) needed
    ground_elevation_m: float | None = None  # AGL = MSL - this; None: AGL from height above home

    def validate(self) -> None:
        a = self
        require_positive("advisory", a, ("assessment_hz",))
        if not ASSESSMENT_HZ_MIN <= a.assessment_hz <= ASSESSMENT_HZ_MAX:
            raise ConfigError(f"advisory.assessment_hz: must be in {ASSESSMENT_HZ_MIN:g}..{ASSESSMENT_HZ_MAX:g} Hz, "
                              f"got {a.assessment_hz:g}")
        if not isinstance(a.assessment_slice, int) or a.assessment_slice < 1:
            raise ConfigError("advisory.assessment_slice: must be a whole number >= 1")
        if a.criterion not in CRITERIA:
            raise ConfigError(f"advisory.criterion: {a.criterion!r} is not tcas, tcas+pc or pc")
        if a.persistence not in PERSISTENCE:
            raise ConfigError(f"advisory.persistence: {a.persistence!r} is not none, m-of-n or binomial")
        if not 1 <= a.persistence_m <= a.persistence_n <= 50:
            raise ConfigError("advisory.persistence_m and persistence_n: need 1 <= m <= n <= 50")
        from avionics.contract.bands import BAND_KIND_NAMES

        unknown = [k for k in a.guidance_band_kinds if k not in BAND_KIND_NAMES]
        if unknown or not a.guidance_band_kinds or len(set(a.guidance_band_kinds)) != len(a.guidance_band_kinds):
            raise ConfigError(f"advisory.guidance_band_kinds: each of {', '.join(BAND_KIND_NAMES)} at most once, at "
                              f"least one; got {list(a.guidance_band_kinds)}")
        for name in ("pc_ta_threshold", "pc_ra_threshold", "persistence_confidence"):
            if not 0.0 <= getattr(a, name) <= 1.0:
                raise ConfigError(f"advisory.{name}: must be a probability in [0, 1]")
        # The profile is data of this package: it must load, with its overrides (reads a file for a path).
        from avionics.advisory.tables import ProfileError, load_profile

        try:
            profile = load_profile(a.profile, a.profile_overrides)
        except ProfileError as exc:
            raise ConfigError(f"advisory.profile: {exc}") from exc
        if profile.alerter is not None and (a.criterion != "tcas" or a.persistence == "binomial"):
            # the gate's Pc volumes and the binomial filter are the TA's and the RA's; a DO-365 alerter has its
            # own levels and its own M of N (the profile's [alerter] table)
            raise ConfigError(f"advisory.profile {a.profile!r} is a DO-365 well-clear alerter: it needs "
                              f"advisory.criterion = \"tcas\" (its detectors decide) and advisory.persistence "
                              f"none or m-of-n (it has its own M of N and persistence)")
