"""[guidance] (avionics/guidance/stage.py). docs/configuration.md and config/default.toml document them."""

from __future__ import annotations

from dataclasses import dataclass

from avionics.base.params import ConfigError, require_positive

GUIDANCE_MODES = ("passive", "advise", "execute")
# The mode ladder's actions, in PX4's DAA order of severity (docs/en/advanced_features/detect_and_avoid.md:
# Disabled < Warn only < Hold < Return < Land; Terminate is not offered)
LADDER_ACTIONS = ("none", "warn", "hold", "return", "land")

# The kinds of guidance bands the guidance stage reads (stage.py: the track resolution and the mission track's
# region); advisory.guidance_band_kinds must keep them, and the evaluation computes only these.
BAND_KINDS_READ = ("track_deg",)


@dataclass(frozen=True)
class GuidanceConfig:
    # passive: no guidance (as before issue 27); advise: the manoeuvre is decided and published, nothing is sent to
    # the autopilot; execute: the autopilot is commanded (ArduCopter GUIDED or PX4 OFFBOARD: docs/integration.md)
    mode: str = "passive"
    # Never command a descent that ends below this height above home (GLOBAL_POSITION_INT relative_alt): level off.
    # 15 m: ArduCopter's RTL_ALT default (1500 cm, ArduCopter/Parameters.cpp), the height it climbs to before flying
    # home, i.e. what the autopilot itself treats as clear of obstacles near home.
    floor_m: float = 15.0
    # Never command a climb that ends above this height above home; 0 = none (as ArduCopter's guided limits:
    # mode_guided.cpp Guided_Limit alt_max_cm, "0 = no limit"). 120 m is the usual legal ceiling (14 CFR 107.51(b)
    # 400 ft; EU 2019/947 UAS.OPEN.010 120 m): set it where it applies.
    ceiling_m: float = 0.0
    # After the last RA ends (clear of conflict), hold level this long before the mission is given back. 2 s:
    # ArduPilot's AP_Avoidance does not downgrade a threat faster (AP_AVOIDANCE_STATE_RECOVERY_TIME_MS 2000,
    # libraries/AP_Avoidance/AP_Avoidance.h).
    quiet_time_s: float = 2.0
    # A velocity setpoint is resent this often while commanding: ArduCopter stops the vehicle when none came for
    # GUID_TIMEOUT (default 3 s; GUIDED_POSVEL_TIMEOUT_MS 3000 in ArduCopter/mode_guided.cpp before it became a
    # parameter, ArduCopter/Parameters.cpp): a third of it, so two lost setpoints in a row do not stop it.
    setpoint_period_s: float = 1.0
    # A mode change not acknowledged (COMMAND_ACK) and confirmed (HEARTBEAT custom_mode) within this is resent with
    # the next confirmation number (MAVLink command protocol, mavlink.io/en/services/command.html) ...
    ack_timeout_s: float = 1.0  # ours: one 1 Hz HEARTBEAT period
    retries: int = 3  # ... at most this many times; then the guidance has failed (STATUSTEXT "DAA GUIDANCE FAILED")
    # A DO-365 horizontal manoeuvre flies this far past the bands' track resolution, on the side of the turn (capped
    # at half the resolution band): the band edge is where the loss of well clear begins. 5 deg: NASA ICAROUS flies
    # DAIDALUS's preferred track resolution 5 deg past its edge (TrafficMonitor::MonitorTraffic, nasa/icarous).
    track_margin_deg: float = 5.0
    # Command only over a link whose frames are authenticated: MAVLink 2 signing on with mavlink.signing_required
    # and signed frames accepted (docs/mavlink.md, "Signing"). false: also on an unsigned link.
    require_signing: bool = False
    # The mode ladder for simple vehicles (avionics/guidance/ladder.py), instead of the RA's manoeuvre: the action at
    # each alert level, from the first (TA; DO-365 PREVENTIVE) up (RA; CORRECTIVE, WARNING), each one of
    # LADDER_ACTIONS, issued once per escalation as PX4's DAA module does (its DAA_LVL_*_ACT). () = off.
    ladder: tuple[str, ...] = ()

    def validate(self) -> None:
        if self.mode not in GUIDANCE_MODES:
            raise ConfigError(f"guidance.mode: {self.mode!r} is not one of {', '.join(GUIDANCE_MODES)}")
        require_positive("guidance", self, ("quiet_time_s", "setpoint_period_s", "ack_timeout_s"))
        if self.setpoint_period_s >= 3.0:
            raise ConfigError(f"guidance.setpoint_period_s: {self.setpoint_period_s} s must be below ArduCopter's "
                              "3 s GUID_TIMEOUT, or the vehicle stops between setpoints")
        if self.floor_m < 0:
            raise ConfigError(f"guidance.floor_m: must be >= 0, got {self.floor_m}")
        if self.ceiling_m < 0 or 0 < self.ceiling_m <= self.floor_m:
            raise ConfigError(f"guidance.ceiling_m: must be 0 (none) or above floor_m ({self.floor_m}), "
                              f"got {self.ceiling_m}")
        if not 0 <= self.track_margin_deg <= 45.0:
            raise ConfigError(f"guidance.track_margin_deg: must be in 0..45, got {self.track_margin_deg}")
        if len(self.ladder) > 3 or any(a not in LADDER_ACTIONS for a in self.ladder):
            raise ConfigError(f"guidance.ladder: at most 3 actions (alert levels 1 to 3), each one of "
                              f"{', '.join(LADDER_ACTIONS)}; got {list(self.ladder)}")
        if not 0 <= self.retries <= 10:
            raise ConfigError(f"guidance.retries: must be in 0..10, got {self.retries}")
