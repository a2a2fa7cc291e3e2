"""Hostile recordings: real MCAP files written by jostle's writer (or the plain MCAP writer with
jostle's schemas), then damaged byte-wise. Bombs run in a subprocess under a 512 MB address-space
cap: bounded memory, one line, no traceback. Damaged chunks are skipped, the rest is kept."""

from __future__ import annotations

import json
import os
import resource
import struct
import subprocess
import sys
import time
import warnings
from pathlib import Path

import cv2
import numpy as np
import pytest
import zstandard
from mcap.writer import CompressionType, Writer
from recording_fixtures import sample_frames, write_recording

from sensors.base import ColorImage, Frame
from sensors.recording.codec import (
    META_KIND,
    META_ROLE,
    META_SENSOR,
    SCHEMA_RAW_IMAGE,
    EncodedMessage,
    encode_frame,
    schema_definition,
)
from sensors.recording.damage import frames_kept, recovered_share
from sensors.recording.index import read_index
from sensors.recording.info import RecordingDamaged, describe_recording, format_info
from sensors.recording.source import iter_frames

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
    prefix = header + b"\x32" + _varint(2 * w * h)
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


def _varint(n: int) -> bytes:
    out = bytearray()
    while True:
        out.append((n & 0x7F) | (0x80 if n > 0x7F else 0))
        n >>= 7
        if not n:
            return bytes(out)


def zeros_zstd_body(c: zstandard.ZstdCompressionObj, n: int) -> bytes:
    block = bytes(1 << 20)
    return b"".join(c.compress(block[: min(1 << 20, n - i)]) for i in range(0, n, 1 << 20))


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


# ---------------------------------------------------------------- recovery past damage


def test_a_zeroed_block_in_chunk_1_keeps_every_later_chunk(tmp_path: Path) -> None:
    with DEMO.open("rb") as f:
        index = read_index(f.fileno(), DEMO.stat().st_size)
    assert index is not None and len(index.chunks) == 8
    second = index.chunks[1]
    data = bytearray(DEMO.read_bytes())
    data[second.offset + 64 : second.offset + 64 + 4096] = bytes(4096)
    lost = sum(1 for _ in range(second.message_count))
    for name, content in (("summary", bytes(data)), ("walk", bytes(data[: len(no_summary(DEMO))]))):
        path = tmp_path / f"zeroed_{name}.mcap"
        path.write_bytes(content)
        assert frames_kept(path) == 240 - lost, name  # chunks 0 and 2-7 all kept
        info = describe_recording(path, verify=True)
        assert info.truncated and info.losses.chunks == 1 and info.losses.messages == lost
        text = format_info(info)
        assert "DAMAGED" in text and f"1 damaged chunk ({second.length / 1e3:.1f} KB, {lost} messages)" in text


def test_a_corrupt_chunk_0_is_not_a_file_without_channels(tmp_path: Path) -> None:
    with DEMO.open("rb") as f:
        index = read_index(f.fileno(), DEMO.stat().st_size)
    assert index is not None
    first = index.chunks[0]
    data = bytearray(DEMO.read_bytes())
    data[first.offset + 80 : first.offset + 80 + 64] = bytes(range(64))
    path = tmp_path / "chunk0.mcap"
    path.write_bytes(bytes(data))
    for verify in (False, True):
        info = describe_recording(path, verify=verify)
        assert [c.topic for c in info.sensor_channels] == ["webcam"] and info.sensor_channels[0].width == 480
    with pytest.warns(RecordingDamaged, match=rf"damaged at byte {first.offset} .*reading goes on"):
        got = list(iter_frames(path))
    assert len(got) == 240 - first.message_count


@pytest.mark.parametrize("source", [DEMO, ROOT / "tests/fixtures/crossing2.mcap"], ids=["demo", "crossing2"])
def test_recovered_share_over_every_kind_of_damage(tmp_path: Path, source: Path) -> None:
    """One colour channel (demo) and webcam + depth + pads (crossing2, the virtual performer's)."""
    recovery = recovered_share(source, tmp_path)
    assert len(recovery.cases) == 8 and recovery.intact > 1000
    assert recovery.share >= 0.99, recovery.cases
    assert not list(tmp_path.iterdir())  # the damaged copies are removed


def test_a_truncated_walk_resumes_after_a_zeroed_chunk_header(tmp_path: Path) -> None:
    """A zeroed chunk header cannot be skipped by its length: the reader scans for the next chunk."""
    with DEMO.open("rb") as f:
        index = read_index(f.fileno(), DEMO.stat().st_size)
    assert index is not None
    third = index.chunks[3]
    data = bytearray(no_summary(DEMO))
    data[third.offset : third.offset + 48] = bytes(48)
    path = tmp_path / "header.mcap"
    path.write_bytes(bytes(data))
    info = describe_recording(path)
    assert info.losses.chunks == 1 and info.losses.bytes >= third.length
    assert info.sensor_channels[0].message_count == 240 - third.message_count


# ---------------------------------------------------------------- time stamps and concatenation


@pytest.mark.parametrize("bad_ns", [10**19 - 1, 2**63 - 1, 1000 * 10**9])
def test_a_frame_stamped_far_ahead_is_skipped_not_waited_for(tmp_path: Path, bad_ns: int) -> None:
    items = colour_items(20)
    _, seq, m = items[10]
    items[10] = (bad_ns, seq, m)
    path = write_messages(tmp_path / "jump.mcap", items)
    info = describe_recording(path)
    (cam,) = info.sensor_channels
    assert cam.message_count == 19 and cam.bad_times == 1 and info.duration < 1.0
    assert info.losses.frames == 1 and "1 damaged frame skipped" in format_info(info)
    from sensors.base import SensorState
    from sensors.clock import SimClock
    from sensors.recording.replay import Replay

    clock = SimClock()
    replay = Replay(path, clock)
    got = []
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        replay.open()
        while replay.status.state is not SensorState.ENDED:
            frame = replay.read(0.0)
            if frame is None:
                clock.advance(1 / 60)
                assert clock.now() < 5.0, "the replay waits for the far frame"
            else:
                got.append(frame.seq)
        replay.close()
    assert got == [i for i in range(20) if i != 10]
    texts = [str(w.message) for w in caught if issubclass(w.category, RecordingDamaged)]
    assert len(texts) == 1 and "skipped: timestamp" in texts[0]


def test_a_second_recording_appended_is_said_not_read(tmp_path: Path) -> None:
    first = write_messages(tmp_path / "a.mcap", colour_items(10))
    second = write_recording(tmp_path / "b.mcap", sample_frames(seconds=0.2))
    both = tmp_path / "both.mcap"
    both.write_bytes(first.read_bytes() + second.read_bytes())
    info = describe_recording(both, verify=True)
    assert info.losses.appended == second.stat().st_size and not info.truncated
    assert "not read" in format_info(info) and "another file appended" in format_info(info)
    with pytest.warns(RecordingDamaged, match=rf"{second.stat().st_size} bytes after the end of the recording"):
        assert len(list(iter_frames(both, "cam"))) == 10


# ---------------------------------------------------------------- what is not a recording file


@pytest.mark.parametrize("kind", ["a folder", "a FIFO", "a character device", "a symlink loop", "missing"])
def test_jostle_info_refuses_what_is_not_a_regular_file_in_one_line(tmp_path: Path, kind: str,
                                                                     capsys: pytest.CaptureFixture[str]) -> None:
    from jostle.cli import main

    path = tmp_path / "take.mcap"
    if kind == "a folder":
        path.mkdir()
    elif kind == "a FIFO":
        os.mkfifo(path)  # opening it would block: it must be refused by its kind, before any open
    elif kind == "a character device":
        path = Path("/dev/zero")
    elif kind == "a symlink loop":
        path.symlink_to(path)
    assert main(["info", str(path)]) == 2
    err = capsys.readouterr().err.strip()
    expected = {"a symlink loop": "symlink loop", "missing": "recording not found"}.get(kind, f"found {kind}")
    assert err.startswith(f"jostle: error: {path}: ") and expected in err and "\n" not in err


def test_a_depth_frame_with_a_calibration_for_another_size_is_skipped(tmp_path: Path) -> None:
    from foxglove_schemas_protobuf.CameraCalibration_pb2 import CameraCalibration

    frames = [f for f in sample_frames(seconds=0.3) if f.sensor == "depth"]
    items = [(round(f.t * 1e9), f.seq, m) for f in frames for m in encode_frame(f, round(f.t * 1e9))]
    for i, (t_ns, seq, m) in enumerate(items):
        if m.role == "calibration" and seq == 3:
            other = CameraCalibration.FromString(m.data)
            other.width, other.height = 640, 400
            items[i] = (t_ns, seq, EncodedMessage(m.topic, m.sensor, m.role, m.kind, m.schema_name,
                                                  m.message_encoding, other.SerializeToString()))
    path = write_messages(tmp_path / "calibration.mcap", items)
    with pytest.warns(RecordingDamaged, match=r"calibration for 640x400 pixels, but the depth image is 160x120"):
        got = list(iter_frames(path, "depth"))
    assert [f.seq for f in got] == [s for s in range(len(frames)) if s != 3]


# ---------------------------------------------------------------- generated damage


def _mutations(data: bytes, n: int, seed: int) -> list[tuple[str, bytes]]:
    """``n`` byte-wise damaged copies of ``data``: zeroed blocks, random bytes, flipped bits, cuts,
    a block moved elsewhere, a record header overwritten; seeded, so a failure can be replayed."""
    rng = np.random.default_rng(seed)
    out = []
    for i in range(n):
        kind = ("zeros", "random", "bits", "cut", "move", "header")[i % 6]
        b = bytearray(data)
        at = int(rng.integers(8, len(b) - 64))
        size = int(rng.choice([1, 16, 512, 4096, 32768]))
        if kind == "zeros":
            b[at : at + size] = bytes(len(b[at : at + size]))
        elif kind == "random":
            b[at : at + size] = rng.integers(0, 256, len(b[at : at + size]), dtype=np.uint8).tobytes()
        elif kind == "bits":
            for j in rng.integers(8, len(b), 8):
                b[int(j)] ^= 1 << int(rng.integers(0, 8))
        elif kind == "cut":
            del b[at:]
        elif kind == "move":
            block = bytes(b[at : at + size])
            del b[at : at + size]
            to = int(rng.integers(8, len(b)))
            b[to:to] = block
        else:  # an opcode and a length that claim anything
            b[at : at + 9] = struct.pack("<BQ", int(rng.choice([0x05, 0x06, 0x07, 0x0F, 0x80])),
                                         int(rng.integers(0, 2**63)))
        out.append((f"{kind} at {at} ({size})", bytes(b)))
    return out


def _read_everything(path: Path) -> int:
    from sensors.base import RecordingCorrupt, SensorUnavailable
    from sensors.recording.source import iter_payloads

    try:
        info = describe_recording(path, verify=True)
        describe_recording(path)
        return sum(sum(1 for _ in iter_payloads(path, c.topic, on_damage=None)) for c in info.sensor_channels)
    except (RecordingCorrupt, SensorUnavailable) as e:  # the user errors a recording may give
        assert "\n" not in str(e)
        return 0


@pytest.mark.parametrize(("seed", "summary"), [(1, True), (2, False)], ids=["summary", "walk"])
def test_generated_damage_gives_frames_or_one_user_error_never_a_crash(tmp_path: Path, seed: int,
                                                                         summary: bool) -> None:
    source = write_recording(tmp_path / "source.mcap", sample_frames(seconds=0.5), chunk_size=16 * 1024)
    data = source.read_bytes() if summary else no_summary(source)
    complete = _read_everything(source)
    for name, damaged in _mutations(data, 24, seed):
        path = tmp_path / "damaged.mcap"
        path.write_bytes(damaged)
        start = time.monotonic()
        assert 0 <= _read_everything(path) <= complete, name
        assert time.monotonic() - start < 10, name


@pytest.mark.slow
def test_generated_damage_many(tmp_path: Path) -> None:
    source = write_recording(tmp_path / "source.mcap", sample_frames(seconds=1.0), chunk_size=16 * 1024)
    complete = _read_everything(source)
    for name, damaged in _mutations(source.read_bytes(), 600, 7):
        path = tmp_path / "damaged.mcap"
        path.write_bytes(damaged)
        assert 0 <= _read_everything(path) <= complete, name
