"""The live loop's compiled kernels, without a stall (issue 26 item 1): the loop never waits for a compile.

`avionics run` (avionics/runner.py) runs its loop inside `jit.deferred()`, where every call site takes the numpy
reference until the loop switches (avionics/base/jit.py `ready`, `switch`); the reference and the kernels agree to
1e-9 (tests/test_kernels_conflict.py, tests/test_kernels_imm.py), so the decisions are the same on either path.
After the first step, a daemon thread:

1. loads the kernels from the disk cache only (`jit.load(cache_only=True)`: numba's import and ~27 cached kernels,
   about 0.3 s); a warm cache ends here, as before this module existed;
2. on a cold cache (ColdCache: a kernel missing or stale), runs `avionics warmup` in a child process at nice
   COMPILE_NICE, which compiles into the same cache (numba's compile holds the GIL most of the time: on a thread of
   this process it would starve the loop, docs/performance.md "A cold cache"), waits for it without the GIL, and
   loads from the now warm cache (1. again);
3. an AVIONICS_CACHE_DIR that cannot be written is a warning (numba falls back to its default cache); when numba
   finds no cache it can write at all, a temporary one serves this run (a warning; removed at exit); when the
   child fails or its compile is still not found in the cache, a warning, and the reference for the run.

The loop's thread calls `after_step()` after every step: the first call starts the thread, a later one switches to
the compiled kernels between two steps once they are loaded, and says so on stderr (one line per path:
"kernels: ..."). `close()` stops a child still compiling (the next run or `avionics warmup` compiles again).
"""

from __future__ import annotations

import logging
import os
import shutil
import subprocess
import sys
import tempfile
import threading
import time

from avionics.base import jit

log = logging.getLogger("avionics")

# How much lower the compiling child runs than the loop: nice(1)'s default adjustment (GNU coreutils, `nice`
# without -n: 10). The loop's process keeps its own priority; the compile takes what the loop leaves.
COMPILE_NICE = 10
# The child: `avionics warmup` (avionics/cli.py cmd_warmup), niced by itself before numba is imported.
_CHILD = "import os, sys; os.nice({nice}); from avionics.cli import main; sys.exit(main(['--quiet', 'warmup']))"
CLOSE_JOIN_S = 5.0  # how long close() waits for the thread (it ends once the child is stopped)


class KernelStartup:
    """The kernels' path for one run of the live loop: reference first, compiled once loaded, never waiting."""

    def __init__(self, clock=time.monotonic):
        self._clock = clock
        self._start_s: float | None = None
        self._thread: threading.Thread | None = None
        self._child: subprocess.Popen | None = None
        self._closing = threading.Event()
        self.compiled_in_child = False  # the cache was cold: the child compiled (for the switch's stderr line)
        self.switched_after_s: float | None = None  # seconds from the first step to the switch
        self._temporary_cache: str | None = None  # no writable cache: one for this run, removed by close()

    def after_step(self) -> None:
        """On the loop's thread after every step: start (first call), then switch once the kernels are loaded."""
        if self._start_s is None:
            self._start()
        elif self.switched_after_s is None and jit.loaded() and jit.switch():
            self.switched_after_s = self._clock() - self._start_s
            if self.compiled_in_child:
                log.info("kernels: compiled, switched from the numpy reference after %.1f s", self.switched_after_s)
            else:
                log.info("kernels: compiled (cache warm)")

    def _start(self) -> None:
        self._start_s = self._clock()
        if not jit.ENABLED:
            log.info("kernels: numpy reference (compiled kernels off: AVIONICS_COMPILED=0 or numba missing)")
            return
        if jit.loaded():  # a second run in one process: switched at once
            jit.switch()
            self.switched_after_s = 0.0
            log.info("kernels: compiled (loaded before this run)")
            return
        self._thread = threading.Thread(target=self._load, name="avionics-kernel-load", daemon=True)
        self._thread.start()

    def _load(self) -> None:
        try:
            _warn_if_unwritable(os.environ.get("NUMBA_CACHE_DIR"))
            try:
                try:
                    jit.load(cache_only=True)
                    return
                except RuntimeError as exc:  # numba found no cache directory it can write: one for this run
                    if "cannot cache" not in str(exc):
                        raise
                    self._temporary_cache = tempfile.mkdtemp(prefix="avionics-kernels-")
                    log.warning("kernels: no writable kernel cache (numba: %s): compiling into %s for this run "
                                "(set AVIONICS_CACHE_DIR to a writable directory and run `avionics warmup`)",
                                _one_line(exc), self._temporary_cache)
                    _use_cache_dir(self._temporary_cache)
                    jit.load(cache_only=True)
                    return
            except jit.ColdCache as cold:
                log.info("kernels: numpy reference while compiling in the background (%s; a child process at "
                         "nice %d runs `avionics warmup`)", cold, COMPILE_NICE)
            self.compiled_in_child = True
            if not self._compile_in_child():
                return
            try:
                jit.load(cache_only=True)
            except jit.ColdCache as cold:
                log.warning("kernels: numpy reference for this run: the background compile did not reach the kernel "
                            "cache (%s; is AVIONICS_CACHE_DIR writable?)", cold)
        except Exception as exc:  # noqa: BLE001  (no usable cache, a broken install: the reference still decides)
            log.warning("kernels: numpy reference for this run: the compiled kernels cannot load (%s: %s)",
                        type(exc).__name__, _one_line(exc))

    def _compile_in_child(self) -> bool:
        """`avionics warmup` in a niced child process; True when it compiled. Its failure is a warning."""
        try:
            self._child = subprocess.Popen([sys.executable, "-c", _CHILD.format(nice=COMPILE_NICE)],
                                           stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL,
                                           stderr=subprocess.PIPE, text=True, errors="replace")
        except OSError as exc:
            log.warning("kernels: numpy reference for this run: the background compile cannot start (%s)", exc)
            return False
        if self._closing.is_set():  # close() ran while the child started
            self._child.terminate()
        _, err = self._child.communicate()  # waits without the GIL
        if self._child.returncode != 0:
            if not self._closing.is_set():
                log.warning("kernels: numpy reference for this run: the background compile failed (exit %s: %s)",
                            self._child.returncode, _one_line(err) or "no message")
            return False
        return True

    def close(self) -> None:
        """Stop a compile still running; wait briefly for the thread (it may be loading from the cache); remove a
        temporary cache (the loaded kernels are in memory)."""
        self._closing.set()
        child = self._child
        if child is not None and child.poll() is None:
            child.terminate()
        if self._thread is not None:
            self._thread.join(CLOSE_JOIN_S)
        if self._temporary_cache is not None and (self._thread is None or not self._thread.is_alive()):
            shutil.rmtree(self._temporary_cache, ignore_errors=True)


def _warn_if_unwritable(cache_dir: str | None) -> None:
    """AVIONICS_CACHE_DIR (or NUMBA_CACHE_DIR, which wins) that numba cannot write: a warning; numba then uses its
    default cache (`__pycache__` beside the modules, else the user's cache directory; numba/core/caching.py,
    _CacheLocator.ensure_cache_path: the same test)."""
    if not cache_dir:
        return
    try:
        os.makedirs(cache_dir, exist_ok=True)
        tempfile.TemporaryFile(dir=cache_dir).close()
    except OSError as exc:
        variable = "AVIONICS_CACHE_DIR" if os.environ.get("AVIONICS_CACHE_DIR") == cache_dir else "NUMBA_CACHE_DIR"
        log.warning("kernels: the kernel cache %s (%s) is not writable (%s): numba uses its default cache instead "
                    "(__pycache__ beside the modules, else the user's cache directory)",
                    cache_dir, variable, exc.strerror or exc)


def _use_cache_dir(cache_dir: str) -> None:
    """The kernel cache for this process (numba reads config.CACHE_DIR when it caches a function) and its child."""
    os.environ["NUMBA_CACHE_DIR"] = cache_dir
    import numba.core.config

    numba.core.config.CACHE_DIR = cache_dir


def _one_line(text) -> str:
    """The last non-empty line of an error (a child's stderr ends with the exception's own line)."""
    lines = [line.strip() for line in str(text).splitlines() if line.strip()]
    return lines[-1] if lines else ""
