"""Parameters of the tracking components: [input] (report plausibility and ownship freshness, applied by
avionics/io/decode.py and avionics/tracking/ownship.py), [tracking] (avionics/tracking/tracker.py,
imm_tracker.py) and [altitude] (avionics/tracking/ownship.py, baro_check.py). docs/configuration.md and
config/default.toml document them."""

from __future__ import annotations

from dataclasses import dataclass

from avionics.base.params import ConfigError, require_non_negative, require_positive


@dataclass(frozen=True)
class InputConfig:
    max_report_age_s: float = 3.0  # tslc older than this: report rejected as stale (tslc 255 = unknown age)
    max_ground_speed_mps: float = 350.0  # faster than any aircraft we protect against: report rejected
    max_vertical_rate_mps: float = 100.0
    min_altitude_m: float = -500.0
    max_altitude_m: float = 20000.0
    ownship_timeout_s: float = 2.0  # no GLOBAL_POSITION_INT for this long: no advisories, status says so
    pressure_timeout_s: float = 3.0  # no SCALED_PRESSURE for this long: ownship pressure altitude unknown
    # GLOBAL_POSITION_INT jump check (avionics/io/ownship_check.py): a fix farther than this (plus 10 m/s^2 over
    # the interval) from the previous fix integrated with their velocities is rejected; rejections that go on for
    # ownship_jump_persist_s make DAA unavailable (ownship_inconsistent), and a fix after that long without an
    # accepted one starts the check again.
    ownship_jump_m: float = 100.0
    ownship_jump_persist_s: float = 5.0

    def validate(self) -> None:
        require_positive("input", self, ("max_report_age_s", "ownship_jump_m", "ownship_jump_persist_s"))


TRACK_FILTERS = ("cv", "imm", "rmimm", "vb-imm", "vb-rmimm")
IMM_HORIZONTAL_MODES = ("cv", "ca", "ct", "cs", "turn_left", "turn_right")
IMM_VERTICAL_MODES = ("ch", "cad")


@dataclass(frozen=True)
class TrackingConfig:
    # Default measurement noise (1-sigma) per address source: ADSB_VEHICLE carries no NACp/NACv.
    position_sigma_1090es_m: float = 30.0  # ~NACp 8 (EPU < 92.6 m at 95 %)
    position_sigma_uat_m: float = 30.0
    velocity_sigma_mps: float = 2.0  # ~NACv 2 (< 3 m/s at 95 %) plus heading quantisation
    altitude_sigma_m: float = 8.0  # 25 ft quantisation and altimetry error
    vertical_rate_sigma_mps: float = 1.0  # 64 fpm quantisation
    horizontal_accel_sigma_mps2: float = 1.5  # CV model white-acceleration noise
    vertical_accel_sigma_mps2: float = 0.7
    max_coast_s: float = 6.0  # without reports for longer: an alert is a lost threat (advisory/logic.py lost_hold)
    delete_after_s: float = 20.0  # without reports for longer: track deleted
    max_innovation_speed_mps: float = 400.0  # a report implying a jump faster than this is not this aircraft
    # Track filter (docs/tracking.md): cv = one Kalman CV filter per track; imm, rmimm (Hwang's residual-mean
    # likelihood), vb-imm, vb-rmimm (Dai's variational-Bayes measurement noise) = the vectorised IMM tracker.
    filter: str = "imm"  # default by measurement: docs/tracking.md "Default filter"
    imm_horizontal_modes: tuple[str, ...] = ("cv", "ct")  # of cv, ca, ct, cs, turn_left, turn_right
    imm_vertical_modes: tuple[str, ...] = ("ch", "cad")  # of ch, cad
    imm_switch_probability: float = 0.05  # per second, out of each mode (Hwang eq 21, Baek & Bang eq 30)
    imm_cv_sigma_mps2: float = 0.3  # CV white acceleration (Baek & Bang eq 5)
    imm_ca_sigma_mps2: float = 3.0  # CA acceleration noise, heading-rotated (Baek & Bang eq 31)
    imm_ct_sigma_mps2: float = 2.0  # CT acceleration increment per step (Hwang eq 18)
    imm_turn_rate_dps: float = 3.0  # turn_left/turn_right: the standard-rate turn (FAA-H-8083-15B, 3 deg/s)
    imm_turn_sigma_mps2: float = 0.3  # their white acceleration (as CV's, Baek & Bang eq 5)
    imm_turn_exit_probability: float = 0.2  # per second, out of each of them (models.mode_switching)
    imm_cs_alpha_per_s: float = 0.1  # CS manoeuvre frequency (Dai eq 10)
    imm_cs_max_accel_mps2: float = 20.0  # CS acceleration bound (Dai eq 12)
    imm_ch_sigma_mps: float = 0.1  # CH vertical-speed increment per step (Baek & Bang eq 7)
    imm_cad_sigma_mps2: float = 1.0  # CAD vertical acceleration (Baek & Bang eq 8)
    imm_initial_accel_sigma_mps2: float = 3.0  # prior on an intruder's acceleration at track initiation
    gate_probability: float = 0.9999  # chi-square validation gate (Radosavljevic eq 17)
    # Radar tracks (tracking/sensor_tracker.py; docs/tracking.md "Turns seen by a radar"): their own horizontal
    # modes and switching, for positions without a velocity that are dense enough to show a turn, and elevations
    # too noisy at 20 km to show a climb. Active surveillance's tracks keep imm_horizontal_modes and
    # imm_switch_probability.
    radar_horizontal_modes: tuple[str, ...] = ("cv", "ct", "turn_left", "turn_right")
    radar_switch_probability: float = 0.01  # per second, out of each mode but the turns, in both banks
    # A sensor track started without an elevation (active surveillance) keeps a range track (range_tracker.py:
    # closure and miss from the ranges, TCAS II's) when its detections' bearings are this coarse: Appendix Q's
    # active surveillance (9-15 deg) needs one, a bearing as fine as the radar's 1 deg does not (docs/tracking.md,
    # "Active surveillance's range track").
    range_track_bearing_sigma_deg: float = 2.0
    # A sensor's measured range rates are taken as one error draw over this long (sensor_tracker.py _range_rates:
    # Appendix Q's radar has a bias for the run under its white error; docs/tracking.md, "A radar track's range
    # rates"). 0: white.
    range_rate_correlation_s: float = 1.0
    rmimm_floor: float = 1.0  # RMIMM: floor of the residual-mean norm (Hwang eq 14), in sigmas
    yaw_rate_time_constant_s: float = 11.9  # turn-rate low-pass 1/(T s + 1) (Hwang)
    vb_iterations: int = 5  # VB fixed-point iterations per report (Dai eqs 22-25)
    vb_c1: float = 1000.0  # VB forgetting factor constants (Dai eq 17), on the estimate / nominal variance
    vb_c2: float = 500.0
    vb_c3: float = 5000.0

    def modes_for(self, kind: str) -> tuple[tuple[str, ...], float]:
        """The horizontal IMM modes of a surveillance kind's tracks ("radar", "active" or "adsb") and how often a
        track leaves each mode of either bank but the turns (those at imm_turn_exit_probability): the radar's own,
        else the ADS-B tracks' (docs/tracking.md, "Turns seen by a radar")."""
        if kind == "radar":
            return self.radar_horizontal_modes, self.radar_switch_probability
        return self.imm_horizontal_modes, self.imm_switch_probability

    def validate(self) -> None:
        t = self
        require_positive("tracking", t, ("position_sigma_1090es_m", "position_sigma_uat_m", "velocity_sigma_mps",
                                         "altitude_sigma_m", "vertical_rate_sigma_mps", "max_coast_s"))
        if t.delete_after_s < t.max_coast_s:
            raise ConfigError("tracking.delete_after_s must be >= tracking.max_coast_s")
        if t.filter not in TRACK_FILTERS:
            raise ConfigError(f"tracking.filter: {t.filter!r} is not one of {', '.join(TRACK_FILTERS)}")
        for name, modes, allowed in (("imm_horizontal_modes", t.imm_horizontal_modes, IMM_HORIZONTAL_MODES),
                                     ("radar_horizontal_modes", t.radar_horizontal_modes, IMM_HORIZONTAL_MODES),
                                     ("imm_vertical_modes", t.imm_vertical_modes, IMM_VERTICAL_MODES)):
            if not modes or len(set(modes)) != len(modes) or not set(modes) <= set(allowed):
                raise ConfigError(f"tracking.{name}: {list(modes)} must be distinct modes out of {list(allowed)}")
        require_positive("tracking", t, ("imm_cv_sigma_mps2", "imm_ca_sigma_mps2", "imm_ct_sigma_mps2",
                                         "imm_cs_alpha_per_s", "imm_cs_max_accel_mps2",
                                         "imm_turn_rate_dps", "imm_turn_sigma_mps2", "imm_ch_sigma_mps",
                                         "imm_cad_sigma_mps2", "imm_initial_accel_sigma_mps2", "rmimm_floor",
                                         "yaw_rate_time_constant_s", "range_track_bearing_sigma_deg"))
        require_non_negative("tracking", t, ("vb_c1", "vb_c2", "vb_c3", "range_rate_correlation_s"))
        for name in ("imm_switch_probability", "radar_switch_probability", "imm_turn_exit_probability"):
            if not 0.0 < getattr(t, name) < 0.5:
                raise ConfigError(f"tracking.{name}: must be in (0, 0.5), got {getattr(t, name)}")
        if not 0.5 < t.gate_probability < 1.0:
            raise ConfigError(f"tracking.gate_probability: must be in (0.5, 1), got {t.gate_probability}")
        if not 1 <= t.vb_iterations <= 100:
            raise ConfigError(f"tracking.vb_iterations: must be in [1, 100], got {t.vb_iterations}")


@dataclass(frozen=True)
class AltitudeConfig:
    # When only mismatched datums exist (pressure vs geometric), the vertical uncertainty is widened by this
    # much: pressure and GNSS altitudes differ by up to a few hundred feet with temperature and weather.
    datum_mismatch_margin_m: float = 60.96  # 200 ft
    baro_offset_smoothing_s: float = 10.0  # time constant of the geometric - pressure altitude offset
    # Barometer cross-check (tracking/baro_check.py; docs/altitude.md, "Barometer cross-check", has the sources).
    baro_noise_sigma_m: float = 3.5  # pressure altitude 1-sigma: PX4 EKF2_BARO_NOISE (ArduPilot EK3_ALT_M_NSE 2-3)
    baro_gate_sigmas: float = 5.0  # residual gate in sigmas: ArduPilot EK3_HGT_I_GATE default 500 (5 sigma)
    baro_offset_drift_mps: float = 0.1  # how fast weather moves the offset (pressure gradients, tendencies)
    baro_offset_drift_per_m: float = 0.2  # offset change per metre climbed: |T_ISA/T - 1| for T >= T_ISA/1.2
    baro_offset_min_m: float = -1000.0  # QNH 1084.8 hPa (world record) = -579 m, plus the temperature term
    baro_offset_max_m: float = 1700.0  # QNH 870 hPa (world record) = +1267 m, plus the temperature term
    baro_stuck_tolerance_m: float = 1.0  # "no change": above a blocked port's sensor noise (MS5611: 0.1 m RMS)
    baro_recovery_s: float = 5.0  # a faulty pressure is used again after this long plausible and consistent

    def validate(self) -> None:
        require_positive("altitude", self, ("baro_offset_smoothing_s", "baro_noise_sigma_m", "baro_gate_sigmas",
                                            "baro_stuck_tolerance_m"))
        require_non_negative("altitude", self, ("datum_mismatch_margin_m", "baro_offset_drift_mps",
                                                "baro_offset_drift_per_m", "baro_recovery_s"))
        if not self.baro_offset_min_m < self.baro_offset_max_m:
            raise ConfigError("altitude.baro_offset_min_m must be < altitude.baro_offset_max_m")
