"""Encounters of the MIT Lincoln Laboratory models for `avionics evaluate --model FILE[,FILE] --ownship ...`.

Each encounter is one importance-weighted pair drawn by avionics_eval.encounter_models.pairing.generate (the
DAA Encounter Generation Tool's method): the ownship from a multirotor UAV mission (uav.py) or a Lincoln model,
the intruder from one of the --model files (chosen uniformly per encounter when several are given), TCA at the
evaluation's T_CPA_S. Like the project's own generator (generator.py), encounter i of set `seed` depends on
(seed, i) alone, so a set is the same on any scheduler and resumes by index.

The 1 Hz tracks are piecewise linear (sample2track.m integrates each second at constant velocity), so the truth
on the evaluation's DT_S grid is their linear interpolation and the velocity of each 1 s segment; the drawn
misses at TCA are then the truth's misses. Altitudes are above ground, the ground at 0 ft MSL as generator.py.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cache
from pathlib import Path

import numpy as np

from avionics.base.units import FPM, FT, KT
from avionics_eval.encounter_models.model import ModelFileError, read_model
from avionics_eval.encounter_models.pairing import PairingError, generate
from avionics_eval.encounter_models.tracks import Tracks, sample_tracks
from avionics_eval.encounter_models.uav import MISSIONS, mission_tracks
from avionics_eval.evaluation.generator import DT_S, DURATION_S, T_CPA_S, grid

UAV_PREFIX = "uav-"
OWNSHIPS = tuple(UAV_PREFIX + m for m in MISSIONS)
TRACK_S = round(DURATION_S)  # 1 Hz tracks cover the evaluation's DURATION_S
TCA_S = round(T_CPA_S)


class LincolnSourceError(ValueError):
    """A --model or --ownship that cannot make encounters (unreadable file, unknown mission)."""


@cache
def _model(path: str):
    return read_model(path)


def _resolve(name: str) -> str:
    from avionics_eval.encounter_models.__main__ import model_path

    return str(model_path(name))


@dataclass(frozen=True)
class LincolnSource:
    """--model and --ownship: picklable (paths and names only), the models read once per process."""

    intruder_models: tuple[str, ...]
    ownship: str

    @classmethod
    def of(cls, models: str, ownship: str) -> "LincolnSource":
        """From the command line's comma-separated --model and --ownship; every file is read now, so a bad one
        fails before anything runs."""
        names = tuple(m.strip() for m in models.split(",") if m.strip())
        if not names:
            raise LincolnSourceError("--model needs at least one model file")
        source = cls(tuple(_resolve(n) for n in names),
                     ownship if ownship.startswith(UAV_PREFIX) else _resolve(ownship))
        if ownship.startswith(UAV_PREFIX) and ownship not in OWNSHIPS:
            raise LincolnSourceError(f"--ownship {ownship!r}: one of {', '.join(OWNSHIPS)} or a model file")
        try:
            for path in source.files():
                _model(path)
        except ModelFileError as exc:
            raise LincolnSourceError(str(exc)) from None
        return source

    def files(self) -> tuple[str, ...]:
        return self.intruder_models + (() if self.ownship in OWNSHIPS else (self.ownship,))

    @property
    def name(self) -> str:
        """What the records and the manifest call this source."""
        return "lincoln:" + ",".join(Path(p).name for p in self.intruder_models) + ";ownship=" + Path(
            self.ownship).name

    def _own_tracks(self, count: int, rng) -> Tracks:
        if self.ownship in OWNSHIPS:
            return mission_tracks(self.ownship[len(UAV_PREFIX):], count, TRACK_S, rng)
        return sample_tracks(_model(self.ownship), count, TRACK_S, rng)

    def encounter(self, seed: int, index: int) -> "LincolnEncounter":
        rng = np.random.default_rng([seed, index])
        which = int(rng.integers(len(self.intruder_models)))
        intruder = _model(self.intruder_models[which])
        try:
            e = generate(self._own_tracks, lambda k, r: sample_tracks(intruder, k, TRACK_S, r), 1, TCA_S, rng)
        except (PairingError, ModelFileError) as exc:
            raise LincolnSourceError(f"{self.name}: {exc}") from None
        return LincolnEncounter(seed, index, self.name, which, float(e.weight[0]), float(e.importance[0]),
                                float(e.hmd_ft[0]), float(e.vmd_ft[0]), _truth(e.own), _truth(e.intruder))


def _truth(tracks: Tracks) -> np.ndarray:
    """Row 0 of tracks on the DT_S grid, in m and m/s: columns east, north, up, v_east, v_north, v_up (the
    columns of generator.Aircraft.sample)."""
    t = grid()
    k = np.minimum((t + 1e-9).astype(int), TRACK_S - 1)  # the 1 s segment each grid time lies in
    cols = []
    for x in (tracks.east_ft[0], tracks.north_ft[0], tracks.alt_ft[0]):
        cols.append(np.interp(t, np.arange(x.size, dtype=float), x) * FT)
    for x in (tracks.east_ft[0], tracks.north_ft[0], tracks.alt_ft[0]):
        cols.append(np.diff(x)[k] * FT)  # per second
    return np.column_stack(cols)


@dataclass(frozen=True)
class LincolnEncounter:
    """An encounter as evaluate.evaluate reads it: identity, truth(), geometry() for the record."""

    seed: int
    index: int
    source: str
    intruder_model: int  # index into the source's --model files
    weight: float        # V * importance (pairing.py)
    importance: float
    hmd_drawn_ft: float  # signed, as drawn
    vmd_drawn_ft: float
    own: np.ndarray      # truth columns (see _truth)
    intruder: np.ndarray

    def truth(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        return grid(), self.own, self.intruder

    def geometry(self) -> dict:
        c = round(T_CPA_S / DT_S)
        own, intr = self.own[c], self.intruder[c]
        rel = np.degrees(np.arctan2(intr[3], intr[4]) - np.arctan2(own[3], own[4])) % 360.0
        return {
            "source": self.source, "weight": self.weight, "layer": None, "alt_ft": own[2] / FT,
            "hmd_drawn_ft": abs(self.hmd_drawn_ft), "vmd_drawn_ft": self.vmd_drawn_ft,
            "rel_heading_deg": float(rel), "own_speed_kt": float(np.hypot(own[3], own[4]) / KT),
            "int_speed_kt": float(np.hypot(intr[3], intr[4]) / KT), "own_vrate_fpm": own[5] / FPM,
            "int_vrate_fpm": intr[5] / FPM, "own_manoeuvres": None, "int_manoeuvres": None,
        }
