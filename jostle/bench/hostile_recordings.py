"""Damaged MCAP recordings for the hostile suite, and how many of their frames are intact.

:func:`write_messages` writes a recording of colour "cam", depth "depth" and pad "pads" frames
(small drawn images, chunks of :data:`CHUNK_BYTES`) with Foxglove schemas, as the recorder does,
letting one message be replaced by crafted bytes (an image whose header lies about its size) or
one frame by a wild time stamp. :func:`chunk_spans` walks a sound file's top-level records itself
(not with the reader under test) and lists each chunk's byte span and the frames it holds;
:func:`intact_frames` counts the frames none of whose messages lie in a damaged byte range: the
frames a reader that recovers past damage should still deliver.
"""

from __future__ import annotations

import struct
import zlib
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from io import BytesIO
from pathlib import Path

import numpy as np
import zstandard
from mcap.data_stream import ReadDataStream
from mcap.opcode import Opcode
from mcap.records import Channel, Chunk, Message
from mcap.stream_reader import breakup_chunk
from mcap.writer import CompressionType, Writer

from sensors.base import ColorImage, DepthImage, Frame, PadSample
from sensors.recording.codec import (
    META_KIND,
    META_ROLE,
    META_SENSOR,
    EncodedMessage,
    encode_frame,
    schema_definition,
)

W, H = 160, 128  # H ≥ 128: its protobuf varint has two bytes, like any crafted height up to 16383
SENSORS = ("cam", "depth", "pads")
CHUNK_BYTES = 48 * 1024
MAGIC = b"\x89MCAP0\r\n"
_HEAD = struct.Struct("<BQ")

FrameKey = tuple[str, int]  # (sensor, log time ns)
Tamper = Callable[[int, EncodedMessage], bytes | None]  # (frame index, message) → new bytes or None


def drawn_frames(seconds: float = 3.0, fps: float = 15.0, pads_hz: float = 50.0) -> list[Frame]:
    """Colour and depth at ``fps`` and 4 pads at ``pads_hz``, time ordered, on whole nanoseconds."""
    y, x = np.mgrid[0:H, 0:W]
    frames: list[Frame] = []
    for i in range(round(seconds * fps)):
        t = round(i * 1e9 / fps) / 1e9
        img = np.stack([(x * 255 // W), (y * 255 // H), np.full_like(x, 60)], axis=-1).astype(np.uint8)
        img[:, (5 * i) % W] = 255
        frames.append(Frame("cam", t, i, ColorImage(img)))
        depth = (3000 + 4 * y + x).astype(np.uint16)
        depth[np.abs(x - (20 + (3 * i) % (W - 40))) < 12] = 1500 + i
        frames.append(Frame("depth", t, i, DepthImage(depth, 141.25, 140.5, 79.5, 63.5)))
    for i in range(round(seconds * pads_hz)):
        t = round(i * 1e9 / pads_hz) / 1e9
        frames.append(Frame("pads", t, i, PadSample((0.5 * i, 12.25, 3.0, -0.125), (i, 512, 515, 3))))
    frames.sort(key=lambda f: f.t)
    return frames


def write_messages(
    path: Path, frames: list[Frame], *, tamper: Tamper | None = None, stamp: Callable[[int, int], int] | None = None
) -> Path:
    """Write ``frames`` as MCAP (zstd chunks); ``tamper`` may replace a message's bytes and
    ``stamp(index, t_ns)`` a frame's time (neither is checked: that is the point)."""
    with path.open("wb") as f:
        w = Writer(f, chunk_size=CHUNK_BYTES, compression=CompressionType.ZSTD)
        w.start(profile="", library="jostle-hostile")
        w.add_metadata("jostle", {"created": "2026-01-01T00:00:00+00:00", "jostle_version": "hostile"})
        schemas: dict[str, int] = {}
        channels: dict[str, int] = {}
        for index, frame in enumerate(frames):
            t_ns = round(frame.t * 1e9)
            t_ns = stamp(index, t_ns) if stamp else t_ns
            for m in encode_frame(frame, round(frame.t * 1e9)):
                if m.schema_name not in schemas:
                    d = schema_definition(m.schema_name)
                    schemas[m.schema_name] = w.register_schema(name=d.name, encoding=d.encoding, data=d.data)
                if m.topic not in channels:
                    channels[m.topic] = w.register_channel(
                        topic=m.topic, message_encoding=m.message_encoding, schema_id=schemas[m.schema_name],
                        metadata={META_SENSOR: m.sensor, META_ROLE: m.role, META_KIND: m.kind})
                data = (tamper(index, m) if tamper else None) or m.data
                w.add_message(channel_id=channels[m.topic], log_time=t_ns, data=data, publish_time=t_ns,
                              sequence=frame.seq)
        w.finish()
    return path


@dataclass(frozen=True)
class ChunkSpan:
    """One chunk record: its byte span in the file and the frames whose messages it holds."""

    start: int
    end: int
    frames: frozenset[FrameKey]


def _records(data: bytes) -> Iterator[tuple[int, int, int]]:
    """(opcode, start, end) of each top-level record of a sound file, magic excluded."""
    pos = len(MAGIC)
    while pos + _HEAD.size <= len(data):
        opcode, length = _HEAD.unpack_from(data, pos)
        end = pos + _HEAD.size + length
        yield opcode, pos, end
        if opcode == Opcode.FOOTER:
            return
        pos = end


def chunk_spans(path: Path) -> list[ChunkSpan]:
    """The chunks of a sound recording and the frames (sensor, t ns) each one holds."""
    data = path.read_bytes()
    spans: list[ChunkSpan] = []
    topics: dict[int, str] = {}
    for opcode, start, end in _records(data):
        if opcode != Opcode.CHUNK:
            continue
        chunk = Chunk.read(ReadDataStream(BytesIO(data[start + _HEAD.size:end])))
        keys: set[FrameKey] = set()
        for record in breakup_chunk(chunk):
            if isinstance(record, Channel):
                topics[record.id] = record.topic
            elif isinstance(record, Message):
                keys.add((topics[record.channel_id].split("/")[0], record.log_time))
        spans.append(ChunkSpan(start, end, frozenset(keys)))
    return spans


def intact_frames(spans: list[ChunkSpan], damaged: list[tuple[int, int]]) -> int:
    """Frames of the sensors none of whose messages lie in a chunk overlapping a damaged range."""
    lost: set[FrameKey] = set()
    every: set[FrameKey] = set()
    for s in spans:
        every |= s.frames
        if any(a < s.end and s.start < b for a, b in damaged):
            lost |= s.frames
    return sum(1 for key in every - lost if key[0] in SENSORS)


def zstd_bomb_chunk(declared: int) -> bytes:
    """A whole MCAP chunk record (opcode and length included) of ``declared`` zero bytes, zstd."""
    out = BytesIO()
    with zstandard.ZstdCompressor(level=3).stream_writer(out, size=declared, closefd=False) as z:
        block = bytes(1 << 20)
        left = declared
        while left > 0:
            z.write(block[: min(left, len(block))])
            left -= len(block)
    records = out.getvalue()
    body = struct.pack("<QQQQ", 0, 2**62, declared, 0)
    body += struct.pack("<I", 4) + b"zstd" + struct.pack("<Q", len(records)) + records
    return _HEAD.pack(Opcode.CHUNK, len(body)) + body


def header_only_bomb(path: Path, declared: int) -> Path:
    """An MCAP file of magic, header and one zstd chunk of zeros: no summary, no footer."""
    header = struct.pack("<I", 0) + struct.pack("<I", 14) + b"jostle-hostile"
    path.write_bytes(MAGIC + _HEAD.pack(Opcode.HEADER, len(header)) + header + zstd_bomb_chunk(declared))
    return path


def jpeg_with_size(jpeg: bytes, width: int, height: int) -> bytes:
    """The JPEG with its frame header (SOF0/SOF2) claiming width × height; the scan is unchanged."""
    for marker in (b"\xff\xc0", b"\xff\xc2"):
        i = jpeg.find(marker)
        if i >= 0:
            return jpeg[: i + 5] + struct.pack(">HH", height, width) + jpeg[i + 9:]
    raise ValueError("no SOF marker in the JPEG")


def png_with_size(png: bytes, width: int, height: int) -> bytes:
    """The PNG with its IHDR claiming width × height (CRC recomputed); the pixel data unchanged."""
    i = png.index(b"IHDR")
    ihdr = b"IHDR" + struct.pack(">II", width, height) + png[i + 12:i + 17]
    return png[:i] + ihdr + struct.pack(">I", zlib.crc32(ihdr)) + png[i + 21:]


def raw_image_with_size(message: bytes, width: int, height: int) -> bytes:
    """A foxglove RawImage message with its width and height fields claiming another size."""
    from foxglove_schemas_protobuf.RawImage_pb2 import RawImage

    raw = RawImage()
    raw.ParseFromString(message)
    raw.width, raw.height, raw.step = width, height, width * 2
    raw.data = bytes(width * height * 2)
    return raw.SerializeToString()
