"""Compiled kernels: numba's `njit`, cached on disk, behind one switch.

Every compiled kernel has a numpy reference beside it (the code that was there before); tests check that they
agree to 1e-9 on random inputs. `kernel` compiles with numba when it is importable and compiled kernels are on
(`AVIONICS_COMPILED=0` in the environment turns them off, e.g. to A/B against the reference); otherwise the
decorated function stays plain Python and callers use the numpy reference.

Kernels are cached on disk (numba `cache=True`) so that a restart does not compile them again. Where: the
environment's NUMBA_CACHE_DIR if set, else AVIONICS_CACHE_DIR, else numba's default (`__pycache__` beside the
module, or a user cache directory when that is not writable). `avionics warmup` compiles every kernel once
after install.
"""

from __future__ import annotations

import os

_ENABLED_ENV = "AVIONICS_COMPILED"
_CACHE_ENV = "AVIONICS_CACHE_DIR"


def _numba():
    if os.environ.get(_ENABLED_ENV, "1").strip().lower() in ("0", "false", "no", "off"):
        return None
    if _CACHE_ENV in os.environ and "NUMBA_CACHE_DIR" not in os.environ:
        os.environ["NUMBA_CACHE_DIR"] = os.environ[_CACHE_ENV]  # read by numba when it is imported
    try:
        import numba
    except ImportError:  # pragma: no cover  (numba is a dependency; a platform without wheels runs the reference)
        return None
    return numba


_NUMBA = _numba()
ENABLED = _NUMBA is not None
KERNELS: list = []  # every compiled kernel, for `avionics warmup` and the tests


def kernel(*signatures):
    """Decorator: numba.njit(signatures, cache=True) of the function when compiled kernels are on, the function
    itself otherwise. With explicit signatures numba compiles (or loads from its cache) when the module is
    imported, never in the middle of a step; `avionics warmup` only has to import the kernel modules."""

    def wrap(fn):
        if not ENABLED:
            return fn
        compiled = _NUMBA.njit(list(signatures) or None, cache=True, nogil=True)(fn)
        KERNELS.append(compiled)
        return compiled

    return wrap


# Every module that defines kernels, for `avionics warmup` (and so for the README's install command, which runs it
# so that the pytest-xdist workers and the first `avionics run` find a warm cache): add yours here.
KERNEL_MODULES: list[str] = [
    "avionics.conflict.kernels",
    "avionics.tracking.kernels",
]


def warmup() -> list[dict]:
    """Import every module of KERNEL_MODULES: each kernel compiles, or loads from the disk cache, at import. Returns
    one record per kernel: name, signatures, 'compiled' or 'cached' (numba's cache counters), cache directory."""
    import importlib

    for name in KERNEL_MODULES:
        importlib.import_module(name)
    out = []
    for k in KERNELS:
        cache = getattr(k, "_cache", None)
        out.append({
            "kernel": f"{k.py_func.__module__}.{k.py_func.__name__}",
            "signatures": [str(s) for s in k.signatures],
            "state": "compiled" if sum(k._cache_misses.values()) else "cached",
            "cache_dir": getattr(cache, "_cache_path", None),
        })
    return out
