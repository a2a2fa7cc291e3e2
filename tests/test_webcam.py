"""WebcamSensor on real video files (file timeline) and on a file:// stream (live thread, reconnects)."""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np
import pytest
from recording_fixtures import drawn_color, write_video

from sensors.base import ColorImage, Frame, SensorState, SensorUnavailable
from sensors.clock import SimClock, WallClock
from sensors.webcam.config import WebcamConfig, source_kind
from sensors.webcam.driver import WebcamSensor


@pytest.fixture(scope="module")
def video(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return write_video(tmp_path_factory.mktemp("webcam") / "drawn.mp4", frames=30, fps=30.0)


def test_file_frames_follow_the_file_timeline(video: Path) -> None:
    clock = SimClock(4.0)
    cam = WebcamSensor(WebcamConfig(source=str(video)), clock, name="cam")
    cam.open()
    assert (cam.spec.width, cam.spec.height, cam.spec.rate_hz) == (160, 120, 30.0)
    got: list[Frame] = []
    first = cam.read(1.0)
    assert first is not None and first.t == 4.0
    got.append(first)
    assert cam.read(1.0) is None  # the next frame is due 1/30 s later; a file never waits
    while cam.status.state is not SensorState.ENDED:
        clock.advance(1 / 90)
        frame = cam.read(0.0)
        if frame is not None:
            assert frame.t <= clock.now() + 1e-9  # due within a nanosecond of rounding
            got.append(frame)
    cam.close()
    assert [f.seq for f in got] == list(range(30))
    assert [f.t for f in got] == [4.0 + i / 30.0 for i in range(30)]
    for i in (0, 13, 29):  # mp4v is lossy: the drawn frames come back close, and in order
        payload = got[i].payload
        assert isinstance(payload, ColorImage)
        diff = np.abs(payload.bgr.astype(int) - drawn_color(i).astype(int)).mean()
        assert diff < 6.0
        other = np.abs(payload.bgr.astype(int) - drawn_color(i + 7).astype(int)).mean()
        assert other > diff


def test_open_errors_name_the_source_and_what_to_check(tmp_path: Path) -> None:
    with pytest.raises(SensorUnavailable, match=r"source '.*nothing.mp4'.*not found"):
        WebcamSensor(WebcamConfig(source=str(tmp_path / "nothing.mp4")), SimClock()).open()
    text = tmp_path / "notes.mp4"
    text.write_text("not a video\n")
    with pytest.raises(SensorUnavailable, match="OpenCV cannot read"):
        WebcamSensor(WebcamConfig(source=str(text)), SimClock()).open()
    with pytest.raises(SensorUnavailable, match="plugged in"):
        WebcamSensor(WebcamConfig(source="9"), SimClock()).open()


def test_stream_that_ends_reconnects(video: Path) -> None:
    """A file:// URL is a live stream: a reader thread, a bounded queue, and a reconnect at its end."""
    cam = WebcamSensor(WebcamConfig(source=f"file://{video}", reconnect_s=0.15), WallClock(), name="stream")
    cam.open()
    time.sleep(0.3)  # nobody reads for a while: the bounded queue drops the oldest frames
    seen_states: list[SensorState] = []
    frames: list[Frame] = []
    deadline = time.monotonic() + 3.0
    while time.monotonic() < deadline:
        frame = cam.read(0.02)
        if frame is not None:
            frames.append(frame)
        state = cam.status.state
        if not seen_states or seen_states[-1] is not state:
            seen_states.append(state)
        if cam.status.extra["reconnects"] >= 2 and frames and frames[-1].seq >= 30:
            break
    status = cam.status
    cam.close()
    assert SensorState.RECONNECTING in seen_states and status.extra["reconnects"] >= 2
    assert frames[-1].seq >= 30  # frames of a later pass arrived after reconnecting: CONNECTED again
    assert all(b.seq > a.seq and b.t >= a.t for a, b in zip(frames, frames[1:], strict=False))
    assert status.dropped > 0  # the thread decodes far faster than we read: the oldest frames go
    assert cam.status.state is SensorState.CLOSED


def test_reconnect_reason_is_reported(video: Path) -> None:
    cam = WebcamSensor(WebcamConfig(source=f"file://{video}", reconnect_s=5.0), WallClock(), name="stream")
    cam.open()
    deadline = time.monotonic() + 3.0
    while cam.status.state is not SensorState.RECONNECTING and time.monotonic() < deadline:
        cam.read(0.01)
    status = cam.status
    cam.close()  # must not wait for the 5 s retry
    assert status.state is SensorState.RECONNECTING
    assert "no frame from" in status.reason and "retrying every 5 s" in status.reason


def test_source_kinds_and_config_errors() -> None:
    assert [source_kind(s) for s in ("0", "/dev/video2", "rtsp://cam/1", "clips/a.mp4")] == [
        "device", "device", "url", "file"]
    for kwargs, field in [({"source": ""}, "source"), ({"width": 0}, "width"), ({"height": 2.5}, "height"),
                          ({"fps": -3}, "fps"), ({"reconnect_s": float("nan")}, "reconnect_s")]:
        with pytest.raises(ValueError, match=rf"^{field}: "):
            WebcamConfig(**kwargs)  # type: ignore[arg-type]
