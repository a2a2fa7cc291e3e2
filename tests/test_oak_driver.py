"""OakSensor on host-only depthai pipelines: real depthai messages, queues, Sync node and failures.

No camera is attached here, so the device is the one thing replaced: each "connect" starts a
``HostPipelineLink`` whose host node sends drawn depth + colour frames. Everything above it — the
driver's thread, frame assembly, reconnection with back-off, status, recording — is the real code.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable, Iterator
from pathlib import Path

import numpy as np
import pytest

from sensors.base import DepthImage, Frame, SensorState, SensorUnavailable
from sensors.clock import SimClock, WallClock
from sensors.oak.config import OakConfig
from sensors.oak.driver import OakFailed, OakSensor
from sensors.oak.frames import Intrinsics
from sensors.oak.host_pipeline import HostPipelineLink
from sensors.oak.search import DeviceSearch, FoundDevice
from sensors.recording.source import iter_frames
from sensors.recording.writer import Recorder, RecordingWriter
from sensors.testing import check_sensor
from sensors.threaded import Backoff

W, H = 64, 40
K = Intrinsics(fx=55.5, fy=55.25, cx=31.75, cy=19.5, width=W, height=H)
FOUND = FoundDevice("SIM0001", "1.1", "X_LINK_UNBOOTED", "X_LINK_USB_VSC")
NOT_FOUND = "Failed to connect to device, error message: X_LINK_DEVICE_NOT_FOUND"


def scene(i: int) -> tuple[np.ndarray, np.ndarray]:
    """Frame ``i``: depth whose first pixel is the index, colour drawn from it."""
    y, x = np.mgrid[0:H, 0:W]
    depth = (2000 + 10 * y + x + (3 * i) % 400).astype(np.uint16)
    depth[0, 0] = i
    color = np.stack([(x * 4 + i) % 256, (y * 6) % 256, np.full_like(x, i % 256)], axis=-1).astype(np.uint8)
    return depth, color


class HostCamera:
    """The connector: a fresh host pipeline per connect; refuses ``refuse`` connects first (a
    device still rebooting); ``stall_after`` makes its links go quiet after that many frames."""

    def __init__(self, *, intrinsics: Intrinsics | None = K, calibration: Intrinsics | None = None,
                 color: bool = True, fps: float = 120.0, hang_s: float = 0.0) -> None:
        self.links: list[HostPipelineLink] = []
        self.intrinsics = intrinsics
        self.calibration = calibration
        self.color = color
        self.fps = fps
        self.hang_s = hang_s
        self.refuse = 0
        self.stall_after: int | None = None
        self.connects = 0
        self._lock = threading.Lock()

    def source(self, i: int) -> tuple[np.ndarray, np.ndarray | None] | None:
        if self.stall_after is not None and i >= self.stall_after:
            return None
        depth, color = scene(i)
        return depth, color if self.color else None

    def __call__(self, found: FoundDevice, config: OakConfig) -> HostPipelineLink:
        with self._lock:
            self.connects += 1
            if self.refuse:
                self.refuse -= 1
                raise RuntimeError(NOT_FOUND)
        if self.hang_s:
            time.sleep(self.hang_s)
        link = HostPipelineLink(self.source, fps=self.fps, intrinsics=self.intrinsics, calibration=self.calibration,
                                color=config.color, device_id=found.device_id)
        with self._lock:
            self.links.append(link)
        return link

    def close_all(self) -> None:
        for link in self.links:
            link.close()


@pytest.fixture
def camera() -> Iterator[HostCamera]:
    cam = HostCamera()
    yield cam
    cam.close_all()  # a host pipeline left running takes the interpreter down at exit


def oak(clock: SimClock | WallClock, camera: HostCamera, **overrides: object) -> OakSensor:
    fields: dict[str, object] = dict(width=W, height=H, fps=camera.fps, reconnect_s=0.05, reconnect_max_s=0.4,
                                     stall_s=0.5, connect_timeout_s=5.0)
    fields.update(overrides)
    config = OakConfig(**fields)  # type: ignore[arg-type]
    return OakSensor(config, clock, "oak", search=DeviceSearch(lambda: [FOUND]), connect=camera)


def depth(frame: Frame) -> DepthImage:
    assert isinstance(frame.payload, DepthImage)
    return frame.payload


def read_for(sensor: OakSensor, seconds: float, until: Callable[[], bool] | None = None) -> list[Frame]:
    frames: list[Frame] = []
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        frame = sensor.read(0.02)
        if frame is not None:
            frames.append(frame)
        if until is not None and until():
            break
    return frames


def states_until(sensor: OakSensor, done: Callable[[], bool], seconds: float = 5.0) -> list[tuple[SensorState, str]]:
    """Every distinct (state, reason) seen while reading, until ``done()``."""
    seen: list[tuple[SensorState, str]] = []
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        sensor.read(0.005)
        s = sensor.status
        if not seen or seen[-1] != (s.state, s.reason):
            seen.append((s.state, s.reason))
        if done():
            return seen
    raise AssertionError(f"gave up waiting; states seen: {seen}")


def test_the_contract_holds(camera: HostCamera) -> None:
    check_sensor(lambda clock: oak(clock, camera), duration=1.0, step=1 / 60, deterministic=False)


def test_frames_carry_depth_intrinsics_and_aligned_colour(camera: HostCamera) -> None:
    with oak(WallClock(), camera) as sensor:
        frames = read_for(sensor, 0.5)
        status = sensor.status
    assert len(frames) > 10
    for f in frames:
        p = depth(f)
        expected_depth, expected_color = scene(int(p.depth_mm[0, 0]))
        assert np.array_equal(p.depth_mm, expected_depth)
        assert p.color is not None and np.array_equal(p.color, expected_color)
        assert (p.fx, p.fy, p.cx, p.cy) == (K.fx, K.fy, K.cx, K.cy)
    assert [f.seq for f in frames] == sorted({f.seq for f in frames})
    assert status.state is SensorState.CONNECTED and status.extra["intrinsics_from_frame"] >= len(frames)


def test_a_recording_replays_depth_and_calibration_exactly(camera: HostCamera, tmp_path: Path) -> None:
    path = tmp_path / "oak.mcap"
    clock = WallClock()
    with RecordingWriter(path) as writer, Recorder(oak(clock, camera), writer) as recorder:
        live = read_for(recorder, 0.4)  # type: ignore[arg-type]
    replayed = list(iter_frames(path, "oak"))
    assert len(replayed) == len(live) > 5
    for a, b in zip(live, replayed, strict=True):
        pa, pb = depth(a), depth(b)
        assert b.seq == a.seq and b.t == pytest.approx(a.t, abs=1e-9)
        assert pb.depth_mm.dtype == np.uint16 and np.array_equal(pa.depth_mm, pb.depth_mm)
        assert pa.color is not None and pb.color is not None and np.array_equal(pa.color, pb.color)
        assert (pb.fx, pb.fy, pb.cx, pb.cy) == (pa.fx, pa.fy, pa.cx, pa.cy)


def test_calibration_fills_in_for_frames_without_intrinsics() -> None:
    camera = HostCamera(intrinsics=None, calibration=Intrinsics(111.0, 110.5, 63.5, 39.5, 128, 80))
    try:
        with oak(WallClock(), camera) as sensor:
            frame = read_for(sensor, 2.0, until=lambda: sensor.status.frames > 0)[0]
            assert sensor.status.extra["intrinsics_from_calibration"] >= 1
    finally:
        camera.close_all()
    assert (depth(frame).fx, depth(frame).cx) == pytest.approx((55.5, 31.5))

    bare = HostCamera(intrinsics=None, color=False)
    try:
        with oak(WallClock(), bare, color=False) as sensor:
            frame = read_for(sensor, 2.0, until=lambda: sensor.status.frames > 0)[0]
            assert "no intrinsics" in sensor.status.reason and sensor.status.state is SensorState.CONNECTED
    finally:
        bare.close_all()
    assert depth(frame).fx == 0.0 and depth(frame).color is None


@pytest.mark.parametrize(
    ("fault", "error", "hint"),
    [("xlink", "(X_LINK_ERROR)", "the link dropped: check the cable"),
     ("unplug", "MessageQueue was closed", "the pipeline stopped")],
)
def test_a_lost_link_reconnects_and_frames_resume(camera: HostCamera, fault: str, error: str, hint: str) -> None:
    with oak(WallClock(), camera) as sensor:
        before = read_for(sensor, 0.3)
        link = camera.links[0]
        if fault == "xlink":
            link.break_link()  # what a queue read raises after a cable glitch
        else:
            link.unplug()  # the pipeline stops: depthai's QueueException from the next read
        seen = states_until(sensor, lambda: sensor.status.extra["reconnects"] >= 1
                            and sensor.status.state is SensorState.CONNECTED)
        after = read_for(sensor, 0.3)
    reconnecting = [r for s, r in seen if s is SensorState.RECONNECTING]
    assert reconnecting, seen
    assert reconnecting[0].startswith("oak 'oak' (OAK SIM0001): lost the camera (")
    assert error in reconnecting[0] and hint in reconnecting[0]
    assert before and after
    frames = before + after
    assert all(b.seq > a.seq for a, b in zip(frames, frames[1:], strict=False))
    assert all(b.t >= a.t for a, b in zip(frames, frames[1:], strict=False))
    assert camera.connects == 2 and not camera.links[0]._pipeline.isRunning()


def test_a_rebooting_camera_is_retried_with_growing_waits(camera: HostCamera) -> None:
    with oak(WallClock(), camera) as sensor:
        read_for(sensor, 0.2)
        camera.refuse = 3  # the next three connects fail, as while the device reboots
        camera.links[0].break_link()
        seen = states_until(sensor, lambda: sensor.status.extra["reconnects"] >= 1
                            and sensor.status.state is SensorState.CONNECTED)
        assert read_for(sensor, 2.0, until=lambda: sensor.status.frames > 0)
    reasons = [r for s, r in seen if s is SensorState.RECONNECTING]
    waits = [r.rsplit("retry ", 1)[1] for r in reasons if "retry " in r]
    assert waits[:4] == ["1 in 0.05 s", "2 in 0.1 s", "3 in 0.2 s", "4 in 0.4 s"]
    assert any("X_LINK_DEVICE_NOT_FOUND" in r and "udev" in r for r in reasons)
    assert camera.connects == 5


def test_it_gives_up_after_the_configured_attempts(camera: HostCamera) -> None:
    with oak(WallClock(), camera, give_up_after=2) as sensor:
        read_for(sensor, 0.2)
        camera.refuse = 100
        camera.links[0].break_link()
        with pytest.raises(OakFailed, match=r"gave up after 2 attempts \(give_up_after\)") as info:
            read_for(sensor, 5.0)  # frames still queued come first, then the failure
        assert sensor.status.state is SensorState.FAILED and sensor.status.reason == str(info.value)
        assert "X_LINK_DEVICE_NOT_FOUND" in str(info.value)
    assert camera.connects == 3


def test_depthais_own_reconnection_shows_in_the_status(camera: HostCamera) -> None:
    with oak(WallClock(), camera) as sensor:
        read_for(sensor, 0.2)
        link = camera.links[0]
        link.report("RECONNECTING")
        states_until(sensor, lambda: sensor.status.state is SensorState.RECONNECTING, 2.0)
        assert "depthai is reconnecting" in sensor.status.reason
        link.report("RECONNECTED")
        states_until(sensor, lambda: sensor.status.state is SensorState.CONNECTED, 2.0)
        assert sensor.status.extra["reconnects"] == 1 and camera.connects == 1
        link.report("FAILED")  # depthai gave up: our own retry takes over with a new connection
        states_until(sensor, lambda: camera.connects == 2 and sensor.status.state is SensorState.CONNECTED)


def test_a_camera_that_goes_quiet_is_reconnected(camera: HostCamera) -> None:
    camera.stall_after = 20
    with oak(WallClock(), camera) as sensor:
        seen = states_until(sensor, lambda: camera.connects >= 2)
    assert any("no frame for 0.5 s (stall_s)" in r for _, r in seen)


def test_read_never_waits_longer_than_asked_while_reconnecting(camera: HostCamera) -> None:
    with oak(WallClock(), camera, reconnect_s=1.0, reconnect_max_s=1.0) as sensor:
        camera.links[0].break_link()
        states_until(sensor, lambda: sensor.status.state is SensorState.RECONNECTING, 2.0)
        for timeout in (0.0, 0.05, 0.2):
            t0 = time.monotonic()
            assert sensor.read(timeout) is None
            assert time.monotonic() - t0 < timeout + 0.1


def test_open_reports_a_camera_that_will_not_start(camera: HostCamera) -> None:
    camera.refuse = 1
    sensor = oak(SimClock(), camera)
    with pytest.raises(SensorUnavailable, match=r"oak 'oak' \(OAK SIM0001\): cannot start: .*NOT_FOUND.*udev"):
        sensor.open()
    assert sensor.status.state is SensorState.CLOSED


def test_open_is_bounded_when_connecting_hangs() -> None:
    camera = HostCamera(hang_s=1.5)
    sensor = oak(SimClock(), camera, connect_timeout_s=0.3)
    t0 = time.monotonic()
    with pytest.raises(SensorUnavailable, match=r"did not start within 0\.3 s \(connect_timeout_s\)"):
        sensor.open()
    assert time.monotonic() - t0 < 1.0
    end = time.monotonic() + 5.0
    while not camera.links and time.monotonic() < end:  # the late connection is closed by its thread
        time.sleep(0.05)
    time.sleep(0.3)
    assert camera.links and not camera.links[0]._pipeline.isRunning()
    camera.close_all()


def test_backoff_doubles_to_its_cap_and_gives_up() -> None:
    b = Backoff(0.5, 3.0, give_up_after=5)
    assert [b.next_delay() for _ in range(6)] == [0.5, 1.0, 2.0, 3.0, 3.0, None]
    b.reset()
    assert b.next_delay() == 0.5
    forever = Backoff(1.0, 1.0)
    assert all(forever.next_delay() == 1.0 for _ in range(1000))
