"""Robust MAVLink frame extraction from a byte stream or from datagrams.

pymavlink's own parser trusts the first 0xFD/0xFE it sees: garbage holding one of those makes it swallow
the length that garbage claims and lose the valid frames inside it. This scanner tries every start marker
and, when a candidate fails its CRC, moves on by one byte, so every valid frame after any garbage is
decoded. pymavlink still does the decoding and CRC check of each candidate.
"""

from __future__ import annotations

from collections import Counter

import avionics.io  # noqa: F401  (sets MAVLINK20 before pymavlink is imported)
from pymavlink.dialects.v20 import common as mavlink2

V1_MARKER = 0xFE
V2_MARKER = 0xFD
V1_OVERHEAD = 6 + 2  # header + CRC
V2_OVERHEAD = 10 + 2
SIGNATURE_LEN = 13
MAX_FRAME = V2_OVERHEAD + 255 + SIGNATURE_LEN


def frame_length(buf: bytes | bytearray, i: int) -> int | None:
    """Total length of the candidate frame starting at buf[i], or None if its header is not complete."""
    if buf[i] == V1_MARKER:
        return V1_OVERHEAD + buf[i + 1] if len(buf) - i >= 2 else None
    if len(buf) - i < 3:
        return None
    signed = buf[i + 2] & mavlink2.MAVLINK_IFLAG_SIGNED
    return V2_OVERHEAD + buf[i + 1] + (SIGNATURE_LEN if signed else 0)


class FrameScanner:
    """Turns bytes into decoded pymavlink messages; every skipped byte run and bad frame is counted."""

    def __init__(self, counters: Counter, src_system: int = 255, src_component: int = 0):
        self.counters = counters
        self.mav = mavlink2.MAVLink(None, srcSystem=src_system, srcComponent=src_component)
        self.mav.robust_parsing = True
        self._buf = bytearray()

    def feed(self, data: bytes, end_of_datagram: bool = False) -> list:
        """Decode what data completes. With end_of_datagram (UDP), a frame cannot continue in the next
        datagram, so an incomplete candidate at the end is garbage, not a frame still arriving."""
        self._buf += data
        buf, out, i, garbage = self._buf, [], 0, 0
        while i < len(buf):
            if buf[i] not in (V1_MARKER, V2_MARKER):
                i += 1
                garbage += 1
                continue
            length = frame_length(buf, i)
            if length is None or len(buf) - i < length:
                if end_of_datagram:
                    i += 1
                    garbage += 1
                    continue
                break  # wait for the rest of this frame
            msg = self._decode(bytes(buf[i:i + length]))
            if msg is None:
                i += 1
                garbage += 1
                continue
            out.append(msg)
            i += length
        if garbage:
            self.counters["frame.skipped_bytes"] += garbage
        del buf[:i]
        if len(buf) > MAX_FRAME:  # only possible without a marker in the tail: cannot start a frame
            self.counters["frame.skipped_bytes"] += len(buf)
            buf.clear()
        return out

    def _decode(self, frame: bytes):
        try:
            msg = self.mav.decode(bytearray(frame))
        except mavlink2.MAVError as exc:
            reason = "frame.bad_crc" if "invalid MAVLink CRC" in str(exc) else "frame.undecodable"
            self.counters[reason] += 1
            return None
        except Exception:  # noqa: BLE001  (pymavlink raises struct/index errors on truncated payloads)
            self.counters["frame.undecodable"] += 1
            return None
        if msg.get_type() == "BAD_DATA":
            self.counters["frame.undecodable"] += 1
            return None
        return msg
