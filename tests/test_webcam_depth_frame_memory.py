"""A steady frame allocates no image-sized work arrays, in the webcam and in the depth observer.

Per frame the observers used to take their work arrays fresh from the allocator (the webcam's
foreground test: ~10 MB of float32 images at 640×480). glibc often hands memory that size back to
the system when it is freed and page-faults it in again on the next frame: up to ~1000 minor faults
a webcam frame, ≈ 0.5 ms of CPU of a 4.4 ms frame on average and more on a loaded machine (``jostle
bench interaction``, ``latency_ms_p99``). Now they write into arrays kept from frame to frame.

Measured with tracemalloc, which is deterministic (numpy's arrays, OpenCV's outputs among them, are
traced): the peak of what is allocated during a frame over what was in use at its start, over the
frames of the real recordings after learning and a few frames of warm-up.
"""

from __future__ import annotations

import tracemalloc
from collections.abc import Iterable
from pathlib import Path

import pytest

from interaction.depth import DepthObserver, DepthObserverConfig
from interaction.depth.calibration import calibrate_depth, fit_floor
from interaction.webcam import WebcamObserver, WebcamObserverConfig
from interaction.webcam.calibration import Calibration
from jostle.performer.truth import read_cameras
from sensors.base import ColorImage, DepthImage, Frame
from sensors.recording.source import iter_payloads

FIXTURES = Path(__file__).parent / "fixtures"
WARM_UP = 25  # frames before measuring: learning (10 webcam, 5 depth frames) and the first people


def _frame_peaks(observer: WebcamObserver | DepthObserver, frames: Iterable[Frame]) -> tuple[list[int], int]:
    """Bytes allocated at the peak of each frame after the warm-up, over those in use at its start; and
    how many contactors those frames gave (the test means nothing on an empty stage)."""
    peaks: list[int] = []
    contactors = 0
    tracemalloc.start()
    try:
        for k, frame in enumerate(frames):
            start = tracemalloc.get_traced_memory()[0]
            tracemalloc.reset_peak()
            obs = observer.observe(frame)
            if k >= WARM_UP:
                peaks.append(tracemalloc.get_traced_memory()[1] - start)
                contactors += len(obs.contactors)
    finally:
        tracemalloc.stop()
    return peaks, contactors


@pytest.mark.parametrize("name", ["crossing2", "group3"])
def test_a_steady_webcam_frame_allocates_no_image_sized_work_arrays(name: str) -> None:
    """What a frame may still allocate at the image's scale: the optical flow in the box around the
    people (OpenCV's DIS returns a new array, at most 8 bytes a pixel) and the people's mask (1 byte a
    pixel; handed out as ``silhouette``, so new each frame): at most 3 frames' bytes (BGR) together.
    The float32 steps of the foreground test (12 bytes a pixel each; there were ~8 of them at once,
    24 frames' bytes) must not be allocated per frame."""
    path = FIXTURES / f"{name}.mcap"
    frames = [Frame("webcam", t / 1e9, seq, p) for t, seq, p in iter_payloads(path, "webcam")]
    first = frames[0].payload
    assert isinstance(first, ColorImage)
    observer = WebcamObserver(WebcamObserverConfig(), Calibration.load(FIXTURES / f"{name}.calibration.toml"))
    peaks, contactors = _frame_peaks(observer, frames)
    assert len(peaks) >= 35 and contactors > 0
    frame_bytes = first.bgr.nbytes
    assert max(peaks) < 4 * frame_bytes, f"a frame allocated {max(peaks) / frame_bytes:.1f} frames' bytes"


@pytest.mark.parametrize("name", ["crossing2", "group3"])
def test_a_steady_depth_frame_allocates_no_image_sized_work_arrays(name: str) -> None:
    """What a depth frame may still allocate: the stage points it keeps (``points``, 24 bytes each, new
    each frame; people are a small share of the pixels), the people's points and the small per-person
    arrays. Each float32 step over the sampled pixels is 2 frames' bytes (uint16); the points from the
    depth took ~7 of them at once, with the floor grid's arrays ~15 frames' bytes."""
    path = FIXTURES / f"{name}.mcap"
    frames = [Frame("oak", t / 1e9, seq, p) for t, seq, p in iter_payloads(path, "oak") if isinstance(p, DepthImage)]
    first = frames[0].payload
    assert isinstance(first, DepthImage)
    fit = fit_floor(first.depth_mm, (first.fx, first.fy, first.cx, first.cy))
    pos = read_cameras(path)["oak"].position
    observer = DepthObserver(DepthObserverConfig(), calibrate_depth(fit, (pos[0], pos[1]), 0.0, first.size))
    assert first.depth_mm.shape[1] <= observer.config.work_width  # every pixel is sampled: the steps are frame-sized
    peaks, contactors = _frame_peaks(observer, frames)
    assert len(peaks) >= 35 and contactors > 0
    frame_bytes = first.depth_mm.nbytes
    assert max(peaks) < 8 * frame_bytes, f"a frame allocated {max(peaks) / frame_bytes:.1f} frames' bytes"
