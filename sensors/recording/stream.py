"""Walk an MCAP file record by record, keeping every message before the first damage.

The reader frames the records itself (opcode, length, body) so it knows the byte offset of every
record, checks each record fits in the file before reading it, and validates chunk CRCs. The first
record that cannot be read ends the walk; :attr:`RecordingStream.damage` then says where and why.
A file that is not MCAP at all is refused up front with :class:`RecordingCorrupt`.
"""

from __future__ import annotations

import struct
from collections.abc import Iterator
from dataclasses import dataclass
from io import BytesIO
from pathlib import Path

from mcap.data_stream import ReadDataStream
from mcap.opcode import Opcode
from mcap.records import Channel, Chunk, Footer, Message, Metadata, Schema
from mcap.stream_reader import breakup_chunk

from sensors.base import RecordingCorrupt, SensorUnavailable

MCAP_MAGIC = b"\x89MCAP0\r\n"
_RECORD_HEAD = struct.Struct("<BQ")


@dataclass(frozen=True, slots=True)
class RecordedMessage:
    """One message as stored: its channel (and schema), time, sequence, bytes and file position."""

    channel: Channel
    schema: Schema | None
    log_time_ns: int
    sequence: int
    data: bytes
    offset: int  # byte offset of the top-level record (chunk or message) that holds it


@dataclass(frozen=True, slots=True)
class RecordingDamage:
    """Where a recording stops being readable."""

    offset: int  # byte offset of the first record that could not be read
    size_bytes: int
    reason: str
    good_messages: int
    last_good_ns: int | None

    def describe(self, path: Path) -> str:
        """One line for the user: the file, the byte, the reason and what is kept."""
        if self.last_good_ns is None:
            kept = "no message before it"
        else:
            kept = f"{self.good_messages} messages kept, the last at t={self.last_good_ns / 1e9:.3f} s"
        return f"{path}: recording damaged at byte {self.offset} of {self.size_bytes} ({self.reason}); {kept}"


def check_recording_file(path: Path) -> int:
    """Raise the user-facing error if ``path`` is missing or not MCAP; return its size in bytes."""
    if not path.exists():
        raise SensorUnavailable(f"{path}: recording not found (check the path; relative paths in a "
                                "config are taken from the config file's folder)")
    if not path.is_file():
        raise SensorUnavailable(f"{path}: expected an .mcap recording file, found a directory or device")
    with path.open("rb") as f:
        head = f.read(len(MCAP_MAGIC))
    if head != MCAP_MAGIC:
        why = "the file is empty" if not head else f"it starts with {head!r}, not the MCAP magic"
        raise RecordingCorrupt(f"{path}: not an MCAP recording ({why})")
    return path.stat().st_size


class RecordingStream:
    """Single-pass reader of one recording.

    Construct it (checks the file), then iterate :meth:`messages`. While iterating, ``channels``,
    ``schemas`` and ``metadata`` fill in; after it, ``damage`` is None for a sound file and
    ``complete`` says whether the footer and closing magic were there.
    """

    def __init__(self, path: Path) -> None:
        self.path = Path(path)
        self.size_bytes = check_recording_file(self.path)
        self.channels: dict[int, Channel] = {}
        self.schemas: dict[int, Schema] = {}
        self.metadata: dict[str, dict[str, str]] = {}
        self.damage: RecordingDamage | None = None
        self.complete = False
        self.good_messages = 0
        self.last_good_ns: int | None = None

    def _damaged(self, offset: int, reason: str) -> None:
        self.damage = RecordingDamage(offset, self.size_bytes, reason, self.good_messages, self.last_good_ns)

    def messages(self) -> Iterator[RecordedMessage]:
        with self.path.open("rb") as f:
            f.seek(len(MCAP_MAGIC))
            offset = len(MCAP_MAGIC)
            while True:
                head = f.read(_RECORD_HEAD.size)
                if len(head) < _RECORD_HEAD.size:
                    why = "the file ends without a footer" if not head else "truncated record header"
                    self._damaged(offset, why)
                    return
                opcode, length = _RECORD_HEAD.unpack(head)
                end = offset + _RECORD_HEAD.size + length
                if end > self.size_bytes:
                    self._damaged(offset, f"{_opcode_name(opcode)} record of {length} bytes runs past the end "
                                          "of the file (truncated)")
                    return
                if not _known_or_private(opcode):
                    self._damaged(offset, f"unknown record opcode {opcode:#04x}")
                    return
                body = f.read(length)
                try:
                    found = self._parse(opcode, body, offset)
                except Exception as e:  # bytes from disk: any parse failure is damage, reported once
                    self._damaged(offset, f"{_opcode_name(opcode)} record unreadable: {type(e).__name__}: {e}")
                    return
                for msg in found:
                    self.good_messages += 1
                    self.last_good_ns = msg.log_time_ns
                    yield msg
                offset = end
                if opcode == Opcode.FOOTER:
                    if f.read(len(MCAP_MAGIC)) != MCAP_MAGIC:
                        self._damaged(offset, "closing magic missing after the footer")
                        return
                    self.complete = True
                    return

    def _parse(self, opcode: int, body: bytes, offset: int) -> list[RecordedMessage]:
        stream = ReadDataStream(BytesIO(body))
        if opcode == Opcode.CHUNK:
            records = breakup_chunk(Chunk.read(stream), validate_crc=True)
        elif opcode == Opcode.SCHEMA:
            records = [Schema.read(stream)]
        elif opcode == Opcode.CHANNEL:
            records = [Channel.read(stream)]
        elif opcode == Opcode.METADATA:
            records = [Metadata.read(stream)]
        elif opcode == Opcode.MESSAGE:
            records = [Message.read(stream, len(body))]
        elif opcode == Opcode.FOOTER:
            Footer.read(stream)
            return []
        else:  # header, indexes, statistics, attachments, unknown: nothing a replay needs
            return []
        out: list[RecordedMessage] = []
        for rec in records:
            if isinstance(rec, Schema):
                self.schemas[rec.id] = rec
            elif isinstance(rec, Channel):
                self.channels[rec.id] = rec
            elif isinstance(rec, Metadata):
                self.metadata[rec.name] = dict(rec.metadata)
            elif isinstance(rec, Message):
                channel = self.channels.get(rec.channel_id)
                if channel is None:
                    raise ValueError(f"message on unknown channel id {rec.channel_id}")
                schema = self.schemas.get(channel.schema_id) if channel.schema_id else None
                out.append(RecordedMessage(channel, schema, rec.log_time, rec.sequence, rec.data, offset))
        return out


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
