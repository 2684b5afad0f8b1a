"""A MAVLink link from any pymavlink connection string, with robust framing and an optional .tlog record.

pymavlink supplies the transports (udpin/udpout/tcp/tcpin/serial/.tlog); frames are extracted by our
FrameScanner (per datagram on UDP, as a stream on TCP and serial) so that garbage never costs valid frames.
"""

from __future__ import annotations

import select
import socket
import struct
import time
from collections import Counter
from pathlib import Path

import avionics.io  # noqa: F401  (sets MAVLINK20 before pymavlink is imported)
from pymavlink import mavutil
from avionics.io.dialect import daa as mavlink2  # common.xml plus our DAA_ADVISORY

from avionics.io.framing import FrameScanner

READ_CHUNK = 65536
MAX_DATAGRAMS_PER_RECEIVE = 256  # drained per wake-up, so that a flood never starves the loop's clock


class LinkError(RuntimeError):
    """The connection string cannot be opened, with pymavlink's reason."""


def _check_udp_port_free(connection: str) -> None:
    """pymavlink binds udpin with SO_REUSEADDR, so a second process on the same port starts silently and the
    two split the datagrams. Bind it once without that option first: a port in use is then a clear error."""
    kind, _, address = connection.partition(":")
    if kind not in ("udpin", "udp"):
        return
    host, _, port = address.rpartition(":")
    if not port.isdigit():
        return  # pymavlink will report the malformed string
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as probe:
        try:
            probe.bind((host or "0.0.0.0", int(port)))
        except OSError as exc:
            raise LinkError(f"cannot open MAVLink connection {connection!r}: UDP port {port} is in use ({exc})") from exc


class MavlinkLink:
    def __init__(self, connection: str, counters: Counter, source_system: int, source_component: int,
                 baud: int = 57600, tlog_out: str | Path | None = None):
        self.connection = connection
        self.counters = counters
        self.is_log = connection.lower().endswith((".tlog", ".raw", ".mavlink")) and \
            not connection.startswith(("udp", "tcp"))
        _check_udp_port_free(connection)
        try:
            self.conn = mavutil.mavlink_connection(connection, baud=baud, source_system=source_system,
                                                   source_component=source_component, autoreconnect=True)
        except Exception as exc:  # noqa: BLE001  (pymavlink raises anything from socket to serial errors)
            raise LinkError(f"cannot open MAVLink connection {connection!r}: {exc}") from exc
        self.datagrams = isinstance(self.conn, mavutil.mavudp)
        if type(self.conn) is mavutil.mavtcp:
            self.conn.retries = 0  # reconnects after EOF: one attempt, not seconds of sleeping inside receive()
        self.scanner = FrameScanner(counters, source_system, source_component)
        self.mav = mavlink2.MAVLink(None, srcSystem=source_system, srcComponent=source_component)
        self._tlog = open(tlog_out, "ab") if tlog_out else None

    def receive(self, timeout_s: float) -> list:
        """Messages that arrived within timeout_s (may be empty). Log replay returns (msg) with
        msg._timestamp set from the log."""
        if self.is_log:
            msg = self.conn.recv_msg()
            return [msg] if msg is not None else []
        fd = self._wait_fd()
        if fd is None:
            time.sleep(timeout_s)
            return []
        readable, _, _ = select.select([fd], [], [], max(timeout_s, 0.0))
        if not readable:
            return []
        out = []
        for _ in range(MAX_DATAGRAMS_PER_RECEIVE):  # drain what is queued
            try:
                data = self.conn.recv(READ_CHUNK)
            except OSError:
                self.counters["link.receive_error"] += 1
                break
            if not data:
                self._drop_closed_tcpin_peer()
                break
            msgs = self.scanner.feed(bytes(data) if isinstance(data, (bytes, bytearray)) else data.encode(),
                                     end_of_datagram=self.datagrams)
            self._record(msgs)
            out.extend(msgs)
            if not self.datagrams:
                break
        return out

    def _wait_fd(self):
        """pymavlink's tcp client reconnects on EOF without updating conn.fd, and leaves no socket when that
        fails: select() on the stale fd raised EBADF and stopped the node. Use the live socket, or retry."""
        conn = self.conn
        if type(conn) is mavutil.mavtcp:
            if conn.port is None:
                try:
                    conn.do_connect()
                except OSError:
                    conn.port = None
                    return None
                self.counters["link.reconnected"] += 1
            conn.fd = conn.port.fileno()
        return conn.fd

    def _drop_closed_tcpin_peer(self) -> None:
        """pymavlink's tcpin keeps a connection its peer has closed: select() then returns at once for ever
        and a reconnecting peer is never accepted. Go back to listening instead."""
        conn = self.conn
        if not isinstance(conn, mavutil.mavtcpin) or conn.port is None:
            return
        try:
            closed = conn.port.recv(1, socket.MSG_PEEK) == b""
        except BlockingIOError:
            return  # nothing queued yet: still connected
        except OSError:
            closed = True
        if closed:
            conn.port.close()
            conn.port = None
            conn.fd = conn.listen.fileno()
            self.counters["link.disconnected"] += 1

    def _record(self, msgs) -> None:
        """pymavlink's setup_logfile() writes nothing on UDP links, so the tlog is written here."""
        if self._tlog is None:
            return
        stamp = struct.pack(">Q", int(time.time() * 1e6))
        for msg in msgs:
            self._tlog.write(stamp + bytes(msg.get_msgbuf()))
        self._tlog.flush()  # a crash must not lose what was received

    def send(self, msg) -> None:
        if self.is_log:
            return  # a log being replayed is read-only: outputs go to the tlog record and zenoh only
        buf = msg.pack(self.mav)
        self.conn.write(buf)
        if self._tlog is not None:
            self._tlog.write(struct.pack(">Q", int(time.time() * 1e6)) + bytes(buf))

    def close(self) -> None:
        if self._tlog is not None:
            self._tlog.close()
        if not (type(self.conn) is mavutil.mavtcp and self.conn.port is None):  # pymavlink would raise
            self.conn.close()

    @property
    def at_end(self) -> bool:
        """A log replay has no more messages."""
        return self.is_log and getattr(self.conn, "_eof", False)
