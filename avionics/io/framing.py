"""Robust MAVLink frame extraction from a byte stream or from datagrams.

pymavlink's own parser trusts the first 0xFD/0xFE it sees: garbage holding one of those makes it swallow
the length that garbage claims and lose the valid frames inside it. This scanner tries every start marker
and, when a candidate fails its CRC, moves on by one byte, so every valid frame after any garbage is
decoded. pymavlink still does the decoding and CRC check of each candidate.
"""

from __future__ import annotations

from collections import Counter

import avionics.io  # noqa: F401  (sets MAVLINK20 before pymavlink is imported)
from pymavlink.dialects.v20 import ardupilotmega

from avionics.io.dialect import daa as mavlink2  # common.xml plus our DAA_ADVISORY

# Frames we can check: ours, and ArduPilot's own messages, which share real links with them (decoded and
# then ignored, instead of being counted as garbage).
KNOWN_MESSAGES = {**ardupilotmega.mavlink_map, **mavlink2.mavlink_map}

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


def header_verdict(buf: bytes | bytearray, i: int) -> bool | str | None:
    """Can the candidate at buf[i] be a frame we decode, judged from its header alone? True; None when the
    header is not complete; else the counter to count it under. Garbage holding a marker is mostly refused
    here, so a stream does not hold back the frames behind it while the length it claims arrives."""
    v1 = buf[i] == V1_MARKER
    if len(buf) - i < (6 if v1 else 10):
        return None
    if not v1 and buf[i + 2] & ~mavlink2.MAVLINK_IFLAG_SIGNED:
        return "frame.bad_header"  # an incompatibility flag we do not know: MAVLink 2 says drop the frame
    msgid = buf[i + 5] if v1 else buf[i + 7] | buf[i + 8] << 8 | buf[i + 9] << 16
    msgtype = KNOWN_MESSAGES.get(msgid)
    if msgtype is None:
        return "frame.unknown_msgid"  # no CRC_EXTRA: it could never be checked
    if v1 and buf[i + 1] > msgtype.unpacker.size:
        return "frame.bad_header"  # MAVLink 1 payloads are never longer than the message (v2 may grow)
    return True


class FrameScanner:
    """Turns bytes into decoded pymavlink messages; every skipped byte run and bad frame is counted."""

    def __init__(self, counters: Counter, src_system: int = 255, src_component: int = 0):
        self.counters = counters
        self.mav = mavlink2.MAVLink(None, srcSystem=src_system, srcComponent=src_component)
        self.mav.robust_parsing = True
        self._ardupilot = ardupilotmega.MAVLink(None, srcSystem=src_system, srcComponent=src_component)
        self._ardupilot.robust_parsing = True
        self._buf = bytearray()
        self._signature_left = 0  # bytes at the buffer head that are the signature of a frame already decoded

    def feed(self, data: bytes, end_of_datagram: bool = False) -> list:
        """Decode what data completes. With end_of_datagram (UDP), a frame cannot continue in the next
        datagram, so an incomplete candidate at the end is garbage, not a frame still arriving."""
        self._buf += data
        buf, out, i, garbage = self._buf, [], 0, 0
        while i < len(buf):
            if self._signature_left:
                resume = self._after_signature(buf, i, end_of_datagram)
                if resume is None:
                    break  # wait for the bytes that tell where the next frame starts
                i, self._signature_left = resume, 0
                continue
            if buf[i] not in (V1_MARKER, V2_MARKER):
                i += 1
                garbage += 1
                continue
            header = header_verdict(buf, i)
            if header is None and not end_of_datagram:
                break  # wait for the rest of this header
            if header is not True:
                if header is not None:
                    self.counters[header] += 1
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
            if buf[i] == V2_MARKER and buf[i + 2] & mavlink2.MAVLINK_IFLAG_SIGNED:
                # The CRC does not cover the signature: a signature cut short by lost bytes still decodes and
                # would swallow the head of the next frame. Decide where the next frame starts next.
                i += length - SIGNATURE_LEN
                self._signature_left = SIGNATURE_LEN
            else:
                i += length
        if garbage:
            self.counters["frame.skipped_bytes"] += garbage
        del buf[:i]
        if end_of_datagram:
            self._signature_left = 0
        if len(buf) > MAX_FRAME + SIGNATURE_LEN:  # cannot happen: a kept tail is one incomplete candidate
            self.counters["frame.skipped_bytes"] += len(buf)
            buf.clear()
            self._signature_left = 0
        return out

    def _after_signature(self, buf: bytearray, i: int, end_of_datagram: bool) -> int | None:
        """buf[i:i + _signature_left] is the signature of a frame just decoded. The next frame starts after it,
        or inside it when the signature lost bytes. Returns where to scan on, or None to wait for more bytes."""
        end = i + self._signature_left
        verdict = self._probe(buf, end, end_of_datagram)
        if verdict:
            return end  # the usual case: a valid frame right after the signature
        undecided = verdict is None
        for j in range(i, min(end, len(buf))):
            if buf[j] in (V1_MARKER, V2_MARKER):
                verdict = self._probe(buf, j, end_of_datagram)
                if verdict:
                    self.counters["frame.signature_truncated"] += 1
                    return j
                undecided = undecided or verdict is None
        # No frame inside the signature: scanning goes on after it (garbage there is counted).
        return None if undecided else end

    def _probe(self, buf: bytearray, j: int, end_of_datagram: bool) -> bool | None:
        """Does a valid frame start at buf[j]? None: cannot tell before more bytes arrive. Counts nothing."""
        if j >= len(buf):
            return False if end_of_datagram else None
        if buf[j] not in (V1_MARKER, V2_MARKER):
            return False
        header = header_verdict(buf, j)
        if header is None:
            return False if end_of_datagram else None
        if header is not True:
            return False
        length = frame_length(buf, j)
        if length is None or len(buf) - j < length:
            return False if end_of_datagram else None
        try:
            msg = self._decoder(buf, j).decode(bytearray(buf[j:j + length]))
        except Exception:  # noqa: BLE001
            return False
        return not isinstance(msg, (mavlink2.MAVLink_unknown, mavlink2.MAVLink_bad_data))

    def _decoder(self, buf, i: int):
        """Our dialect for its messages, pymavlink's ArduPilot dialect for the rest."""
        msgid = buf[i + 5] if buf[i] == V1_MARKER else buf[i + 7] | buf[i + 8] << 8 | buf[i + 9] << 16
        return self.mav if msgid in mavlink2.mavlink_map else self._ardupilot

    def _decode(self, frame: bytes):
        try:
            msg = self._decoder(frame, 0).decode(bytearray(frame))
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
        if isinstance(msg, mavlink2.MAVLink_unknown):
            # pymavlink returns an unknown msgid without any CRC check (no CRC_EXTRA): garbage holding a 0xFD
            # and a length would be accepted and swallow the valid frames it spans.
            self.counters["frame.unknown_msgid"] += 1
            return None
        return msg
