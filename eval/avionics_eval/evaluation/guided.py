"""One encounter flown through the guidance port: `avionics evaluate --pilot guidance --vehicle NAME` (issue 27
item 4; issue 28 item 4's "UAV autopilot of the vehicle profile through the guidance path").

Instead of a pilot model, the vehicle's autopilot flies the RAs as the flight install would make it: the
encounter becomes a sitl scenario (its 0.1 s truth as sampled trajectories, scenario()) and is flown by sitl
replay's fast-time loop with guidance.mode = "execute" and vehicle.profile = NAME, exactly as `sitl replay
--fly-guidance --vehicle NAME` flies it: the MAVLink schedule (ownship 5 Hz, ADS-B 1 Hz through the set's
surveillance model) framed and decoded, the core stepped at every delivery and at advisory.assessment_hz, the
guidance stage's DO_SET_MODE and velocity setpoints framed to the simulated ArduCopter (avionics_sitl.guided:
AUTO flies the encounter's ownship path as the mission, GUIDED the setpoints, with the vehicle profile's
accelerations and rates), its HEARTBEAT and COMMAND_ACK framed back. The RA logic's response model is the vehicle
profile's (vehicle.profile), so the logic asks for what the vehicle flies.

fly() returns what the vehicle flew (Flown); evaluate.py makes the record of it (RECORD_SCHEMA, the same
definitions: truth on the 0.1 s grid, NMAC, loss of well clear), the flown ownship being the mission path plus the
vehicle's offset from it in all three axes, with GUIDANCE_FIELDS added (this module does not import evaluate.py:
tests/test_layers.py keeps the import graph free of cycles). Its misses are those `sitl replay ENCOUNTER.daa --fly-guidance --vehicle NAME --noise
SURVEILLANCE --seed REPLAY_SEED --misses FILE` writes for the encounter written out with
avionics_sitl.daa_file.format_daa (tests/test_evaluation_guidance.py checks it).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pyarrow as pa

from avionics.advisory.vehicle import load_vehicle
from avionics.base.types import AdvisoryLevel
from avionics.base.units import FT
from avionics_eval.evaluation.generator import DT_S, DURATION_S
from avionics_sitl.aircraft import AircraftSpec
from avionics_sitl.autopilot import AutopilotConfig
from avionics_sitl.guided import SimCopter
from avionics_sitl.replay import replay
from avionics_sitl.scenario import DEFAULT_ADDRESS_BASE, Scenario
from avionics_sitl.trajectory import SampledTrajectory

# Added to evaluate.RECORD_SCHEMA in records of the guidance path (evaluate.record_schema)
GUIDANCE_FIELDS = [
    ("replay_seed", pa.int64()),  # `sitl replay --seed` of this encounter's surveillance noise
    # the guidance took the vehicle off its mission (a command sent to the autopilot) and when it first did
    ("guidance_commanded", pa.bool_()), ("first_command_s", pa.float64()),
    # each change of the guidance's state, "state:reason" joined by "|" (avionics/guidance/stage.py STATES)
    ("guidance_states", pa.string()),
    # time away from the mission: seconds not in the mission's mode (ArduCopter AUTO) within the encounter;
    # whether the vehicle was back in it at the end; seconds from the first command to its last return to it
    ("mission_away_s", pa.float64()), ("mission_resumed", pa.bool_()), ("mission_return_s", pa.float64()),
    # the misses `sitl replay --misses` writes: at the flown closest approach, and the lowest height flown
    ("t_cpa_flown_s", pa.float64()), ("hmd_flown_ft", pa.float64()), ("vmd_flown_ft", pa.float64()),
    ("min_agl_flown_ft", pa.float64()),
]
GUIDANCE_OVERRIDES = ("guidance.mode=execute",)  # as `sitl replay --fly-guidance` sets it (sitl/avionics_sitl/cli.py)
OWNSHIP_ADDRESS, INTRUDER_ADDRESS = DEFAULT_ADDRESS_BASE, DEFAULT_ADDRESS_BASE + 1  # as a .daa file's aircraft


# Vehicle profiles the simulated ArduCopter cannot stand for: sitl replay flies them with another simulated
# autopilot (or not at all), which this path does not use.
NOT_A_COPTER = ("fixed-wing",)


def check_vehicle(name: str) -> None:
    """ValueError unless `name` is a vehicle profile (a built-in name or a .toml) this path can fly."""
    if name in NOT_A_COPTER:
        raise ValueError(f"vehicle {name!r}: the evaluation's guidance path flies the simulated ArduCopter "
                         "(avionics_sitl.guided.SimCopter) only")
    load_vehicle(name)  # ProfileError (a ValueError) names the built-in ones


def overrides(vehicle: str) -> tuple[str, ...]:
    """The configuration the guidance path adds to the evaluation's (sitl replay --fly-guidance --vehicle)."""
    return (*GUIDANCE_OVERRIDES, f"vehicle.profile={vehicle}")


def scenario(encounter, plane) -> Scenario:
    """The encounter (generator.Encounter or lincoln.LincolnEncounter) as a sitl scenario: its truth samples as
    sampled trajectories on `plane` (the evaluation's, evaluate.PLANE), the ground at 0 ft MSL, as long as the
    encounter."""
    t, own, intruder = encounter.truth()
    specs, trajectories = [], []
    for i, (name, x) in enumerate((("ownship", own), ("intruder", intruder))):
        lat, lon = plane.to_geodetic(x[:, 0], x[:, 1])
        trajectory = SampledTrajectory(t, lat, lon, x[:, 2], x[:, 3], x[:, 4], x[:, 5], plane=plane)
        s = trajectory.state_at(0.0)
        specs.append(AircraftSpec(name, DEFAULT_ADDRESS_BASE + i, s.lat_deg, s.lon_deg, s.alt_msl_m,
                                  s.track_deg % 360.0, s.ground_speed_mps, s.vel_up_mps, callsign=name.upper()[:8]))
        trajectories.append(trajectory)
    return Scenario(f"evaluation {encounter.seed}/{encounter.index}", "an avionics evaluate encounter", specs[0],
                    (specs[1],), float(t[-1]), 0.0, (trajectories[0], (trajectories[1],)),
                    origin=(plane.lat0_deg, plane.lon0_deg))


class _FlownCopter(SimCopter):
    """The simulated ArduCopter, keeping its offset from the mission path at every tick it is flown."""

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        self.flown: list[tuple[float, float, float, float]] = []  # (t, east, north, up)

    def fly(self, mission):
        state = super().fly(mission)
        self.flown.append((mission.t_s, *self.offset))
        return state


@dataclass(frozen=True)
class Flown:
    """What the vehicle flew, for evaluate._record: its offsets from the mission path on the truth grid (east,
    north, up columns), the advisory changes, the time from the first RA to the first setpoint (None: none), the
    RA response model the logic assumed (the vehicle's), and the record's GUIDANCE_FIELDS."""

    offsets: np.ndarray
    changes: list
    delay_s: float | None
    response: object
    fields: dict


def fly(encounter, plane, config, impairments, seed, vehicle_name: str) -> Flown:
    """Fly one encounter through the guidance port: config with guidance.mode execute and vehicle.profile
    vehicle_name (overrides()), impairments the set's surveillance; seed draws the replay's surveillance seed."""
    replay_seed = int(np.random.default_rng(seed).integers(2**31))
    autopilot = AutopilotConfig()
    vehicle = load_vehicle(vehicle_name)
    copter = _FlownCopter(vehicle, autopilot.system_id, autopilot.component_id)
    result = replay(scenario(encounter, plane), config, impairments, seed=replay_seed, autopilot=autopilot,
                    fly_guidance=True, copter=copter)
    ras = [c for c in result.changes if c.level is AdvisoryLevel.RA]
    setpoints = [when for when, msg in result.sent if msg.get_type().startswith("SET_POSITION_TARGET")]
    (miss,) = result.misses
    first_command = result.sent[0][0] if result.sent else None
    away, resumed, back = _away(copter.modes, copter.mission_mode)
    fields = {
        "replay_seed": replay_seed, "guidance_commanded": first_command is not None, "first_command_s": first_command,
        "guidance_states": "|".join(f"{d.state}:{d.reason}" for d in result.guidance),
        "mission_away_s": away, "mission_resumed": resumed,
        "mission_return_s": back - first_command if first_command is not None and back is not None else None,
        "t_cpa_flown_s": miss.t_cpa_flown_s, "hmd_flown_ft": miss.hmd_flown_m / FT,
        "vmd_flown_ft": miss.vmd_with_m / FT, "min_agl_flown_ft": result.min_agl_m / FT,
    }
    return Flown(_on_grid(copter.flown, len(encounter.truth()[0])), result.changes,
                 setpoints[0] - ras[0].time_s if ras and setpoints else None, vehicle.response_model(), fields)


def _on_grid(flown, n: int) -> np.ndarray:
    """The vehicle's (east, north, up) offsets on the truth grid: the tick at each grid time (the replay ticks at
    the grid's 0.1 s), the latest before it where a tick is missing."""
    offsets = np.zeros((n, 3))
    seen = np.zeros(n, dtype=bool)
    for when, east, north, up in flown:
        k = round(when / DT_S)
        if 0 <= k < n:
            offsets[k], seen[k] = (east, north, up), True
    for k in range(1, n):
        if not seen[k]:
            offsets[k] = offsets[k - 1]
    return offsets


def _away(modes, mission_mode) -> tuple[float, bool, float | None]:
    """(seconds not in the mission's mode up to DURATION_S, in it at the end, when it last came back to it (None:
    never left it, or not back))."""
    away, back = 0.0, None
    spans = [*modes, (DURATION_S, None)]
    for (start, mode), (end, _) in zip(spans, spans[1:]):
        if mode != mission_mode:
            away += max(0.0, min(end, DURATION_S) - start)
        elif start > 0.0:
            back = start
    resumed = modes[-1][1] == mission_mode
    return away, resumed, back if resumed else None


__all__ = ["GUIDANCE_FIELDS", "Flown", "check_vehicle", "fly", "overrides", "scenario"]
