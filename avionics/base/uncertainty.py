"""What the surveillance states about its own error: NASA DAIDALUS's SUMData (Java v2.0.4,
gov.nasa.larcfm.ACCoRD.SUMData), one aircraft's 1-sigma uncertainties, carried by the core's inputs
(IntruderReport.uncertainty, OwnshipFix.uncertainty) to the sensor-uncertainty-mitigation detector
(advisory/wcv_sum.py WCV_TAUMOD_SUM)."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

UNCERTAINTY_FIELDS = ("s_ew_std_m", "s_ns_std_m", "s_en_std_m", "sz_std_m",
                      "v_ew_std_mps", "v_ns_std_mps", "v_en_std_mps", "vz_std_mps")


def horizontal_uncertainty(x_std: float, y_std: float, xy_std: float) -> float:
    """SUMData.horizontal_uncertainty: sqrt of the larger eigenvalue of [[x^2, c], [c, y^2]], c = sign(xy) xy^2
    (Util.sign: +1 at 0); sqrt_safe of a negative gives 0."""
    var1, var2 = x_std * x_std, y_std * y_std
    cov = (1.0 if xy_std >= 0.0 else -1.0) * xy_std * xy_std
    ave = (var1 + var2) / 2.0
    det = var1 * var2 - cov * cov
    return math.sqrt(max(ave + math.sqrt(max(ave * ave - det, 0.0)), 0.0))


@dataclass(frozen=True, slots=True)
class SumData:
    """One aircraft's stated uncertainties (DAIDALUS SUMData), 1 sigma, SI units, East/North/Up axes. All zero:
    no uncertainty (the default: SUM then changes nothing)."""

    s_ew_std_m: float = 0.0
    s_ns_std_m: float = 0.0
    s_en_std_m: float = 0.0
    sz_std_m: float = 0.0
    v_ew_std_mps: float = 0.0
    v_ns_std_mps: float = 0.0
    v_en_std_mps: float = 0.0
    vz_std_mps: float = 0.0

    def __post_init__(self):
        for name in UNCERTAINTY_FIELDS:
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and math.isfinite(value)):
                raise ValueError(f"uncertainty {name} must be a finite number, got {value!r}")
            if name not in ("s_en_std_m", "v_en_std_mps") and value < 0.0:
                raise ValueError(f"uncertainty {name} must be >= 0, got {value!r}")

    def errors(self) -> tuple[float, float, float, float]:
        """(horizontal position, vertical position, horizontal speed, vertical speed) errors before z-scores
        (SUMData.getHorizontalPositionError, getVerticalPositionError, getHorizontalSpeedError,
        getVerticalSpeedError)."""
        return (horizontal_uncertainty(self.s_ew_std_m, self.s_ns_std_m, self.s_en_std_m), self.sz_std_m,
                horizontal_uncertainty(self.v_ew_std_mps, self.v_ns_std_mps, self.v_en_std_mps), self.vz_std_mps)


NO_UNCERTAINTY = SumData()


NO_ERRORS = (0.0, 0.0, 0.0, 0.0)


def errors_from_covariance(p) -> np.ndarray:
    """(..., 4) SumData.errors of tracks from their state covariances (..., 6, 6), state order east, north, up,
    v_east, v_north, v_up (m, m/s; the tracking frame's ENU axes, DAIDALUS's too): the square roots of the
    larger eigenvalue of the horizontal position block and of the horizontal velocity block (the 1-sigma
    ellipse's semi-major axis: SUMData.horizontal_uncertainty of sigma_E = sqrt(P_ee), sigma_N = sqrt(P_nn) and
    s_EN = sign(P_en) sqrt(|P_en|), whose signed square is the covariance P_en), and the vertical sigmas
    sqrt(P_uu), sqrt(P_vu vu). A covariance is 1 sigma by definition: no 95 % bound is involved."""
    p = np.asarray(p, float)

    def major(a, b, c):
        ave = (a + b) / 2.0
        return np.sqrt(np.maximum(ave + np.sqrt(np.maximum(ave * ave - (a * b - c * c), 0.0)), 0.0))

    return np.stack([major(p[..., 0, 0], p[..., 1, 1], p[..., 0, 1]), np.sqrt(np.maximum(p[..., 2, 2], 0.0)),
                     major(p[..., 3, 3], p[..., 4, 4], p[..., 3, 4]), np.sqrt(np.maximum(p[..., 5, 5], 0.0))],
                    axis=-1)
