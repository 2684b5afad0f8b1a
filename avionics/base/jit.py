"""Compiled kernels: numba's `njit`, cached on disk, behind one switch.

Every compiled kernel has a numpy reference beside it (the code that was there before); tests check that they
agree to 1e-9 on random inputs. `kernel` compiles with numba when it is importable and compiled kernels are on
(`AVIONICS_COMPILED=0` in the environment turns them off, e.g. to A/B against the reference); otherwise the
decorated function stays plain Python and callers use the numpy reference.

Kernels are cached on disk (numba `cache=True`) so that a restart does not compile them again. Where: the
environment's NUMBA_CACHE_DIR if set, else AVIONICS_CACHE_DIR, else numba's default (`__pycache__` beside the
module, or a user cache directory when that is not writable). `avionics warmup` compiles every kernel once
after install.

When kernels load (issue 13 item 5, start-up): importing this module does not import numba (0.2-0.3 s) and no
caller imports a kernel module at its own import; they hold `lazy(...)` stand-ins instead. The kernel modules
(KERNEL_MODULES) are imported by `load()`: numba imported, every kernel loaded from the disk cache (or compiled
when the cache is cold) when its module is imported, so a kernel that calls another finds a real dispatcher.
After it the stand-ins are replaced by the modules in their holders' namespaces: a call is then a plain module
attribute.

Which path a call site takes (issue 26 item 1, "no stall, ever"): every call site asks `ready()` and runs the numpy
reference when it is False. Outside `deferred()` (a test, a replay, a benchmark, `avionics warmup`) the first
`ready()` loads the kernels, waiting for them (or compiling them on a cold cache), as before. Inside it (the live
loop, avionics/runner.py with avionics/base/kernel_startup.py) `ready()` never waits: it is False until the loop's
own thread calls `switch()` between two steps, once a background `load(cache_only=True)` found every kernel in the
disk cache. `load(cache_only=True)` never compiles: it raises ColdCache at the first kernel the cache lacks (numba's
"numba:compile" event, which numba sends only after its cache missed), so that the compile can run elsewhere (a
niced child process: numba's compile holds the GIL most of the time, docs/performance.md "A cold cache").
"""

from __future__ import annotations

import contextlib
import importlib
import importlib.util
import os
import sys
import threading

_ENABLED_ENV = "AVIONICS_COMPILED"
_CACHE_ENV = "AVIONICS_CACHE_DIR"


def _enabled() -> bool:
    """Compiled kernels are on unless switched off, when numba is installed; found without importing it."""
    if os.environ.get(_ENABLED_ENV, "1").strip().lower() in ("0", "false", "no", "off"):
        return False
    if _CACHE_ENV in os.environ and "NUMBA_CACHE_DIR" not in os.environ:
        os.environ["NUMBA_CACHE_DIR"] = os.environ[_CACHE_ENV]  # read by numba when it is imported
    # numba is a dependency; a platform without its wheels runs the reference
    return importlib.util.find_spec("numba") is not None


ENABLED = _enabled()
KERNELS: list = []  # every compiled kernel, for `avionics warmup` and the tests


def kernel(*signatures):
    """Decorator: numba.njit(signatures, cache=True) of the function when compiled kernels are on, the function
    itself otherwise. With explicit signatures numba compiles (or loads from its cache) when the module is
    imported, never in the middle of a step: kernel modules are imported by `load()` only."""

    def wrap(fn):
        if not ENABLED:
            return fn
        import numba

        compiled = numba.njit(list(signatures) or None, cache=True, nogil=True)(fn)
        KERNELS.append(compiled)
        return compiled

    return wrap


# Every module that defines kernels, for `avionics warmup` (and so for the README's install command, which runs it
# so that the pytest-xdist workers and the first `avionics run` find a warm cache): add yours here.
KERNEL_MODULES: list[str] = [
    "avionics.base.kernels",
    "avionics.conflict.kernels",
    "avionics.tracking.kernels",
    "avionics.advisory.kernels",
]


_lock = threading.Lock()
_loaded = threading.Event()
_LAZY: list = []  # (holder module name, attribute, kernel module name) of every stand-in
_thread: threading.Thread | None = None
_ready = False  # the call sites run the compiled kernels (ready())
_deferred = 0  # depth of deferred(): ready() does not wait for a load


class ColdCache(Exception):
    """load(cache_only=True): a kernel is not in the disk cache (or its source changed since it was cached)."""


class _Lazy:
    """Stands for a kernel module in the namespace of the module that uses it (`kernels = jit.lazy(...)`) until
    `load()` replaces it there by the module: the first attribute asked of it loads every kernel module."""

    def __init__(self, name: str):
        self._name = name

    def __getattr__(self, attr):
        load()
        return getattr(sys.modules[self._name], attr)

    def __repr__(self) -> str:
        return f"<kernel module {self._name}, not loaded yet>"


def lazy(holder: str, name: str, attr: str = "kernels") -> _Lazy:
    """The stand-in for kernel module `name`, held as `attr` by module `holder` (its __name__)."""
    assert name in KERNEL_MODULES, name
    _LAZY.append((holder, attr, name))
    return _Lazy(name)


def loaded() -> bool:
    """True once every kernel module is imported (its kernels loaded or compiled)."""
    return _loaded.is_set()


def ready() -> bool:
    """True: call the compiled kernels; False: the numpy reference. Off (AVIONICS_COMPILED=0, no numba): False.
    Outside `deferred()` the first call loads the kernels (waits, or compiles on a cold cache) and is True; inside
    it, False until `switch()`. Cheap: one global read once True."""
    global _ready
    if _ready:
        return True
    if not ENABLED or _deferred:
        return False
    load()
    _ready = True
    return True


def switch() -> bool:
    """Inside `deferred()`, on the loop's thread between two steps: the compiled kernels from now on, if they are
    loaded. Returns ready()'s new value (False while they are not loaded)."""
    global _ready
    if not _ready and ENABLED and _loaded.is_set():
        _ready = True
    return _ready


@contextlib.contextmanager
def deferred():
    """The live loop's scope: ready() never waits for a load (it stays False until switch()). On exit, the next
    ready() outside any deferred() loads (or waits for the load still running) as before."""
    global _deferred
    _deferred += 1
    try:
        yield
    finally:
        _deferred -= 1


@contextlib.contextmanager
def reference():
    """The numpy reference at every call site while inside (tests and benchmarks A/B both paths in one process);
    `switch()` inside it switches until its end. Not for the live loop, which uses `deferred()`."""
    global _ready
    was = _ready
    _ready = False
    try:
        with deferred():
            yield
    finally:
        _ready = was


class _NoCompile:
    """A numba event listener (numba.core.event) that stops the compile of a kernel on the loading thread: numba
    sends "numba:compile" only once its disk cache missed (numba/core/dispatcher.py, Dispatcher.compile)."""

    def __init__(self):
        import numba.core.event as ev

        class Listener(ev.Listener):
            def on_start(inner, event):  # noqa: N805
                if threading.get_ident() == self.thread:
                    raise ColdCache(f"{event.data['dispatcher'].py_func.__qualname__} is not in the kernel cache")

            def on_end(inner, event):  # noqa: N805
                pass

        self.thread = threading.get_ident()
        self._ev = ev
        self.listener = Listener()

    def __enter__(self):
        self._ev.register("numba:compile", self.listener)
        return self

    def __exit__(self, *exc):
        self._ev.unregister("numba:compile", self.listener)


def load(cache_only: bool = False) -> None:
    """Import every module of KERNEL_MODULES (once; a second caller waits for the first), then put the modules in
    place of their stand-ins. Cheap once done: one Event check. cache_only: load every kernel from the disk cache
    or raise ColdCache (nothing is loaded then; a later load() imports the modules that failed again)."""
    if _loaded.is_set():
        return
    with _lock:
        if _loaded.is_set():
            return
        guard = _NoCompile() if cache_only and ENABLED else contextlib.nullcontext()
        try:
            with guard:
                modules = {name: importlib.import_module(name) for name in KERNEL_MODULES}
        except BaseException:
            # a module whose import failed is gone from sys.modules (imported again next time): so are its kernels
            KERNELS[:] = [k for k in KERNELS if k.py_func.__module__ in sys.modules]
            raise
        for holder, attr, name in _LAZY:
            owner = sys.modules.get(holder)
            if owner is not None and isinstance(getattr(owner, attr, None), _Lazy):
                setattr(owner, attr, modules[name])
        _loaded.set()


def warmup() -> list[dict]:
    """Import every module of KERNEL_MODULES: each kernel compiles, or loads from the disk cache, at import. Returns
    one record per kernel: name, signatures, 'compiled' or 'cached' (numba's cache counters), cache directory."""
    load()
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
