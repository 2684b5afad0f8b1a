"""A MAVLink link from any pymavlink connection string, with robust framing and an optional .tlog record.

pymavlink supplies the transports (udpin/udpout/tcp/serial/.tlog; tcpin is avionics/io/tcpin.py); frames are
extracted by our FrameScanner (per datagram on UDP, as a stream on TCP and serial) so that garbage never costs
valid frames.
With a MAVLink 2 signing key, every frame we send is signed and every frame received is checked
(avionics/io/signing.py) before it is used; a replayed log's timestamps are checked before they become time.
"""

from __future__ import annotations

import errno
import math
import os
import select
import socket
import struct
import time
from collections import Counter, deque
from pathlib import Path

import avionics.io  # noqa: F401  (sets MAVLINK20 before pymavlink is imported)
from pymavlink import mavutil
from avionics.io.dialect import daa as mavlink2  # ardupilotmega.xml plus our DAA_ADVISORY, DAA_BANDS

from avionics.base.params import ConfigError
from avionics.io.framing import FrameScanner
from avionics.io.signing import Signing, SigningKeyError, load_key
from avionics.io.sinks import FileSink, SinkHealth
from avionics.io.tcpin import IDLE_TIMEOUT_S, TcpInServer

READ_CHUNK = 65536
MAX_DATAGRAMS_PER_RECEIVE = 256  # drained per wake-up, so that a flood never starves the loop's clock
# Overload on UDP (receive()): the socket is drained into a backlog (cheap), then datagrams are framed for at
# most STEP_BUDGET_S per call, small ones (real MAVLink traffic: a frame is at most 280 bytes) before large ones,
# and the rest waits for the next call, which does not wait for the socket. Beyond MAX_BACKLOG_BYTES the oldest
# large datagrams (then small ones) are dropped and counted: link.dropped_datagrams, link.dropped_bytes.
STEP_BUDGET_S = 0.010
SMALL_DATAGRAM = 2048
MAX_BACKLOG_BYTES = 1 << 20
RECEIVE_BUFFER_BYTES = 4 << 20  # SO_RCVBUF asked for (the kernel caps it at net.core.rmem_max)
SO_RXQ_OVFL = getattr(socket, "SO_RXQ_OVFL", 40)  # Linux: the socket's drop count with each datagram
_DROPS_CMSG_SPACE = socket.CMSG_SPACE(4) if hasattr(socket, "CMSG_SPACE") else 0

# A .tlog's 8-byte timestamps become the replay's clock; a corrupted one must not (LogClock).
LOG_STAMP_MAX_S = 4102444800.0  # 2100-01-01 (microseconds since 1970; synthetic logs may start near 0)
LOG_STAMP_STEP_S = 5.0  # a jump further than this either way waits for the next frame to confirm it


def _enable_drop_counter(sock: socket.socket) -> bool:
    """Ask for the kernel's receive-queue drop count (SO_RXQ_OVFL) and a larger receive buffer."""
    try:
        if sock.getsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF) < RECEIVE_BUFFER_BYTES:
            sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, RECEIVE_BUFFER_BYTES)
    except OSError:
        pass
    try:
        sock.setsockopt(socket.SOL_SOCKET, SO_RXQ_OVFL, 1)
        return _DROPS_CMSG_SPACE > 0 and hasattr(sock, "recvmsg")
    except OSError:
        return False


def udp_kernel_drops(sock: socket.socket) -> int | None:
    """Datagrams the kernel dropped for this socket (receive buffer full), from /proc/net/udp[6]; None when
    not available. The same count SO_RXQ_OVFL reports."""
    try:
        inode = str(os.fstat(sock.fileno()).st_ino)
    except OSError:
        return None
    for table in ("/proc/net/udp", "/proc/net/udp6"):
        try:
            with open(table) as f:
                next(f)
                for line in f:
                    fields = line.split()
                    if len(fields) >= 13 and fields[9] == inode:
                        return int(fields[12])
        except (OSError, StopIteration, ValueError):
            continue
    return None


class LinkError(RuntimeError):
    """The connection string cannot be opened, with pymavlink's reason."""


URL_SCHEMES = {"udp": "udpin", "udpin": "udpin", "udpout": "udpout", "tcp": "tcp", "tcpin": "tcpin"}


def translate_connection(connection: str, baud: int) -> tuple[str, int]:
    """A MAVSDK/MAVROS-style URL as pymavlink's connection string and baud rate; anything else unchanged.

    `udp://[HOST]:PORT` listens (MAVSDK: `udp://:14540` is all interfaces; a MAVROS `@` with nothing after it
    is allowed), `udpin://HOST:PORT`, `udpout://HOST:PORT`, `tcp://HOST:PORT` (client), `tcpin://HOST:PORT`,
    `serial://DEVICE[:BAUD]` (e.g. `serial:///dev/ttyUSB0:921600`; without BAUD, mavlink.baud). A malformed URL
    is a ConfigError naming it (exit 2)."""
    scheme, sep, rest = connection.partition("://")
    if not sep:
        return connection, baud
    def bad(why: str) -> ConfigError:
        return ConfigError(f"mavlink.connection: {connection!r} {why}")
    scheme = scheme.lower()
    if scheme == "serial":
        device, colon, speed = rest.rpartition(":")
        if not colon or not speed.isdigit():
            device, speed = rest, ""
        if not device.startswith("/") and not device[:3].upper() == "COM":
            raise bad("is not serial://DEVICE[:BAUD] (e.g. serial:///dev/ttyUSB0:921600)")
        if speed and not 0 < int(speed) <= 20_000_000:
            raise bad(f"has baud rate {speed} out of range")
        return device, int(speed) if speed else baud
    if scheme not in URL_SCHEMES:
        raise bad("has an unknown scheme (udp://, udpin://, udpout://, tcp://, tcpin://, serial://)")
    address, at, remote = rest.partition("@")
    if at and remote:
        raise bad("sends to a remote address after '@' (MAVROS bind@remote): use udpin:HOST:PORT and let the "
                  "sender address us, or udpout:HOST:PORT")
    host, colon, port = address.rpartition(":")
    if not colon or not port.isdigit() or not 0 < int(port) < 65536:
        raise bad("needs HOST:PORT with a port in 1..65535")
    if not host:
        if scheme not in ("udp", "udpin", "tcpin"):
            raise bad("needs a host")
        host = "0.0.0.0"
    return f"{URL_SCHEMES[scheme]}:{host}:{int(port)}", baud


def _check_udp_port_free(connection: str) -> None:
    """pymavlink binds udpin with SO_REUSEADDR, so a second process on the same port starts silently and the
    two split the datagrams. Bind it once without that option first: a port in use is then a clear error."""
    kind, _, address = connection.partition(":")
    if kind not in ("udpin", "udp"):
        return
    host, _, port = address.rpartition(":")
    if not port.isdigit():
        return  # pymavlink will report the malformed string
    if not 0 < int(port) < 65536:
        raise LinkError(f"cannot open MAVLink connection {connection!r}: UDP port {port} is not in 1..65535")
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as probe:
        try:
            probe.bind((host or "0.0.0.0", int(port)))
        except OSError as exc:
            raise LinkError(f"cannot open MAVLink connection {connection!r}: UDP port {port} is in use ({exc})") from exc


class LogError(ValueError):
    """A log given as the connection yields no usable time: nothing in it can be replayed (exit 2, a file
    error)."""


class LogClock:
    """Checks a log's timestamps before they become the replay's time, which never goes back.

    A stamp that is not finite, negative or after 2100 is rejected. Within LOG_STAMP_STEP_S of the last time:
    taken (a small step back is held at the last time). Further either way, and the log's first frame: held
    until the next frame confirms it (within LOG_STAMP_STEP_S of it); unconfirmed, it is rejected, so one
    corrupted stamp costs one frame. A confirmed step is the log's clock stepping:
    - back (the recording computer's clock was set back, by NTP or a GNSS time fix): no time can have passed
      backwards, so the replay goes on from the last time and every later stamp is shifted by the step
      (`tlog.clock_step_back`); without this the rest of the log was rejected as "behind";
    - ahead: kept as time that passed (`tlog.clock_step_ahead`): the recorder writes only what it receives, so a
      link that went quiet is a step ahead too, and the tracks coast and end over it as they did in flight.
    Rejected frames count `tlog.bad_timestamp`. At the end, a log without a usable stamp (no frame, every
    stamp rejected, or a time that never advanced: all zero, frozen) is a LogError: it would replay to
    nothing, silently."""

    def __init__(self, counters: Counter):
        self.counters = counters
        self.last_s: float | None = None  # the replay's time of the last frame released
        self.shift_s = 0.0  # added to the log's stamps after steps back
        self.held = None  # a frame whose timestamp waits for confirmation: (frame, its stamp)
        self.first_s: float | None = None
        self.frames = 0  # frames fed, for the error

    def _reject(self) -> None:
        self.counters["tlog.bad_timestamp"] += 1

    def feed(self, msg) -> list:
        """The frames msg releases, with msg._timestamp as the replay should use it."""
        self.frames += 1
        t = getattr(msg, "_timestamp", None)
        if not isinstance(t, (int, float)) or not math.isfinite(t) or not 0.0 <= t <= LOG_STAMP_MAX_S:
            self._reject()
            return []
        out = []
        if self.held is not None:
            (held, held_t), self.held = self.held, None
            if abs(t - held_t) <= LOG_STAMP_STEP_S:  # confirmed: the log really goes on there
                if self.last_s is not None and held_t + self.shift_s < self.last_s:
                    self.shift_s = self.last_s - held_t
                    self.counters["tlog.clock_step_back"] += 1
                elif self.last_s is not None:
                    self.counters["tlog.clock_step_ahead"] += 1
                out.append(self._release(held, held_t))
            else:
                self._reject()
        if self.last_s is None or abs(t + self.shift_s - self.last_s) > LOG_STAMP_STEP_S:
            self.held = (msg, t)
            return out
        out.append(self._release(msg, t))
        return out

    def _release(self, msg, t: float):
        time_s = t + self.shift_s if self.last_s is None else max(t + self.shift_s, self.last_s)
        msg._timestamp = self.last_s = time_s
        if self.first_s is None:
            self.first_s = time_s
        return msg

    def end(self, name: str) -> None:
        """At the end of the log a held frame was never confirmed. LogError when the log had no usable time."""
        if self.held is not None:
            self._reject()
            self.held = None
        if not self.frames:
            raise LogError(f"read 0 MAVLink messages from {name}: empty, or not a MAVLink log (.tlog: 8-byte "
                           f"timestamp + frame): nothing to replay")
        if self.first_s is None or self.last_s == self.first_s:
            why = "no frame" if not self.frames else f"every stamp of {self.frames} frame(s) rejected" \
                if self.first_s is None else f"{self.frames} frame(s) all at one time: zero or frozen stamps"
            raise LogError(f"{name}: no usable timestamp ({why}): nothing to replay on the log's time")


class MavlinkLink:
    def __init__(self, connection: str, counters: Counter, source_system: int, source_component: int,
                 baud: int = 57600, tlog_out: str | Path | None = None, signing_key_file: str = "",
                 signing_required: bool = True, sinks: SinkHealth | None = None,
                 tcpin_idle_timeout_s: float = IDLE_TIMEOUT_S):
        """sinks: where a failing record (tlog_out) or endpoint write is reported (avionics/io/sinks.py)."""
        connection, baud = translate_connection(connection, baud)  # MAVSDK/MAVROS URLs; a bad one: ConfigError
        self.connection = connection
        self.counters = counters
        self.is_log = connection.lower().endswith((".tlog", ".raw", ".mavlink")) and \
            not connection.startswith(("udp", "tcp"))
        self.signing: Signing | None = None
        if signing_key_file:  # a bad key stops us before any socket is opened
            try:
                key = load_key(signing_key_file)
            except SigningKeyError as exc:
                raise ConfigError(f"mavlink.signing_key_file: {exc}") from None
            # A log has no clock of its own: its streams are judged against each other, not against today.
            self.signing = Signing(key, counters, signing_required, clock=None if self.is_log else time.time)
        if self.is_log and not Path(connection).is_file():
            # pymavlink opens a name that is no file as a serial device: "could not open port", or "No module named
            # 'serial'" without pyserial. A log that is not there is a file error (exit 2).
            raise ConfigError(f"mavlink.connection {connection!r}: no such file")
        _check_udp_port_free(connection)
        try:
            if connection.startswith("tcpin:"):  # ours, not pymavlink's one-connection mavtcpin (tcpin.py)
                host, _, port = connection[len("tcpin:"):].rpartition(":")
                self.conn = TcpInServer(host, int(port), counters, source_system,
                                        lambda: FrameScanner(counters, source_system, source_component),
                                        tcpin_idle_timeout_s)
            else:
                self.conn = mavutil.mavlink_connection(connection, baud=baud, source_system=source_system,
                                                       source_component=source_component, autoreconnect=True)
        except ModuleNotFoundError as exc:
            if exc.name != "serial":
                raise
            # pymavlink opens anything that is not udp/tcp/a file as a serial device, through pyserial
            raise LinkError(f"cannot open MAVLink connection {connection!r}: a serial device needs pyserial, which "
                            f"is not installed: pip install 'avionics-daa[serial]' (from a clone: "
                            f"pip install '.[serial]')") from None
        except Exception as exc:  # noqa: BLE001  (pymavlink raises anything from socket to serial errors)
            raise LinkError(f"cannot open MAVLink connection {connection!r}: {exc}") from exc
        self.datagrams = isinstance(self.conn, mavutil.mavudp)
        if type(self.conn) is mavutil.mavtcp:
            self.conn.retries = 0  # reconnects after EOF: one attempt, not seconds of sleeping inside receive()
        self.scanner = FrameScanner(counters, source_system, source_component)
        self.mav = mavlink2.MAVLink(None, srcSystem=source_system, srcComponent=source_component)
        if self.signing is not None:
            self.signing.attach(self.mav)  # what we send is signed
        self._encoders: dict = {}  # other components of ours (send_as)
        self._log_clock = LogClock(counters) if self.is_log else None
        self._log_ready: deque = deque()
        self._log_done = False
        self.sinks = sinks if sinks is not None else SinkHealth(counters)
        self._tlog = FileSink("tlog", tlog_out, "ab", self.sinks) if tlog_out else None
        # Overload (UDP, see STEP_BUDGET_S): datagrams read and not framed yet; the kernel's drop counter.
        self.step_budget_s = STEP_BUDGET_S
        self.max_backlog_bytes = MAX_BACKLOG_BYTES
        self._small: deque = deque()
        self._large: deque = deque()
        self._backlog_bytes = 0
        self._drops_cmsg = self.datagrams and _enable_drop_counter(self.conn.port)
        self._next_drops_poll = 0.0

    def receive(self, timeout_s: float) -> list:
        """Messages that arrived within timeout_s (may be empty). Log replay returns (msg) with
        msg._timestamp set from the log."""
        if self.is_log:
            return self._receive_log()
        if isinstance(self.conn, TcpInServer):
            received, msgs = self.conn.receive(timeout_s, self._authentic)
            self._record(received)
            return msgs
        fd = self._wait_fd()
        if fd is None:
            time.sleep(timeout_s)
            return []
        if self.datagrams:
            return self._receive_datagrams(fd, timeout_s)
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
                break
            msgs = self.scanner.feed(bytes(data) if isinstance(data, (bytes, bytearray)) else data.encode(),
                                     end_of_datagram=self.datagrams)
            self._record(msgs)  # everything received, as received: a replay checks signatures again
            out.extend(self._authentic(msgs))
            if not self.datagrams:
                break
        return out

    # -- UDP: a bounded step whatever arrives (see STEP_BUDGET_S) ------------------------------------------------
    def _receive_datagrams(self, fd, timeout_s: float) -> list:
        """Drain the socket into the backlog, then frame it within the step's time budget."""
        backlog = bool(self._small or self._large)
        readable, _, _ = select.select([fd], [], [], 0.0 if backlog else max(timeout_s, 0.0))
        if readable:
            self._read_datagrams()
        return self._frame_backlog()

    def _read_datagrams(self) -> None:
        conn = self.conn
        sock = conn.port
        for _ in range(MAX_DATAGRAMS_PER_RECEIVE):
            try:
                if self._drops_cmsg:
                    data, ancillary, _, address = sock.recvmsg(READ_CHUNK, _DROPS_CMSG_SPACE)
                else:
                    data, address = sock.recvfrom(READ_CHUNK)
                    ancillary = ()
            except (BlockingIOError, InterruptedError, ConnectionRefusedError):
                break  # nothing more queued (or an ICMP error from an earlier send, as pymavlink ignores)
            except OSError:
                self.counters["link.receive_error"] += 1
                break
            for level, kind, value in ancillary:
                if level == socket.SOL_SOCKET and kind == SO_RXQ_OVFL and len(value) >= 4:
                    self._note_kernel_drops(struct.unpack("=I", value[:4])[0])
            if conn.udp_server:  # what pymavlink's recv() does: replies go to every sender
                conn.clients.add(address)
                conn.clients_last_alive[address] = time.time()
            elif conn.broadcast:
                conn.last_address = address
            self.counters["link.datagrams"] += 1
            (self._small if len(data) <= SMALL_DATAGRAM else self._large).append(data)
            self._backlog_bytes += len(data)
            while self._backlog_bytes > self.max_backlog_bytes:  # oldest large ones first
                dropped = (self._large or self._small).popleft()
                self._backlog_bytes -= len(dropped)
                self.counters["link.dropped_datagrams"] += 1
                self.counters["link.dropped_bytes"] += len(dropped)
        if not self._drops_cmsg and time.monotonic() >= self._next_drops_poll:
            self._next_drops_poll = time.monotonic() + 1.0
            self.poll_kernel_drops()

    def _frame_backlog(self) -> list:
        """Frame small datagrams, then large ones, until the budget is spent (at least one per call)."""
        out, framed = [], 0
        deadline = time.perf_counter() + self.step_budget_s
        for queue in (self._small, self._large):
            while queue and (not framed or time.perf_counter() < deadline):
                data = queue.popleft()
                self._backlog_bytes -= len(data)
                msgs = self.scanner.feed(data, end_of_datagram=True)
                self._record(msgs)  # everything received, as received: a replay checks signatures again
                out.extend(self._authentic(msgs))
                framed += 1
        if self._small or self._large:
            self.counters["link.deferred"] += 1  # a step that left datagrams for the next one
        return out

    def _note_kernel_drops(self, total: int) -> None:
        """The kernel's count is cumulative for the socket; ours follows it (and only grows)."""
        if total > self.counters["link.kernel_drops"]:
            self.counters["link.kernel_drops"] = total

    def poll_kernel_drops(self) -> None:
        """Read the kernel's drop count now (/proc): SO_RXQ_OVFL only tells it with the next datagram."""
        if self.datagrams:
            total = udp_kernel_drops(self.conn.port)
            if total is not None:
                self._note_kernel_drops(total)

    @property
    def backlog(self) -> tuple[int, int]:
        """(datagrams, bytes) read from the socket and not framed yet."""
        return len(self._small) + len(self._large), self._backlog_bytes

    @property
    def authenticated(self) -> bool:
        """Every frame used is signed with our key (signing on and required) and signed frames have come: what the
        guidance stage needs before it commands the autopilot (guidance.require_signing)."""
        return self.signing is not None and self.signing.required and self.counters["signing.accepted"] > 0

    def _authentic(self, msgs) -> list:
        """With signing: only the frames whose signature (or, when allowed, absence of one) passes."""
        if self.signing is None:
            return msgs
        return [m for m in msgs if self.signing.accept(m)]

    def _receive_log(self) -> list:
        """The next message of the log whose timestamp and signature pass ([] only at the end of the log:
        the runner stops there)."""
        while not self._log_ready:
            msg = self.conn.recv_msg()
            if msg is None:
                self._log_done = True
                self._log_clock.end(self.connection)  # a log without usable time: LogError
                return []
            if msg.get_type() == "BAD_DATA":  # pymavlink's parser: bytes that are no frame (no usable time)
                self.counters["tlog.bad_data"] += 1
                continue
            self._log_ready.extend(self._authentic(self._log_clock.feed(msg)))
        return [self._log_ready.popleft()]

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
        if self.signing is not None:
            self.signing.before_send(self.mav)
        self._write(msg.pack(self.mav))

    def send_as(self, msg, component: int) -> None:
        """send() from another component id of our system (the ADSB_VEHICLE re-broadcast): its own encoder, so
        its sequence numbers and signing stream are its own."""
        mav = self._encoders.get(component)
        if mav is None:
            mav = self._encoders[component] = mavlink2.MAVLink(None, srcSystem=self.mav.srcSystem,
                                                               srcComponent=component)
            if self.signing is not None:
                self.signing.attach(mav)
        if self.is_log:
            return
        if self.signing is not None:
            self.signing.before_send(mav)
        self._write(msg.pack(mav))

    def _write(self, buf: bytes) -> None:
        """To the endpoint and the record. A serial port that fails (EIO: a USB adapter unplugged) is the
        endpoint's fault, retried with the next message (pymavlink reopens it), never the loop's: pymavlink's
        mavserial.write() returns -1 then. Its mavudp and mavtcp write() drop a socket's send errors themselves
        (a lost TCP peer is counted link.disconnected / link.reconnected)."""
        if self.conn.write(buf) == -1:
            self.sinks.failed("mavlink", OSError(errno.EIO, f"{self.connection} cannot be written"), closed=False)
        if self._tlog is not None:
            self._tlog.write(struct.pack(">Q", int(time.time() * 1e6)) + bytes(buf))

    def close(self) -> None:
        self.poll_kernel_drops()  # drops since the last datagram received are counted too
        if self._tlog is not None:
            self._tlog.close()
        if not (type(self.conn) is mavutil.mavtcp and self.conn.port is None):  # pymavlink would raise
            self.conn.close()

    @property
    def at_end(self) -> bool:
        """A log replay has no more messages."""
        return self.is_log and self._log_done and not self._log_ready
