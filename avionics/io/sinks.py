"""Output sinks that fail alone: a logging option must never switch off collision avoidance (issue 25).

A sink is where the process writes besides its decisions: the record (`--tlog-out`), the advisory CSV (`--csv`),
the zenoh publication and the MAVLink endpoint. When one cannot be written (a full disk, EIO, a dead serial
port, a closed zenoh session) its error is counted `sink.<name>.errors`, announced once (a WARNING line on
stderr here; STATUSTEXT by ports.MavlinkOut; the zenoh status's `output_faults` and `warnings` by
ports.ZenohOut), and the sink is closed (a file: a record cut in the middle would corrupt everything written
after it, so nothing more is appended; the writes refused after that are counted `sink.<name>.dropped`) or
retried with its next write (the links). The DAA loop goes on, and a clean stop stays exit 0
(docs/architecture.md, "Failure states").
"""

from __future__ import annotations

import errno
import logging
from collections import Counter
from dataclasses import dataclass

# a warning is one line the monitor accepts (at most 256 characters, no control characters): as a feed's
from avionics.io.feeds.source import WARNING_ERROR_CHARS, _one_line

log = logging.getLogger("avionics.sinks")


def error_code(exc: BaseException) -> str:
    """The errno's name ("ENOSPC", "EIO"), else the exception's class name: short enough for a STATUSTEXT."""
    code = getattr(exc, "errno", None)
    return errno.errorcode.get(code, type(exc).__name__) if isinstance(code, int) else type(exc).__name__


@dataclass(slots=True)
class SinkFault:
    sink: str  # tlog | csv | zenoh | mavlink
    code: str  # of the first error (error_code)
    reason: str  # the first error's text
    closed: bool  # closed for good (a file), else retried with each write (a link)
    errors: int = 1

    @property
    def state(self) -> str:
        return "closed" if self.closed else "retrying"

    def as_dict(self) -> dict:
        return {"state": self.state, "error": f"{self.code} {self.reason}", "errors": self.errors}

    def warning(self) -> str:
        """The stderr line and the status warning."""
        then = "closed, nothing more is written" if self.closed else "retried with each write"
        return f"output {self.sink} failed ({self.code} {self.reason}): {then}; the DAA goes on"


class SinkHealth:
    """The faults of the process's output sinks, one record per sink from its first failure on, in the order
    they failed, so that each announcer (a port) sends every new one once (`since`)."""

    def __init__(self, counters: Counter):
        self.counters = counters
        self.faults: dict[str, SinkFault] = {}
        self.order: list[SinkFault] = []

    def failed(self, sink: str, exc: BaseException, closed: bool, errors: int = 1) -> None:
        """errors: how many writes failed (a publisher thread reports its failures in batches)."""
        self.counters[f"sink.{sink}.errors"] += errors
        fault = self.faults.get(sink)
        if fault is not None:
            fault.errors += errors
            return
        reason = _one_line(getattr(exc, "strerror", None) or str(exc) or type(exc).__name__, WARNING_ERROR_CHARS)
        fault = self.faults[sink] = SinkFault(sink, error_code(exc), reason, closed, errors)
        self.order.append(fault)
        log.warning("%s", fault.warning())

    def dropped(self, sink: str) -> None:
        """A write to a sink after it closed: lost, counted (what its buffer held when it failed is lost too)."""
        self.counters[f"sink.{sink}.dropped"] += 1

    def since(self, seen: int) -> list[SinkFault]:
        """The faults after the first `seen` (an announcer keeps its own count)."""
        return self.order[seen:]

    def as_dict(self) -> dict:
        return {fault.sink: fault.as_dict() for fault in self.order}

    def warnings(self) -> list[str]:
        return [fault.warning() for fault in self.order]


class FileSink:
    """A file the process writes (the tlog record, the CSV), which never raises: its first OSError closes it
    (SinkHealth.failed, closed) and every write after that is dropped and counted. flush() pushes what is
    buffered to the disk now, so that a failure is seen when it happens, not at exit."""

    def __init__(self, name: str, path, mode: str, health: SinkHealth, **kw):
        self.name, self.health = name, health
        self._file = open(path, mode, **kw)  # checked writable before (cli.check_output_file: exit 2)

    @property
    def closed(self) -> bool:
        return self._file is None

    def write(self, data) -> None:
        if self._file is None:
            self.health.dropped(self.name)
        else:
            self._call("write", data)

    def flush(self) -> None:
        self._call("flush")

    def close(self) -> None:
        self._call("close")  # a failed flush in it still releases the descriptor
        self._file = None

    def _call(self, method: str, *args) -> None:
        if self._file is None:
            return
        try:
            getattr(self._file, method)(*args)
        except OSError as exc:
            f, self._file = self._file, None
            try:
                f.close()  # the file object's own buffer is lost with it: it cannot be written
            except OSError:
                pass
            self.health.failed(self.name, exc, closed=True)
