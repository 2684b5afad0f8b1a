"""The vehicle's own performance (`vehicle.profile`), so that what the logic assumes is what the vehicle can fly.

A profile is data (advisory/vehicles/*.toml, or a .toml file of the same keys), each value cited to the autopilot
parameter it is the default of. It replaces two models of the alerting profile:
- the RA response model (advisory/tables.py ResponseModel, read by advisory/resolution.py and flown by the
  closed loops): after `response_delay_s`, constant `vertical_accel_mps2` to the vehicle's climb or descent
  rate. A corrective and an increase RA both ask for that rate: the vehicle has no faster one (an INCREASE then
  adds nothing, and the logic, which strengthens only where the stronger RA projects more separation, does
  not issue it); strengthening and reversal answer after the same delay.
- the guidance bands' kinematics (advisory/bands.py BandsParams: DAIDALUS's turn rate, horizontal and vertical
  acceleration, the altitude bands' climb rate and the ground and vertical speed ranges).
"""

from __future__ import annotations

import tomllib
from dataclasses import dataclass, fields, replace
from importlib import resources
from pathlib import Path

from avionics.advisory.tables import ProfileError, ResponseModel
from avionics.base.params import ConfigError, check_float, is_file

VEHICLE_DIR = "vehicles"


@dataclass(frozen=True, slots=True)
class VehicleProfile:
    name: str
    description: str
    climb_rate_mps: float
    descent_rate_mps: float
    vertical_accel_mps2: float
    max_ground_speed_mps: float
    horizontal_accel_mps2: float
    turn_rate_deg_s: float
    response_delay_s: float

    def response_model(self) -> ResponseModel:
        """The RA response this vehicle flies (see the module's docstring)."""
        return ResponseModel(
            delay_s=self.response_delay_s, accel_mps2=self.vertical_accel_mps2, rate_mps=self.climb_rate_mps,
            strengthen_delay_s=self.response_delay_s, strengthen_accel_mps2=self.vertical_accel_mps2,
            strengthen_rate_mps=self.climb_rate_mps, descent_rate_mps=self.descent_rate_mps,
            strengthen_descent_rate_mps=self.descent_rate_mps)

    def bands_params(self, params):
        """The guidance bands' parameters with this vehicle's kinematics (DAIDALUS: turn_rate, horizontal_accel,
        vertical_accel, vertical_rate, max_hs, min_vs, max_vs)."""
        return replace(params, turn_rate_deg_s=self.turn_rate_deg_s, horizontal_accel_mps2=self.horizontal_accel_mps2,
                       vertical_accel_mps2=self.vertical_accel_mps2, vertical_rate_mps=self.climb_rate_mps,
                       max_gs_mps=self.max_ground_speed_mps, min_vs_mps=-self.descent_rate_mps,
                       max_vs_mps=self.climb_rate_mps)


NUMBERS = tuple(f.name for f in fields(VehicleProfile) if f.type in ("float", float))


def builtin_vehicles() -> list[str]:
    return sorted(p.name[:-5] for p in resources.files("avionics.advisory").joinpath(VEHICLE_DIR).iterdir()
                  if p.name.endswith(".toml"))


def load_vehicle(name_or_path: str) -> VehicleProfile:
    """A built-in vehicle profile by name, or a .toml file with the same keys."""
    builtin = resources.files("avionics.advisory").joinpath(VEHICLE_DIR, f"{name_or_path}.toml")
    if is_file(builtin):
        where, source = f"built-in vehicle {name_or_path!r}", builtin
    elif Path(name_or_path).suffix == ".toml" and is_file(Path(name_or_path)):
        where, source = name_or_path, Path(name_or_path)
    else:
        raise ProfileError(f"unknown vehicle {name_or_path!r}: expected one of {builtin_vehicles()} or a .toml file")
    try:
        data = tomllib.loads(source.read_text(encoding="utf-8"))
    except (OSError, tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
        raise ProfileError(f"{where}: {exc}") from exc
    keys = {"name", "description", *NUMBERS}
    if set(data) != keys:
        missing, unknown = sorted(keys - set(data)), sorted(set(data) - keys)
        raise ProfileError(f"{where}: " + "; ".join(
            ([f"missing {missing}"] if missing else []) + ([f"unknown {unknown}"] if unknown else [])))
    numbers = {}
    for key in NUMBERS:
        try:
            numbers[key] = check_float(data[key], f"{where}: {key}")
        except ConfigError as exc:
            raise ProfileError(str(exc)) from None
        if numbers[key] <= 0:
            raise ProfileError(f"{where}: {key} must be > 0, got {data[key]!r}")
    if numbers["response_delay_s"] > 10.0:
        raise ProfileError(f"{where}: response_delay_s {data['response_delay_s']} s is not a vehicle's response")
    return VehicleProfile(name=str(data["name"]), description=str(data["description"]), **numbers)


def response_banner(response: ResponseModel, vehicle: str, profile: str) -> str:
    """The start-up line that says which response the RA logic assumes: "vehicle multirotor: RAs ask for climb
    2.5 m/s, descent 1.5 m/s ..." or, with no vehicle profile, the alerting profile's pilot and how to change it."""
    rates = (f"climb {response.rate(True):.1f} m/s, descent {response.rate(False):.1f} m/s, "
             f"after {response.delay_s:.1f} s at {response.accel_mps2:.2f} m/s^2")
    if vehicle:
        return f"vehicle {vehicle}: RAs ask for {rates}"
    return (f"vehicle: profile {profile}'s RA response ({rates}); for a vehicle that cannot fly it, "
            f"--set vehicle.profile={'|'.join(builtin_vehicles())} or a .toml of its own")
