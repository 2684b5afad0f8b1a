"""zenoh publishing of advisories, tracks and status as JSON (encoding application/json).

Key expressions (vehicle = config vehicle.id, intruder = "<source>-<ICAO hex>", e.g. 1090es-A1B2C3):
  <prefix>/<vehicle>/advisories/<intruder>   on every level change and each collision_refresh_s while active
  <prefix>/<vehicle>/tracks/<intruder>       at zenoh.tracks_hz
  <prefix>/<vehicle>/status                  at zenoh.status_hz, with the rejection counters
Peer mode on loopback with multicast and gossip scouting off unless configured otherwise.
"""

from __future__ import annotations

import json
import math

import zenoh

from avionics.config import ZenohConfig


class ZenohBusError(RuntimeError):
    """The zenoh session cannot be opened (bad endpoint, port in use), with zenoh's reason."""


def session_config(cfg: ZenohConfig) -> zenoh.Config:
    config = zenoh.Config()
    config.insert_json5("mode", json.dumps(cfg.mode))
    config.insert_json5("scouting/multicast/enabled", json.dumps(cfg.scouting))
    config.insert_json5("scouting/gossip/enabled", json.dumps(cfg.scouting))
    config.insert_json5("listen/endpoints", json.dumps(list(cfg.listen)))
    config.insert_json5("connect/endpoints", json.dumps(list(cfg.connect)))
    return config


def open_session(cfg: ZenohConfig) -> zenoh.Session:
    try:
        return zenoh.open(session_config(cfg))
    except zenoh.ZError as exc:
        raise ZenohBusError(f"cannot open zenoh session (listen={list(cfg.listen)}, "
                            f"connect={list(cfg.connect)}): {exc}") from exc


def _finite(value):
    """JSON has no inf/NaN: an infinite tau becomes null."""
    if isinstance(value, float) and not math.isfinite(value):
        return None
    if isinstance(value, dict):
        return {k: _finite(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_finite(v) for v in value]
    return value


def to_json(payload: dict) -> bytes:
    return json.dumps(_finite(payload), separators=(",", ":"), allow_nan=False).encode()


class ZenohBus:
    def __init__(self, cfg: ZenohConfig, vehicle_id: str, session: zenoh.Session | None = None):
        self.cfg = cfg
        self.prefix = f"{cfg.key_prefix}/{vehicle_id}"
        self._own_session = session is None
        self.session = session if session is not None else open_session(cfg)
        self._publishers: dict[str, zenoh.Publisher] = {}

    def _publisher(self, key: str) -> zenoh.Publisher:
        pub = self._publishers.get(key)
        if pub is None:
            pub = self.session.declare_publisher(key, encoding=zenoh.Encoding.APPLICATION_JSON)
            self._publishers[key] = pub
        return pub

    def publish(self, suffix: str, payload: dict) -> None:
        self._publisher(f"{self.prefix}/{suffix}").put(to_json(payload))

    def forget(self, suffix: str) -> None:
        """Undeclare the publisher of a deleted track so that 1000 intruders a day do not pile up."""
        pub = self._publishers.pop(f"{self.prefix}/{suffix}", None)
        if pub is not None:
            pub.undeclare()

    def close(self) -> None:
        for pub in self._publishers.values():
            pub.undeclare()
        self._publishers.clear()
        if self._own_session:
            self.session.close()
