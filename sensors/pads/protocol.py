"""Wire formats of serial force-pad boards, as data: a table of framings and one stream parser.

Both framings end every message with one delimiter byte, so one parser serves both; what differs
(delimiter, longest message, how a message decodes, how sequence numbers wrap) is a row of
:data:`FRAMINGS`. The byte-level specification is ``docs/pads-protocol.md``.

- ``binary``: COBS-encoded frames ended (and, from the reference firmware, also started) by 0x00.
  Decoded frame: header byte (version << 4 | type), sequence u16 LE, pad count u8, one int32 LE
  raw count per pad, CRC-16/CCITT-FALSE of everything before it, big-endian.
- ``csv``: text lines ``seq,raw0,raw1,...`` (or ``raw0,raw1,...`` without a sequence number), ended
  by ``\\n`` (``\\r\\n`` accepted); blank lines and lines starting with ``#`` are ignored.

The parser never raises on bad input: a message that does not decode is counted (``bad``,
``bad_bytes``, ``last_bad``) and skipped, and the next delimiter resynchronises the stream.
This module imports no hardware backend.
"""

from __future__ import annotations

import binascii
import re
import struct
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import NamedTuple

PROTOCOL_VERSION = 1
TYPE_PAD_SAMPLE = 1
HEADER_PAD_SAMPLE = (PROTOCOL_VERSION << 4) | TYPE_PAD_SAMPLE  # 0x11
MAX_PADS = 255  # the pad-count byte
_HEAD = 4  # header, seq (2), pad count
_CRC = 2
_INT32 = (-(2**31), 2**31 - 1)
_CSV_FIELD_CHARS = 24  # generous: "-2147483648" is 11, spaces allowed around fields
_CSV_NUMBER = re.compile(rb"[ \t]*[+-]?[0-9]{1,20}[ \t]*")  # plain decimal: no '_', no '0x', no other digits


class WireSample(NamedTuple):
    """One decoded message: the board's sequence number (None if it sends none) and raw counts."""

    seq: int | None
    counts: tuple[int, ...]


class BadMessage(ValueError):
    """A message that cannot be decoded; the text says why (kept as the parser's ``last_bad``)."""


Decoder = Callable[[bytes], WireSample | None]  # None: a message to ignore (blank, comment, other type)


# ---------------------------------------------------------------- COBS and CRC


def crc16_ccitt_false(data: bytes) -> int:
    """CRC-16/CCITT-FALSE: polynomial 0x1021, init 0xFFFF, not reflected, no final XOR."""
    return binascii.crc_hqx(data, 0xFFFF)


def cobs_encode(data: bytes) -> bytes:
    """Consistent Overhead Byte Stuffing: ``data`` with every 0x00 removed (no delimiter added).

    Blocks of up to 254 bytes; a block that ends the data exactly after 254 non-zero bytes gets no
    trailing code (the canonical form: 254 non-zero bytes encode to 0xFF and the bytes).
    """
    out = bytearray()
    start = 0
    n = len(data)
    while True:
        zero = data.find(0, start, start + 254)
        if zero >= 0:
            out.append(zero - start + 1)
            out += data[start:zero]
            start = zero + 1
            continue
        end = min(start + 254, n)
        out.append(end - start + 1)
        out += data[start:end]
        if end == n:
            return bytes(out)
        start = end  # a full block of 254 non-zero bytes (code 0xFF): no zero follows it


def cobs_decode(encoded: bytes) -> bytes:
    """Undo :func:`cobs_encode`; raise BadMessage on a 0x00 inside or a block past the end."""
    out = bytearray()
    i = 0
    n = len(encoded)
    while i < n:
        code = encoded[i]
        if code == 0:
            raise BadMessage("COBS: a zero byte inside a frame")
        j = i + code
        if j > n:
            raise BadMessage("COBS: a block runs past the end of the frame (truncated frame)")
        out += encoded[i + 1 : j]
        if code != 0xFF and j < n:
            out.append(0)
        i = j
    return bytes(out)


# ---------------------------------------------------------------- binary frames


def binary_frame_size(pads: int) -> int:
    """Bytes of one decoded pad-sample frame: header, seq, pad count, counts, CRC."""
    return _HEAD + 4 * pads + _CRC


def _binary_max_message(pads: int) -> int:
    """The longest frame of any pad count (not only ``pads``), so a board with another count is named."""
    size = binary_frame_size(max(pads, MAX_PADS))
    return size + size // 254 + 1  # COBS adds one code byte per 254-byte block


def _binary_decoder(pads: int) -> Decoder:
    size = binary_frame_size(pads)
    counts = struct.Struct(f"<{pads}i")
    crc_hqx = binascii.crc_hqx

    def decode(message: bytes) -> WireSample | None:
        frame = cobs_decode(message)
        if len(frame) < _HEAD + _CRC:
            raise BadMessage(f"a frame of {len(frame)} bytes is too short (truncated)")
        if crc_hqx(frame, 0xFFFF) != 0:  # the CRC over the frame and its big-endian CRC is 0
            raise BadMessage("CRC mismatch (corrupted or truncated frame)")
        header = frame[0]
        if header >> 4 != PROTOCOL_VERSION:
            raise BadMessage(f"the board speaks protocol version {header >> 4}, this driver reads version "
                             f"{PROTOCOL_VERSION} (update the firmware or jostle)")
        if header & 0x0F != TYPE_PAD_SAMPLE:
            return None  # another frame type of this version: not a pad sample, skipped
        if frame[3] != pads:
            raise BadMessage(f"the board sends {frame[3]} pads, the config says pads = {pads}")
        if len(frame) != size:
            raise BadMessage(f"a {pads}-pad frame is {size} bytes, this one is {len(frame)}")
        return WireSample(frame[1] | frame[2] << 8, counts.unpack_from(frame, _HEAD))

    return decode


def encode_binary(seq: int, counts: Sequence[int]) -> bytes:
    """One pad-sample frame on the wire, as the reference firmware sends it: 0x00, COBS, 0x00."""
    n = len(counts)
    if not 1 <= n <= MAX_PADS:
        raise ValueError(f"counts: expected 1..{MAX_PADS} pads, got {n}")
    frame = bytes((HEADER_PAD_SAMPLE, seq & 0xFF, (seq >> 8) & 0xFF, n)) + struct.pack(f"<{n}i", *counts)
    frame += crc16_ccitt_false(frame).to_bytes(2, "big")
    return b"\x00" + cobs_encode(frame) + b"\x00"


# ---------------------------------------------------------------- CSV lines


def _csv_max_message(pads: int) -> int:
    return _CSV_FIELD_CHARS * (pads + 1) + 2


def _csv_decoder(pads: int) -> Decoder:
    lo, hi = _INT32

    def decode(line: bytes) -> WireSample | None:
        line = line.strip()  # also drops the \r of \r\n
        if not line or line[0] == 0x23:  # blank, or a "# comment" (boot banners, notes)
            return None
        fields = line.split(b",") if b"," in line else line.split()
        n = len(fields)
        if n != pads and n != pads + 1:
            raise BadMessage(f"a line of {n} fields; expected {pads} counts, or seq and {pads} counts")
        if not all(_CSV_NUMBER.fullmatch(f) for f in fields):  # int() also takes 1_000 (1000), 2_2 (22)
            raise BadMessage("a field is not a whole number in plain decimal (digits, an optional sign)")
        values = [int(f) for f in fields]
        seq: int | None = None
        if n == pads + 1:
            seq = values.pop(0)
            if not 0 <= seq < 2**32:
                raise BadMessage(f"seq {seq} is outside 0..4294967295")
        for v in values:
            if not lo <= v <= hi:
                raise BadMessage(f"count {v} does not fit a signed 32-bit integer")
        return WireSample(seq, tuple(values))

    return decode


def encode_csv(seq: int, counts: Sequence[int]) -> bytes:
    """One CSV line ``seq,raw0,raw1,...\\n``."""
    return (",".join(str(int(v)) for v in (seq, *counts)) + "\n").encode()


# ---------------------------------------------------------------- the table


@dataclass(frozen=True)
class Framing:
    """One wire format: how messages end, how long they may be, how they decode and encode."""

    name: str
    delimiter: int  # the byte that ends every message
    message: str  # what one message is called in reports: "frame" or "line"
    seq_modulus: int  # sequence numbers wrap at this value
    max_message: Callable[[int], int]  # longest acceptable message for N pads (delimiter excluded)
    decoder: Callable[[int], Decoder]  # N pads → a decoder of one message
    encode: Callable[[int, Sequence[int]], bytes]  # (seq, counts) → bytes on the wire
    description: str


FRAMINGS: dict[str, Framing] = {
    "binary": Framing("binary", 0x00, "frame", 2**16, _binary_max_message, _binary_decoder, encode_binary,
                      "COBS frames ended by 0x00, CRC-16/CCITT-FALSE, u16 sequence, int32 LE counts"),
    "csv": Framing("csv", 0x0A, "line", 2**32, _csv_max_message, _csv_decoder, encode_csv,
                   "text lines 'seq,raw0,raw1,...' (or without seq), \\n or \\r\\n, no integrity check"),
}


# ---------------------------------------------------------------- the stream parser


class StreamParser:
    """Bytes in, decoded samples out; resynchronises at every delimiter, never raises on bad input.

    Counters (cumulative; :meth:`reset` keeps them): ``samples`` decoded, ``bad`` messages that did
    not decode (``last_bad`` says why), ``bad_bytes`` in them, ``ignored`` messages (blank lines,
    comments, frame types that are not pad samples), ``skipped_bytes`` before the first delimiter
    after a (re)start — a frame the port opened in the middle of, not counted as bad unless it
    is a whole bad message.
    """

    def __init__(self, framing: Framing | str, pads: int) -> None:
        self.framing = FRAMINGS[framing] if isinstance(framing, str) else framing
        if not 1 <= pads <= MAX_PADS:
            raise ValueError(f"pads: expected 1..{MAX_PADS}, got {pads}")
        self.pads = pads
        self._decode = self.framing.decoder(pads)
        self._max = self.framing.max_message(pads)
        self._delimiter = bytes((self.framing.delimiter,))
        self._pending = b""
        self._discarding = False  # inside a run longer than any message, until the next delimiter
        self._fresh = True  # no delimiter seen since the (re)start
        self.samples = 0
        self.bad = 0
        self.bad_bytes = 0
        self.ignored = 0
        self.skipped_bytes = 0
        self.last_bad = ""

    def reset(self) -> None:
        """Forget a partial message (after a reconnect); the counters are kept."""
        self._pending = b""
        self._discarding = False
        self._fresh = True

    def _reject(self, part: bytes, reason: str, fresh: bool) -> None:
        if fresh:
            self.skipped_bytes += len(part)
            return
        self.bad += 1
        self.bad_bytes += len(part)
        self.last_bad = reason

    def _count_run(self, part: bytes, fresh: bool) -> None:
        if fresh:
            self.skipped_bytes += len(part)
        else:
            self.bad_bytes += len(part)

    def feed(self, data: bytes) -> list[WireSample]:
        """Parse the next bytes of the stream; return the samples completed by them, in order."""
        if self._pending:
            data = self._pending + data
        parts = data.split(self._delimiter)
        tail = parts.pop()
        out: list[WireSample] = []
        decode = self._decode
        limit = self._max
        for part in parts:
            fresh = self._fresh
            self._fresh = False
            if self._discarding:  # the end of an over-long run, already counted as one message
                self._discarding = False
                self._count_run(part, fresh)
                continue
            if not part:
                continue
            if len(part) > limit:
                self._reject(part, f"a {len(part)}-byte {self.framing.message}, longer than any "
                                   f"{self.framing.message} can be", fresh)
                continue
            try:
                sample = decode(part)
            except BadMessage as e:
                self._reject(part, str(e), fresh)
                continue
            if sample is None:
                self.ignored += 1
            else:
                out.append(sample)
        if self._discarding:
            self._count_run(tail, self._fresh)
            tail = b""
        elif len(tail) > limit:
            self._reject(tail, f"more than {limit} bytes with no delimiter (wrong framing or baudrate?)",
                         self._fresh)
            self._discarding = True
            tail = b""
        self._pending = tail
        self.samples += len(out)
        return out


class SequenceTracker:
    """Counts frames lost between the board's wrapping sequence numbers (serial-number arithmetic).

    A step forward of ``d`` (mod ``modulus``) means ``d - 1`` frames were lost; a step of 0 is a
    repeated frame; a step back (more than half the range "forward", or more than ``max_gap``) means
    the board restarted, and counting starts again from that frame.
    """

    def __init__(self, modulus: int) -> None:
        self.modulus = modulus
        self.last: int | None = None
        self.dropped = 0
        self.restarts = 0
        self.repeats = 0

    def reset(self) -> None:
        self.last = None

    def advance(self, seq: int | None, max_gap: int | None = None) -> int | None:
        """Frames lost just before this one (0 if none or unknown); None for a repeat (discard it)."""
        if seq is None:
            return 0
        last, self.last = self.last, seq
        if last is None:
            return 0
        step = (seq - last) % self.modulus
        if step == 0:
            self.repeats += 1
            return None
        if step > self.modulus // 2 or (max_gap is not None and step - 1 > max_gap):
            self.restarts += 1
            return 0
        self.dropped += step - 1
        return step - 1
