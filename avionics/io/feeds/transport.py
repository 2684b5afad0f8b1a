"""Byte transports of the feeds, run on a feed's thread (source.py): a TCP stream (SBS, Beast) and a polled
document (readsb aircraft.json from a file or an http:// URL). Each returns or raises when its source fails, and
checks ctx.stop at least every READ_TIMEOUT_S."""

from __future__ import annotations

import socket
import urllib.request
from typing import Iterator

CONNECT_TIMEOUT_S = 2.0  # a refused loopback connection fails at once; an unreachable host costs this
READ_TIMEOUT_S = 0.25  # how often a quiet stream looks at ctx.stop (shutdown joins the thread within this)
RECV_BYTES = 65536
MAX_DOCUMENT_BYTES = 64 * 1024 * 1024  # readsb's aircraft.json is ~0.5 kB per aircraft: 1000 aircraft ~ 0.5 MB


def tcp_chunks(host: str, port: int, ctx) -> Iterator[tuple[bytes, float]]:
    """(bytes, loop time of receipt) from a TCP connection until the server closes it (ConnectionError) or ctx.stop
    is set (returns). Calls ctx.connected() once connected. TCP keepalive finds a peer that vanished silently."""
    with socket.create_connection((host, port), timeout=CONNECT_TIMEOUT_S) as sock:
        sock.setsockopt(socket.SOL_SOCKET, socket.SO_KEEPALIVE, 1)
        sock.settimeout(READ_TIMEOUT_S)
        ctx.connected()
        while not ctx.stop.is_set():
            try:
                chunk = sock.recv(RECV_BYTES)
            except (socket.timeout, TimeoutError):
                continue
            if not chunk:
                raise ConnectionError("closed by the source")
            yield chunk, ctx.clock()


class LineSplitter:
    """Bytes -> complete lines (without the line end). A partial line waits for the next chunk; a line longer
    than max_bytes is dropped up to its end (counted by the caller: `too_long` is set for each)."""

    def __init__(self, max_bytes: int):
        self.max_bytes = max_bytes
        self._buffer = b""
        self._skipping = False
        self.too_long = 0

    def feed(self, chunk: bytes) -> list[bytes]:
        data = self._buffer + chunk
        lines = data.split(b"\n")
        self._buffer = lines.pop()
        out = []
        for line in lines:
            if self._skipping:  # the end of an over-long line
                self._skipping = False
                continue
            if len(line) > self.max_bytes:
                self.too_long += 1
                continue
            out.append(line.rstrip(b"\r"))
        if len(self._buffer) > self.max_bytes:
            self._buffer = b""
            if not self._skipping:
                self.too_long += 1
            self._skipping = True
        return out


def read_document(target: str, timeout_s: float) -> bytes:
    """The whole document at target: an http:// or https:// URL (GET), else a file path. Raises OSError (also
    urllib's URLError / HTTPError) when it cannot be read."""
    if target.startswith(("http://", "https://")):
        with urllib.request.urlopen(target, timeout=timeout_s) as response:  # noqa: S310  (the user's URL)
            data = response.read(MAX_DOCUMENT_BYTES + 1)
    else:
        with open(target, "rb") as f:
            data = f.read(MAX_DOCUMENT_BYTES + 1)
    if len(data) > MAX_DOCUMENT_BYTES:
        raise ValueError(f"document larger than {MAX_DOCUMENT_BYTES} bytes")
    return data
