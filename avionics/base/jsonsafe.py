"""JSON without inf/NaN: the one cleaner behind the zenoh payloads (io/zenoh_bus.py) and the monitor's page and
API (monitor/web.py). JSON has no inf or NaN, so a non-finite float (an infinite tau, a NaN VMD) is null."""

from __future__ import annotations

import json
import math


def finite_or_null(value):
    """`value` with every non-finite float, at any depth of dicts, lists and tuples, replaced by None."""
    if isinstance(value, float) and not math.isfinite(value):
        return None
    if isinstance(value, dict):
        return {k: finite_or_null(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [finite_or_null(v) for v in value]
    return value


def dumps(obj) -> str:
    """Compact JSON of `obj`, inf/NaN as null."""
    try:  # the C encoder alone when every float is finite (most payloads)
        return json.dumps(obj, separators=(",", ":"), allow_nan=False)
    except ValueError:
        return json.dumps(finite_or_null(obj), separators=(",", ":"), allow_nan=False)
