"""Trajectories from sampled model variables, integrated at 1 s as sample2track.m does
(em-model-manned-bayes code/matlab/sample2track.m lines 199-218: altitude from the vertical rate, speed from the
acceleration, heading from the turn rate, position from the previous second's speed and heading, heading 0 =
north, x north), with its rejections (lines 236-244: below ground, or speed outside the model's speed bins)."""

from __future__ import annotations

import csv
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from avionics.base.geodesy import MEAN_EARTH_RADIUS_M  # for lat/lon of the local flat-earth track
from avionics.base.units import FT
from avionics_eval.encounter_models.model import EncounterModel, ModelFileError
from avionics_eval.encounter_models.sampler import sample

KT_TO_FTPS = 6076.11549 / 3600.0   # international nautical mile in feet, per hour -> per second
CSV_COLUMNS = ("ID", "Time", "lat", "lon", "alt_AGL_ft", "speed_kts", "heading_deg", "dh_fpm", "alt_MSL_ft")
# the variables sample2track.m reads (its label_initial_* defaults, lines 25-31), as labelled in the files
ALTITUDE, SPEED, ACCELERATION, VERTICAL_RATE, TURN_RATE = "L", "v", "\\dot v", "\\dot h", "\\dot \\psi"


@dataclass(frozen=True)
class Tracks:
    """n trajectories at 1 Hz, arrays (n, steps + 1); north/east in ft from the start, heading in deg [0, 360)."""

    time_s: np.ndarray
    north_ft: np.ndarray
    east_ft: np.ndarray
    alt_ft: np.ndarray
    speed_kts: np.ndarray
    heading_deg: np.ndarray
    dh_fpm: np.ndarray

    def __len__(self) -> int:
        return self.north_ft.shape[0]


def integrate(model: EncounterModel, samples) -> tuple[Tracks, np.ndarray]:
    """Tracks of all samples and the mask of those sample2track.m keeps."""
    dyn = samples.dynamic_variables
    try:
        acc, vert, turn = (dyn.index(model.variable(label)) for label in (ACCELERATION, VERTICAL_RATE, TURN_RATE))
    except ValueError:
        raise ModelFileError(f"{model.path}: the transition network does not evolve acceleration, vertical rate "
                             "and turn rate") from None
    v0 = samples.initial_values[:, model.variable(SPEED)]
    h0 = samples.initial_values[:, model.variable(ALTITUDE)]
    dv, dh, dpsi = (samples.dynamic_values[:, :, c] for c in (acc, vert, turn))
    n, points = dv.shape
    speed = v0[:, None] + np.concatenate([np.zeros((n, 1)), np.cumsum(dv[:, :-1], axis=1)], axis=1)
    alt = h0[:, None] + np.concatenate([np.zeros((n, 1)), np.cumsum(dh[:, :-1] / 60.0, axis=1)], axis=1)
    heading = np.concatenate([np.zeros((n, 1)), np.cumsum(dpsi[:, :-1], axis=1)], axis=1)
    step_ft = speed[:, :-1] * KT_TO_FTPS
    rad = np.radians(heading[:, :-1])
    zeros = np.zeros((n, 1))
    north = np.concatenate([zeros, np.cumsum(step_ft * np.cos(rad), axis=1)], axis=1)
    east = np.concatenate([zeros, np.cumsum(step_ft * np.sin(rad), axis=1)], axis=1)
    edges = model.boundaries[model.variable(SPEED)]
    keep = (alt >= 0).all(axis=1) & (speed > edges[0]).all(axis=1) & (speed < edges[-1]).all(axis=1)
    time = np.broadcast_to(np.arange(points, dtype=float), (n, points))
    return Tracks(time, north, east, alt, speed, np.mod(heading, 360.0), dh), keep


def sample_tracks(model: EncounterModel, n: int, duration_s: int, rng: np.random.Generator,
                  prior: float | str = 0.0, transition: str = "reference", max_rounds: int = 50) -> Tracks:
    """n kept trajectories of duration_s seconds: rejected ones are replaced by new draws (sample2track.m
    discards them; a fixed count is what a user asks for)."""
    parts: list[Tracks] = []
    have = 0
    for _ in range(max_rounds):
        if have >= n:
            break
        batch = max(16, int((n - have) * 1.25))
        tracks, keep = integrate(model, sample(model, batch, duration_s, rng, prior, transition))
        kept = Tracks(*(getattr(tracks, f)[keep] for f in Tracks.__dataclass_fields__))
        parts.append(kept)
        have += len(kept)
    if have < n:
        raise ModelFileError(f"{model.path}: only {have} of {n} trajectories kept after {max_rounds} rounds "
                             "(below ground or outside the speed bins)")
    if not parts:
        parts.append(integrate(model, sample(model, 0, duration_s, rng, prior, transition))[0])
    return Tracks(*(np.concatenate([getattr(p, f) for p in parts])[:n] for f in Tracks.__dataclass_fields__))


def lat_lon(north_ft: np.ndarray, east_ft: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Degrees of a local flat-earth track started at 0,0, on a sphere of the mean Earth radius."""
    lat = np.degrees(north_ft * FT / MEAN_EARTH_RADIUS_M)
    lon = np.degrees(east_ft * FT / (MEAN_EARTH_RADIUS_M * np.cos(np.radians(lat))))
    return lat, lon


def write_csv(tracks: Tracks, out_dir: Path, ground_msl_ft: float = 0.0, first_id: int = 1) -> list[Path]:
    """One CSV per trajectory with CSV_COLUMNS (the columns of MIT LL's example trajectories)."""
    out_dir.mkdir(parents=True, exist_ok=True)
    digits = max(1, int(math.log10(max(1, len(tracks) + first_id))) + 1)
    paths = []
    lat, lon = lat_lon(tracks.north_ft, tracks.east_ft)
    for row in range(len(tracks)):
        ident = first_id + row
        path = out_dir / f"track_{ident:0{digits}d}.csv"
        with path.open("w", newline="", encoding="utf-8") as handle:
            w = csv.writer(handle)
            w.writerow(CSV_COLUMNS)
            for t in range(tracks.time_s.shape[1]):
                alt = tracks.alt_ft[row, t]
                w.writerow((ident, f"{tracks.time_s[row, t]:.0f}", f"{lat[row, t]:.9f}", f"{lon[row, t]:.9f}",
                            f"{alt:.2f}", f"{tracks.speed_kts[row, t]:.3f}", f"{tracks.heading_deg[row, t]:.3f}",
                            f"{tracks.dh_fpm[row, t]:.2f}", f"{alt + ground_msl_ft:.2f}"))
        paths.append(path)
    return paths
