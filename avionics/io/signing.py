"""MAVLink 2 message signing (https://mavlink.io/en/guide/message_signing.html): our frames signed, every
received frame checked, each rejection counted by its reason.

The check is ours, not pymavlink's MAVLink.check_signature, which (pymavlink 2.4) records a stream's
timestamp *before* it verifies the signature (one forged frame with a far-future timestamp then locks the
real sender out), gives one error text for every reason, and keeps state per MAVLink object: FrameScanner
decodes the frame after a signed one twice (once to find it, once to use it), and pymavlink would reject the
second decode as a replay. So the scanner's pymavlink objects carry no key and pass signed frames through
unchecked; MavlinkLink hands every decoded frame to Signing.accept() before anything uses it.

No pymavlink import here: config.py loads keys through load_key() without importing the link.
"""

from __future__ import annotations

import hashlib
import hmac
import time
from collections import Counter
from pathlib import Path

KEY_LEN = 32
SIGNATURE_BLOCK_LEN = 13  # link id (1), timestamp (6), signature (6)
IFLAG_SIGNED = 0x01
EPOCH_2015_UNIX_S = 1420070400  # signing timestamps count 10 us units from 2015-01-01 00:00 UTC
TIMESTAMP_MAX = (1 << 48) - 1
NEW_STREAM_MAX_AGE = 6_000_000  # a new stream may be at most one minute (in 10 us units) behind our timestamp


class SigningKeyError(ValueError):
    """The key file cannot be used; the message names the file."""


def load_key(path: str | Path) -> bytes:
    """The 32-byte key held in path as 64 hexadecimal characters (surrounding whitespace ignored)."""
    try:
        text = Path(path).read_text(encoding="ascii").strip()
    except (OSError, UnicodeDecodeError) as exc:
        raise SigningKeyError(f"{path}: cannot read the signing key ({exc})") from None
    if len(text) != 2 * KEY_LEN:
        raise SigningKeyError(f"{path}: expected {2 * KEY_LEN} hexadecimal characters (a {KEY_LEN}-byte key), "
                              f"found {len(text)} characters")
    try:
        key = bytes.fromhex(text)
    except ValueError:
        raise SigningKeyError(f"{path}: the signing key is not hexadecimal") from None
    if key == bytes(KEY_LEN):
        raise SigningKeyError(f"{path}: an all-zero key means 'signing off' to SETUP_SIGNING; use a random key")
    return key


def timestamp_at(unix_s: float) -> int:
    """The signing timestamp of a wall-clock time: 10 us units since 2015-01-01 (clamped to 48 bits)."""
    return max(0, min(TIMESTAMP_MAX, int((unix_s - EPOCH_2015_UNIX_S) * 100_000)))


def is_signed(frame: bytes | bytearray) -> bool:
    """A MAVLink 2 frame with its signed flag (MAVLink 1 frames cannot be signed)."""
    return len(frame) > 2 and frame[0] == 0xFD and bool(frame[2] & IFLAG_SIGNED)


def signature_of(key: bytes, frame_without_signature: bytes | bytearray) -> bytes:
    """The 6-byte signature: SHA-256(key + header + payload + CRC + link id + timestamp), first 6 bytes."""
    return hashlib.sha256(key + bytes(frame_without_signature)).digest()[:6]


class Signing:
    """Signing state of one link: our outgoing timestamp and the last timestamp of every incoming stream.

    clock: the wall clock behind our timestamp (None: no clock, as when replaying a log; our timestamp is then
    the newest one received). required: reject unsigned frames (else accept them, counted)."""

    def __init__(self, key: bytes, counters: Counter, required: bool = True, link_id: int = 0, clock=time.time):
        if len(key) != KEY_LEN:
            raise ValueError(f"a MAVLink signing key has {KEY_LEN} bytes, not {len(key)}")
        self.key = bytes(key)
        self.counters = counters
        self.required = required
        self.link_id = link_id
        self.clock = clock
        self.streams: dict[tuple[int, int, int], int] = {}  # (link id, system, component) -> last timestamp
        self._newest = 0  # newest timestamp received with a good signature

    # -- outgoing -------------------------------------------------------------------------------------------
    def timestamp(self) -> int:
        """Our timestamp now: the wall clock, never behind the newest timestamp received (the spec's rule)."""
        now = timestamp_at(self.clock()) if self.clock is not None else 0
        return max(now, self._newest)

    def attach(self, mav) -> None:
        """Make a pymavlink MAVLink object sign what it packs (MAVLink 2 only) with our key and link id."""
        mav.signing.secret_key = self.key
        mav.signing.link_id = self.link_id
        mav.signing.sign_outgoing = True
        mav.signing.timestamp = self.timestamp()

    def before_send(self, mav) -> None:
        """pymavlink adds 1 per frame it signs; keep the timestamp also moving with the clock."""
        mav.signing.timestamp = max(mav.signing.timestamp, self.timestamp())

    # -- incoming -------------------------------------------------------------------------------------------
    def accept(self, msg) -> bool:
        """Is this decoded frame to be used? Counts signing.accepted, signing.unsigned (rejected),
        signing.unsigned_allowed (signing_required off), signing.bad_signature, signing.replayed (not newer than
        the last frame of its stream) and signing.old_stream (a new stream over a minute behind our time)."""
        frame = bytes(msg.get_msgbuf())
        if not is_signed(frame):
            if self.required:
                self.counters["signing.unsigned"] += 1
                return False
            self.counters["signing.unsigned_allowed"] += 1
            return True
        if len(frame) < 12 + SIGNATURE_BLOCK_LEN:
            self.counters["signing.bad_signature"] += 1
            return False
        # The signature first: what an unsigned-in sender claims must never change any state.
        if not hmac.compare_digest(signature_of(self.key, frame[:-6]), frame[-6:]):
            self.counters["signing.bad_signature"] += 1
            return False
        link_id = frame[-SIGNATURE_BLOCK_LEN]
        stamp = int.from_bytes(frame[-12:-6], "little")
        stream = (link_id, msg.get_srcSystem(), msg.get_srcComponent())
        last = self.streams.get(stream)
        if last is not None and stamp <= last:
            self.counters["signing.replayed"] += 1
            return False
        if last is None and stamp + NEW_STREAM_MAX_AGE < self.timestamp():
            self.counters["signing.old_stream"] += 1
            return False
        self.streams[stream] = stamp
        self._newest = max(self._newest, stamp)
        self.counters["signing.accepted"] += 1
        return True
