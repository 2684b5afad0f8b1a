"""Parameters of the I/O components: [vehicle], [mavlink] (avionics/io/link.py, decode.py, signing.py) and [zenoh]
(avionics/io/zenoh_bus.py). docs/configuration.md and config/default.toml document them."""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Protocol

from avionics.base.params import ConfigError, _show, is_file, require_positive

if TYPE_CHECKING:
    from avionics.tracking.params import InputConfig, TrackingConfig


@dataclass(frozen=True)
class VehicleConfig:
    id: str = "uav1"  # zenoh key segment: daa/<id>/...
    own_icao: int = 0  # our own ADS-B address, ignored in ADSB_VEHICLE (0: we transmit none)
    # the vehicle's own performance (avionics/advisory/vehicle.py): "" = the alerting profile's response model
    profile: str = ""

    def validate(self) -> None:
        if not self.id or any(c in self.id for c in "/*$?#"):
            raise ConfigError(f"vehicle.id: {self.id!r} must be a non-empty zenoh key chunk "
                              "(no '/', '*', '$', '?', '#')")
        if not 0 <= self.own_icao <= 0xFFFFFF:
            raise ConfigError(f"vehicle.own_icao: {self.own_icao:#x} is not a 24-bit address")
        if self.profile:
            from avionics.advisory.tables import ProfileError
            from avionics.advisory.vehicle import load_vehicle

            try:
                load_vehicle(self.profile)
            except ProfileError as exc:
                raise ConfigError(f"vehicle.profile: {exc}") from exc


@dataclass(frozen=True)
class MavlinkConfig:
    # pymavlink or MAVSDK/MAVROS-style connection string (avionics/io/link.py translate_connection); 14540 is
    # PX4's onboard port and what the docs/integration.md recipes send to
    connection: str = "udpin:0.0.0.0:14540"
    baud: int = 57600  # serial links only
    source_system: int = 1  # our HEARTBEAT/COLLISION system id (the vehicle's)
    source_component: int = 191  # MAV_COMP_ID_ONBOARD_COMPUTER
    heartbeat_hz: float = 1.0
    collision_refresh_s: float = 1.0  # re-send an active COLLISION this often
    statustext: bool = True
    # COLLISION action on an RA: false = MAV_COLLISION_ACTION_REPORT (we act on nothing; the RA is in DAA_ADVISORY),
    # true = MAV_COLLISION_ACTION_ASCEND_OR_DESCEND, asking an autopilot that acts on COLLISION to manoeuvre.
    collision_action_request: bool = False
    # Ground station view (docs/mavlink.md, "ADSB_VEHICLE re-broadcast"): the fused tracks as ADSB_VEHICLE from
    # component traffic_rebroadcast_component, flagged ADSB_FLAGS_DAA_REBROADCAST, at traffic_rebroadcast_hz.
    traffic_rebroadcast: bool = False
    traffic_rebroadcast_hz: float = 1.0
    traffic_rebroadcast_component: int = 192  # MAV_COMP_ID_ONBOARD_COMPUTER2; never our own source_component
    # MAVLink 2 signing (docs/mavlink.md, "Signing"): a file holding the 32-byte key as 64 hex characters;
    # "" = off. With a key our frames are signed, and wrong-key and replayed frames are rejected.
    signing_key_file: str = ""
    signing_required: bool = True  # with a key: unsigned frames rejected (false: accepted, counted)
    # Whose ADSB_VEHICLE is used: "SYS" (any component) or "SYS:COMP" ids; empty = discovered (io/senders.py):
    # the ownship component, MAV_COMP_ID_ADSB and components whose HEARTBEAT says MAV_TYPE_ADSB, of source_system.
    traffic_sources: tuple[int | str, ...] = ()
    # The component of source_system whose GLOBAL_POSITION_INT and SCALED_PRESSURE are the ownship; 0 = the first
    # one whose HEARTBEAT names an autopilot (autopilot != MAV_AUTOPILOT_INVALID), MAV_COMP_ID_AUTOPILOT1 until then.
    ownship_component: int = 0
    # tcpin (avionics/io/tcpin.py): a connection that sends no valid frame of source_system for this long is closed,
    # so an idle or garbage-only client cannot hold the link: tcpin.IDLE_TIMEOUT_S, with its source (not imported:
    # this module stays free of pymavlink, and link.py imports it)
    tcpin_idle_timeout_s: float = 5.0
    # Wiring diagnostics (avionics/io/diagnostics.py, `avionics run` on a live link): no MAVLink, or no ownship
    # position, for this long is named on stderr, STATUSTEXT and zenoh status. 4 s: MAVLink's heartbeat service
    # takes "four or five" missed 1 Hz HEARTBEATs for a lost link (mavlink.io/en/services/heartbeat.html).
    silence_warn_s: float = 4.0
    # The ownship GLOBAL_POSITION_INT rate below which a warning is named. 2 Hz: every relative position is as old
    # as the last ownship fix, and at 1 Hz a single lost fix leaves it input.ownship_timeout_s (2 s) old, DAA then
    # unavailable; at 2 Hz three fixes in a row may be lost. ADS-B airborne positions come at 2 Hz (DO-260B).
    min_ownship_hz: float = 2.0

    def validate(self) -> None:
        traffic_source_ids(self)
        from avionics.io.link import translate_connection  # noqa: PLC0415  (link imports pymavlink)

        translate_connection(self.connection, self.baud)  # a malformed URL is a configuration error
        if self.signing_key_file:
            from avionics.io.signing import SigningKeyError, load_key

            try:
                load_key(self.signing_key_file)
            except SigningKeyError as exc:
                raise ConfigError(f"mavlink.signing_key_file: {exc}") from None
        require_positive("mavlink", self, ("heartbeat_hz", "collision_refresh_s", "traffic_rebroadcast_hz",
                                           "tcpin_idle_timeout_s", "silence_warn_s", "min_ownship_hz"))
        if not 1 <= self.traffic_rebroadcast_component <= 255 or \
                self.traffic_rebroadcast_component == self.source_component:
            raise ConfigError("mavlink.traffic_rebroadcast_component must be in 1..255 and differ from "
                              f"mavlink.source_component ({self.source_component})")
        if self.traffic_rebroadcast_hz > 10.0:
            raise ConfigError(f"mavlink.traffic_rebroadcast_hz: at most 10 Hz, got {self.traffic_rebroadcast_hz}")
        if not 1 <= self.source_system <= 255 or not 0 <= self.source_component <= 255:
            raise ConfigError("mavlink.source_system must be in 1..255 and mavlink.source_component in 0..255")
        if not 0 <= self.ownship_component <= 255:
            raise ConfigError(f"mavlink.ownship_component: {self.ownship_component} is not 0 (the autopilot's, "
                              "from its HEARTBEAT) or a component id 1..255")


def traffic_source_ids(m: MavlinkConfig) -> tuple[tuple[int, int | None], ...]:
    """mavlink.traffic_sources as (system, component or None for any); empty: discovered (avionics/io/senders.py)."""
    out = []
    for i, entry in enumerate(m.traffic_sources):
        system, sep, component = str(entry).strip().partition(":")
        try:
            ids = (int(system), int(component) if sep else None)
        except ValueError:
            ids = None
        if ids is None or not 1 <= ids[0] <= 255 or (ids[1] is not None and not 0 <= ids[1] <= 255):
            raise ConfigError(f"mavlink.traffic_sources[{i}]: {entry!r} is not \"SYS\" or \"SYS:COMP\" "
                              "(system 1..255, component 0..255)")
        out.append(ids)
    return tuple(out)


ZENOH_MODES = ("peer", "client", "router")
ROS_NAMESPACE = re.compile(r"/?[A-Za-z_][A-Za-z0-9_]*(/[A-Za-z_][A-Za-z0-9_]*)*")


def read_password(path: str) -> str:
    """The first line of a password file, without its line end ("" when it is empty or unreadable)."""
    try:
        with open(path, encoding="utf-8") as f:
            return f.readline().rstrip("\r\n")
    except (OSError, UnicodeDecodeError):
        return ""


@dataclass(frozen=True)
class ZenohConfig:
    enabled: bool = True
    mode: str = "peer"
    listen: tuple[str, ...] = ("tcp/127.0.0.1:7447",)
    connect: tuple[str, ...] = ()
    scouting: bool = False  # multicast and gossip scouting
    key_prefix: str = "daa"
    tracks_hz: float = 2.0
    status_hz: float = 1.0
    # Publishing off the loop (docs/zenoh.md, "Queues, snapshot and liveliness"): advisories are never dropped;
    # tracks, ownship and status wait in a FIFO of this many samples that drops its oldest when full.
    queue_size: int = 4096
    snapshot_changes: int = 256  # advisory changes kept for the snapshot queryable (late join, reconnection)
    reconnect_max_s: float = 1.0  # lost connect endpoints are re-dialled from 0.25 s, doubling up to this
    # TLS (endpoints tls/HOST:PORT): PEM file paths, passed to zenoh's transport/link/tls; "" = not set.
    tls_root_ca_certificate: str = ""  # CA that signed the other side's certificate (needed to connect)
    tls_listen_certificate: str = ""  # our certificate and key on tls/ listen endpoints
    tls_listen_private_key: str = ""
    tls_connect_certificate: str = ""  # our client certificate and key, for mutual TLS
    tls_connect_private_key: str = ""
    tls_enable_mtls: bool = False
    tls_verify_name_on_connect: bool = True
    # Authentication and access control (docs/zenoh.md, "Security recipes"): zenoh's usrpwd authentication
    # (transport/auth/usrpwd) and a zenoh JSON5 file read first, for what has no key here (access_control, ...).
    auth_user: str = ""  # our user name when we open a link (with auth_password_file)
    auth_password_file: str = ""  # a file whose first line is that user's password (not on a command line)
    auth_dictionary_file: str = ""  # "user:password" lines: a link opened to us must log in as one of them
    config_file: str = ""  # zenoh JSON5 configuration; the keys of this section are set on top of it
    # ROS 2 (docs/zenoh.md, "ROS 2"): the advisories, traffic, bands and status also as CDR-encoded ROS 2 messages
    # on <ros2_namespace>/daa/..., the keys zenoh-bridge-ros2dds maps to ROS topics ("" = the vehicle id).
    ros2: bool = False
    ros2_namespace: str = ""

    def validate(self) -> None:
        z = self
        if z.mode not in ZENOH_MODES:
            raise ConfigError(f"zenoh.mode: {z.mode!r} is not peer, client or router")
        chunks = z.key_prefix.split("/")
        if not all(chunks) or any(c in z.key_prefix for c in "*$?#"):
            raise ConfigError(f"zenoh.key_prefix: {z.key_prefix!r} must be a zenoh key expression without wildcards "
                              "(chunks separated by single '/', none empty; no '*', '$', '?', '#')")
        if z.ros2_namespace and not ROS_NAMESPACE.fullmatch(z.ros2_namespace):
            raise ConfigError(f"zenoh.ros2_namespace: {z.ros2_namespace!r} is not a ROS 2 namespace (tokens of letters, "
                              "digits and '_', not starting with a digit, separated by '/'; ROS 2 design article "
                              "'Topic and Service name mapping to DDS')")
        if z.queue_size < 1:
            raise ConfigError(f"zenoh.queue_size: must be >= 1, got {z.queue_size}")
        if z.snapshot_changes < 0:
            raise ConfigError(f"zenoh.snapshot_changes: must be >= 0, got {z.snapshot_changes}")
        if not 0.0 < z.reconnect_max_s <= 60.0:
            raise ConfigError(f"zenoh.reconnect_max_s: must be in (0, 60], got {z.reconnect_max_s}")
        files = ("tls_root_ca_certificate", "tls_listen_certificate", "tls_listen_private_key",
                 "tls_connect_certificate", "tls_connect_private_key", "auth_password_file", "auth_dictionary_file",
                 "config_file")
        for name in files:
            path = getattr(z, name)
            if path and not is_file(Path(path)):
                raise ConfigError(f"zenoh.{name}: no such file {_show(path)}")
        if bool(z.tls_listen_certificate) != bool(z.tls_listen_private_key):
            raise ConfigError("zenoh.tls_listen_certificate and tls_listen_private_key go together")
        if bool(z.tls_connect_certificate) != bool(z.tls_connect_private_key):
            raise ConfigError("zenoh.tls_connect_certificate and tls_connect_private_key go together")
        if any(e.startswith("tls/") for e in z.listen) and not z.tls_listen_certificate:
            raise ConfigError("zenoh.listen has a tls/ endpoint: set zenoh.tls_listen_certificate and "
                              "zenoh.tls_listen_private_key")
        if any(e.startswith("tls/") for e in z.connect) and not z.tls_root_ca_certificate:
            raise ConfigError("zenoh.connect has a tls/ endpoint: set zenoh.tls_root_ca_certificate")
        if z.tls_enable_mtls and not (z.tls_root_ca_certificate and (z.tls_connect_certificate
                                                                     or z.tls_listen_certificate)):
            raise ConfigError("zenoh.tls_enable_mtls needs tls_root_ca_certificate and our own certificate and key")
        if bool(z.auth_user) != bool(z.auth_password_file):
            raise ConfigError("zenoh.auth_user and auth_password_file go together")
        if z.auth_password_file and not read_password(z.auth_password_file):
            raise ConfigError(f"zenoh.auth_password_file: {z.auth_password_file!r} holds no password on its first line")
        if z.config_file:
            import zenoh  # noqa: PLC0415  (only a configuration that names a file needs zenoh here)

            try:
                zenoh.Config.from_file(z.config_file)
            except zenoh.ZError as exc:
                raise ConfigError(f"zenoh.config_file: {z.config_file!r} is not a zenoh configuration: "
                                  f"{zenoh_error_text(exc)}") from None
        require_positive("zenoh", z, ("tracks_hz", "status_hz"))


class DecoderConfig(Protocol):
    """The sections the MAVLink decoder (avionics/io/decode.py) reads: any object with these attributes, e.g. the
    assembled avionics.config.Config (which the decoder does not import: config.py is the shells' layer)."""

    vehicle: VehicleConfig
    mavlink: MavlinkConfig
    input: InputConfig
    tracking: TrackingConfig


# zenoh's errors end with the Rust source location of the raise ("at src/...rs:12:5"): not for a user's eyes.
_RUST_LOCATION = re.compile(r"\s*\bat \S+\.rs:\d+(:\d+)?\.?")


def zenoh_error_text(exc: BaseException) -> str:
    """A zenoh error's message without the Rust source locations, on one line (here, below zenoh_bus, because
    the configuration's check of zenoh.config_file needs it too)."""
    text = _RUST_LOCATION.sub("", str(exc))
    return " ".join(text.split()) or type(exc).__name__
