"""Robust MAVLink frame extraction from a byte stream or from datagrams.

pymavlink's own parser trusts the first 0xFD/0xFE it sees: garbage holding one of those makes it swallow
the length that garbage claims and lose the valid frames inside it. This scanner tries every start marker
and, when a candidate fails its CRC, moves on by one byte, so every valid frame after any garbage is
decoded. pymavlink still does the decoding and CRC check of each candidate.

Speed: start markers are found with bytes.find() (C) on a copy of the buffer in which 0xFE reads as 0xFD, so the
bytes between candidates cost nothing in Python; a candidate is refused from its header (message id, strict
payload length per message id and protocol version, flags) with a few index operations, and its CRC is computed
(fastcrc, C) before pymavlink is asked to decode it. A buffer dense with markers (noise a quarter of which is
0xFD/0xFE) has every candidate's header verdict computed at once with numpy instead, and Python visits only the
candidates whose header passes: same result and counters (tests/test_overload.py compares both paths).
"""

from __future__ import annotations

import inspect
from collections import Counter

import numpy as np

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


try:  # pymavlink's own CRC uses it when installed (a pymavlink dependency); without it the pre-check is skipped
    from fastcrc.crc16 import mcrf4xx as _crc16
except ImportError:  # pragma: no cover
    _crc16 = None

_TYPE_SIZE = {"char": 1, "int8_t": 1, "uint8_t": 1, "int16_t": 2, "uint16_t": 2, "int32_t": 4, "uint32_t": 4,
              "float": 4, "int64_t": 8, "uint64_t": 8, "double": 8}


def base_length(msgtype) -> int:
    """Payload bytes of a message without its MAVLink 2 extension fields (the C library's MIN_LEN). pymavlink's
    generated classes give extension fields, and only them, a default in __init__ (checked against the XML
    definitions by tests/test_overload.py)."""
    params = list(inspect.signature(msgtype.__init__).parameters.values())[1:]
    extensions = {p.name for p in params if p.default is not inspect.Parameter.empty}
    size = 0
    for name, kind in zip(msgtype.fieldnames, msgtype.fieldtypes):
        if name not in extensions:
            size += _TYPE_SIZE[kind] * (msgtype.array_lengths[msgtype.ordered_fieldnames.index(name)] or 1)
    return size


# Strict payload lengths per message id. MAVLink 1 carries the whole payload: exactly the message's length,
# without its extensions (C libraries) or with them (pymavlink sends them in MAVLink 1 too). MAVLink 2 cuts
# trailing zero bytes down to at least one, so anything from 1 byte to the full length with extensions.
# A checksum-collision "frame" claiming any other length is refused before it can swallow what follows it.
V2_MAX_PAYLOAD = {msgid: msgtype.unpacker.size for msgid, msgtype in KNOWN_MESSAGES.items()}
V1_PAYLOAD_LENGTHS = {msgid: frozenset({base_length(msgtype), msgtype.unpacker.size})
                      for msgid, msgtype in KNOWN_MESSAGES.items() if msgid < 256}
CRC_EXTRA = {msgid: msgtype.crc_extra for msgid, msgtype in KNOWN_MESSAGES.items()}
_ONE_MARKER = bytes.maketrans(bytes([V1_MARKER]), bytes([V2_MARKER]))  # find() then looks for one byte value


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
    if buf[i] == V1_MARKER:
        if len(buf) - i < 6:
            return None
        lengths = V1_PAYLOAD_LENGTHS.get(buf[i + 5])
        if lengths is None:
            return "frame.unknown_msgid"  # no CRC_EXTRA: it could never be checked
        return True if buf[i + 1] in lengths else "frame.bad_length"
    if len(buf) - i < 10:
        return None
    if buf[i + 2] & ~mavlink2.MAVLINK_IFLAG_SIGNED:
        return "frame.bad_header"  # an incompatibility flag we do not know: MAVLink 2 says drop the frame
    full = V2_MAX_PAYLOAD.get(buf[i + 7] | buf[i + 8] << 8 | buf[i + 9] << 16)
    if full is None:
        return "frame.unknown_msgid"
    return True if 1 <= buf[i + 1] <= full else "frame.bad_length"


def crc_matches(buf: bytes | bytearray, i: int, length: int) -> bool:
    """The X.25 CRC of the complete candidate buf[i:i + length] (header verdict True) matches its CRC field.
    True without fastcrc: pymavlink then checks it."""
    if _crc16 is None:
        return True
    if buf[i] == V1_MARKER:
        msgid, end = buf[i + 5], i + length - 2
    else:
        msgid = buf[i + 7] | buf[i + 8] << 8 | buf[i + 9] << 16
        end = i + length - 2 - (SIGNATURE_LEN if buf[i + 2] & mavlink2.MAVLINK_IFLAG_SIGNED else 0)
    crc = _crc16(bytes([CRC_EXTRA[msgid]]), _crc16(memoryview(buf)[i + 1:end]))
    return crc == buf[end] | buf[end + 1] << 8


_PLAUSIBLE, _UNKNOWN_MSGID, _BAD_HEADER, _BAD_LENGTH, _INCOMPLETE = range(5)
_REASONS = (None, "frame.unknown_msgid", "frame.bad_header", "frame.bad_length", None)
# header_verdict() as tables: MAVLink 1 by (message id, payload length); MAVLink 2 by sorted message id.
_V1_CODE = np.full((256, 256), _UNKNOWN_MSGID, dtype=np.uint8)
for _msgid, _lengths in V1_PAYLOAD_LENGTHS.items():
    _V1_CODE[_msgid, :] = _BAD_LENGTH
    _V1_CODE[_msgid, sorted(_lengths)] = _PLAUSIBLE
_V2_IDS = np.array(sorted(V2_MAX_PAYLOAD), dtype=np.int64)
_V2_FULL = np.array([V2_MAX_PAYLOAD[m] for m in _V2_IDS.tolist()], dtype=np.int64)


_V2_EXTRA = np.array([CRC_EXTRA[m] for m in _V2_IDS.tolist()], dtype=np.int64)  # v1 ids are v2 ids too
_BYTES = [bytes([b]) for b in range(256)]


def _v2_msgid(a: np.ndarray, p: np.ndarray) -> np.ndarray:
    n = a.size
    return a[np.minimum(p + 7, n - 1)].astype(np.int64) | a[np.minimum(p + 8, n - 1)].astype(np.int64) << 8 | \
        a[np.minimum(p + 9, n - 1)].astype(np.int64) << 16


def _classify(a: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Every start marker's position in a (the buffer's bytes) and its header verdict as a code (_PLAUSIBLE, a
    refusal, or _INCOMPLETE when the header runs past the end): header_verdict() for all candidates at once."""
    n = a.size
    v1_at = a == V1_MARKER
    pos = np.flatnonzero(v1_at | (a == V2_MARKER))
    code = np.full(pos.size, _INCOMPLETE, dtype=np.uint8)
    v1 = v1_at[pos]
    sel = v1 & (pos + 6 <= n)
    p = pos[sel]
    code[sel] = _V1_CODE[a[p + 5], a[p + 1]]
    sel = ~v1 & (pos + 10 <= n)
    p = pos[sel]
    msgid = a[p + 7].astype(np.int64) | a[p + 8].astype(np.int64) << 8 | a[p + 9].astype(np.int64) << 16
    k = np.minimum(np.searchsorted(_V2_IDS, msgid), _V2_IDS.size - 1)
    mlen = a[p + 1]
    code[sel] = np.where(a[p + 2] & (0xFF ^ mavlink2.MAVLINK_IFLAG_SIGNED), _BAD_HEADER,
                         np.where(_V2_IDS[k] != msgid, _UNKNOWN_MSGID,
                                  np.where((mlen >= 1) & (mlen <= _V2_FULL[k]), _PLAUSIBLE, _BAD_LENGTH)))
    return pos, code


class FrameScanner:
    """Turns bytes into decoded pymavlink messages; every skipped byte run and bad frame is counted."""

    # A buffer holding at least this many start markers is scanned with numpy (same result, see _scan_vector):
    # numpy's fixed cost (~70 us) is then below the ~0.8 us per marker of the Python loop.
    vector_min_markers = 128

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
        buf = self._buf
        self._probed = {}  # position -> message decoded while looking inside a signature (not decoded twice)
        markers = buf.count(V1_MARKER) + buf.count(V2_MARKER)  # C
        scan = self._scan_vector if markers >= self.vector_min_markers else self._scan
        out, i, garbage, refused = scan(buf, end_of_datagram)
        self._probed = {}
        for reason, count in refused.items():
            if count:
                self.counters[reason] += count
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

    def _scan(self, buf: bytearray, end_of_datagram: bool) -> tuple[list, int, int, dict]:
        """The scan loop: (messages, bytes consumed, of which garbage, refused candidates by counter)."""
        out, i, garbage, n = [], 0, 0, len(buf)
        find = buf.translate(_ONE_MARKER).find  # the next 0xFD or 0xFE at or after a position, in C
        refused = {}  # counter -> candidates refused from their header or CRC
        while i < n:
            if self._signature_left:
                resume = self._after_signature(buf, i, end_of_datagram)
                if resume is None:
                    break  # wait for the bytes that tell where the next frame starts
                i, self._signature_left = resume, 0
                continue
            j = find(V2_MARKER, i)
            if j < 0:
                garbage += n - i
                i = n
                break
            garbage += j - i
            i = j
            # The header verdict (header_verdict(), inlined: this runs once per marker in the noise).
            if buf[i] == V1_MARKER:
                if n - i < 6:
                    header = None
                else:
                    lengths = V1_PAYLOAD_LENGTHS.get(buf[i + 5])
                    header = "frame.unknown_msgid" if lengths is None else \
                        True if buf[i + 1] in lengths else "frame.bad_length"
            elif n - i < 10:
                header = None
            elif buf[i + 2] & ~mavlink2.MAVLINK_IFLAG_SIGNED:
                header = "frame.bad_header"
            else:
                full = V2_MAX_PAYLOAD.get(buf[i + 7] | buf[i + 8] << 8 | buf[i + 9] << 16)
                header = "frame.unknown_msgid" if full is None else \
                    True if 1 <= buf[i + 1] <= full else "frame.bad_length"
            if header is None and not end_of_datagram:
                break  # wait for the rest of this header
            if header is not True:
                if header is not None:
                    refused[header] = refused.get(header, 0) + 1
                i += 1
                garbage += 1
                continue
            length = frame_length(buf, i)
            if n - i < length:
                if end_of_datagram:
                    i += 1
                    garbage += 1
                    continue
                break  # wait for the rest of this frame
            msg = self._take(buf, i, length, refused)
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
        return out, i, garbage, refused

    def _scan_vector(self, buf: bytearray, end_of_datagram: bool) -> tuple[list, int, int, dict]:
        """_scan() for a large buffer, with the same result: every candidate's header verdict is computed at
        once with numpy (_classify), and Python only visits the candidates that can be frames. Candidates
        refused from their header are counted afterwards, except those inside the frames decoded (which
        _scan() never visits)."""
        data = bytes(buf)
        data_array = np.frombuffer(data, dtype=np.uint8)
        pos, code = _classify(data_array)
        n = len(data)
        # The candidates to visit, with their frame length, CRC position and CRC_EXTRA byte.
        sel = code == _PLAUSIBLE
        p = pos[sel]
        v2 = data_array[p] == V2_MARKER
        signed = v2 & ((data_array[np.minimum(p + 2, n - 1)] & mavlink2.MAVLINK_IFLAG_SIGNED) > 0)
        mlen = data_array[np.minimum(p + 1, n - 1)].astype(np.int64)
        length = np.where(v2, V2_OVERHEAD, V1_OVERHEAD) + mlen + np.where(signed, SIGNATURE_LEN, 0)
        crc_at = p + length - 2 - np.where(signed, SIGNATURE_LEN, 0)
        msgid = np.where(v2, _v2_msgid(data_array, p), data_array[np.minimum(p + 5, n - 1)])
        extra = _V2_EXTRA[np.minimum(np.searchsorted(_V2_IDS, msgid), _V2_IDS.size - 1)]
        if end_of_datagram:  # a candidate longer than what is left is skipped, as _scan() does
            fits = p + length <= n
            p, length, crc_at, extra = p[fits], length[fits], crc_at[fits], extra[fits]
            visit = zip(p.tolist(), [_PLAUSIBLE] * p.size, length.tolist(), crc_at.tolist(), extra.tolist())
        else:
            incomplete = pos[code == _INCOMPLETE]  # wait there, whatever follows
            at = np.concatenate([p, incomplete])
            order = np.argsort(at, kind="stable")
            zeros = np.zeros(incomplete.size, dtype=np.int64)
            codes = np.concatenate([np.full(p.size, _PLAUSIBLE), np.full(incomplete.size, _INCOMPLETE)])
            visit = zip(at[order].tolist(), codes[order].tolist(), np.concatenate([length, zeros])[order].tolist(),
                        np.concatenate([crc_at, zeros])[order].tolist(), np.concatenate([extra, zeros])[order].tolist())
        out, i = [], 0
        spans: list[tuple[int, int]] = []  # [start, end) of what decoded frames consumed (signatures included)
        refused = {"frame.bad_crc": 0}
        if self._signature_left:  # a stream's previous feed ended inside the signature of a decoded frame
            resume = self._after_signature(buf, 0, end_of_datagram)
            if resume is None:
                return out, 0, 0, refused
            spans.append((0, resume))
            i, self._signature_left = resume, 0
        crc16, view, probed, bad_crc = _crc16, memoryview(data), self._probed, 0
        for p, c, length, crc_at, extra in visit:
            if p < i:
                continue  # inside a frame already decoded
            if c == _INCOMPLETE:  # only when streaming: wait for the rest of the header
                i = p
                break
            if n - p < length:  # only when streaming
                i = p
                break  # wait for the rest of this frame
            msg = probed.pop(p, None) if probed else None
            if msg is None:
                if crc16 is not None and \
                        crc16(_BYTES[extra], crc16(view[p + 1:crc_at])) != data[crc_at] | data[crc_at + 1] << 8:
                    bad_crc += 1
                    continue
                msg = self._decode(data[p:p + length])
                if msg is None:
                    continue
            out.append(msg)
            if data[p] == V2_MARKER and data[p + 2] & mavlink2.MAVLINK_IFLAG_SIGNED:
                end = p + length - SIGNATURE_LEN
                self._signature_left = SIGNATURE_LEN
                resume = self._after_signature(buf, end, end_of_datagram)
                if resume is None:
                    spans.append((p, end))
                    i = end
                    break  # wait for the bytes that tell where the next frame starts
                self._signature_left = 0
                spans.append((p, resume))
                i = resume
            else:
                spans.append((p, p + length))
                i = p + length
        else:
            i = n
        # Refused candidates in what was consumed, outside decoded frames; garbage: the rest of it.
        counted = (pos < i) & (code >= _UNKNOWN_MSGID) & (code <= _BAD_LENGTH)
        if spans:
            starts = np.fromiter((s for s, _ in spans), dtype=np.int64, count=len(spans))
            ends = np.fromiter((e for _, e in spans), dtype=np.int64, count=len(spans))
            k = np.searchsorted(starts, pos, side="right") - 1
            counted &= ~((k >= 0) & (pos < ends[np.maximum(k, 0)]))
        tally = np.bincount(code[counted], minlength=len(_REASONS))
        for c, reason in enumerate(_REASONS):
            if reason is not None:
                refused[reason] = int(tally[c])
        refused["frame.bad_crc"] = bad_crc
        return out, i, i - sum(e - s for s, e in spans), refused

    def _take(self, buf: bytearray, i: int, length: int, refused: dict):
        """The message of the complete candidate at buf[i], or None (counted)."""
        msg = self._probed.pop(i, None)
        if msg is not None:
            return msg
        if not crc_matches(buf, i, length):
            refused["frame.bad_crc"] = refused.get("frame.bad_crc", 0) + 1
            return None
        return self._decode(bytes(buf[i:i + length]))

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
        if not crc_matches(buf, j, length):
            return False
        try:
            msg = self._decoder(buf, j).decode(bytearray(buf[j:j + length]))
        except Exception:  # noqa: BLE001
            return False
        if isinstance(msg, (mavlink2.MAVLink_unknown, mavlink2.MAVLink_bad_data)):
            return False
        # feed() takes this message when it gets to j, instead of decoding the frame a second time (a signed
        # frame decoded twice would look like a replay of itself).
        self._probed[j] = msg
        return True

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
