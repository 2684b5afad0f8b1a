"""Association without identity: a chi-square gate and the global nearest neighbour (GNN) assignment.

Used twice: radar or active-surveillance reports to the sensor tracks (sensor_tracker.py), and sensor tracks to
ADS-B tracks, which are then one aircraft (fusion.py). GNN (Blackman & Popoli 1999, Sec. 6.4) picks the one
assignment of reports to tracks that pairs the most of them inside their gates at the least summed normalised
distance d^2 = r^T S^-1 r (scipy.optimize.linear_sum_assignment, the Hungarian/Jonker-Volgenant solution);
a pair outside its gate is never made. JPDA would weigh several reports per track where returns are dense; at a
UAV's traffic densities a gate holds one report, and GNN keeps two aircraft apart rather than averaging them.
"""

from __future__ import annotations

import numpy as np
from scipy.optimize import linear_sum_assignment

from avionics.tracking.imm import spd_inverse

_FORBIDDEN = 1e12  # a cost no in-gate pair reaches: the solver pairs the most in-gate pairs first


def normalised_distances(xa: np.ndarray, pa: np.ndarray, xb: np.ndarray, pb: np.ndarray) -> np.ndarray:
    """d^2 (A, B) of every pair of a and b: xa (A, k), pa (A, k, k), xb (B, k), pb (B, k, k) with independent
    errors, S = Pa + Pb."""
    if not len(xa) or not len(xb):
        return np.empty((len(xa), len(xb)))
    r = xa[:, None, :] - xb[None, :, :]
    s_inv, _ = spd_inverse(pa[:, None] + pb[None, :])
    return np.einsum("abi,abij,abj->ab", r, s_inv, r)


def gnn(d2: np.ndarray, gate: float) -> list[tuple[int, int]]:
    """Global nearest neighbour pairs (row, column) of a d^2 matrix, each inside the gate."""
    if d2.size == 0:
        return []
    inside = d2 <= gate
    rows, cols = linear_sum_assignment(np.where(inside, d2, _FORBIDDEN))
    return [(int(r), int(c)) for r, c in zip(rows, cols) if inside[r, c]]
