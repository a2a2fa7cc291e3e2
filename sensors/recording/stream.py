"""Walk an MCAP file record by record, keeping every message that can be read.

The reader frames the records itself (opcode, length, body) so it knows the byte offset of every
record, checks each record fits in the file before reading it, decompresses chunks within a budget
and validates their CRCs (:mod:`sensors.recording.chunks`). A record that cannot be read is
skipped: reading resumes after a chunk whose header is sound, else at the next plausible chunk
(chunks are independent). :attr:`RecordingStream.damage` says where the first damage is and
:attr:`RecordingStream.losses` how much was skipped. A file that is not MCAP at all is refused up
front with :class:`RecordingCorrupt`.
"""

from __future__ import annotations

import os
import stat
import struct
import zlib
from collections.abc import Iterator
from dataclasses import dataclass
from io import BytesIO
from pathlib import Path

from mcap.data_stream import ReadDataStream
from mcap.opcode import Opcode
from mcap.records import Channel, Footer, Message, Metadata, Schema

from sensors.base import RecordingCorrupt, SensorUnavailable
from sensors.recording.chunks import (
    CHUNK_FIXED,
    ChunkUnreadable,
    RecordedMessage,
    chunk_length_at,
    chunk_messages,
    file_budget,
    find_chunk,
    open_chunk,
    over_file_budget,
)
from sensors.untrusted import MissingInput, one_line
from sensors.untrusted.files import kind_of, refuse_os_error
from sensors.untrusted.limits import DECOMPRESS_CAP

MCAP_MAGIC = b"\x89MCAP0\r\n"
_RECORD_HEAD = struct.Struct("<BQ")
_FOOTER_BYTES = _RECORD_HEAD.size + 20 + len(MCAP_MAGIC)  # footer record and closing magic
_SUMMARY_MAX = 64 * 1024 * 1024  # a summary is kilobytes: one entry per chunk, schema and channel
_RECORD_MAX = DECOMPRESS_CAP  # a top-level record read whole (a chunk is 512 KiB as jostle writes them)
_READ = frozenset({Opcode.CHUNK, Opcode.SCHEMA, Opcode.CHANNEL, Opcode.METADATA, Opcode.MESSAGE, Opcode.FOOTER})

__all__ = ["MCAP_MAGIC", "Losses", "RecordedMessage", "RecordingDamage", "RecordingStream", "check_recording_file"]


@dataclass(frozen=True, slots=True)
class RecordingDamage:
    """Where a recording stops being readable."""

    offset: int  # byte offset of the first record that could not be read
    size_bytes: int
    reason: str
    good_messages: int
    last_good_ns: int | None

    def describe(self, path: Path) -> str:
        """One line for the user: the file, the byte, the reason and what was read before it."""
        if self.last_good_ns is None:
            kept = "no message before it"
        else:
            kept = f"{self.good_messages} messages before it, the last at t={self.last_good_ns / 1e9:.3f} s"
        return f"{path}: recording damaged at byte {self.offset} of {self.size_bytes} ({self.reason}); {kept}"


def check_recording_file(path: Path) -> int:
    """Raise the user-facing error if ``path`` is missing, not a regular file (a folder, FIFO or
    device is refused by name, before opening) or not MCAP; return its size in bytes."""
    try:
        st = os.stat(path)
    except (OSError, ValueError) as e:
        refusal = refuse_os_error(path, e)
        if isinstance(refusal, MissingInput):
            raise SensorUnavailable(f"{refusal.source}: recording not found (check the path; relative paths in "
                                    "a config are taken from the config file's folder)") from None
        raise SensorUnavailable(refusal.message) from None
    if not stat.S_ISREG(st.st_mode):
        raise SensorUnavailable(f"{one_line(str(path))}: expected an .mcap recording file, found {kind_of(st.st_mode)}")
    with path.open("rb") as f:
        head = f.read(len(MCAP_MAGIC))
    if head != MCAP_MAGIC:
        why = "the file is empty" if not head else f"it starts with {head!r}, not the MCAP magic"
        raise RecordingCorrupt(f"{one_line(str(path))}: not an MCAP recording ({why})")
    return st.st_size


@dataclass
class Losses:
    """What a reader skipped. ``chunks``: damaged chunks (or other records) passed over, ``bytes``
    their bytes and the gaps scanned past; ``messages``: messages known lost with them (from their
    message indexes or the file's index); ``frames``: frames skipped one by one (a bad time stamp,
    a payload that does not decode); ``appended``: bytes after the end of the recording (another
    MCAP file appended to it), not read."""

    chunks: int = 0
    bytes: int = 0
    messages: int = 0
    frames: int = 0
    appended: int = 0

    def __bool__(self) -> bool:
        return any((self.chunks, self.bytes, self.messages, self.frames, self.appended))

    def describe(self) -> str:
        """One line, e.g. '2 damaged chunks (8.2 KB, 31 messages) skipped, 1 damaged frame skipped'."""
        parts = []
        if self.chunks or self.bytes:
            what = f"{self.bytes / 1e3:.1f} KB" + (f", {self.messages} messages" if self.messages else "")
            parts.append(f"{self.chunks} damaged {'chunk' if self.chunks == 1 else 'chunks'} ({what}) skipped")
        if self.frames:
            parts.append(f"{self.frames} damaged {'frame' if self.frames == 1 else 'frames'} skipped")
        if self.appended:
            parts.append(f"{self.appended} bytes after the end of the recording (another file appended?) not read")
        return ", ".join(parts)


class RecordingStream:
    """Single-pass reader of one recording.

    Construct it (checks the file), then iterate :meth:`messages`. While iterating, ``channels``,
    ``schemas`` and ``metadata`` fill in (seeded from the summary section when the file has a
    readable one); after it, ``damage`` is None for a sound file (else where the first damage is),
    ``losses`` says what was skipped, and ``complete`` whether the footer and closing magic were there.
    A damaged record is skipped: reading resumes at the next record whose chunk header is sound.
    """

    def __init__(self, path: Path) -> None:
        self.path = Path(path)
        self.size_bytes = check_recording_file(self.path)
        self.channels: dict[int, Channel] = {}
        self.schemas: dict[int, Schema] = {}
        self.metadata: dict[str, dict[str, str]] = {}
        self.damage: RecordingDamage | None = None
        self.losses = Losses()
        self.complete = False
        self.good_messages = 0
        self.last_good_ns: int | None = None
        self._counting_lost = False  # message indexes that follow now belong to a lost chunk
        self._budget_left = file_budget(self.size_bytes)  # bytes this pass may still decompress

    def _damaged(self, offset: int, reason: str) -> None:
        if self.damage is None:
            self.damage = RecordingDamage(offset, self.size_bytes, reason, self.good_messages, self.last_good_ns)

    def messages(self) -> Iterator[RecordedMessage]:
        with self.path.open("rb") as f:
            fd = f.fileno()
            size = self.size_bytes
            self._seed_from_summary(fd)
            offset = len(MCAP_MAGIC)
            while True:
                head = os.pread(fd, _RECORD_HEAD.size, offset)
                if len(head) < _RECORD_HEAD.size:
                    self._damaged(offset, "the file ends without a footer" if not head else "truncated record header")
                    self.losses.bytes += len(head)
                    return
                opcode, length = _RECORD_HEAD.unpack(head)
                end = offset + _RECORD_HEAD.size + length
                problem = ""
                found: list[RecordedMessage] = []
                if end > size:
                    problem = f"{_opcode_name(opcode)} record of {length} bytes runs past the end of the file"
                elif not _known_or_private(opcode):
                    problem = f"unknown record opcode {opcode:#04x}"
                else:
                    try:
                        found = self._parse(fd, opcode, offset, length)
                    except Exception as e:  # bytes from disk: any parse failure is damage
                        problem = f"{_opcode_name(opcode)} record unreadable: {one_line(str(e) or type(e).__name__, 160)}"
                if problem:
                    self._damaged(offset, problem)
                    resume = self._resume(fd, offset, opcode, length, problem)
                    if resume is None:
                        return
                    offset = resume
                    continue
                for msg in found:
                    self.good_messages += 1
                    self.last_good_ns = msg.log_time_ns
                    yield msg
                offset = end
                if opcode == Opcode.FOOTER:
                    if os.pread(fd, len(MCAP_MAGIC), offset) != MCAP_MAGIC:
                        self._damaged(offset, "closing magic missing after the footer")
                        return
                    self.complete = True
                    self.losses.appended = max(0, size - offset - len(MCAP_MAGIC))
                    return

    def _resume(self, fd: int, offset: int, opcode: int, length: int, problem: str) -> int | None:
        """Where reading goes on after the damaged record at ``offset``: its end if it is a chunk with
        a sound header (only its contents are bad), else the next plausible chunk; None if none."""
        head = os.pread(fd, 64, offset)
        whole = chunk_length_at(head, 0, self.size_bytes - offset, bounded=False)
        if opcode == Opcode.CHUNK and whole is not None and whole == _RECORD_HEAD.size + length:
            self.losses.chunks += 1
            self.losses.bytes += whole
            self._counting_lost = True
            return offset + whole
        found = find_chunk(fd, offset + 1, self.size_bytes)
        nxt = found[0] if found is not None else self.size_bytes
        self.losses.chunks += 1
        self.losses.bytes += nxt - offset
        self._counting_lost = False
        return found[0] if found is not None else None

    def _seed_from_summary(self, fd: int) -> None:
        """Schemas and channels from the summary section, if the footer points to a readable one:
        a damaged first chunk then does not take every channel with it."""
        try:
            tail = os.pread(fd, _FOOTER_BYTES, self.size_bytes - _FOOTER_BYTES)
            opcode, length, start, _, crc = struct.unpack_from("<BQQQI", tail, 0)
            if opcode != Opcode.FOOTER or not tail.endswith(MCAP_MAGIC) or not 8 <= start < self.size_bytes:
                return
            if self.size_bytes - _FOOTER_BYTES - start > _SUMMARY_MAX:
                return
            summary = os.pread(fd, self.size_bytes - _FOOTER_BYTES - start, start)
            if crc and zlib.crc32(tail[:_RECORD_HEAD.size + 16], zlib.crc32(summary)) != crc:
                return  # not this file's summary (another file appended?) or a damaged one
            pos = 0
            while pos + _RECORD_HEAD.size <= len(summary):
                op, n = _RECORD_HEAD.unpack_from(summary, pos)
                body = summary[pos + _RECORD_HEAD.size:pos + _RECORD_HEAD.size + n]
                if op == Opcode.SCHEMA:
                    schema = Schema.read(ReadDataStream(BytesIO(body)))
                    self.schemas[schema.id] = schema
                elif op == Opcode.CHANNEL:
                    channel = Channel.read(ReadDataStream(BytesIO(body)))
                    self.channels[channel.id] = channel
                pos += _RECORD_HEAD.size + n
        except Exception:  # a damaged summary seeds nothing (or what was read before the damage)
            return

    def _parse(self, fd: int, opcode: int, offset: int, length: int) -> list[RecordedMessage]:
        if opcode == Opcode.MESSAGE_INDEX and self._counting_lost and length <= _RECORD_MAX:
            body = os.pread(fd, length, offset + _RECORD_HEAD.size)
            (entries,) = struct.unpack_from("<I", body, 2)
            self.losses.messages += min(entries, length) // 16
            return []
        if opcode not in _READ:
            if opcode != Opcode.MESSAGE_INDEX:
                self._counting_lost = False
            return []  # header, indexes, statistics, attachments, …: nothing a replay needs
        self._counting_lost = False
        if length > _RECORD_MAX:
            raise ValueError(f"a {_opcode_name(opcode)} record of {length} bytes is over the {_RECORD_MAX} allowed")
        if opcode == Opcode.CHUNK:  # reads overlap only when resuming past damage: they share the budget
            if _RECORD_HEAD.size + length > self._budget_left:
                raise ChunkUnreadable(over_file_budget(_RECORD_HEAD.size + length, self._budget_left))
            self._budget_left -= _RECORD_HEAD.size + length
        record = os.pread(fd, _RECORD_HEAD.size + length, offset)
        body = record[_RECORD_HEAD.size:]
        stream = ReadDataStream(BytesIO(body))
        if opcode == Opcode.CHUNK:
            left = self._budget_left
            _, _, declared, _, _ = CHUNK_FIXED.unpack_from(record, _RECORD_HEAD.size)
            if declared <= left and chunk_length_at(record, 0, len(record)) == len(record):
                self._budget_left -= declared  # charged before the attempt: one that fails costs time too
            data = open_chunk(record, f"chunk at byte {offset}", left)
            found, orphans = chunk_messages(data, self.channels, self.schemas, offset)
            if orphans:
                self.losses.messages += orphans
                self._damaged(offset, f"{orphans} messages on channels declared in no readable record")
            return found
        if opcode == Opcode.SCHEMA:
            schema = Schema.read(stream)
            self.schemas[schema.id] = schema
        elif opcode == Opcode.CHANNEL:
            channel = Channel.read(stream)
            self.channels[channel.id] = channel
        elif opcode == Opcode.METADATA:
            found_metadata = Metadata.read(stream)
            self.metadata[found_metadata.name] = dict(found_metadata.metadata)
        elif opcode == Opcode.MESSAGE:
            rec = Message.read(stream, len(body))
            channel_found = self.channels.get(rec.channel_id)
            if channel_found is None:
                raise ValueError(f"message on unknown channel id {rec.channel_id}")
            schema_found = self.schemas.get(channel_found.schema_id) if channel_found.schema_id else None
            return [RecordedMessage(channel_found, schema_found, rec.log_time, rec.sequence, rec.data, offset)]
        elif opcode == Opcode.FOOTER:
            Footer.read(stream)
        return []


def _known_or_private(opcode: int) -> bool:
    """Known opcodes and the range the MCAP spec leaves to private records (0x80-0xff)."""
    if opcode >= 0x80:
        return True
    try:
        Opcode(opcode)
    except ValueError:
        return False
    return True


def _opcode_name(opcode: int) -> str:
    try:
        return Opcode(opcode).name.lower()
    except ValueError:
        return f"unknown (opcode {opcode})"
