"""One MCAP chunk record, opened within bounds, and the next good chunk found past damage.

A chunk record is opcode 0x06, a u64 length, then start and end time, uncompressed size and CRC,
the compression name, and the compressed records. :func:`open_chunk` decompresses it through
:func:`sensors.untrusted.decompress` with a budget tied to the compressed size (the declared
uncompressed size is a claim, never trusted), checks the CRC, and gives the inner records.
:func:`find_chunk` scans forward from a byte for the next record whose header is a consistent chunk
(known compression, fields adding up to the record length, inside the file): MCAP chunks are
independent, so reading can resume there after a damaged one.
"""

from __future__ import annotations

import os
import struct
import zlib
from collections.abc import Iterator
from dataclasses import dataclass
from io import BytesIO

from mcap.data_stream import ReadDataStream
from mcap.exceptions import McapError
from mcap.opcode import Opcode
from mcap.records import Channel, Schema

from sensors.untrusted import UntrustedInput, budget_for, decompress
from sensors.untrusted.limits import CHUNK_RECORDS_MAX, DECOMPRESS_CAP, DECOMPRESS_FLOOR, DECOMPRESS_RATIO

HEAD = struct.Struct("<BQ")  # opcode, record length
CHUNK_FIXED = struct.Struct("<QQQII")  # start, end, uncompressed size, uncompressed CRC, compression length
COMPRESSIONS = (b"", b"zstd", b"lz4")
# records a chunk may hold (MCAP spec): schema, channel, message; 0x80-0xff are private and skipped
INNER_OPCODES = frozenset({Opcode.SCHEMA, Opcode.CHANNEL, Opcode.MESSAGE})
_MESSAGE_FIXED = struct.Struct("<HIQQ")  # channel id, sequence, log time, publish time
_LONGEST_HEAD = HEAD.size + CHUNK_FIXED.size + 4 + 8  # up to the records length, compression "zstd"
_SCAN_BLOCK = 1 << 20


@dataclass(frozen=True, slots=True)
class RecordedMessage:
    """One message as stored: its channel (and schema), time, sequence, bytes and file position."""

    channel: Channel
    schema: Schema | None
    log_time_ns: int
    sequence: int
    data: bytes
    offset: int  # byte offset of the top-level record (chunk or message) that holds it


class ChunkUnreadable(Exception):
    """A chunk that cannot be read (CRC, compression, framing, limits); the message says why, one line."""


def chunk_length_at(head: bytes, at: int, room: int, *, bounded: bool = True) -> int | None:
    """The whole record length (opcode and length included) if ``head[at:]`` starts a plausible chunk
    record that fits in ``room`` bytes: opcode 0x06, a known compression, the fields adding up to
    the record length and, if ``bounded``, a declared size within the decompression budget. None
    otherwise (reads no more than the header)."""
    if at + HEAD.size + CHUNK_FIXED.size > len(head) or head[at] != Opcode.CHUNK:
        return None
    _, length = HEAD.unpack_from(head, at)
    _, _, size, _, name_length = CHUNK_FIXED.unpack_from(head, at + HEAD.size)
    name_at = at + HEAD.size + CHUNK_FIXED.size
    if name_length > 4 or name_at + name_length + 8 > len(head):
        return None
    if bytes(head[name_at:name_at + name_length]) not in COMPRESSIONS:
        return None
    (records_length,) = struct.unpack_from("<Q", head, name_at + name_length)
    if length != CHUNK_FIXED.size + name_length + 8 + records_length or HEAD.size + length > room:
        return None
    if records_length > DECOMPRESS_CAP or (bounded and size > budget_for(records_length)):
        return None
    return int(HEAD.size + length)


def file_budget(size_bytes: int) -> int:
    """Bytes all the chunks of a file of ``size_bytes`` may be read and decompressed to in one pass:
    DECOMPRESS_RATIO × its size, at least DECOMPRESS_FLOOR (``sensors.untrusted.limits``). Each chunk
    also has its own budget (``budget_for``); this one bounds the time a file of many small
    chunks, each within its own budget, can take (the recordings here decompress to 1–9× their size)."""
    return max(DECOMPRESS_FLOOR, DECOMPRESS_RATIO * size_bytes)


def open_chunk(record: bytes, what: str, left: int | None = None) -> bytes:
    """The uncompressed records of one whole chunk record (opcode and length included), CRC checked.
    ``left``: what is left of the file's budget (:func:`file_budget`), if the caller counts it.
    Raises ChunkUnreadable with one line; never allocates more than the decompression budget."""
    if chunk_length_at(record, 0, len(record), bounded=False) != len(record):
        raise ChunkUnreadable("the chunk header is not consistent with its record")
    _, _, size, crc, name_length = CHUNK_FIXED.unpack_from(record, HEAD.size)
    at = HEAD.size + CHUNK_FIXED.size
    compression = record[at:at + name_length].decode("ascii")
    at += name_length + 8
    compressed = record[at:]
    if left is not None and left < size <= budget_for(len(compressed)):  # else decompress says why
        raise ChunkUnreadable(over_file_budget(size, left))
    try:
        data = decompress(compressed, compression, size, budget_for(len(compressed)), what)
    except UntrustedInput as e:
        raise ChunkUnreadable(e.problem) from None
    if crc and zlib.crc32(data) != crc:
        raise ChunkUnreadable(f"chunk CRC {crc:#010x}, computed {zlib.crc32(data):#010x}")
    return data


def over_file_budget(size: int, left: int) -> str:
    """Why a chunk of ``size`` bytes (to read or to decompress) is refused when ``left`` remain."""
    return (f"{size} bytes to read or decompress, more than the {max(0, left)} left of the file's budget "
            f"({DECOMPRESS_RATIO}× its size) for this pass")


def inner_records(data: bytes) -> Iterator[tuple[int, int, int]]:
    """(opcode, body start, body end) of each schema, channel or message record in uncompressed chunk
    ``data``; private records are skipped. ChunkUnreadable on any other record, a cut one, or more
    than CHUNK_RECORDS_MAX records (each becomes a Python object: bounded memory)."""
    pos, end, count = 0, len(data), 0
    while pos < end:
        count += 1
        if count > CHUNK_RECORDS_MAX:
            raise ChunkUnreadable(f"more than the {CHUNK_RECORDS_MAX} records allowed in one chunk")
        if pos + HEAD.size > end:
            raise ChunkUnreadable("a record header inside the chunk is cut")
        opcode, length = HEAD.unpack_from(data, pos)
        body = pos + HEAD.size
        pos = body + length
        if pos > end:
            raise ChunkUnreadable("a record inside the chunk runs past its end")
        if opcode >= 0x80:
            continue
        if opcode not in INNER_OPCODES:
            raise ChunkUnreadable(f"a record of opcode {opcode:#04x} inside the chunk")
        yield opcode, body, pos


def find_chunk(fd: int, start: int, end: int) -> tuple[int, int] | None:
    """(offset, record length) of the first plausible chunk record at or after byte ``start`` and
    ending by ``end``, scanning ``fd`` 1 MiB at a time (bounded memory, time linear in the bytes)."""
    pos = start
    while pos < end:
        block = os.pread(fd, min(_SCAN_BLOCK + _LONGEST_HEAD, end - pos), pos)
        if not block:
            return None
        at = block.find(b"\x06")
        while 0 <= at < min(len(block), _SCAN_BLOCK):
            length = chunk_length_at(block, at, end - pos - at)
            if length is not None:
                return pos + at, length
            at = block.find(b"\x06", at + 1)
        pos += _SCAN_BLOCK
    return None


def chunk_messages(data: bytes, channels: dict[int, Channel], schemas: dict[int, Schema],
                   offset: int) -> tuple[list[RecordedMessage], int]:
    """The messages in the uncompressed records ``data`` of the chunk at byte ``offset``, and how many
    more are on channels declared nowhere (not returned); schemas and channels declared in it are
    added to ``schemas`` and ``channels``. Raises ChunkUnreadable."""
    out = []
    orphans = 0
    try:
        for opcode, body, end in inner_records(data):
            if opcode == Opcode.SCHEMA:
                schema = Schema.read(ReadDataStream(BytesIO(data[body:end])))
                schemas[schema.id] = schema
            elif opcode == Opcode.CHANNEL:
                channel = Channel.read(ReadDataStream(BytesIO(data[body:end])))
                channels[channel.id] = channel
            else:
                if end - body < _MESSAGE_FIXED.size:
                    raise ChunkUnreadable(f"message record of {end - body} bytes")
                channel_id, sequence, log_time, _ = _MESSAGE_FIXED.unpack_from(data, body)
                found = channels.get(channel_id)
                if found is None:
                    orphans += 1
                    continue
                schema = schemas.get(found.schema_id) if found.schema_id else None
                out.append(RecordedMessage(found, schema, log_time, sequence,
                                           data[body + _MESSAGE_FIXED.size:end], offset))
    except (struct.error, UnicodeDecodeError, McapError) as e:  # a schema or channel record cut short
        raise ChunkUnreadable(f"a record inside the chunk is unreadable ({type(e).__name__})") from None
    return out, orphans
