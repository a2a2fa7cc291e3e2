"""A depth calibration made for another image size, on the performer's OAK recording: the same aspect
ratio at another scale is the same camera (one warning line, the same people found); another aspect
ratio is refused, and through the observer guard every frame is skipped with one line, never a crash."""

from __future__ import annotations

import dataclasses
import logging
from pathlib import Path

import pytest

from interaction.depth import DepthObserver, DepthObserverConfig
from interaction.depth.calibration import DepthCalibration, calibrate_depth, fit_floor
from jostle.observer_guard import ObserverGuard
from jostle.performer.truth import read_cameras
from sensors.base import DepthImage, Frame
from sensors.clock import SimClock
from sensors.recording.source import iter_payloads
from sensors.untrusted import UntrustedInput

PATH = Path(__file__).parent / "fixtures" / "crossing2.mcap"


def _frames(n: int) -> list[Frame]:
    out = [Frame("oak", t / 1e9, seq, p) for t, seq, p in iter_payloads(PATH, "oak") if isinstance(p, DepthImage)]
    return out[:n]


def _calibration(frames: list[Frame]) -> DepthCalibration:
    first = frames[0].payload
    assert isinstance(first, DepthImage)
    fit = fit_floor(first.depth_mm, (first.fx, first.fy, first.cx, first.cy))
    pos = read_cameras(PATH)["oak"].position
    return calibrate_depth(fit, (pos[0], pos[1]), 0.0, first.size)


def test_another_scale_warns_once_and_sees_the_same(caplog: pytest.LogCaptureFixture) -> None:
    frames = _frames(40)
    cal = _calibration(frames)
    assert cal.image_size is not None
    w, h = cal.image_size
    scaled = dataclasses.replace(cal, image_size=(2 * w, 2 * h))
    exact, other = DepthObserver(DepthObserverConfig(), cal), DepthObserver(DepthObserverConfig(), scaled)
    with caplog.at_level(logging.WARNING, logger="interaction.depth"):
        for f in frames:
            assert exact.observe(f) == other.observe(f)
    lines = [r.getMessage() for r in caplog.records if r.name == "interaction.depth"]
    assert lines == [f"depth calibration: the camera's depth frame is {w}×{h}, but the calibration was made for "
                     f"{2 * w}×{2 * h}: the same aspect ratio, taken as the same camera at another resolution"]
    assert cal.fits_image((w, h)) is None and dataclasses.replace(cal, image_size=None).fits_image((5, 7)) is None


def test_another_aspect_ratio_is_refused_and_the_guard_skips_with_one_line(caplog: pytest.LogCaptureFixture) -> None:
    frames = _frames(30)
    cal = _calibration(frames)
    assert cal.image_size is not None
    w, h = cal.image_size
    wrong = dataclasses.replace(cal, image_size=(w, w))
    with pytest.raises(UntrustedInput, match=rf"^depth calibration: the camera's depth frame is {w}×{h}, but the "
                                             rf"calibration was made for {w}×{w} \(another aspect ratio"):
        DepthObserver(DepthObserverConfig(), wrong).observe(frames[0])
    clock = SimClock()
    guard = ObserverGuard("oak", lambda: DepthObserver(DepthObserverConfig(), wrong), clock)
    with caplog.at_level(logging.INFO):
        for f in frames:
            clock.advance(0.1)
            guard.observe(f)
    health = guard.health()
    assert (health.crashes, health.restarts, health.bad_frames, health.observations) == (0, 0, len(frames), 0)
    lines = [r for r in caplog.records if r.levelno >= logging.WARNING]
    assert len(lines) == 1 and "another aspect ratio" in lines[0].getMessage() and lines[0].exc_info is None
    said = guard.never_observed()
    assert said is not None and f"bad frames: {len(frames)} (depth calibration)" in said and "\n" not in said
