"""Hostile recordings for the tests: real MCAP files written with jostle's schemas and writer, then
damaged byte-wise; bombs built as they stream (never the decompressed size in memory); and a
subprocess under a 512 MB address-space cap that reports peak RSS (VmHWM of its own image)."""

from __future__ import annotations

import os
import resource
import struct
import subprocess
import sys
from pathlib import Path

import cv2
import numpy as np
import zstandard
from mcap.writer import CompressionType, Writer

from sensors.base import ColorImage, Frame
from sensors.recording.codec import (
    META_KIND,
    META_ROLE,
    META_SENSOR,
    EncodedMessage,
    encode_frame,
    schema_definition,
)

ROOT = Path(__file__).resolve().parents[1]
DEMO = ROOT / "configs/recordings/demo.mcap"  # 240 colour frames in 8 chunks, written by jostle
PHOTO = ROOT / "tests/fixtures/photos/camera.jpg"
CAP_BYTES = 512 * 1024 * 1024


def capped(code: str, *args: str) -> subprocess.CompletedProcess[str]:
    """``python -c code args`` from the repo under a 512 MB address-space cap and a 60 s timeout."""
    def cap() -> None:
        resource.setrlimit(resource.RLIMIT_AS, (CAP_BYTES, CAP_BYTES))

    env = dict(os.environ, PYTHONPATH=str(ROOT), OPENBLAS_NUM_THREADS="1", OMP_NUM_THREADS="1")
    return subprocess.run([sys.executable, "-c", code, *args], preexec_fn=cap, capture_output=True, text=True,
                          env=env, timeout=60, cwd=ROOT)


JOSTLE_INFO = "import sys; from jostle.cli import main; sys.exit(main(['info', *sys.argv[1:]]))"
# every frame of every sensor: prints frames, warnings and peak RSS (MB, VmHWM: this process image
# only, unlike ru_maxrss which a forked child inherits from pytest) as JSON
PLAY_ALL = """
import json, sys, warnings
from sensors.recording.info import describe_recording
from sensors.recording.source import iter_payloads
with warnings.catch_warnings(record=True) as caught:
    warnings.simplefilter("always")
    info = describe_recording(sys.argv[1])
    frames = sum(sum(1 for _ in iter_payloads(sys.argv[1], c.topic)) for c in info.sensor_channels)
print(json.dumps({"frames": frames, "warnings": [str(w.message) for w in caught],
                  "rss_mb": next(int(line.split()[1]) for line in open("/proc/self/status")
                                 if line.startswith("VmHWM:")) / 1024}))
"""


def write_messages(path: Path, items: list[tuple[int, int, EncodedMessage]], chunk_size: int = 16 * 1024) -> Path:
    """(t_ns, seq, message) written with the plain MCAP writer, jostle's schemas and channel metadata."""
    ids: dict[str, int] = {}
    schemas: dict[str, int] = {}
    with path.open("wb") as f:
        w = Writer(f, chunk_size=chunk_size, compression=CompressionType.ZSTD)
        w.start()
        for t_ns, seq, m in items:
            if m.schema_name not in schemas:
                d = schema_definition(m.schema_name)
                schemas[m.schema_name] = w.register_schema(d.name, d.encoding, d.data)
            if m.topic not in ids:
                ids[m.topic] = w.register_channel(m.topic, m.message_encoding, schemas[m.schema_name],
                                                  metadata={META_SENSOR: m.sensor, META_ROLE: m.role, META_KIND: m.kind})
            w.add_message(ids[m.topic], t_ns, m.data, t_ns, sequence=seq)
        w.finish()
    return path


def colour_items(n: int = 20) -> list[tuple[int, int, EncodedMessage]]:
    """``n`` frames of the real photo (shrunk to 160×120) at 30 Hz on sensor "cam"."""
    photo = cv2.resize(cv2.imread(str(PHOTO)), (160, 120))
    out = []
    for i in range(n):
        t_ns = round(i * 1e9 / 30)
        (m,) = encode_frame(Frame("cam", t_ns / 1e9, i, ColorImage(np.roll(photo, i, axis=1))), t_ns)
        out.append((t_ns, i, m))
    return out


def with_payload(message: EncodedMessage, data: bytes) -> EncodedMessage:
    from foxglove_schemas_protobuf.CompressedImage_pb2 import CompressedImage

    body = CompressedImage(frame_id=message.sensor, data=data, format="jpeg").SerializeToString()
    return EncodedMessage(message.topic, message.sensor, message.role, message.kind, message.schema_name,
                          message.message_encoding, body)


def chunk_record(compressed: bytes, declared: int, compression: bytes = b"zstd") -> bytes:
    """An MCAP chunk record around ``compressed``, claiming ``declared`` uncompressed bytes (CRC 0)."""
    body = struct.pack("<QQQII", 0, 0, declared, 0, len(compression)) + compression
    body += struct.pack("<Q", len(compressed)) + compressed
    return struct.pack("<BQ", 0x06, len(body)) + body


def zeros_zstd(n: int) -> bytes:
    """``n`` zero bytes as one zstd frame, compressed as it streams (never ``n`` bytes in memory)."""
    c = zstandard.ZstdCompressor(level=3).compressobj(size=n)
    block = bytes(1 << 20)
    parts = [c.compress(block) for _ in range(n >> 20)]
    return b"".join(parts) + c.flush()


def no_summary(path: Path) -> bytes:
    """The recording up to its summary section: chunks and message indexes, no footer."""
    data = path.read_bytes()
    (start,) = struct.unpack_from("<Q", data, len(data) - 8 - 20)
    return data[:start]


def varint(n: int) -> bytes:
    out = bytearray()
    while True:
        out.append((n & 0x7F) | (0x80 if n > 0x7F else 0))
        n >>= 7
        if not n:
            return bytes(out)


def zeros_zstd_body(c: zstandard.ZstdCompressionObj, n: int) -> bytes:
    block = bytes(1 << 20)
    return b"".join(c.compress(block[: min(1 << 20, n - i)]) for i in range(0, n, 1 << 20))


