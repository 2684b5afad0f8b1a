"""A MAVLink link from any pymavlink connection string, with robust framing and an optional .tlog record.

pymavlink supplies the transports (udpin/udpout/tcp/tcpin/serial/.tlog); frames are extracted by our
FrameScanner (per datagram on UDP, as a stream on TCP and serial) so that garbage never costs valid frames.
"""

from __future__ import annotations

import select
import struct
import time
from collections import Counter
from pathlib import Path

import avionics.io  # noqa: F401  (sets MAVLINK20 before pymavlink is imported)
from pymavlink import mavutil
from pymavlink.dialects.v20 import common as mavlink2

from avionics.io.framing import FrameScanner

READ_CHUNK = 65536


class LinkError(RuntimeError):
    """The connection string cannot be opened, with pymavlink's reason."""


class MavlinkLink:
    def __init__(self, connection: str, counters: Counter, source_system: int, source_component: int,
                 baud: int = 57600, tlog_out: str | Path | None = None):
        self.connection = connection
        self.counters = counters
        self.is_log = connection.endswith((".tlog", ".bin.tlog")) and not connection.startswith(("udp", "tcp"))
        try:
            self.conn = mavutil.mavlink_connection(connection, baud=baud, source_system=source_system,
                                                   source_component=source_component, autoreconnect=True)
        except Exception as exc:  # noqa: BLE001  (pymavlink raises anything from socket to serial errors)
            raise LinkError(f"cannot open MAVLink connection {connection!r}: {exc}") from exc
        self.datagrams = isinstance(self.conn, mavutil.mavudp)
        self.scanner = FrameScanner(counters, source_system, source_component)
        self.mav = mavlink2.MAVLink(None, srcSystem=source_system, srcComponent=source_component)
        self._tlog = open(tlog_out, "ab") if tlog_out else None

    def receive(self, timeout_s: float) -> list:
        """Messages that arrived within timeout_s (may be empty). Log replay returns (msg) with
        msg._timestamp set from the log."""
        if self.is_log:
            msg = self.conn.recv_msg()
            return [msg] if msg is not None else []
        fd = self.conn.fd
        if fd is None:
            time.sleep(timeout_s)
            return []
        readable, _, _ = select.select([fd], [], [], max(timeout_s, 0.0))
        if not readable:
            return []
        out = []
        for _ in range(256):  # drain what is queued without starving the caller's clock
            try:
                data = self.conn.recv(READ_CHUNK)
            except OSError:
                self.counters["link.receive_error"] += 1
                break
            if not data:
                break
            msgs = self.scanner.feed(bytes(data) if isinstance(data, (bytes, bytearray)) else data.encode(),
                                     end_of_datagram=self.datagrams)
            self._record(msgs)
            out.extend(msgs)
            if not self.datagrams:
                break
        return out

    def _record(self, msgs) -> None:
        """pymavlink's setup_logfile() writes nothing on UDP links, so the tlog is written here."""
        if self._tlog is None:
            return
        stamp = struct.pack(">Q", int(time.time() * 1e6))
        for msg in msgs:
            self._tlog.write(stamp + bytes(msg.get_msgbuf()))

    def send(self, msg) -> None:
        buf = msg.pack(self.mav)
        self.conn.write(buf)
        if self._tlog is not None:
            self._tlog.write(struct.pack(">Q", int(time.time() * 1e6)) + bytes(buf))

    def close(self) -> None:
        if self._tlog is not None:
            self._tlog.close()
        self.conn.close()

    @property
    def at_end(self) -> bool:
        """A log replay has no more messages."""
        return self.is_log and getattr(self.conn, "_eof", False)
