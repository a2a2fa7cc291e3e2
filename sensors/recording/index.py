"""A complete recording's summary section, and its chunks read one at a time by position.

An MCAP file that was closed properly ends with a summary (schemas, channels, statistics, one
index entry per chunk) and a footer pointing to it; each chunk is followed by message indexes (time
and position of every message in it). :func:`read_index` reads those — a few kilobytes — instead
of decompressing the whole file, and :func:`read_chunk` decompresses one chunk when it is needed.

The summary is used only if it is *usable*: footer and closing magic present, summary CRC right,
statistics present, every chunk's message indexes present and adding up to the statistics' message
count (so no message lives outside a chunk), every chunk inside the data section. Anything else
(a cut file, a file written without indexes, a damaged summary) gives None, and the caller walks the
file record by record instead (:class:`sensors.recording.stream.RecordingStream`).

Chunk contents are not checked here: a corrupt chunk is found (CRC, decompression, record framing)
when it is read, and :class:`ChunkUnreadable` says why.
"""

from __future__ import annotations

import os
import struct
import zlib
from collections.abc import Iterable
from dataclasses import dataclass
from io import BytesIO

from mcap.data_stream import ReadDataStream
from mcap.opcode import Opcode
from mcap.records import Channel, ChunkIndex, Metadata, MetadataIndex, Schema, Statistics

from sensors.recording.chunks import ChunkUnreadable, RecordedMessage, chunk_messages, file_budget, open_chunk
from sensors.recording.stream import MCAP_MAGIC
from sensors.untrusted import Timeline

__all__ = ["ChannelStats", "ChunkRef", "ChunkUnreadable", "RecordingIndex", "channel_stats", "chunk_messages", "read_chunk",
           "read_index"]

_HEAD = struct.Struct("<BQ")  # opcode, record length
_FOOTER = struct.Struct("<QQI")  # summary start, summary offset start, summary CRC
_FOOTER_BYTES = _HEAD.size + _FOOTER.size + len(MCAP_MAGIC)
_INDEX_ENTRY = struct.Struct("<QQ")  # log time, offset in the uncompressed chunk


@dataclass(frozen=True, slots=True)
class ChunkRef:
    """Where one chunk is and what its message indexes say about it."""

    offset: int  # byte offset of the chunk record in the file
    length: int  # the whole record, opcode and length included
    uncompressed_size: int
    message_count: int
    last_ns: int | None  # log time of its last message in file order
    channel_ids: frozenset[int]
    budget_left: int | None = None  # of the file's decompression budget before it (None: not counted)


@dataclass(frozen=True, slots=True)
class ChannelStats:
    count: int  # messages with a sound stamp (see channel_stats)
    first_ns: int
    last_ns: int
    refused: int = 0  # messages whose stamp went back or jumped too far ahead


@dataclass(frozen=True)
class RecordingIndex:
    """What the summary section and the message indexes of a complete recording say."""

    size_bytes: int
    schemas: dict[int, Schema]
    channels: dict[int, Channel]
    chunks: tuple[ChunkRef, ...]  # in file order
    channel_stats: dict[int, ChannelStats]
    metadata: dict[str, dict[str, str]]  # in file order, a later record of one name replacing an earlier


class _Unusable(Exception):
    pass


def fd_size(fd: int) -> int:
    return os.fstat(fd).st_size


def _pread(fd: int, length: int, offset: int) -> bytes:
    data = os.pread(fd, length, offset)
    if len(data) != length:
        raise _Unusable(f"{length} bytes at {offset} run past the end of the file")
    return data


def _summary_records(data: bytes) -> list[tuple[int, bytes]]:
    out = []
    pos = 0
    while pos < len(data):
        if pos + _HEAD.size > len(data):
            raise _Unusable("summary record header cut")
        opcode, length = _HEAD.unpack_from(data, pos)
        body_start = pos + _HEAD.size
        if body_start + length > len(data):
            raise _Unusable("summary record runs past the summary")
        out.append((opcode, data[body_start : body_start + length]))
        pos = body_start + length
    return out


def _message_indexes(data: bytes) -> dict[int, list[tuple[int, int]]]:
    """Message index records after one chunk → channel id → [(log time, offset in chunk)]."""
    out: dict[int, list[tuple[int, int]]] = {}
    for opcode, body in _summary_records(data):
        if opcode != Opcode.MESSAGE_INDEX:
            continue
        channel_id, length = struct.unpack_from("<HI", body, 0)
        if 6 + length > len(body) or length % _INDEX_ENTRY.size:
            raise _Unusable("message index runs past its record")
        out.setdefault(channel_id, []).extend(_INDEX_ENTRY.iter_unpack(body[6 : 6 + length]))
    return out


def read_index(fd: int, size_bytes: int) -> RecordingIndex | None:
    """The index of a complete recording open as ``fd``, or None if it has no usable summary."""
    try:
        return _read_index(fd, size_bytes)
    except Exception:  # _Unusable, or bytes from disk that do not parse: walk the file instead
        return None


def _read_index(fd: int, size_bytes: int) -> RecordingIndex:
    footer_at = size_bytes - _FOOTER_BYTES
    if footer_at < len(MCAP_MAGIC):
        raise _Unusable("too small for a footer")
    tail = _pread(fd, _FOOTER_BYTES, footer_at)
    opcode, length = _HEAD.unpack_from(tail, 0)
    if tail[-len(MCAP_MAGIC) :] != MCAP_MAGIC or opcode != Opcode.FOOTER or length != _FOOTER.size:
        raise _Unusable("no footer")
    summary_start, _, summary_crc = _FOOTER.unpack_from(tail, _HEAD.size)
    if summary_start == 0 or not len(MCAP_MAGIC) <= summary_start <= footer_at:
        raise _Unusable("no summary")
    summary = _pread(fd, footer_at - summary_start, summary_start)
    if summary_crc and zlib.crc32(tail[: _HEAD.size + 16], zlib.crc32(summary)) != summary_crc:
        raise _Unusable("summary CRC mismatch")
    schemas: dict[int, Schema] = {}
    channels: dict[int, Channel] = {}
    chunk_indexes: list[ChunkIndex] = []
    metadata_indexes: list[MetadataIndex] = []
    statistics: Statistics | None = None
    for opcode, body in _summary_records(summary):
        stream = ReadDataStream(BytesIO(body))
        if opcode == Opcode.SCHEMA:
            schema = Schema.read(stream)
            schemas[schema.id] = schema
        elif opcode == Opcode.CHANNEL:
            channel = Channel.read(stream)
            channels[channel.id] = channel
        elif opcode == Opcode.STATISTICS:
            statistics = Statistics.read(stream)
        elif opcode == Opcode.CHUNK_INDEX:
            chunk_indexes.append(ChunkIndex.read(stream))
        elif opcode == Opcode.METADATA_INDEX:
            metadata_indexes.append(MetadataIndex.read(stream))
    if statistics is None:
        raise _Unusable("no statistics")
    chunks, stats = _chunks(fd, sorted(chunk_indexes, key=lambda c: c.chunk_start_offset), summary_start)
    if sum(c.message_count for c in chunks) != statistics.message_count:
        raise _Unusable("messages outside the indexed chunks")
    for cid, s in stats.items():
        channel = channels.get(cid)
        if channel is None or (channel.schema_id and channel.schema_id not in schemas):
            raise _Unusable(f"channel {cid} not in the summary")
        if statistics.channel_message_counts.get(cid, s.count + s.refused) != s.count + s.refused:
            raise _Unusable(f"channel {cid}: statistics and message index disagree")
    metadata: dict[str, dict[str, str]] = {}
    for m in metadata_indexes:
        if not len(MCAP_MAGIC) <= m.offset < m.offset + m.length <= summary_start:
            raise _Unusable("metadata index out of the data section")
        record = _pread(fd, m.length, m.offset)
        if record[0] != Opcode.METADATA:
            raise _Unusable("metadata index points elsewhere")
        found = Metadata.read(ReadDataStream(BytesIO(record[_HEAD.size :])))
        metadata[found.name] = dict(found.metadata)
    return RecordingIndex(size_bytes, schemas, channels, tuple(chunks), stats, metadata)


def _chunks(fd: int, indexes: list[ChunkIndex], data_end: int) -> tuple[list[ChunkRef], dict[int, ChannelStats]]:
    chunks: list[ChunkRef] = []
    left = file_budget(fd_size(fd))
    stamps: dict[int, list[tuple[int, int, int]]] = {}  # channel → [(chunk offset, offset in chunk, time)]
    previous_end = len(MCAP_MAGIC)
    for c in indexes:
        index_end = c.chunk_start_offset + c.chunk_length + c.message_index_length
        if c.chunk_start_offset < previous_end or index_end > data_end or c.chunk_length <= _HEAD.size:
            raise _Unusable("chunk index out of the data section")
        previous_end = index_end
        if not c.message_index_offsets or not c.message_index_length:
            raise _Unusable("chunk without message indexes")
        entries = _message_indexes(_pread(fd, c.message_index_length, c.chunk_start_offset + c.chunk_length))
        if set(entries) != set(c.message_index_offsets):
            raise _Unusable("message indexes do not match the chunk index")
        last: tuple[int, int] | None = None  # (offset, time) of the last message in the chunk
        total = 0
        for cid, pairs in entries.items():
            total += len(pairs)
            stamps.setdefault(cid, []).extend((c.chunk_start_offset, at, t) for t, at in pairs)
            if pairs:
                at = max(pairs, key=lambda p: p[1])
                if last is None or at[1] > last[0]:
                    last = (at[1], at[0])
        chunks.append(ChunkRef(c.chunk_start_offset, c.chunk_length, c.uncompressed_size, total,
                               None if last is None else last[1], frozenset(entries), left))
        left -= c.uncompressed_size
    return chunks, {cid: channel_stats(t for _, _, t in sorted(found)) for cid, found in stamps.items() if found}


def channel_stats(times: Iterable[int]) -> ChannelStats:
    """Count, first and last of one channel's stamps in file order, through a ``Timeline``: a stamp
    going back or jumping beyond the sane gap is not counted but ``refused`` (a damaged message)."""
    timeline = Timeline("channel")
    first: int | None = None
    count = 0
    for t in times:
        if timeline.flag(t) is None:
            count += 1
            first = t if first is None else first
    last = timeline.last_ns
    return ChannelStats(count, first or 0, last or 0, timeline.refused)


# ---------------------------------------------------------------- one chunk


def read_chunk(fd: int, ref: ChunkRef, channels: dict[int, Channel],
               schemas: dict[int, Schema]) -> list[RecordedMessage]:
    """Every message of one chunk, in record order (decompressed within the budget, CRC checked);
    channels and schemas the chunk declares itself are used too. Raises ChunkUnreadable."""
    record = os.pread(fd, ref.length, ref.offset)
    if len(record) != ref.length:
        raise ChunkUnreadable("the chunk runs past the end of the file")
    data = open_chunk(record, f"chunk at byte {ref.offset}", ref.budget_left)
    if len(data) != ref.uncompressed_size:
        raise ChunkUnreadable(f"the chunk holds {len(data)} bytes, its index says {ref.uncompressed_size}")
    messages, orphans = chunk_messages(data, dict(channels), dict(schemas), ref.offset)
    if orphans:
        raise ChunkUnreadable(f"{orphans} messages on channels declared nowhere")
    return messages
