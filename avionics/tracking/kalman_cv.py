"""Constant-velocity Kalman filter on [east, north, alt, v_east, v_north, v_up] for any time step.

Horizontal and vertical axes share the CV structure (Baek & Bang eqs 1-2 with the vertical CH/CAD split of
eqs 7-8 collapsed to one CV axis); process noise is the piecewise-constant white-acceleration model
(Bar-Shalom, Li & Kirubarajan 2001, sec. 6.3.3): Q = G G^T sigma_a^2 with G = [dt^2/2, dt].
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np

POS = slice(0, 3)
VEL = slice(3, 6)


def cv_transition(dt: float) -> np.ndarray:
    f = np.eye(6)
    f[0, 3] = f[1, 4] = f[2, 5] = dt
    return f


def cv_process_noise(dt: float, sigma_h_mps2: float, sigma_v_mps2: float) -> np.ndarray:
    var = np.array([sigma_h_mps2, sigma_h_mps2, sigma_v_mps2]) ** 2
    q = np.empty((6, 6))
    q[:3, :3] = np.diag(var * dt**4 / 4.0)  # G G^T with G = [dt^2/2, dt], per axis
    q[:3, 3:] = q[3:, :3] = np.diag(var * dt**3 / 2.0)
    q[3:, 3:] = np.diag(var * dt**2)
    return q


@lru_cache(maxsize=16)
def _model(dt: float, sigma_h_mps2: float, sigma_v_mps2: float) -> tuple[np.ndarray, np.ndarray]:
    """F and Q for a step of dt, kept for the next call with the same step: the ownship filter is predicted to
    the same few offsets from its last fix (the 5 Hz fixes, the assessment's ticks) several times a step.
    Read-only: shared by every caller."""
    f, q = cv_transition(dt), cv_process_noise(abs(dt), sigma_h_mps2, sigma_v_mps2)
    f.flags.writeable = q.flags.writeable = False
    return f, q


@dataclass(frozen=True, slots=True)
class Measurement:
    """Observed components of the state: which indices of the 6-vector, their values and 1-sigma noise."""

    index: tuple[int, ...]
    value: np.ndarray
    sigma: np.ndarray


class CvKalman:
    """One target's CV Kalman filter. predict_to() never mutates; update() advances the filter."""

    def __init__(self, t_s: float, x: np.ndarray, p: np.ndarray, sigma_h_mps2: float, sigma_v_mps2: float):
        self.t_s = t_s
        self.x = np.asarray(x, float)
        self.p = np.asarray(p, float)
        self.sigma_h = sigma_h_mps2
        self.sigma_v = sigma_v_mps2

    def predict_to(self, t_s: float) -> tuple[np.ndarray, np.ndarray]:
        f, q = _model(t_s - self.t_s, self.sigma_h, self.sigma_v)
        return f @ self.x, f @ self.p @ f.T + q

    def innovation(self, t_s: float, z: Measurement) -> tuple[np.ndarray, np.ndarray]:
        """Innovation and its covariance S = H P- H^T + R of a measurement at t_s (nothing mutated)."""
        x, p = self.predict_to(t_s)
        idx = list(z.index)
        return z.value - x[idx], p[np.ix_(idx, idx)] + np.diag(z.sigma**2)

    def update(self, t_s: float, z: Measurement) -> None:
        x, p = self.predict_to(t_s)
        idx = list(z.index)
        h = np.zeros((len(idx), 6))
        h[np.arange(len(idx)), idx] = 1.0
        s = h @ p @ h.T + np.diag(z.sigma**2)
        k = np.linalg.solve(s, h @ p).T  # P H^T S^-1, S symmetric
        x = x + k @ (z.value - h @ x)
        i_kh = np.eye(6) - k @ h
        p = i_kh @ p @ i_kh.T + k @ np.diag(z.sigma**2) @ k.T  # Joseph form: stays symmetric PD
        self.t_s, self.x, self.p = t_s, x, 0.5 * (p + p.T)

    def reset_vertical(self, alt_m: float | None, sigma_alt_m: float, vrate: float | None, sigma_vrate: float):
        """Restart the vertical axis (a datum change makes the old altitude meaningless)."""
        for i, j in ((2, 3), (2, 4), (5, 3), (5, 4), (2, 0), (2, 1), (5, 0), (5, 1)):
            self.p[i, j] = self.p[j, i] = 0.0
        self.p[2, 5] = self.p[5, 2] = 0.0
        self.x[2] = 0.0 if alt_m is None else alt_m
        self.x[5] = 0.0 if vrate is None else vrate
        self.p[2, 2] = sigma_alt_m**2
        self.p[5, 5] = sigma_vrate**2
