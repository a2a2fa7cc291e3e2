"""Recording and replay: round trips, the Recorder wrapper, damaged files, info, the registry."""

from __future__ import annotations

import json
import subprocess
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest
from mcap.reader import make_reader
from mcap_protobuf.decoder import DecoderFactory
from recording_fixtures import INTRINSICS, drawn_color, sample_frames, write_recording

from sensors.base import (
    ColorImage,
    DepthImage,
    Frame,
    PadSample,
    RecordingCorrupt,
    Sensor,
    SensorState,
    SensorUnavailable,
    frame_digest,
)
from sensors.clock import SimClock
from sensors.recording.info import RecordingDamaged, describe_recording, format_info
from sensors.recording.replay import Replay, ReplayConfig
from sensors.recording.source import iter_frames
from sensors.recording.writer import Recorder, RecordingWriter
from sensors.registry import SENSOR_TYPES

JPEG_MEAN_ABS_MAX = 3.0  # levels; measured ≈1.1 first generation, ≈0.6 the next, at quality 85


def by_sensor(frames: list[Frame], name: str) -> list[Frame]:
    return [f for f in frames if f.sensor == name]


def play_all(sensor: Sensor, clock: SimClock, step: float = 1 / 60, limit: float = 30.0) -> list[Frame]:
    """Step the clock and read every frame until the sensor's recording ends."""
    out: list[Frame] = []
    sensor.open()
    while sensor.status.state is not SensorState.ENDED and clock.now() < limit:
        frame = sensor.read(0.0)
        if frame is None:
            clock.advance(step)
        else:
            out.append(frame)
    sensor.close()
    return out


def replay_channel(path: Path, channel: str, *, loop: bool = False) -> list[Frame]:
    clock = SimClock(3.0)
    return play_all(Replay(path, clock, channel=channel, loop=loop), clock)


@pytest.fixture(scope="module")
def frames() -> list[Frame]:
    return sample_frames(seconds=1.0)


@pytest.fixture(scope="module")
def jpeg_file(tmp_path_factory: pytest.TempPathFactory, frames: list[Frame]) -> Path:
    path = tmp_path_factory.mktemp("rec") / "jpeg.mcap"
    return write_recording(path, frames, chunk_size=64 * 1024, metadata={"scene": "test bench"})


@pytest.fixture(scope="module")
def png_file(tmp_path_factory: pytest.TempPathFactory, frames: list[Frame]) -> Path:
    return write_recording(tmp_path_factory.mktemp("rec") / "png.mcap", frames, color_format="png")


# ---------------------------------------------------------------- round trips


@pytest.mark.parametrize("sensor", ["depth", "pads"])
def test_depth_and_pads_round_trip_exactly(jpeg_file: Path, frames: list[Frame], sensor: str) -> None:
    want = by_sensor(frames, sensor)
    got = list(iter_frames(jpeg_file, sensor))
    assert [frame_digest(f) for f in got] == [frame_digest(f) for f in want]
    if sensor == "depth":
        d = got[0].payload
        assert isinstance(d, DepthImage)
        assert (d.fx, d.fy, d.cx, d.cy) == INTRINSICS and d.depth_mm.dtype == np.uint16
        assert got[0].payload.color is not None and got[1].payload.color is None  # type: ignore[union-attr]


def test_color_png_is_exact_and_jpeg_within_tolerance(png_file: Path, jpeg_file: Path, frames: list[Frame]) -> None:
    want = by_sensor(frames, "cam")
    png = list(iter_frames(png_file, "cam"))
    assert [frame_digest(f) for f in png] == [frame_digest(f) for f in want]
    jpeg = list(iter_frames(jpeg_file, "cam"))
    assert [(f.t, f.seq) for f in jpeg] == [(f.t, f.seq) for f in want]
    for a, b in zip(jpeg, want, strict=True):
        assert isinstance(a.payload, ColorImage) and isinstance(b.payload, ColorImage)
        diff = np.abs(a.payload.bgr.astype(int) - b.payload.bgr.astype(int))
        assert a.payload.size == b.payload.size
        assert 0 < diff.mean() < JPEG_MEAN_ABS_MAX  # lossy, but close


def test_times_round_to_whole_nanoseconds(tmp_path: Path) -> None:
    t = 1 / 3 + 1e-11
    path = write_recording(tmp_path / "t.mcap", [Frame("pads", t, 7, PadSample((1.0,), (2,)))])
    (got,) = iter_frames(path, "pads")
    assert got.t == round(t * 1e9) / 1e9 and abs(got.t - t) <= 0.5e-9 and got.seq == 7


def test_standard_mcap_reader_sees_foxglove_schemas(jpeg_file: Path) -> None:
    """What Foxglove Studio reads: schema names, formats, encodings, times and calibration."""
    seen: dict[str, int] = {}
    with jpeg_file.open("rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        for schema, channel, message in reader.iter_messages():
            seen[channel.topic] = seen.get(channel.topic, 0) + 1
            assert message.log_time == message.publish_time
            if channel.message_encoding == "json":
                assert schema is not None and schema.encoding == "jsonschema"
                assert json.loads(schema.data)["type"] == "object"
                body = json.loads(message.data)
                assert set(body) == {"newtons", "raw"}
        summary = reader.get_summary()
        assert summary is not None and summary.statistics is not None
    with jpeg_file.open("rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        for schema, channel, message, proto in reader.iter_decoded_messages(topics=["cam", "depth", "depth/calibration"]):
            assert proto.timestamp.seconds * 10**9 + proto.timestamp.nanos == message.log_time
            assert schema is not None
            if channel.topic == "cam":
                assert schema.name == "foxglove.CompressedImage" and proto.format == "jpeg"
            elif channel.topic == "depth":
                assert schema.name == "foxglove.RawImage" and proto.encoding == "16UC1"
                assert proto.step == 2 * proto.width
            else:
                assert schema.name == "foxglove.CameraCalibration"
                fx, fy, cx, cy = INTRINSICS
                assert list(proto.K) == [fx, 0, cx, 0, fy, cy, 0, 0, 1]
    assert seen["cam"] == 30 and seen["depth"] == 30 and seen["pads"] == 100 and seen["depth/color"] == 10


# ---------------------------------------------------------------- recorder


def test_recorder_writes_exactly_what_read_returned(png_file: Path, tmp_path: Path) -> None:
    returned: dict[str, list[Frame]] = {}
    out = tmp_path / "rerecorded.mcap"
    with RecordingWriter(out, color_format="png") as writer:
        for channel in ("cam", "depth", "pads"):
            clock = SimClock(3.0)
            recorder = Recorder(Replay(png_file, clock, channel=channel), writer)
            returned[channel] = play_all(recorder, clock)
    for channel, frames in returned.items():
        assert len(frames) > 0
        assert [frame_digest(f) for f in iter_frames(out, channel)] == [frame_digest(f) for f in frames]
        # replaying the re-recording gives the very frames a replay of the original gives
        again, original = replay_channel(out, channel), replay_channel(png_file, channel)
        assert [frame_digest(f) for f in again] == [frame_digest(f) for f in original]


def test_jpeg_rerecording_keeps_times_and_stays_within_tolerance(jpeg_file: Path, tmp_path: Path) -> None:
    out = tmp_path / "again.mcap"
    clock = SimClock(3.0)  # as replay_channel
    with RecordingWriter(out) as writer:
        first = play_all(Recorder(Replay(jpeg_file, clock, channel="cam"), writer), clock)
    second = replay_channel(out, "cam")
    assert [(f.t, f.seq) for f in second] == [(f.t, f.seq) for f in first]
    for a, b in zip(first, second, strict=True):
        diff = np.abs(a.payload.bgr.astype(int) - b.payload.bgr.astype(int))  # type: ignore[union-attr]
        assert diff.mean() < JPEG_MEAN_ABS_MAX


# ---------------------------------------------------------------- replay timing


def test_replay_delivers_frames_only_when_due(jpeg_file: Path, frames: list[Frame]) -> None:
    clock = SimClock(10.0)
    replay = Replay(jpeg_file, clock, channel="pads")
    replay.open()
    first = replay.read(0.0)
    assert first is not None and first.t == 10.0 and first.seq == 0
    assert replay.read(5.0) is None  # next pad sample is 10 ms away: nothing due, and no waiting
    assert clock.now() == 10.0
    clock.advance(0.0255)  # two more samples (t+0.01, t+0.02) are due now, not the third
    got = [replay.read(0.0), replay.read(0.0), replay.read(0.0)]
    assert [f.seq for f in got if f] == [1, 2] and got[2] is None
    want = by_sensor(frames, "pads")[1:3]
    assert [round(f.t - 10.0, 9) for f in got if f] == [w.t for w in want]
    replay.close()


def test_channels_stay_in_step_and_spec_comes_from_the_recording(jpeg_file: Path) -> None:
    clock = SimClock(0.0)
    cam, pads = Replay(jpeg_file, clock, channel="cam"), Replay(jpeg_file, clock, channel="pads")
    assert cam.spec.kind == "color" and (cam.spec.width, cam.spec.height) == (160, 120)
    assert cam.spec.rate_hz == pytest.approx(30.0, rel=1e-6) and pads.spec.pads == 4
    cam.open()
    pads.open()
    clock.advance(0.5)
    cam_frames = list(iter(lambda: cam.read(0.0), None))
    pad_frames = list(iter(lambda: pads.read(0.0), None))
    assert (cam_frames[-1].seq, pad_frames[-1].seq) == (15, 50)
    assert cam_frames[-1].t == pad_frames[-1].t == 0.5  # one time origin for every channel of a file


def test_loop_keeps_seq_and_t_increasing(jpeg_file: Path) -> None:
    clock = SimClock(0.0)
    replay = Replay(jpeg_file, clock, channel="cam", loop=True)
    replay.open()
    got: list[Frame] = []
    while clock.now() < 2.5:
        frame = replay.read(0.0)
        if frame is None:
            clock.advance(1 / 60)
        else:
            got.append(frame)
    assert len(got) >= 70 and replay.status.state is SensorState.CONNECTED
    assert all(b.seq > a.seq and b.t > a.t for a, b in zip(got, got[1:], strict=False))
    assert got[30].seq == 30 and got[30].t == pytest.approx(1.0, abs=1e-6)  # second pass starts one frame later


def test_channel_choice_errors_list_the_channels(jpeg_file: Path, tmp_path: Path) -> None:
    with pytest.raises(SensorUnavailable, match=r"3 sensor channels \(cam \(color\), depth \(depth\), pads \(pads\)\)"):
        Replay(jpeg_file, SimClock()).open()
    with pytest.raises(SensorUnavailable, match="no sensor channel 'nope'"):
        Replay(jpeg_file, SimClock(), channel="nope").open()
    single = write_recording(tmp_path / "one.mcap", [Frame("pads", 0.0, 0, PadSample((1.0,), (1,)))])
    assert Replay(single, SimClock()).spec.name == "pads"


# ---------------------------------------------------------------- damaged and wrong files


@pytest.mark.parametrize("fraction", [0.12, 0.37, 0.5, 0.81, 0.97])
def test_truncated_file_replays_a_prefix_and_warns_once(jpeg_file: Path, tmp_path: Path, fraction: float) -> None:
    data = jpeg_file.read_bytes()
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(data[: int(len(data) * fraction)])
    complete = replay_channel(jpeg_file, "depth")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        got = replay_channel(cut, "depth")
    damage = [w for w in caught if issubclass(w.category, RecordingDamaged)]
    assert len(damage) == 1, [str(w.message) for w in caught]
    text = str(damage[0].message)
    assert str(cut) in text and "damaged at byte" in text and "\n" not in text
    assert 0 < len(got) < len(complete)
    assert [frame_digest(f) for f in got] == [frame_digest(f) for f in complete[: len(got)]]
    info = describe_recording(cut)
    assert info.truncated and not info.complete


def test_file_cut_in_its_summary_keeps_every_frame(jpeg_file: Path, tmp_path: Path) -> None:
    data = jpeg_file.read_bytes()
    cut = tmp_path / "cut_summary.mcap"
    cut.write_bytes(data[:-30])  # the footer and magic are gone, all chunks remain
    with pytest.warns(RecordingDamaged, match="damaged at byte"):
        got = replay_channel(cut, "pads")
    assert len(got) == 100


def test_corrupt_chunk_in_the_middle_is_skipped(jpeg_file: Path, tmp_path: Path) -> None:
    data = bytearray(jpeg_file.read_bytes())
    middle = len(data) // 2
    data[middle : middle + 64] = bytes(64)  # zeroes inside a compressed chunk
    bad = tmp_path / "flipped.mcap"
    bad.write_bytes(bytes(data))
    with pytest.warns(RecordingDamaged, match=r"chunk record unreadable.*reading goes on"):
        got = replay_channel(bad, "cam")
    assert 20 < len(got) < 30  # one chunk lost, the ones after it played


def test_garbage_file_is_refused_in_one_line(tmp_path: Path) -> None:
    junk = tmp_path / "holiday.mcap"
    junk.write_bytes(b"GIF89a" + bytes(range(256)) * 4)
    with pytest.raises(RecordingCorrupt) as e:
        Replay(junk, SimClock()).open()
    assert str(e.value).startswith(f"{junk}: not an MCAP recording (") and "\n" not in str(e.value)
    empty = tmp_path / "empty.mcap"
    empty.write_bytes(b"")
    with pytest.raises(RecordingCorrupt, match="the file is empty"):
        describe_recording(empty)


def test_missing_file_is_unavailable_and_named(tmp_path: Path) -> None:
    missing = tmp_path / "nowhere" / "take1.mcap"
    with pytest.raises(SensorUnavailable, match=str(missing)):
        Replay(missing, SimClock()).open()


# ---------------------------------------------------------------- info


def test_describe_recording_counts_and_duration(jpeg_file: Path) -> None:
    info = describe_recording(jpeg_file)
    counts = {c.topic: c.message_count for c in info.channels}
    assert counts == {"cam": 30, "depth": 30, "depth/calibration": 30, "depth/color": 10, "pads": 100}
    assert [c.topic for c in info.sensor_channels] == ["cam", "depth", "pads"]
    assert info.duration == pytest.approx(0.99)  # last pad sample at 0.99 s
    assert not info.truncated and info.complete and info.size_bytes == jpeg_file.stat().st_size
    assert info.metadata["scene"] == "test bench" and info.metadata["jostle_version"]
    cam = next(c for c in info.channels if c.topic == "cam")
    assert (cam.width, cam.height, cam.schema_name) == (160, 120, "foxglove.CompressedImage")
    assert cam.rate_hz == pytest.approx(30.0, rel=1e-6) and cam.last_t == pytest.approx(29 / 30)
    text = format_info(info)
    assert "depth/calibration" in text and "160x120" in text and "complete" in text and "4 pads" in text


# ---------------------------------------------------------------- writer rules


def test_writer_refuses_time_going_back_and_kind_changes(tmp_path: Path) -> None:
    with RecordingWriter(tmp_path / "w.mcap") as w:
        w.write(Frame("cam", 1.0, 0, ColorImage(drawn_color(0))))
        with pytest.raises(ValueError, match="time went back"):
            w.write(Frame("cam", 0.5, 1, ColorImage(drawn_color(1))))
        with pytest.raises(ValueError, match="recorded color frames so far"):
            w.write(Frame("cam", 2.0, 2, PadSample((1.0,), (1,))))
        with pytest.raises(ValueError, match="metadata"):
            RecordingWriter(tmp_path / "x.mcap", metadata={"created": "yesterday"})
    w.close()  # idempotent
    with pytest.raises(ValueError, match="closed"):
        w.write(Frame("cam", 3.0, 3, ColorImage(drawn_color(3))))


# ---------------------------------------------------------------- registry and config


def test_registry_imports_no_backend() -> None:
    code = ("import sys, sensors.registry; "
            "print(','.join(m for m in ('cv2', 'depthai', 'serial') if m in sys.modules))")
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert result.stdout.strip() == ""


def test_registry_loads_a_replay(jpeg_file: Path) -> None:
    entry = SENSOR_TYPES["replay"]
    config = entry.config(path=jpeg_file, channel="pads")
    clock = SimClock()
    sensor = entry.loader(config, "floor", clock)
    frames = play_all(sensor, clock)
    assert len(frames) == 100 and frames[0].sensor == "floor" and sensor.spec.name == "floor"
    assert set(SENSOR_TYPES) >= {"webcam", "replay"} and all(t.description for t in SENSOR_TYPES.values())


@pytest.mark.parametrize(
    ("kwargs", "field"),
    [({"path": "x.mcap"}, "path"), ({"path": Path("")}, "path"), ({"path": Path("a.mcap"), "loop": 1}, "loop"),
     ({"path": Path("a.mcap"), "channel": 3}, "channel")],
)
def test_replay_config_errors_name_the_field(kwargs: dict[str, object], field: str) -> None:
    with pytest.raises(ValueError, match=rf"^{field}: "):
        ReplayConfig(**kwargs)  # type: ignore[arg-type]


def test_a_foxglove_file_from_another_writer_replays(tmp_path: Path) -> None:
    """Channels without jostle metadata are recognised by their Foxglove schema."""
    import cv2
    from foxglove_schemas_protobuf.CompressedImage_pb2 import CompressedImage
    from mcap_protobuf.writer import Writer

    path = tmp_path / "foreign.mcap"
    with path.open("wb") as f, Writer(f) as writer:
        for i in range(5):
            ok, png = cv2.imencode(".png", drawn_color(i))
            msg = CompressedImage(frame_id="front", data=png.tobytes(), format="png")
            writer.write_message("/front/image", msg, log_time=10**9 + i * 10**8, publish_time=0)
    got = list(iter_frames(path))
    assert [f.sensor for f in got] == ["/front/image"] * 5 and [f.t for f in got] == [1.0, 1.1, 1.2, 1.3, 1.4]
    assert all(np.array_equal(f.payload.bgr, drawn_color(i)) for i, f in enumerate(got))  # type: ignore[union-attr]
    assert [f.seq for f in got] == [0] * 5  # that writer leaves sequence at 0 ...
    replayed = replay_channel(path, "/front/image")
    assert [f.seq for f in replayed] == [0, 1, 2, 3, 4]  # ... a Replay keeps its seq increasing
