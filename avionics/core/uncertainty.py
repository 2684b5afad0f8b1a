"""What the surveillance states about its own error: NASA DAIDALUS's SUMData (Java v2.0.4,
gov.nasa.larcfm.ACCoRD.SUMData), one aircraft's 1-sigma uncertainties, carried by the core's inputs
(IntruderReport.uncertainty, OwnshipFix.uncertainty) to the sensor-uncertainty-mitigation detector
(advisory/wcv_sum.py WCV_TAUMOD_SUM)."""

from __future__ import annotations

import math
from dataclasses import dataclass

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
