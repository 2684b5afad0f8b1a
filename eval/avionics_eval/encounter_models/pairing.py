"""Pairing two trajectories into an encounter with importance sampling, as MIT LL's DAA Encounter Generation
Tool does (github.com/Airspace-Encounter-Models/em-pairing-uncor-importancesampling, Encounter_Generation_Tool;
line numbers of its files below):

- VMD by rejection: the intruder's altitude minus the ownship's at the time of closest approach (TCA) falls in a
  bin of the VMD proposal; it is kept with probability q_b = p_b / max(p), p_b the bin's desired proportion, and
  weighted 1 / q_b; outside the bins it is rejected (generateDAAEncounterSet.m lines 132-157, 353-379);
- the intruder's heading relative to the ownship at TCA psi, drawn by rejection with probability proportional to
  the relative speed |v_rel(psi)| (initializeUncorrelatedEncounter.m lines 86-99), and the encounter weighted by
  the relative speed integrated over a uniform heading, V = integral_0^2pi |v_rel(psi)| dpsi (line 227, the
  rate at which two aircraft meet in uncorrelated airspace; computed here by quadrature of its definition);
- HMD from a piecewise-uniform proposal g over [-H, H], with the nominal uniform on [-H, H], weight
  (1 / 2H) / g(hmd) (lines 230-232, 243-277);
- the ownship rotated to heading 0 at TCA, the intruder to psi and translated so that at TCA it is hmd away
  across the relative velocity (lines 119-153);
- each encounter's weight w = V * w_hmd * w_vmd (line 238). `importance` = w_hmd * w_vmd alone is 1 for every
  encounter when the proposals equal the nominal distributions.

The horizontal miss at TCA is |hmd| by construction; a pair whose 1 Hz tracks come closer at another time (a
turn near TCA) is rejected and counted, as the tool rejects a pair whose misses differ from the drawn ones
(generateDAAEncounterSet.m lines 408-424).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from avionics_eval.encounter_models.tracks import Tracks

# the tool's example proposals (Example_Inputs/UncorVsUncor.ini): bins in ft and their desired proportions
VMD_EDGES_FT = (-1500.0, -500.0, -100.0, 0.0, 100.0, 500.0, 1500.0)
VMD_PROPORTIONS = (1 / 2, 1 / 1.5, 1.0, 1.0, 1 / 1.5, 1 / 2)
HMD_EDGES_FT = (-18240.0, -1500.0, -500.0, 0.0, 500.0, 1500.0, 18240.0)
HMD_PROPORTIONS = (1 / 1.5, 1 / 1.25, 1.0, 1.0, 1 / 1.25, 1 / 1.5)
QUADRATURE_POINTS = 256  # periodic trapezoid rule: spectrally accurate for the smooth periodic |v_rel(psi)|


class PairingError(ValueError):
    """Bad proposal or tracks that cannot be paired (exit 2 on the command line)."""


@dataclass(frozen=True)
class Proposal:
    """A piecewise-uniform distribution: edges (k+1) and the share of probability in each of the k bins."""

    edges: np.ndarray
    shares: np.ndarray

    @classmethod
    def of(cls, edges, proportions) -> "Proposal":
        e, p = np.asarray(edges, float), np.asarray(proportions, float)
        if e.ndim != 1 or p.shape != (e.size - 1,) or (np.diff(e) <= 0).any() or (p < 0).any() or p.sum() <= 0:
            raise PairingError("a proposal needs rising edges and one proportion >= 0 per bin, not all 0")
        return cls(e, p / p.sum())

    def density(self, x: np.ndarray) -> np.ndarray:
        b = np.clip(np.searchsorted(self.edges, x, side="right") - 1, 0, self.shares.size - 1)
        return self.shares[b] / np.diff(self.edges)[b]

    def draw(self, n: int, rng: np.random.Generator) -> np.ndarray:
        b = rng.choice(self.shares.size, size=n, p=self.shares)
        return self.edges[b] + rng.random(n) * np.diff(self.edges)[b]


@dataclass(frozen=True)
class Encounters:
    own: Tracks
    intruder: Tracks
    tca_s: int
    hmd_ft: np.ndarray        # signed, as drawn; |hmd| is the horizontal miss at TCA
    vmd_ft: np.ndarray        # intruder altitude - ownship altitude at TCA
    weight: np.ndarray        # V * importance
    importance: np.ndarray    # w_hmd * w_vmd
    rejected_vmd: int
    rejected_cpa: int

    def __len__(self) -> int:
        return self.hmd_ft.size


def _take(tracks: Tracks, mask) -> Tracks:
    return Tracks(*(getattr(tracks, f)[mask] for f in Tracks.__dataclass_fields__))


def relative_speed_integral(v1, v2, dh1, dh2) -> np.ndarray:
    """V = integral over psi in [0, 2pi) of |(v2 cos psi - v1, v2 sin psi, dh2 - dh1)| (ft/s rad)."""
    psi = np.linspace(0.0, 2 * np.pi, QUADRATURE_POINTS, endpoint=False)
    c = np.cos(psi)[None, :]
    rel = np.sqrt(v1[:, None] ** 2 + v2[:, None] ** 2 - 2 * v1[:, None] * v2[:, None] * c
                  + (dh2 - dh1)[:, None] ** 2)
    return rel.mean(axis=1) * 2 * np.pi


def _rotate(tracks: Tracks, centre_n, centre_e, angle, to_n, to_e) -> Tracks:
    """Rotate each track by angle (rad, clockwise from north) about its point at TCA and put that point at
    (to_n, to_e)."""
    n = tracks.north_ft - centre_n[:, None]
    e = tracks.east_ft - centre_e[:, None]
    c, s = np.cos(angle)[:, None], np.sin(angle)[:, None]
    return replace(tracks, north_ft=n * c - e * s + to_n[:, None], east_ft=n * s + e * c + to_e[:, None],
                   heading_deg=np.mod(tracks.heading_deg + np.degrees(angle)[:, None], 360.0))


def horizontal_cpa(own: Tracks, intruder: Tracks) -> tuple[np.ndarray, np.ndarray]:
    """(time s, range ft) of the horizontal closest approach of piecewise-linear 1 Hz tracks."""
    pn = intruder.north_ft - own.north_ft
    pe = intruder.east_ft - own.east_ft
    dn, de = np.diff(pn, axis=1), np.diff(pe, axis=1)
    d2 = dn * dn + de * de
    with np.errstate(invalid="ignore", divide="ignore"):
        t = np.where(d2 > 0, np.clip(-(pn[:, :-1] * dn + pe[:, :-1] * de) / d2, 0.0, 1.0), 0.0)
    r = np.hypot(pn[:, :-1] + t * dn, pe[:, :-1] + t * de)
    k = np.argmin(r, axis=1)
    rows = np.arange(r.shape[0])
    return k + t[rows, k], r[rows, k]


def pair(own: Tracks, intruder: Tracks, tca_s: int, rng: np.random.Generator, hmd: Proposal | None = None,
         vmd: Proposal | None = None, tolerance_ft: float = 1e-6) -> Encounters:
    """Encounters from row-wise pairs of tracks (same length, 1 Hz); pairs rejected by VMD or CPA are dropped
    and counted."""
    hmd = hmd or Proposal.of(HMD_EDGES_FT, HMD_PROPORTIONS)
    vmd = vmd or Proposal.of(VMD_EDGES_FT, VMD_PROPORTIONS)
    if own.north_ft.shape != intruder.north_ft.shape:
        raise PairingError("ownship and intruder tracks differ in number or length")
    points = own.north_ft.shape[1]
    if not 0 <= tca_s < points - 1:
        raise PairingError(f"TCA {tca_s} s is not inside tracks of {points - 1} s")
    n, c = own.north_ft.shape[0], tca_s
    # VMD by rejection (generateDAAEncounterSet.m lines 132-157, 366-379)
    rel_alt = intruder.alt_ft[:, c] - own.alt_ft[:, c]
    bin_probs = vmd.shares / vmd.shares.max()
    b = np.searchsorted(vmd.edges, rel_alt, side="right") - 1
    inside = (b >= 0) & (b < bin_probs.size) & (rel_alt < vmd.edges[-1])
    b = np.clip(b, 0, bin_probs.size - 1)
    keep = inside & (rng.random(n) <= bin_probs[b])
    rejected_vmd = int(n - keep.sum())
    own, intruder, rel_alt, b = _take(own, keep), _take(intruder, keep), rel_alt[keep], b[keep]
    w_vmd = 1.0 / bin_probs[b]
    m = rel_alt.size
    # velocities at TCA: the 1 Hz segment that starts there (ft/s), and headings (rad, clockwise from north)
    def velocity(t: Tracks):
        dn, de = t.north_ft[:, c + 1] - t.north_ft[:, c], t.east_ft[:, c + 1] - t.east_ft[:, c]
        return np.hypot(dn, de), np.arctan2(de, dn), t.alt_ft[:, c + 1] - t.alt_ft[:, c]
    v1, h1, dh1 = velocity(own)
    v2, h2, dh2 = velocity(intruder)
    # relative heading by rejection, proportional to |v_rel| (initializeUncorrelatedEncounter.m lines 86-99)
    psi = np.zeros(m)
    todo = np.ones(m, dtype=bool)
    vmax = np.sqrt((v1 + v2) ** 2 + (dh2 - dh1) ** 2)
    while todo.any():
        k = int(todo.sum())
        cand = (rng.random(k) - 0.5) * 2 * np.pi
        rel = np.sqrt((np.cos(cand) * v2[todo] - v1[todo]) ** 2 + (np.sin(cand) * v2[todo]) ** 2
                      + (dh2[todo] - dh1[todo]) ** 2)
        ok = rng.random(k) * vmax[todo] <= rel
        idx = np.flatnonzero(todo)[ok]
        psi[idx] = cand[ok]
        todo[idx] = False
    rate = relative_speed_integral(v1, v2, dh1, dh2)
    # HMD from the proposal, weighted to the nominal uniform on the proposal's span (lines 212, 230-232)
    drawn = hmd.draw(m, rng)
    w_hmd = (1.0 / (hmd.edges[-1] - hmd.edges[0])) / hmd.density(drawn)
    vr_n, vr_e = v2 * np.cos(psi) - v1, v2 * np.sin(psi)
    vr = np.hypot(vr_n, vr_e)
    with np.errstate(invalid="ignore", divide="ignore"):
        n_pt, e_pt = drawn * vr_e / vr, -drawn * vr_n / vr  # across the relative velocity (lines 223-224)
    zeros = np.zeros(m)
    own = _rotate(own, own.north_ft[:, c], own.east_ft[:, c], -h1, zeros, zeros)
    intruder = _rotate(intruder, intruder.north_ft[:, c], intruder.east_ft[:, c], psi - h2, n_pt, e_pt)
    # the ownship starts at 0,0 (lines 145-153)
    n0, e0 = own.north_ft[:, 0].copy(), own.east_ft[:, 0].copy()
    own = replace(own, north_ft=own.north_ft - n0[:, None], east_ft=own.east_ft - e0[:, None])
    intruder = replace(intruder, north_ft=intruder.north_ft - n0[:, None], east_ft=intruder.east_ft - e0[:, None])
    t_cpa, r_cpa = horizontal_cpa(own, intruder)
    good = (vr > 0) & (r_cpa >= np.abs(drawn) - tolerance_ft)
    rejected_cpa = int(m - good.sum())
    importance = (w_hmd * w_vmd)[good]
    return Encounters(_take(own, good), _take(intruder, good), tca_s, drawn[good], rel_alt[good],
                      rate[good] * importance, importance, rejected_vmd, rejected_cpa)


def generate(own_tracks, intruder_tracks, n: int, tca_s: int, rng: np.random.Generator,
             hmd: Proposal | None = None, vmd: Proposal | None = None, max_rounds: int = 200) -> Encounters:
    """n encounters from two track sources (callables (count, rng) -> Tracks), drawing batches until enough
    pairs survive the rejections; the rejection counts add up over the batches."""
    parts: list[Encounters] = []
    have = 0
    for _ in range(max_rounds):
        if have >= n:
            break
        batch = max(64, 2 * (n - have))
        e = pair(own_tracks(batch, rng), intruder_tracks(batch, rng), tca_s, rng, hmd, vmd)
        parts.append(e)
        have += len(e)
    if have < n:
        raise PairingError(f"only {have} of {n} encounters after {max_rounds} rounds: the tracks rarely meet the "
                           "VMD proposal's span")

    def cat(get):
        return np.concatenate([get(p) for p in parts])[:n]

    def cat_tracks(which):
        return Tracks(*(cat(lambda p, f=f: getattr(getattr(p, which), f)) for f in Tracks.__dataclass_fields__))

    return Encounters(cat_tracks("own"), cat_tracks("intruder"), tca_s, cat(lambda p: p.hmd_ft),
                      cat(lambda p: p.vmd_ft), cat(lambda p: p.weight), cat(lambda p: p.importance),
                      sum(p.rejected_vmd for p in parts), sum(p.rejected_cpa for p in parts))
