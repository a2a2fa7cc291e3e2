"""Fast replay: a complete file described from its summary, each chunk read once for all sensors,
frames decoded ahead in threads — and still the very same frames, in the same order, at the same
times, whatever the timing. (Speed itself is measured by `jostle bench sensors`, not here.)"""

from __future__ import annotations

import dataclasses
import gc
import json
import os
import random
import threading
import time
import warnings
from pathlib import Path

import pytest
from mcap.writer import CompressionType, Writer
from recording_fixtures import sample_frames, write_recording

from sensors.base import Frame, SensorState, frame_digest
from sensors.clock import SimClock
from sensors.recording.codec import META_KIND, META_ROLE, META_SENSOR, encode_frame, schema_definition
from sensors.recording.index import read_chunk, read_index
from sensors.recording.info import RecordingDamaged, describe_recording, format_info
from sensors.recording.replay import Replay
from sensors.recording.source import iter_frames, open_recording

CHANNELS = ("cam", "depth", "pads")


@pytest.fixture(scope="module")
def frames() -> list[Frame]:
    return sample_frames(seconds=1.0)


@pytest.fixture(scope="module")
def recording(tmp_path_factory: pytest.TempPathFactory, frames: list[Frame]) -> Path:
    path = tmp_path_factory.mktemp("fast") / "take.mcap"
    return write_recording(path, frames, chunk_size=64 * 1024, metadata={"scene": "speed"})


def write_with(path: Path, frames: list[Frame], *, compression: CompressionType, chunked: bool = True) -> Path:
    """Frames written by the plain MCAP writer with other settings than jostle's (lossless PNG colour),
    plus a JSON channel that is no sensor."""
    ids: dict[str, int] = {}
    schemas: dict[str, int] = {}
    with path.open("wb") as f:
        w = Writer(f, chunk_size=32 * 1024, compression=compression, use_chunking=chunked)
        w.start()
        notes_schema = w.register_schema("notes", "jsonschema", b'{"type": "object"}')
        notes = w.register_channel("notes", "json", notes_schema, metadata={META_ROLE: "other"})
        for i, frame in enumerate(frames):
            t_ns = round(frame.t * 1e9)
            for m in encode_frame(frame, t_ns, color_format="png"):
                if m.schema_name not in schemas:
                    d = schema_definition(m.schema_name)
                    schemas[m.schema_name] = w.register_schema(d.name, d.encoding, d.data)
                if m.topic not in ids:
                    ids[m.topic] = w.register_channel(m.topic, m.message_encoding, schemas[m.schema_name],
                                                      metadata={META_SENSOR: m.sensor, META_ROLE: m.role,
                                                                META_KIND: m.kind})
                w.add_message(ids[m.topic], t_ns, m.data, t_ns, sequence=frame.seq)
            if i % 7 == 0:
                w.add_message(notes, t_ns, json.dumps({"i": i}).encode(), t_ns, sequence=i)
        w.finish()
    return path


def play(replays: list[Replay], clock: SimClock, step: float = 1 / 60,
         pause: random.Random | None = None, limit: float = 30.0) -> dict[str, list[Frame]]:
    """Open every replay, step the clock, read every due frame of each (sleeping at random if
    ``pause`` is given) until all have ended."""
    got: dict[str, list[Frame]] = {r.spec.name: [] for r in replays}
    for r in replays:
        r.open()
    while not all(r.status.state is SensorState.ENDED for r in replays):
        for r in replays:
            while (frame := r.read(0.0)) is not None:
                got[r.spec.name].append(frame)
                if pause is not None and pause.random() < 0.2:
                    time.sleep(pause.random() * 0.003)  # let the decoding threads run ahead, or not
        clock.advance(step)
        assert clock.now() < limit, "a replay never ended"
    for r in replays:
        r.close()
    return got


def play_file(path: Path, channels: tuple[str, ...] = CHANNELS, start: float = 0.0,
              pause: random.Random | None = None) -> dict[str, list[Frame]]:
    """One replay per channel, all on one SimClock starting at ``start``."""
    clock = SimClock(start)
    return play([Replay(path, clock, channel=c) for c in channels], clock, pause=pause)


def digests(frames: list[Frame]) -> list[str]:
    return [frame_digest(f) for f in frames]


def test_a_complete_file_is_described_from_its_summary_as_a_full_walk_would(recording: Path, tmp_path: Path,
                                                                           frames: list[Frame]) -> None:
    for path in (recording, write_with(tmp_path / "lz4.mcap", frames, compression=CompressionType.LZ4)):
        fast, walked = describe_recording(path), describe_recording(path, verify=True)
        assert not fast.checked and walked.checked
        assert dataclasses.replace(fast, checked=True) == walked
    assert "from its summary" in format_info(fast) and "notes" in format_info(fast)
    assert {c.topic: c.kind for c in fast.channels}["notes"] == "other"


def test_a_corrupt_chunk_behind_a_sound_summary_is_skipped_by_every_sensor(recording: Path, tmp_path: Path) -> None:
    with recording.open("rb") as f:
        index = read_index(f.fileno(), recording.stat().st_size)
        assert index is not None and len(index.chunks) > 4
        bad = index.chunks[len(index.chunks) // 2]
        in_bad = [m.channel.topic for m in read_chunk(f.fileno(), bad, index.channels, index.schemas)]
    data = bytearray(recording.read_bytes())
    data[bad.offset + 100 : bad.offset + 164] = bytes(64)  # inside the compressed records
    broken = tmp_path / "broken.mcap"
    broken.write_bytes(bytes(data))
    fast = describe_recording(broken)
    assert not fast.truncated and not fast.checked  # the summary is sound; chunks were not read
    walked = describe_recording(broken, verify=True)
    where = f"damaged at byte {bad.offset} "
    assert walked.truncated and where in walked.damage
    assert (walked.losses.chunks, walked.losses.bytes, walked.losses.messages) == (1, bad.length, bad.message_count)
    assert "DAMAGED" in format_info(walked) and f"1 damaged chunk ({bad.length / 1e3:.1f} KB" in format_info(walked)
    complete = play_file(recording)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        got = play_file(broken)
    texts = [str(w.message) for w in caught if issubclass(w.category, RecordingDamaged)]
    assert len(texts) == 3 and all(where in t and str(broken) in t and "\n" not in t for t in texts)  # one each
    for c in CHANNELS:
        # every frame outside the damaged chunk is played, the same frame (an aligned colour image
        # that was in the damaged chunk may be missing from the one depth frame after it)
        assert len(got[c]) == len(complete[c]) - in_bad.count(c)
        assert sum(d not in set(digests(complete[c])) for d in digests(got[c])) <= (c == "depth")


def test_every_chunk_is_decompressed_once_for_all_sensors(recording: Path) -> None:
    shared = open_recording(recording)
    try:
        clock = SimClock(5.0)
        replays = [Replay(recording, clock, channel=c) for c in CHANNELS]
        got = play(replays, clock)
        assert shared.index is not None and shared.chunks_read == len(shared.index.chunks)
        assert {c: len(f) for c, f in got.items()} == {"cam": 30, "depth": 30, "pads": 100}
    finally:
        shared.release()
    again = open_recording(recording)  # the last user gone, the file was closed: a fresh reader
    again.release()
    assert again is not shared


def test_frames_do_not_depend_on_timing_or_company(recording: Path) -> None:
    together = play_file(recording, start=2.0)
    jittered = play_file(recording, start=2.0, pause=random.Random(7))
    for c in CHANNELS:
        alone = play_file(recording, (c,), start=2.0)[c]
        assert digests(together[c]) == digests(jittered[c]) == digests(alone)
        assert [f.seq for f in alone] == list(range(len(alone)))


@pytest.mark.parametrize(
    ("compression", "chunked", "indexed"),
    [(CompressionType.ZSTD, True, True), (CompressionType.LZ4, True, True), (CompressionType.NONE, True, True),
     (CompressionType.NONE, False, False)],
)
def test_other_writers_settings_replay_exactly(tmp_path: Path, frames: list[Frame], compression: CompressionType,
                                               chunked: bool, indexed: bool) -> None:
    path = write_with(tmp_path / "other.mcap", frames, compression=compression, chunked=chunked)
    info = describe_recording(path)
    assert info.checked is not indexed and not info.truncated  # unchunked: walked record by record
    assert [c.topic for c in info.sensor_channels] == list(CHANNELS)
    for c in CHANNELS:
        want = [f for f in frames if f.sensor == c]
        assert digests(list(iter_frames(path, c))) == digests(want)  # PNG colour: bit-exact too


def test_looping_repeats_the_same_payloads(recording: Path) -> None:
    clock = SimClock(0.0)
    replay = Replay(recording, clock, channel="depth", loop=True)
    replay.open()
    got: list[Frame] = []
    while len(got) < 75:
        frame = replay.read(0.0)
        if frame is None:
            clock.advance(1 / 60)
        else:
            got.append(frame)
    replay.close()
    payloads = [frame_digest(Frame("d", 0.0, 0, f.payload)) for f in got]
    assert payloads[30:60] == payloads[:30] and payloads[60:75] == payloads[:15]
    assert [f.seq for f in got] == list(range(75))


def test_close_stops_the_decoding_thread_and_spec_alone_keeps_nothing_open(recording: Path) -> None:
    def decoders() -> list[threading.Thread]:
        return [t for t in threading.enumerate() if t.name.startswith(f"replay {recording.name}:")]

    probe = Replay(recording, SimClock(), channel="cam")
    assert probe.spec.width == 160 and not decoders()  # reading the spec starts no thread
    first = open_recording(recording)
    first.release()
    second = open_recording(recording)
    second.release()
    assert first is not second  # nobody kept the file open
    replay = Replay(recording, SimClock(), channel="cam")
    replay.open()
    assert replay.read(0.0) is not None and len(decoders()) == 1
    replay.close()
    replay.close()
    assert not decoders()


def test_a_file_cut_while_it_plays_is_damage_not_a_crash(recording: Path, tmp_path: Path) -> None:
    copy = tmp_path / "shrinking.mcap"
    copy.write_bytes(recording.read_bytes())
    clock = SimClock()
    replay = Replay(copy, clock, channel="depth")
    replay.open()
    first = replay.read(0.0)
    os.truncate(copy, copy.stat().st_size // 3)
    with pytest.warns(RecordingDamaged, match=rf"{copy.name}: recording damaged at byte \d+"):
        rest = play([replay], clock)["depth"]
    complete = play_file(recording, ("depth",))["depth"]
    got = [first, *rest]
    assert 0 < len(got) < len(complete) and digests(got) == digests(complete[: len(got)])  # type: ignore[arg-type]


def test_a_replay_dropped_open_stops_its_thread(recording: Path) -> None:
    replay = Replay(recording, SimClock(), channel="depth")
    replay.open()
    name = f"replay {recording.name}:depth"
    assert any(t.name == name for t in threading.enumerate())
    del replay
    gc.collect()
    assert not any(t.name == name for t in threading.enumerate())
