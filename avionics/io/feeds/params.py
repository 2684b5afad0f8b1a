"""Parameters of the traffic feeds (avionics/io/feeds/): the [traffic] section. docs/configuration.md and
config/default.toml document them; docs/traffic-inputs.md explains them."""

from __future__ import annotations

from dataclasses import dataclass

from avionics.base.params import ConfigError, require_positive

SCHEMES = ("sbs", "readsb-json", "beast")


@dataclass(frozen=True)
class TrafficConfig:
    # A source's accuracy when its messages do not say it (1-sigma per horizontal axis). SBS carries no NACp/NACv;
    # readsb JSON and Beast do when the aircraft has sent them (NACp/NACv 0 or absent: these defaults).
    # 30 m ~ NACp 8 (EPU < 92.6 m at 95 %, / 2.45) and 2 m/s ~ NACv 2 (< 3 m/s at 95 %), as tracking's defaults.
    sbs_position_sigma_m: float = 30.0
    sbs_velocity_sigma_mps: float = 2.0
    readsb_position_sigma_m: float = 30.0
    readsb_velocity_sigma_mps: float = 2.0
    beast_position_sigma_m: float = 30.0
    beast_velocity_sigma_mps: float = 2.0
    # Merging partial messages (SBS MSG,3 position, MSG,4 velocity, ...): a velocity, altitude or vertical rate
    # older than this at the position's time is not merged (DO-260B airborne position and velocity are each
    # broadcast at 2 Hz: 3 s is six missed messages; the MAVLink path's input.max_report_age_s is also 3 s).
    merge_max_age_s: float = 3.0
    readsb_poll_s: float = 1.0  # readsb writes aircraft.json once a second (its --write-json-every default)
    reconnect_initial_s: float = 0.5  # a lost or refused source is retried after this, doubling ...
    reconnect_max_s: float = 2.0  # ... up to this: a restarted receiver is read again within 2 s (issue 14)
    queue_size: int = 4096  # reports waiting for the loop per feed; when full the oldest is dropped (counted)
    # Receiver clock alignment (clock.py): the offset is the least (receipt - receiver time) over this window.
    clock_window_s: float = 60.0

    def validate(self) -> None:
        require_positive("traffic", self, (
            "sbs_position_sigma_m", "sbs_velocity_sigma_mps", "readsb_position_sigma_m", "readsb_velocity_sigma_mps",
            "beast_position_sigma_m", "beast_velocity_sigma_mps", "merge_max_age_s", "readsb_poll_s",
            "reconnect_initial_s", "reconnect_max_s", "clock_window_s"))
        if self.reconnect_max_s < self.reconnect_initial_s:
            raise ConfigError(f"traffic.reconnect_max_s: must be >= traffic.reconnect_initial_s "
                              f"({self.reconnect_initial_s}), got {self.reconnect_max_s}")
        if self.reconnect_max_s > 60.0:
            raise ConfigError(f"traffic.reconnect_max_s: must be <= 60, got {self.reconnect_max_s}")
        if self.queue_size < 1:
            raise ConfigError(f"traffic.queue_size: must be >= 1, got {self.queue_size}")

    def default_sigmas(self, scheme: str) -> tuple[float, float]:
        """(position 1-sigma m, velocity 1-sigma m/s) of a source scheme whose messages do not say them."""
        prefix = {"sbs": "sbs", "readsb-json": "readsb", "beast": "beast"}[scheme]
        return getattr(self, f"{prefix}_position_sigma_m"), getattr(self, f"{prefix}_velocity_sigma_mps")
