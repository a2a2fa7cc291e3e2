"""Decompression bombs and images whose headers lie, in real MCAP files: each run in a subprocess
under a 512 MB address-space cap: bounded memory, one line, no traceback; the good frames kept."""

from __future__ import annotations

import json
import struct
import time
from pathlib import Path

import cv2
import pytest
import zstandard
from hostile_recordings import (
    JOSTLE_INFO,
    PHOTO,
    PLAY_ALL,
    capped,
    chunk_record,
    colour_items,
    no_summary,
    varint,
    with_payload,
    write_messages,
    zeros_zstd,
    zeros_zstd_body,
)
from recording_fixtures import sample_frames

from sensors.recording.codec import SCHEMA_RAW_IMAGE, EncodedMessage, encode_frame
from sensors.recording.info import RecordingDamaged
from sensors.recording.source import iter_frames

# ---------------------------------------------------------------- decompression bombs


@pytest.mark.parametrize(("declared_mb", "actual_mb"), [(4900, 512), (1, 512), (100, 512), (60, 60)])
def test_a_zstd_bomb_chunk_without_a_summary_is_bounded(tmp_path: Path, declared_mb: int, actual_mb: int) -> None:
    """A small file whose one chunk of zeros claims (or really holds) gigabytes: `jostle info` stays
    under the cap and says in one line which chunk was damaged; the frames before it are kept."""
    good = write_messages(tmp_path / "good.mcap", colour_items(12))
    bomb = zeros_zstd(actual_mb << 20)
    assert len(bomb) < 80_000  # the bombs were 37-77 KB
    path = tmp_path / "bomb.mcap"
    path.write_bytes(no_summary(good) + chunk_record(bomb, declared_mb << 20))
    out = capped(JOSTLE_INFO, str(path))
    assert out.returncode == 0 and "Traceback" not in out.stderr, out.stderr[-2000:]
    status = [line for line in out.stdout.splitlines() if line.startswith("status")]
    assert len(status) == 1 and "DAMAGED" in status[0] and "chunk record unreadable" in status[0]
    assert "12 msgs" in out.stdout and "1 damaged chunk" in out.stdout
    played = json.loads(capped(PLAY_ALL, str(path)).stdout)
    assert played["frames"] == 12 and len(played["warnings"]) == 1 and played["rss_mb"] < 512


def test_many_small_bomb_chunks_are_bounded_by_the_file_budget(tmp_path: Path) -> None:
    """1500 chunks of 2 KB, each 64 MiB of zeros (each within its own budget): without a budget for
    the whole file, 96 GB to decompress (7 min here); with it, 64× the file's size at most."""
    good = write_messages(tmp_path / "good.mcap", colour_items(3))
    path = tmp_path / "many.mcap"
    path.write_bytes(no_summary(good) + chunk_record(zeros_zstd(64 << 20), 64 << 20) * 1500)
    start = time.monotonic()
    out = capped(JOSTLE_INFO, str(path))
    assert out.returncode == 0 and "Traceback" not in out.stderr, out.stderr[-2000:]
    assert "lost       1500 damaged chunks" in out.stdout and time.monotonic() - start < 30


def test_a_chunk_of_two_million_empty_messages_is_refused_by_its_record_count(tmp_path: Path) -> None:
    """22 KB on disk, 62 MB decompressed (within budget), but 2 million Python objects: refused."""
    message = struct.pack("<BQHIQQ", 0x05, 22, 1, 0, 10**8, 10**8)  # an empty message on channel 1
    c = zstandard.ZstdCompressor(level=3).compressobj()
    compressed = b"".join(c.compress(message * 100_000) for _ in range(20)) + c.flush()
    good = write_messages(tmp_path / "good.mcap", colour_items(3))
    path = tmp_path / "tiny.mcap"
    path.write_bytes(no_summary(good) + chunk_record(compressed, len(message) * 2_000_000))
    assert path.stat().st_size < 30_000
    played = json.loads(capped(PLAY_ALL, str(path)).stdout)
    assert played["frames"] == 3 and played["rss_mb"] < 512
    assert len(played["warnings"]) == 1 and "more than the 250000 records allowed in one chunk" in played["warnings"][0]


def test_a_raw_image_chunk_of_14000_squared_is_refused_by_its_budget(tmp_path: Path) -> None:
    """The issue's 15 KB depth RawImage of 14000 × 14000: a chunk claiming 392 MB from a few KB."""
    from foxglove_schemas_protobuf.RawImage_pb2 import RawImage

    w = h = 14000
    header = RawImage(frame_id="depth", width=w, height=h, encoding="16UC1", step=2 * w).SerializeToString()
    # the message record: the field's tag and length, then 392 MB of zero pixels (compressed as it streams)
    prefix = header + b"\x32" + varint(2 * w * h)
    message_body = struct.pack("<HIQQ", 1, 0, 0, 0) + prefix
    record_head = struct.pack("<BQ", 0x05, len(message_body) + 2 * w * h)
    c = zstandard.ZstdCompressor(level=3).compressobj()
    compressed = c.compress(record_head + message_body) + zeros_zstd_body(c, 2 * w * h) + c.flush()
    good = write_messages(tmp_path / "good.mcap", colour_items(5))
    path = tmp_path / "huge_raw.mcap"
    path.write_bytes(no_summary(good) + chunk_record(compressed, len(record_head) + len(message_body) + 2 * w * h))
    played = json.loads(capped(PLAY_ALL, str(path)).stdout)
    assert played["frames"] == 5 and played["rss_mb"] < 512
    assert len(played["warnings"]) == 1 and "more than the 64 MiB allowed" in played["warnings"][0]


# ---------------------------------------------------------------- images checked before decoding


def _jpeg_claiming(width: int, height: int) -> bytes:
    data = bytearray(cv2.imencode(".jpg", cv2.resize(cv2.imread(str(PHOTO)), (64, 48)))[1].tobytes())
    sof = next(i for i in range(2, len(data) - 9) if data[i] == 0xFF and data[i + 1] in (0xC0, 0xC2))
    data[sof + 5 : sof + 9] = struct.pack(">HH", height, width)
    return bytes(data)


def _png_claiming(width: int, height: int) -> bytes:
    data = bytearray(cv2.imencode(".png", cv2.resize(cv2.imread(str(PHOTO)), (64, 48)))[1].tobytes())
    data[16:24] = struct.pack(">II", width, height)
    return bytes(data)


@pytest.mark.parametrize(("name", "payload"), [
    ("jpeg 30000x30000", _jpeg_claiming(30000, 30000)),
    ("png 20000x20000", _png_claiming(20000, 20000)),
    ("jpeg 0x48", _jpeg_claiming(0, 48)),
    ("jpeg 65000x65000", _jpeg_claiming(65000, 65000)),
    ("empty", b""),
    ("not an image", b"GIF89a" + bytes(100)),
])
def test_an_image_whose_header_lies_is_one_damaged_frame(tmp_path: Path, name: str, payload: bytes) -> None:
    items = colour_items(20)
    t_ns, seq, m = items[10]
    items[10] = (t_ns, seq, with_payload(m, payload))
    path = write_messages(tmp_path / "lying.mcap", items)
    played = json.loads(capped(PLAY_ALL, str(path)).stdout)
    assert played["frames"] == 19 and played["rss_mb"] < 512, name
    (warning,) = played["warnings"]
    assert "skipped: it cannot be decoded" in warning and "\n" not in warning and "byte" in warning


def test_a_raw_image_whose_shape_does_not_fit_its_payload_is_skipped(tmp_path: Path) -> None:
    frames = [f for f in sample_frames(seconds=0.4) if f.sensor == "depth"]
    from foxglove_schemas_protobuf.RawImage_pb2 import RawImage

    items = [(round(f.t * 1e9), f.seq, m) for f in frames for m in encode_frame(f, round(f.t * 1e9))]
    for i, (t_ns, seq, m) in enumerate(items):
        if m.topic == "depth" and seq == 5:
            lie = RawImage(frame_id="depth", width=14000, height=14000, encoding="16UC1", step=28000,
                           data=bytes(15_000)).SerializeToString()
            items[i] = (t_ns, seq, EncodedMessage(m.topic, m.sensor, m.role, m.kind, SCHEMA_RAW_IMAGE,
                                                  m.message_encoding, lie))
    path = write_messages(tmp_path / "raw.mcap", items)
    with pytest.warns(RecordingDamaged, match=r"14000 × 14000 pixels, more than"):
        got = list(iter_frames(path, "depth"))
    assert [f.seq for f in got] == [s for s in range(len(frames)) if s != 5]


