"""Who may tell us what (docs/mavlink.md, "Trusted sources"): the ownship comes from one component of our vehicle,
the traffic from the configured or discovered receiver components; any other component of our vehicle that claims
either is rejected, counted and a spoof suspect while it goes on (announced on MAVLink and in the status by ports.py
and daa.py).

Ownship: component `mavlink.ownship_component` of `mavlink.source_system`, or (0, the default) the first component of
it whose HEARTBEAT names an autopilot (`autopilot` != MAV_AUTOPILOT_INVALID, which MAVLink common.xml defines as "No
valid autopilot, e.g. a GCS or other MAVLink component"; the heartbeat microservice, mavlink.io/en/services/
heartbeat.html, tells flight controllers from other components so), MAV_COMP_ID_AUTOPILOT1 until one is heard
(ArduPilot and PX4 are component 1).

Traffic, with `mavlink.traffic_sources = []`: ADSB_VEHICLE from the ownship component (ArduPilot and PX4 re-send their
receiver's traffic as their own), from MAV_COMP_ID_ADSB (156, common.xml: "Automatic Dependent Surveillance-Broadcast
(ADS-B) component") and from any component of source_system whose HEARTBEAT says MAV_TYPE_ADSB ("ADSB system",
common.xml: how a receiver on a MAVLink port of its own announces itself). A component that is none of these cannot
become a traffic source by reporting first. A configured list is used as it is.
"""

from __future__ import annotations

from collections import Counter

import avionics.io  # noqa: F401  (MAVLink 2)
from pymavlink.dialects.v20 import common as mavlink2

from avionics.io.params import MavlinkConfig, traffic_source_ids

Sender = tuple[int, int]  # (system id, component id)
# Types that are never the flight controller, whatever their `autopilot` field says (a misconfigured companion)
NOT_AUTOPILOT_TYPES = {mavlink2.MAV_TYPE_GCS, mavlink2.MAV_TYPE_ONBOARD_CONTROLLER, mavlink2.MAV_TYPE_ADSB}
MAX_SUSPECTS = 512  # every component of our system claiming each of the two roles; more is not kept
SUSPECT_ACTIVE_S = 10.0  # a suspect is reported while its last rejected claim is this recent


class Senders:
    """The ownship component and the trusted traffic senders, pinned by configuration or HEARTBEAT."""

    def __init__(self, m: MavlinkConfig, counters: Counter):
        self.counters = counters
        self.system = m.source_system
        self._ownship_pinned = m.ownship_component != 0
        self.ownship_component = m.ownship_component or mavlink2.MAV_COMP_ID_AUTOPILOT1
        configured = traffic_source_ids(m)
        self._discover = not configured
        self._trusted_systems = {s for s, c in configured if c is None}
        self._trusted_senders = {(s, c) for s, c in configured if c is not None}
        self._receivers = {mavlink2.MAV_COMP_ID_ADSB}  # discovered receiver components of our system
        # (system, component, "ownship" | "traffic") -> when it last claimed it: components of our system whose claim
        # was rejected
        self.suspects: dict[tuple[int, int, str], float] = {}
        # (system, component) of another system whose ADSB_VEHICLE was ignored -> when last (io/diagnostics.py names
        # them: not a claim about us, but traffic the integrator may have meant to use)
        self.untrusted: dict[tuple[int, int], float] = {}

    def active_suspects(self, now_s: float) -> frozenset[tuple[int, int, str]]:
        """The suspects whose last rejected claim is at most SUSPECT_ACTIVE_S old (the older ones are forgotten)."""
        if not self.suspects:
            return frozenset()
        for key in [k for k, last in self.suspects.items() if now_s - last > SUSPECT_ACTIVE_S]:
            del self.suspects[key]
        return frozenset(self.suspects)

    def heartbeat(self, msg, now_s: float) -> None:
        """A HEARTBEAT of our vehicle pins the autopilot (the first one heard) and announces receivers."""
        system, component = msg.get_srcSystem(), msg.get_srcComponent()
        if system != self.system:
            return
        autopilot = msg.autopilot != mavlink2.MAV_AUTOPILOT_INVALID and msg.type not in NOT_AUTOPILOT_TYPES
        if autopilot and not self._ownship_pinned:
            self._ownship_pinned = True
            self.ownship_component = component
        elif autopilot and component != self.ownship_component:
            self._claim((system, component), "heartbeat.second_autopilot", "ownship", now_s)
        if msg.type == mavlink2.MAV_TYPE_ADSB and component not in self._receivers and self._discover:
            self._receivers.add(component)

    def ownship(self, sender: Sender, prefix: str, now_s: float) -> bool:
        """May sender tell us our own position / pressure? Counted `<prefix>.other_system` / `.other_component`."""
        if sender[0] != self.system:
            self.counters[f"{prefix}.other_system"] += 1  # another vehicle on the link: not a claim about us
            return False
        if sender[1] != self.ownship_component:
            return self._claim(sender, f"{prefix}.other_component", "ownship", now_s)
        return True

    def traffic(self, sender: Sender, now_s: float) -> bool:
        """May sender report traffic? Counted `adsb.untrusted_source` when not."""
        system, component = sender
        if self._discover:
            trusted = system == self.system and (component == self.ownship_component or component in self._receivers)
        else:
            trusted = system in self._trusted_systems or sender in self._trusted_senders
        if trusted:
            return True
        if system != self.system:
            self.counters["adsb.untrusted_source"] += 1  # another system: not trusted, but not posing as ours
            if sender in self.untrusted or len(self.untrusted) < MAX_SUSPECTS:
                self.untrusted[sender] = now_s
            return False
        return self._claim(sender, "adsb.untrusted_source", "traffic", now_s)

    def _claim(self, sender: Sender, counter: str, role: str, now_s: float) -> bool:
        """A component of our vehicle claimed a role that is another's: rejected, counted, a suspect."""
        self.counters[counter] += 1
        key = (sender[0], sender[1], role)
        if key in self.suspects or len(self.suspects) < MAX_SUSPECTS:
            self.suspects[key] = now_s
        return False
