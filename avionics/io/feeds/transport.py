"""Byte transports of the feeds, run on a feed's thread (source.py): a TCP stream (SBS, Beast) and a polled
document (readsb aircraft.json from a file or an http:// URL). Each returns or raises when its source fails; a
stream checks ctx.stop at least every READ_TIMEOUT_S, a document read ends within its deadline."""

from __future__ import annotations

import http.client
import socket
import threading
import urllib.parse
from typing import Iterator

from avionics.io.feeds.aircraft import MAX_AIRCRAFT

CONNECT_TIMEOUT_S = 2.0  # a refused loopback connection fails at once; an unreachable host costs this
READ_TIMEOUT_S = 0.25  # how often a quiet stream looks at ctx.stop (shutdown joins the thread within this)
RECV_BYTES = 65536
# A larger aircraft.json is refused unread: readsb writes at most ~0.8 kB per aircraft (every field of its
# README-json.md, no spaces), and the merge takes at most MAX_AIRCRAFT of one source, so MAX_AIRCRAFT x 1 KiB (4.1 MB)
# holds every aircraft it would use. json.loads holds the GIL while it parses (0.1 s for 3 MB here): a 50 MB
# document stalled the loop 2.2-4.8 s and kept 290 MB (issue 25).
MAX_DOCUMENT_BYTES = MAX_AIRCRAFT * 1024


class DocumentTooLarge(ValueError):
    """A document above MAX_DOCUMENT_BYTES (refused: the session fails, the source is retried)."""


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


def read_document(target: str, timeout_s: float, deadline_s: float) -> bytes:
    """The whole document at target: an http:// or https:// URL (GET), else a file path. Raises OSError when it
    cannot be read, TimeoutError (an OSError) when an HTTP response has not completed within deadline_s of the
    request, however slowly its bytes keep coming, DocumentTooLarge (a ValueError) above MAX_DOCUMENT_BYTES."""
    if target.startswith(("http://", "https://")):
        data = _http_get(target, timeout_s, deadline_s)
    else:
        with open(target, "rb") as f:
            data = f.read(MAX_DOCUMENT_BYTES + 1)
    if len(data) > MAX_DOCUMENT_BYTES:
        raise DocumentTooLarge(f"document larger than {MAX_DOCUMENT_BYTES} bytes")
    return data


def _http_get(url: str, timeout_s: float, deadline_s: float) -> bytes:
    """GET url (no redirects: readsb and dump1090 serve aircraft.json directly). timeout_s bounds each connect or
    read, as a socket timeout; deadline_s the whole exchange: at the deadline a timer shuts the socket down, which
    ends a read that a server trickling one byte at a time would otherwise keep alive for ever."""
    parts = urllib.parse.urlsplit(url)
    if not parts.hostname:
        raise OSError(f"{url}: no host")
    kind = http.client.HTTPSConnection if parts.scheme == "https" else http.client.HTTPConnection
    connection = kind(parts.hostname, parts.port, timeout=timeout_s)
    expired = threading.Event()
    sockets: list[socket.socket] = []  # the connection's socket: http.client drops its own reference to it when the
    # response will close the connection (HTTP/1.0), while the response still reads from it

    def cut() -> None:
        expired.set()
        for sock in sockets:
            try:
                sock.shutdown(socket.SHUT_RDWR)
            except OSError:
                pass  # already closed

    timer = threading.Timer(deadline_s, cut)
    timer.daemon = True
    timer.start()
    try:
        connection.connect()  # within timeout_s; from here on the timer can cut the socket
        sockets.append(connection.sock)
        if expired.is_set():
            raise TimeoutError
        connection.request("GET", urllib.parse.urlunsplit(("", "", parts.path or "/", parts.query, "")),
                           headers={"Accept": "application/json"})
        response = connection.getresponse()
        if response.status != 200:
            raise OSError(f"HTTP {response.status} {response.reason}")
        length = response.getheader("Content-Length", "")
        if length.isascii() and length.isdigit() and (len(length) > 12 or int(length) > MAX_DOCUMENT_BYTES):
            raise DocumentTooLarge(f"document of {length} bytes, larger than {MAX_DOCUMENT_BYTES}")
        data = response.read(MAX_DOCUMENT_BYTES + 1)  # a cut or closed connection ends it short, not raising
        if expired.is_set():
            raise TimeoutError
        if response.length:  # bytes of its Content-Length that never came
            raise OSError(f"HTTP: the connection ended {response.length} bytes before the document's end")
    except (OSError, http.client.HTTPException) as exc:
        if expired.is_set():
            raise TimeoutError(f"no complete document within {deadline_s:g} s") from None
        if isinstance(exc, OSError):
            raise
        raise OSError(f"HTTP: {type(exc).__name__}: {exc}") from None  # a malformed response: the source fails
    finally:
        timer.cancel()
        connection.close()
    return data
