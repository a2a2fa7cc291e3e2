"""Damaged recordings: real MCAP files written by jostle's writer (or the plain MCAP writer with
jostle's schemas), then damaged byte-wise. Damaged chunks are skipped and counted, the rest kept;
bad time stamps skipped, never waited for; files that are not regular refused in one line."""

from __future__ import annotations

import os
import struct
import time
import warnings
from pathlib import Path

import numpy as np
import pytest
from hostile_recordings import DEMO, ROOT, colour_items, no_summary, write_messages
from recording_fixtures import sample_frames, write_recording

from sensors.recording.codec import EncodedMessage, encode_frame
from sensors.recording.damage import frames_kept, recovered_share
from sensors.recording.index import read_index
from sensors.recording.info import RecordingDamaged, describe_recording, format_info
from sensors.recording.source import iter_frames

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
