"""Compiled kernels of the base layer: DAIDALUS's Util.almost_equals and almost_less (base/almost.py, the numpy
reference).

The guidance bands compare arrays of a few hundred samples at a time, tens of thousands of times an encounter; the
reference's dozen numpy calls cost ~40 us a call whatever the size. The same arithmetic, element for element, in
one loop: the ordered bit patterns in int64, whose wrap between far-apart doubles is the reference's too
(tests/test_ties.py holds every decision identical).
"""

from __future__ import annotations

import math

import numpy as np

from avionics.base.jit import kernel

SIGN_FLIP = -(2**63)  # = base/almost.py _SIGN_FLIP


@kernel("int64(float64)")
def ordered(x):
    """The bit pattern of x as an integer ordered like the doubles (base/almost.py _ordered)."""
    bits = np.float64(x).view(np.int64)
    return SIGN_FLIP - bits if bits < 0 else bits


@kernel("boolean(float64, float64, int64, float64)")
def almost_equals_one(a, b, precision, zero):
    """Util.almost_equals(a, b, precision): equal, or the zero special case (both below `zero`, one exactly 0),
    or within `precision` ULPs."""
    if a == b:
        return True
    if (a == 0.0 or b == 0.0) and abs(a) < zero and abs(b) < zero:
        return True
    if not (math.isfinite(a) and math.isfinite(b)):
        return False
    diff = abs(ordered(a) - ordered(b))  # wraps like the reference's int64: never counted equal then
    return 0 <= diff <= precision


@kernel("boolean[::1](float64[::1], float64[::1], int64, float64, boolean)")
def almost_flat(a, b, precision, zero, less):
    """Every element pair of a and b (a one-element side against every element of the other): almost_equals_one,
    or with less Util.almost_less (a < b and not almost equal)."""
    n = a.shape[0] if b.shape[0] == 1 else b.shape[0]  # (0,) against one element: none
    out = np.empty(n, np.bool_)
    one_a, one_b = a.shape[0] != n, b.shape[0] != n
    for i in range(n):
        x, y = a[0] if one_a else a[i], b[0] if one_b else b[i]
        equal = almost_equals_one(x, y, precision, zero)
        out[i] = (x < y and not equal) if less else equal
    return out
