"""A point-mass vertical simulation of the standard RA response, independent of advisory/resolution.py.

Straight-line horizontal paths with exact states; ownship's vertical channel flies each RA as the profile's
response model says (after the delay, constant acceleration toward the target rate; a preventive RA only
stops motion toward the threat; strengthening and reversal with the strengthened delay and acceleration);
when every RA ends, ownship returns to its original vertical rate and keeps the altitude gained. The RA
logic sees the exact states each step through the same detection and resolution the core uses.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from avionics.advisory.inhibits import LowAltitudeInhibits
from avionics.advisory.alerting import Encounter as Pairs, tcas2_alerter
from avionics.advisory.resolution import ResolutionLogic, Sense, Strength, Threat
from avionics.advisory.tables import AlertProfile, select_level
from avionics.conflict.cpa import pair_geometry
from avionics.base.types import AdvisoryLevel

ALERTER = tcas2_alerter()  # TA and RA, TCAS3D with the HMD filter (advisory/alerting.py)


@dataclass(frozen=True)
class Intruder:
    x_m: float  # horizontal position relative to ownship at t = 0
    y_m: float
    vx_mps: float  # horizontal velocity relative to ownship
    vy_mps: float
    sz_m: float  # altitude above ownship at t = 0
    vz_mps: float  # its own vertical rate


@dataclass(frozen=True)
class Encounter:
    agl_m: float  # ownship height above ground at t = 0 (altitude MSL = AGL: ground at 0)
    vz_own_mps: float
    intruders: tuple[Intruder, ...]
    duration_s: float = 90.0


@dataclass
class Outcome:
    vmd_unflown_m: list[float]  # |vertical separation| at each intruder's true horizontal CPA
    vmd_flown_m: list[float]
    first_ra: object = None  # (time, Resolution, threats, inhibits) of the first RA
    threats: set[int] = field(default_factory=set)  # intruders that were RA threats at some time
    # per RA threat, |vertical miss| at its CPA on the path ownship was flying when it became a threat, flown on
    # by this pilot with no new command (the RA logic's "never worse than doing nothing" reference: before the
    # first RA, the unflown path; during an RA, the RA being flown)
    joined_miss_m: dict[int, float] = field(default_factory=dict)
    # threats whose reference, flown on, goes below the descend floor: no RA may fly it (the ground ranks first)
    reference_below_floor: set[int] = field(default_factory=set)
    # the TCAS II v7.1 HMD filter ended an RA while the range still closed: (its threats' HMD, the filter's HMD),
    # [B71] "the HMD filter can terminate an RA prior to ALIM being obtained"
    hmd_filter_ended: tuple | None = None
    # per RA threat, the least ALIM in force while it was one: ALIM is the sensitivity level's, and the level
    # follows ownship's altitude (an RA begun at 20,100 ft is judged with SL 6's ALIM once below 20,000 ft)
    alim_m: dict[int, float] = field(default_factory=dict)
    min_agl_m: float = math.inf  # the lowest height above ground ownship flew
    # every RA as issued: (time, Resolution, the RA threats' intruder indices, ownship altitude and rate then,
    # the ALIM in force then)
    issued: list = field(default_factory=list)

    @property
    def words(self) -> list[str]:
        """The RAs' words in the order they changed."""
        return [ra.words() for _, ra, *_ in self.issued]


def true_cpa_time(intr: Intruder) -> float:
    v2 = intr.vx_mps**2 + intr.vy_mps**2
    return max(0.0, -(intr.x_m * intr.vx_mps + intr.y_m * intr.vy_mps) / v2) if v2 > 0 else 0.0


class Pilot:
    """Flies the RAs: one command at a time, started after its delay."""

    def __init__(self, profile: AlertProfile, vz0: float):
        self.r = profile.response
        self.vz0 = vz0
        self.vz = vz0
        self.command = None  # (kind, value, sign, accel, start)
        self.key = None

    def receive(self, t: float, ra) -> None:
        if ra is None:
            self.command, self.key = None, None
            return
        key = (ra.sense, ra.strength, ra.reversed)
        if key == self.key:
            return
        stronger = ra.strength is Strength.INCREASE or ra.reversed
        delay = self.r.strengthen_delay_s if stronger else self.r.delay_s
        accel = self.r.strengthen_accel_mps2 if stronger else self.r.accel_mps2
        if ra.sense is None:  # composite: neither climb nor descend
            command = ("target", 0.0, 0.0)
        elif ra.strength is Strength.PREVENTIVE:
            command = ("limit", 0.0, ra.sense.sign)
        elif ra.strength is Strength.LEVEL_OFF:
            command = ("target", 0.0, ra.sense.sign)
        else:
            rate = self.r.rate(ra.sense is Sense.CLIMB, ra.strength is Strength.INCREASE)
            command = ("at_least", rate, ra.sense.sign)
        if self.command is not None and command[0] == "target" and self.command[:2] == command[:2]:
            start = self.command[4]  # the same level-off (a LEVEL OFF turned composite): already being flown
        else:
            start = t + delay
        self.command, self.key = (*command, accel, start), key

    def flown_on(self, t: float, until: float, dt: float) -> tuple[float, float]:
        """The altitude change from t to until of this pilot given no new command (a copy flies it), and the
        lowest altitude change on the way. With no RA in force it is the present vertical rate held (rule 1's
        "doing nothing"; the return to the rate before an RA is this pilot's intent, which no logic can see)."""
        if self.command is None:
            dz = self.vz * (until - t)
            return dz, min(dz, 0.0)
        copy = Pilot.__new__(Pilot)
        copy.__dict__.update(self.__dict__)
        dz, lowest, n = 0.0, 0.0, int(round((until - t) / dt))
        for k in range(max(n, 0)):
            dz += copy.step(t + k * dt, dt)
            lowest = min(lowest, dz)
        return dz, lowest

    def step(self, t: float, dt: float) -> float:
        """Advance dt; return the altitude change."""
        if self.command is None:
            wanted, accel = self.vz0, self.r.accel_mps2
        else:
            kind, value, sign, accel, start = self.command
            if t < start:
                wanted = self.vz
            elif kind == "target":
                wanted = value
            elif kind == "limit":  # no motion toward the threat
                wanted = max(self.vz, 0.0) if sign > 0 else min(self.vz, 0.0)
            else:  # at least the rate in the sense; faster is kept
                wanted = max(self.vz, value) if sign > 0 else min(self.vz, -value)
        new = self.vz + max(-accel * dt, min(accel * dt, wanted - self.vz))
        dz = 0.5 * (self.vz + new) * dt
        self.vz = new
        return dz


def fly(encounter: Encounter, profile: AlertProfile, respond: bool = True, dt: float = 0.1) -> Outcome:
    logic = ResolutionLogic(profile)
    inhibits = LowAltitudeInhibits(profile)
    pilot = Pilot(profile, encounter.vz_own_mps)
    own_z = encounter.agl_m
    intr = encounter.intruders
    t_cpa = [true_cpa_time(i) for i in intr]
    at_cpa: list[float | None] = [None] * len(intr)
    out = Outcome([], [])
    was_ra = np.zeros(len(intr), bool)
    n = int(round(encounter.duration_s / dt))
    for k in range(n + 1):
        t = k * dt
        s = np.array([[i.x_m + i.vx_mps * t, i.y_m + i.vy_mps * t] for i in intr])
        v = np.array([[i.vx_mps, i.vy_mps] for i in intr])
        iz = np.array([encounter.agl_m + i.sz_m + i.vz_mps * t for i in intr])
        ivz = np.array([i.vz_mps for i in intr])
        for j in range(len(intr)):  # the true miss at the horizontal CPA, on the 0.1 s grid
            if at_cpa[j] is None and t >= t_cpa[j] - 1e-9:
                at_cpa[j] = iz[j] - own_z
        if k % 10 == 0 and respond:  # the logic runs at 1 Hz on exact states
            g = pair_geometry(s, v, iz - own_z, ivz - pilot.vz)
            level = select_level(own_z, own_z, profile.levels)
            inh = inhibits.update(own_z)
            pairs = Pairs(g, np.ones(len(intr), bool), np.zeros(len(intr)),
                          np.abs(ivz) <= profile.max_threat_vertical_rate_mps)
            most = None if not inh.ra else int(AdvisoryLevel.TA)
            candidate = ALERTER.alert(pairs, level, most)
            candidate, _ = ALERTER.hold(pairs, level, np.where(was_ra, int(AdvisoryLevel.RA), 0), candidate, most)
            ra_now = [j for j in range(len(intr)) if candidate[j] == int(AdvisoryLevel.RA)]
            threats = [Threat(float(g.sz_m[j]), float(ivz[j]), float(g.t_cpa_s[j]), j) for j in ra_now]
            floors = inhibits.floors(own_z, own_z)
            ra = logic.resolve(t, threats, pilot.vz, level.alim_m or 0.0, inh, own_z, floors)
            ended = [j for j in np.flatnonzero(was_ra) if j not in ra_now and g.s_dot_v[j] < 0.0]
            if ended and level.ra_hmd_m is not None and all(g.hmd_m[j] > level.ra_hmd_m for j in ended):
                out.hmd_filter_ended = (min(float(g.hmd_m[j]) for j in ended), level.ra_hmd_m)
            was_ra = (candidate == int(AdvisoryLevel.RA)) & (ra is not None)  # a blocked RA stays a TA
            if ra is not None:
                out.threats.update(ra_now)
                for j in ra_now:
                    out.alim_m[j] = min(out.alim_m.get(j, math.inf), level.alim_m or 0.0)
                for j in ra_now:
                    if j not in out.joined_miss_m and at_cpa[j] is not None:  # joined after its CPA: the miss is past
                        out.joined_miss_m[j] = abs(at_cpa[j])
                    elif j not in out.joined_miss_m:
                        at_cpa_z = encounter.agl_m + intr[j].sz_m + intr[j].vz_mps * t_cpa[j]
                        dz, lowest = pilot.flown_on(t, t_cpa[j], dt)
                        out.joined_miss_m[j] = abs(at_cpa_z - (own_z + dz))
                        if own_z + lowest < floors.descend_m:
                            out.reference_below_floor.add(j)
                if out.first_ra is None:
                    out.first_ra = (t, ra, threats, inh, pilot.vz, level.alim_m)
            if ra is not None and (not out.issued or out.issued[-1][1].words() != ra.words()):
                out.issued.append((t, ra, tuple(ra_now), own_z, pilot.vz, level.alim_m or 0.0))
            pilot.receive(t, ra)
        own_z += pilot.step(t, dt) if respond else encounter.vz_own_mps * dt
        out.min_agl_m = min(out.min_agl_m, own_z)
    unflown = [abs(i.sz_m + i.vz_mps * tc - encounter.vz_own_mps * tc) for i, tc in zip(intr, t_cpa)]
    out.vmd_unflown_m = unflown
    out.vmd_flown_m = [abs(m) if m is not None else math.inf for m in at_cpa]
    return out


def non_crossing_sense(threats: list[Threat]) -> Sense | None:
    """The sense that crosses no threat's current altitude, if there is one (all threats on one side)."""
    if all(th.sz_m > 0 for th in threats):
        return Sense.DESCEND
    if all(th.sz_m < 0 for th in threats):
        return Sense.CLIMB
    return None


def corrective_separation(profile: AlertProfile, threats: list[Threat], sense: Sense, v0: float) -> float:
    """Closed-form separation at each CPA with the corrective standard response (independent of resolution.py)."""
    r = profile.response
    target = max(v0, r.rate(climb=True)) if sense is Sense.CLIMB else min(v0, -r.rate(climb=False))
    seps = []
    for th in threats:
        t = max(th.t_cpa_s, 0.0)
        t_acc = abs(target - v0) / r.accel_mps2
        if t <= r.delay_s:
            dz = v0 * t
        elif t <= r.delay_s + t_acc:
            u = t - r.delay_s
            dz = v0 * t + 0.5 * math.copysign(r.accel_mps2, target - v0) * u * u
        else:
            dz = v0 * r.delay_s + 0.5 * (v0 + target) * t_acc + target * (t - r.delay_s - t_acc)
        seps.append(sense.sign * (dz - (th.sz_m + th.vz_intruder_mps * t)))
    return min(seps)


def random_encounter(rng: np.random.Generator, t_cpa_s=(25.0, 60.0), duration_s: float = 65.0) -> Encounter:
    """The encounter model of tests/test_ra_properties.py, drawn from a numpy generator: each intruder reaches
    its horizontal CPA after t_cpa_s with a drawn HMD and unflown VMD; the start is traced back."""
    from avionics.base.units import FPM, FT

    agl = rng.uniform(500 * FT, 12000 * FT)
    vz_own = 0.0 if rng.random() < 0.3 else rng.uniform(-3000 * FPM, 3000 * FPM)
    intruders = []
    for _ in range(1 if rng.random() < 0.75 else 2):
        t_cpa, closure, bearing = rng.uniform(*t_cpa_s), rng.uniform(30.0, 250.0), rng.uniform(0, 2 * math.pi)
        hmd, side = rng.uniform(0.0, 1500.0), rng.choice([-1.0, 1.0])
        vmd = 0.0 if rng.random() < 0.2 else rng.uniform(-800 * FT, 800 * FT)
        vz = 0.0 if rng.random() < 0.3 else rng.uniform(-4000 * FPM, 4000 * FPM)
        vx, vy = -closure * math.cos(bearing), -closure * math.sin(bearing)
        cx, cy = side * hmd * math.sin(bearing), -side * hmd * math.cos(bearing)
        intruders.append(Intruder(cx - vx * t_cpa, cy - vy * t_cpa, vx, vy, vmd - (vz - vz_own) * t_cpa, vz))
    return Encounter(agl, vz_own, tuple(intruders), duration_s)


def to_scenario(enc: Encounter, name: str = "generated", own_speed_mps: float = 60.0):
    """The same encounter as a SITL scenario (ground at 0 ft MSL, ownship northbound at own_speed_mps), for
    `sitl replay --fly-ras`."""
    from avionics.base.geodesy import LocalTangentPlane
    from avionics_sitl.aircraft import AircraftSpec
    from avionics_sitl.scenario import Scenario

    origin = (47.4, 8.5)
    plane = LocalTangentPlane(*origin)
    own_v = (0.0, own_speed_mps)

    def spec(label, icao, east, north, alt, ve, vn, vu):
        lat, lon = (float(c) for c in plane.to_geodetic(east, north))
        return AircraftSpec(name=label, icao_address=icao, lat_deg=lat, lon_deg=lon, alt_msl_m=alt,
                            heading_deg=math.degrees(math.atan2(ve, vn)) % 360.0, speed_mps=math.hypot(ve, vn),
                            vertical_rate_mps=vu)

    own = spec("ownship", 0xC0FFEE, 0.0, 0.0, enc.agl_m, *own_v, enc.vz_own_mps)
    intruders = tuple(spec(f"intruder{k}", 0xA20000 + k, i.x_m, i.y_m, enc.agl_m + i.sz_m, own_v[0] + i.vx_mps,
                           own_v[1] + i.vy_mps, i.vz_mps) for k, i in enumerate(enc.intruders))
    return Scenario(name=name, description="generated encounter (tests/ra_sim.py)", ownship=own,
                    intruders=intruders, duration_s=enc.duration_s, origin=origin)


def level_off_dz(t: float, v0: float, delay: float, accel: float) -> float:
    """Ownship's altitude change t seconds after a LEVEL OFF command (closed form, independent of the logic):
    v0 for the delay, then constant deceleration to 0."""
    if t <= delay:
        return v0 * t
    stop = abs(v0) / accel
    u = min(t - delay, stop)
    return v0 * delay + v0 * u - math.copysign(0.5 * accel * u * u, v0)


def uav_encounter(seed: int, own_speed_mps: float, vz_own_range: tuple[float, float],
                  closure_range: tuple[float, float], name: str):
    """A UAV's random encounter for the guidance properties (tests/test_guidance*.py): ownship at own_speed_mps and
    150-900 m AGL, level or at a rate in vz_own_range; one intruder reaching its drawn HMD (0-150 m) and VMD
    (+-60 m) at t_cpa (25-35 s), level or at +-5 m/s. (scenario, ownship height, its vertical rate, t_cpa)."""
    rng = np.random.default_rng(seed)
    agl = rng.uniform(150.0, 900.0)
    vz_own = 0.0 if rng.random() < 0.4 else rng.uniform(*vz_own_range)
    t_cpa, closure, bearing = rng.uniform(25.0, 35.0), rng.uniform(*closure_range), rng.uniform(0, 2 * math.pi)
    hmd, vmd, vz = rng.uniform(0.0, 150.0), rng.uniform(-60.0, 60.0), 0.0 if rng.random() < 0.5 else \
        rng.uniform(-5.0, 5.0)
    vx, vy = -closure * math.cos(bearing), -closure * math.sin(bearing)
    cx, cy = hmd * math.sin(bearing), -hmd * math.cos(bearing)
    intruder = Intruder(cx - vx * t_cpa, cy - vy * t_cpa, vx, vy, vmd - (vz - vz_own) * t_cpa, vz)
    scenario = to_scenario(Encounter(agl, vz_own, (intruder,), t_cpa + 12.0), name, own_speed_mps=own_speed_mps)
    return scenario, agl, vz_own, t_cpa
