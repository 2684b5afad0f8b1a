"""What an ImmBank needs of the compiled IMM kernels (tracking/kernels.py) before any kernel runs: the mode codes,
BankSpec (a configuration as the kernels' arrays, and whether they cover it) and `arr`. Kept apart from the
kernels so that building a tracker imports neither numba nor the kernels (avionics.base.jit loads them later,
issue 13 item 5)."""

from __future__ import annotations

import numpy as np

from avionics.tracking import models

# mode codes
CV, CA, CA_ISO, CT, CH, CAD = 0, 1, 2, 3, 4, 5


def mode_code(mode) -> tuple[int, float] | None:
    """(code, noise parameter) of a models.MotionModel the kernels cover, else None."""
    if isinstance(mode, models.ConstantVelocity):
        return CV, mode.sigma_mps2
    if isinstance(mode, models.ConstantAcceleration):
        return (CA if mode.heading_noise else CA_ISO), mode.sigma_mps2
    if isinstance(mode, models.CoordinatedTurn):
        return CT, mode.sigma_mps2
    if isinstance(mode, models.ConstantHeight):
        return CH, mode.sigma_mps
    if isinstance(mode, models.ConstantAltitudeChange):
        return CAD, mode.sigma_mps2
    return None


def arr(a, dtype=float) -> np.ndarray:
    """a as a writable C-contiguous array of dtype (a kernel's explicit signature takes no read-only or strided
    views, e.g. of np.broadcast_to); no copy when it already is one."""
    return np.require(a, dtype, ("C", "W"))


class BankSpec:
    """What a kernel needs of an ImmBank's configuration, as arrays: mode codes and noise parameters, the Markov
    chain's eigendecomposition. `covered` is False when a mode, the likelihood or VB is not compiled."""

    def __init__(self, modes, chain: models.MarkovChain, likelihood: str = "standard", vb=None):
        codes = [mode_code(m) for m in modes]
        self.covered = likelihood == "standard" and vb is None and all(c is not None for c in codes)
        self.codes = np.array([c[0] if c else -1 for c in codes], np.int64)
        self.sigma = np.array([c[1] if c else 0.0 for c in codes], float)
        self.v = np.ascontiguousarray(chain._v, float)
        self.vinv = np.ascontiguousarray(chain._vinv, float)
        self.lam = np.ascontiguousarray(chain._lam, float)
        self.turn_mode = next((i for i, m in enumerate(modes) if m.estimates_turn), -1)
