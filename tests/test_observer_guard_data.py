"""The observer guard and frames the data makes wrong: a frame size changing mid-stream (real
OpenCV webcam observer on a real photo, and in the App on the demo recording), a pad count changing to 0/3/10⁶, pad forces NaN, infinite,
1e999 or int32 extremes (5.4e8 N): each kind one warning line, the frame skipped and counted, the
observer never rebuilt, the frames before and after observed."""

from __future__ import annotations

import dataclasses
import logging
import math
from pathlib import Path

import cv2
import numpy as np
import pytest

from interaction.pads import PadsObserver, PadsObserverConfig
from interaction.webcam import WebcamObserver, WebcamObserverConfig
from interaction.webcam.calibration import Calibration
from jostle.app import App, RunOptions
from jostle.config import load_config
from jostle.observer_guard import PAD_MAX_NEWTONS, ObserverGuard
from sensors.base import ColorImage, Frame, PadSample
from sensors.clock import SimClock
from sensors.recording.source import iter_payloads
from sensors.recording.writer import RecordingWriter
from sensors.untrusted import UntrustedInput

PHOTO = Path(__file__).resolve().parent / "fixtures" / "photos" / "camera.jpg"
FOUR = PadsObserverConfig(positions=(0.0, 0.0, 1.0) * 4, directions=(0.0, 1.0, 0.0) * 4)


def _records(caplog: pytest.LogCaptureFixture) -> list[logging.LogRecord]:
    return [r for r in caplog.records if r.name == "jostle.observers" and r.levelno >= logging.WARNING]


def _guard(build: object, clock: SimClock) -> ObserverGuard:
    builds = []

    def counted() -> object:
        builds.append(1)
        return build()  # type: ignore[operator]

    guard = ObserverGuard("under-test", counted, clock)  # type: ignore[arg-type]
    guard.builds = builds  # type: ignore[attr-defined]
    return guard


def test_a_frame_size_changing_mid_stream_is_skipped_with_one_line(caplog: pytest.LogCaptureFixture) -> None:
    photo = cv2.imread(str(PHOTO))
    assert photo is not None
    big, small = cv2.resize(photo, (320, 240)), cv2.resize(photo, (200, 150))
    uv = np.array([[0, 0], [320, 0], [320, 240], [0, 240]], dtype=np.float64)
    xz = np.array([[-2.0, 3.0], [2.0, 3.0], [1.7, 0.0], [-1.7, 0.0]])
    cal = Calibration.from_correspondences(uv, xz, plane_y=0.5, half_depth=0.8, image_size=(320, 240))
    clock = SimClock()
    guard = _guard(lambda: WebcamObserver(WebcamObserverConfig(), cal), clock)
    caplog.set_level(logging.INFO, "jostle.observers")
    images = [big] * 5 + [small] * 20 + [big] * 5
    for i, img in enumerate(images):
        clock.advance(1 / 30)
        guard.observe(Frame("cam", clock.now(), i, ColorImage(img.copy())))
    h = guard.health()
    assert (h.bad_frames, h.observations, h.crashes, h.restarts) == (20, 10, 0, 0)
    assert h.bad_kinds == ("frame size",) and h.state == "running" and len(guard.builds) == 1  # type: ignore[attr-defined]
    assert h.frames == len(images) and guard.never_observed() is None
    [line] = _records(caplog)
    assert line.levelno == logging.WARNING and line.exc_info is None
    assert "a color frame of 200×150 after frames of 320×240" in line.getMessage()
    assert "\n" not in line.getMessage()


@pytest.mark.parametrize("bad", [0, 3, 1_000_000])
def test_a_pad_count_changing_is_skipped_with_one_line(caplog: pytest.LogCaptureFixture, bad: int) -> None:
    clock = SimClock()
    guard = _guard(lambda: PadsObserver(FOUR), clock)
    caplog.set_level(logging.INFO, "jostle.observers")
    samples = {n: PadSample((10.0,) * n, (10,) * n) for n in (4, bad)}
    counts = [4] * 10 + [bad] * 50 + [4] * 10
    for i, n in enumerate(counts):
        clock.advance(0.0125)
        guard.observe(Frame("pads", clock.now(), i, samples[n]))
    h = guard.health()
    assert (h.bad_frames, h.observations, h.crashes, h.restarts, h.bad_kinds) == (50, 20, 0, 0, ("pad count",))
    [line] = _records(caplog)
    assert line.levelno == logging.WARNING and "pad" in line.getMessage()
    assert len(line.getMessage()) < 400  # a million pads are not echoed


@pytest.mark.parametrize("force", [math.nan, math.inf, -math.inf, float("1e999"), (2**31 - 1) * 0.25,
                                   -(2**31) * 0.25, PAD_MAX_NEWTONS * 1.01])
def test_impossible_pad_forces_are_skipped_counted_and_said_once(caplog: pytest.LogCaptureFixture,
                                                                 force: float) -> None:
    clock = SimClock()
    guard = _guard(lambda: PadsObserver(FOUR), clock)
    caplog.set_level(logging.INFO, "jostle.observers")
    for i in range(40):
        clock.advance(0.0125)
        newtons = (force, 0.0, 0.0, 0.0) if 10 <= i < 30 else (5.0, 0.0, 0.0, 0.0)
        guard.observe(Frame("pads", clock.now(), i, PadSample(newtons, (0, 0, 0, 0))))
    h = guard.health()
    assert (h.bad_frames, h.observations, h.crashes, h.bad_kinds) == (20, 20, 0, ("pad force",))
    assert h.non_finite_inputs == (0 if math.isfinite(force) else 20)
    [line] = _records(caplog)
    assert "pad" in line.getMessage() and "force" in line.getMessage()


def test_a_force_a_person_can_make_is_observed() -> None:
    clock = SimClock()
    guard = _guard(lambda: PadsObserver(FOUR), clock)
    for i in range(20):
        clock.advance(0.0125)
        guard.observe(Frame("pads", clock.now(), i, PadSample((3000.0, -50.0, 0.0, 900.0), (0, 0, 0, 0))))
    assert (guard.health().bad_frames, guard.health().observations) == (0, 20)


class Refusing:
    """A real pads observer that refuses a frame as bad data, as an observer does with UntrustedInput."""

    def __init__(self) -> None:
        self.inner = PadsObserver(FOUR)

    def observe(self, frame: Frame) -> object:
        if frame.seq % 2:
            raise UntrustedInput(f"sensor {frame.sensor}", f"frame {frame.seq} holds nonsense")
        return self.inner.observe(frame)


def test_an_observer_refusing_data_is_not_rebuilt(caplog: pytest.LogCaptureFixture) -> None:
    clock = SimClock()
    guard = _guard(Refusing, clock)
    caplog.set_level(logging.INFO, "jostle.observers")
    for i in range(100):
        clock.advance(0.0125)
        guard.observe(Frame("pads", clock.now(), i, PadSample((1.0,) * 4, (0,) * 4)))
    h = guard.health()
    assert (h.bad_frames, h.observations, h.crashes, h.restarts) == (50, 50, 0, 0)
    assert len(_records(caplog)) == 1 and len(guard.builds) == 1  # type: ignore[attr-defined]


def test_in_the_app_a_recording_whose_frames_shrink_midway_is_one_line_and_goes_on(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    root = Path(__file__).resolve().parent.parent
    demo = root / "configs" / "recordings" / "demo.mcap"
    shrunk = tmp_path / "shrunk.mcap"
    writer = RecordingWriter(shrunk)
    n = 0
    for t_ns, seq, payload in iter_payloads(demo, "webcam"):
        assert isinstance(payload, ColorImage)
        if t_ns > 2_000_000_000:  # from 2 s on, the frames are half the size
            w, h = payload.size
            payload = ColorImage(cv2.resize(payload.bgr, (w // 2, h // 2)))
        writer.write(Frame("webcam", t_ns / 1e9, seq, payload))
        n += 1
        if t_ns > 4_000_000_000:
            break
    writer.close()
    cfg = load_config(root / "configs" / "demo.toml")
    cam = cfg.sensors[0]
    cfg = dataclasses.replace(cfg, sensors=(dataclasses.replace(cam, config=dataclasses.replace(cam.config, path=shrunk)),),
                              render=dataclasses.replace(cfg.render, width=160, height=90))
    app = App(cfg, RunOptions(out_dir=None, seed=7, duration_s=4.0, video=False, progress=False))
    with caplog.at_level(logging.INFO):
        app.run()
    health = app.observer_guards["webcam"].health()
    assert (health.crashes, health.restarts, health.bad_kinds) == (0, 0, ("frame size",))
    assert health.bad_frames > 20 and health.observations > 20 and health.bad_frames + health.observations <= n
    lines = [r for r in caplog.records if r.levelno >= logging.WARNING and r.name == "jostle.observers"]
    assert len(lines) == 1 and lines[0].exc_info is None
