"""NASA DAIDALUS's floating-point comparisons (gov.nasa.larcfm.Util.Util, Java v2.0.4), vectorised over numpy arrays.

DAIDALUS decides every tie of its detectors and bands with these, not with `<` and `<=`: two numbers are equal when
they are within PRECISION13 = 16348 units in the last place (about 13 significant digits; Util.almost_equals), and,
as a special case, when one of them is exactly 0 and both are below 1e-13 in magnitude (there is no relative
precision at zero). From it: almost_less(a, b) = a < b and not almost equal; almost_leq(a, b) = a <= b or almost
equal; almost_greater and almost_geq likewise. A separation equal to a threshold to 1e-12 m is therefore on the
threshold for DAIDALUS (a conflict that begins and ends at the same instant is none: LossData.conflict is
almost_less(time_in, time_out)); ADS-B barometric altitude comes in 25 ft steps, so such ties happen on real data.

NaN is almost equal to nothing; infinities are almost equal only to themselves.
"""

from __future__ import annotations

import math
import struct

import numpy as np

from avionics.base import jit

kernels = jit.lazy(__name__, "avionics.base.kernels")  # the module, once jit.load() ran (jit.py)

PRECISION13 = 16348  # Util.PRECISION13 = PRECISION_DEFAULT: the ULP distance that counts as equal (~13 digits)
PRECISION9 = 1 << 27  # Util.PRECISION9 (~9 digits)
PRECISION7 = 1 << 34  # Util.PRECISION7 (~7 digits)
PRECISION5 = 1 << 40  # Util.PRECISION5 (~5 digits; DaidalusParameters.ALMOST_, the bands' comparisons)
# Util.almost_equals' bound for the zero special case at each precision
ZERO_COMPARISON = {PRECISION13: 1e-13, PRECISION9: 1e-9, PRECISION7: 1e-7, PRECISION5: 1e-5}

_SIGN_FLIP = np.int64(-(2**63))  # 0x8000000000000000: makes negative doubles' bit patterns ordered


def _ordered(x: np.ndarray) -> np.ndarray:
    """The bit pattern of each double as an integer ordered like the doubles (Util.almost_equals)."""
    bits = np.array(x, dtype=np.float64, order="C").view(np.int64)  # a copy: contiguous, same shape
    with np.errstate(over="ignore"):
        return np.where(bits < 0, _SIGN_FLIP - bits, bits)


_SCALARS = frozenset((float, int, np.float64))
_INT64_OF_DOUBLE = struct.Struct("<q")
_DOUBLE = struct.Struct("<d")


def _ordered_scalar(x: float) -> int:
    """_ordered for one double, as a Python int."""
    bits = _INT64_OF_DOUBLE.unpack(_DOUBLE.pack(x))[0]
    return -(2**63) - bits if bits < 0 else bits


def _almost_equals_scalar(a: float, b: float, precision: int) -> bool:
    """almost_equals for two numbers on Python floats: the array arithmetic without a dozen numpy calls (one
    comparison of the alerter's reference or the bands costs a microsecond, not 40). Exact integers: the array
    path's int64 wrap never makes two far-apart doubles equal (below), so no case differs."""
    comp = ZERO_COMPARISON.get(precision, 1e-13)
    if a == b or ((a == 0.0 or b == 0.0) and abs(a) < comp and abs(b) < comp):
        return True
    return math.isfinite(a) and math.isfinite(b) and abs(_ordered_scalar(a) - _ordered_scalar(b)) <= precision


def _flat_pair(a, b) -> tuple[np.ndarray, np.ndarray, tuple]:
    """a and b as the kernels take them (one C-contiguous, writable dimension each: numba types a read-only array
    apart), a one-element side kept as one element, and the shape of the result."""
    shape = np.broadcast_shapes(a.shape, b.shape)

    def flat(x):
        x = np.ravel(x) if x.shape == shape or x.size == 1 else np.ravel(np.broadcast_to(x, shape))
        return x if x.flags.writeable else x.copy()

    return flat(a), flat(b), shape


def almost_equals(a, b, precision: int = PRECISION13) -> np.ndarray | bool:
    """Util.almost_equals(a, b, maxUlps): equal, or the zero special case, or within `precision` ULPs."""
    if type(a) in _SCALARS and type(b) in _SCALARS:
        return _almost_equals_scalar(float(a), float(b), precision)
    a, b = np.asarray(a, np.float64), np.asarray(b, np.float64)
    comp = ZERO_COMPARISON.get(precision, 1e-13)
    if (a.ndim or b.ndim) and jit.ready():  # the compiled loop (base/kernels.py), element for element the below
        fa, fb, shape = _flat_pair(a, b)
        return kernels.almost_flat(fa, fb, precision, comp, False).reshape(shape)
    zero_case = ((a == 0.0) | (b == 0.0)) & (np.abs(a) < comp) & (np.abs(b) < comp)
    finite = np.isfinite(a) & np.isfinite(b)
    with np.errstate(over="ignore"):
        diff = np.abs(_ordered(a) - _ordered(b))  # int64 wrap only between far-apart doubles: never <= 16348
    # a wrap (two far-apart values) leaves |diff| >= 2^53 or negative (np.abs(INT64_MIN)): never counted equal
    out = (a == b) | zero_case | (finite & (diff >= 0) & (diff <= precision))
    return out if out.ndim else bool(out)


def almost_less(a, b, precision: int = PRECISION13):
    """Util.almost_less: a < b and not almost equal."""
    if type(a) in _SCALARS and type(b) in _SCALARS:
        a, b = float(a), float(b)
        return np.bool_(a < b and not _almost_equals_scalar(a, b, precision))
    if (np.ndim(a) or np.ndim(b)) and jit.ready():  # the compiled loop (base/kernels.py almost_flat)
        fa, fb, shape = _flat_pair(np.asarray(a, np.float64), np.asarray(b, np.float64))
        return kernels.almost_flat(fa, fb, precision, ZERO_COMPARISON.get(precision, 1e-13), True).reshape(shape)
    return np.logical_and(np.less(a, b), np.logical_not(almost_equals(a, b, precision)))


def almost_greater(a, b, precision: int = PRECISION13):
    """Util.almost_greater: a > b and not almost equal."""
    if type(a) in _SCALARS and type(b) in _SCALARS:
        a, b = float(a), float(b)
        return np.bool_(a > b and not _almost_equals_scalar(a, b, precision))
    return np.logical_and(np.greater(a, b), np.logical_not(almost_equals(a, b, precision)))


def almost_leq(a, b, precision: int = PRECISION13):
    """Util.almost_leq: a <= b or almost equal."""
    if type(a) in _SCALARS and type(b) in _SCALARS:
        a, b = float(a), float(b)
        return np.bool_(a <= b or _almost_equals_scalar(a, b, precision))
    return np.logical_or(np.less_equal(a, b), almost_equals(a, b, precision))


def almost_geq(a, b, precision: int = PRECISION13):
    """Util.almost_geq: a >= b or almost equal."""
    if type(a) in _SCALARS and type(b) in _SCALARS:
        a, b = float(a), float(b)
        return np.bool_(a >= b or _almost_equals_scalar(a, b, precision))
    return np.logical_or(np.greater_equal(a, b), almost_equals(a, b, precision))
