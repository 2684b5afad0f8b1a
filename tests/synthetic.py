"""Straight-line encounters fed straight into DaaCore (no MAVLink): for tests of the core's timing logic."""

from __future__ import annotations

from dataclasses import dataclass, field

from avionics.config import load_config
from avionics.base.geodesy import LocalTangentPlane
from avionics.base.types import AddressSource, AltitudeDatum, IntruderKey, IntruderReport, OwnshipFix, OwnshipPressure
from avionics.pipeline.daa_core import DaaCore
from avionics_sitl.trajectory import plane_velocity_to_true

PLANE = LocalTangentPlane(47.0, 8.0)


@dataclass
class Mover:
    """Straight constant-velocity flight in the encounter's plane: position (e, n, alt) at t=0, velocity (ve, vn,
    vu) in the plane's axes (reported as true east/north at the aircraft, as an aircraft would)."""

    p0: tuple[float, float, float]
    v: tuple[float, float, float]

    def at(self, t: float):
        return tuple(p + v * t for p, v in zip(self.p0, self.v))

    def velocity(self, t: float):
        return self.v


@dataclass
class Reversal:
    """Flies `before` until turn_s, then reverses its velocity in place (an idealised 180-degree turn)."""

    before: Mover
    turn_s: float

    def at(self, t: float):
        if t < self.turn_s:
            return self.before.at(t)
        here = self.before.at(self.turn_s)
        return tuple(p - v * (t - self.turn_s) for p, v in zip(here, self.before.v))

    def velocity(self, t: float):
        return self.before.v if t < self.turn_s else tuple(-v for v in self.before.v)


@dataclass
class Encounter:
    ownship: Mover
    intruder: Mover | Reversal
    key: IntruderKey = IntruderKey(0xABC123, AddressSource.ES1090)
    datum: AltitudeDatum | None = AltitudeDatum.PRESSURE
    pressure: bool = True  # ownship SCALED_PRESSURE available
    report_from_s: float = 0.0
    report_until_s: float = float("inf")
    report_gap_s: tuple[float, float] | None = None  # (from, until): no intruder report in between
    ownship_until_s: float = float("inf")
    overrides: list[str] = field(default_factory=list)
    plane: LocalTangentPlane = PLANE  # where on Earth the encounter is flown

    def core(self) -> DaaCore:
        return DaaCore(load_config(overrides=self.overrides))

    def run(self, duration_s: float, dt: float = 0.1, core: DaaCore | None = None, results: list | None = None):
        """Step at dt, ownship at 5 Hz, intruder reports at 1 Hz (into `core`, or a new one); returns
        (core, [(t, change)]); every step's StepResult is appended to `results` when given."""
        core = core if core is not None else self.core()
        changes = []
        for k in range(int(round(duration_s / dt)) + 1):
            t = round(k * dt, 6)
            inputs = []
            if abs(t * 5 - round(t * 5)) < 1e-6 and t <= self.ownship_until_s:
                e, n, alt = self.ownship.at(t)
                lat, lon = self.plane.to_geodetic(e, n)
                vu = self.ownship.v[2]
                ve, vn = plane_velocity_to_true(self.plane, lat, lon, *self.ownship.v[:2])
                inputs.append(OwnshipFix(t, float(lat), float(lon), alt, alt, (vn, ve, -vu)))
                if self.pressure:
                    inputs.append(OwnshipPressure(t, alt))
            gap = self.report_gap_s is not None and self.report_gap_s[0] < t < self.report_gap_s[1]
            if abs(t - round(t)) < 1e-6 and self.report_from_s <= t <= self.report_until_s and not gap:
                e, n, alt = self.intruder.at(t)
                lat, lon = self.plane.to_geodetic(e, n)
                ve, vn, vu = self.intruder.velocity(t)
                ve, vn = plane_velocity_to_true(self.plane, lat, lon, ve, vn)
                inputs.append(IntruderReport(self.key, t, t, float(lat), float(lon),
                                             alt if self.datum else None, self.datum, (ve, vn),
                                             vu if self.datum else None))
            result = core.step(t, inputs)
            if results is not None:
                results.append(result)
            for change in result.changes:
                changes.append((t, change))
        return core, changes
