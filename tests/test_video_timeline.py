"""A video file as a webcam source plays on its own timeline: frames stamped from the file's frame
index and fps, the run on simulated time, so the same file and seed give the same trace."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from video_source import CLIP, CLIP_FPS, CLIP_FRAMES, CLIP_SIZE, calibration_for, video_config

from jostle.app import App, RunOptions, expected_duration
from jostle.cli import main
from jostle.config import load_config
from sensors.clock import SimClock, WallClock
from sensors.webcam.config import WebcamConfig
from sensors.webcam.driver import WebcamSensor, video_duration

TAIL_S = 0.5


def test_frames_carry_the_files_own_times() -> None:
    clock = SimClock(100.0)  # whatever the clock says at open, frame i is due i / fps later
    with WebcamSensor(WebcamConfig(source=str(CLIP)), clock, "cam") as cam:
        times = []
        for _ in range(3 * CLIP_FRAMES):
            clock.advance(1.0 / 60)
            while (frame := cam.read(0.0)) is not None:
                assert frame.seq == len(times) and frame.t <= clock.now() + 1e-9
                times.append(frame.t)
    assert len(times) == CLIP_FRAMES
    assert times == pytest.approx([100.0 + i / CLIP_FPS for i in range(CLIP_FRAMES)], abs=1e-9)
    assert video_duration(str(CLIP)) == pytest.approx((CLIP_FRAMES - 1) / CLIP_FPS)


def test_a_video_file_runs_on_simulated_time(tmp_path: Path) -> None:
    config = load_config(video_config(tmp_path, calibration_for(CLIP_SIZE, tmp_path), tail_s=TAIL_S))
    options = RunOptions(out_dir=None, video=False, progress=False)
    assert isinstance(App(config, options).clock, SimClock)  # not the wall clock, a live camera's
    assert isinstance(App(config, RunOptions(speed="realtime")).clock, WallClock)  # unless asked for
    assert expected_duration(config, options) == pytest.approx((CLIP_FRAMES - 1) / CLIP_FPS + TAIL_S)


def test_the_same_video_twice_gives_the_same_trace(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    config = video_config(tmp_path, calibration_for(CLIP_SIZE, tmp_path), tail_s=TAIL_S)
    hashes = []
    for run in ("a", "b"):
        out = tmp_path / run
        assert main(["run", str(config), "--headless", "--no-video", "--quiet", "--out", str(out)]) == 0
        summary = json.loads((out / "summary.json").read_text())
        assert summary["sensor_frames"] == CLIP_FRAMES  # every frame, once
        assert summary["recording"] == str(CLIP)
        assert summary["stopped_because"] == "all recordings ended"
        assert summary["sim_seconds"] == pytest.approx((CLIP_FRAMES - 1) / CLIP_FPS + TAIL_S, abs=2 / 30)
        assert summary["observed_frames_with_people"] > 0  # the person in the clip is seen
        hashes.append(summary["trace_sha256"])
    assert hashes[0] == hashes[1]  # exact: the same machine (tests/README.md)
    assert "warning" not in capsys.readouterr().err  # a calibration made for this size: no rescale
