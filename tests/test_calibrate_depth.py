"""Depth calibration: the floor by RANSAC and the camera's pose, against the virtual OAK's true pose."""

from __future__ import annotations

import argparse
import math
from pathlib import Path

import numpy as np
import pytest

from interaction.depth.calibration import DepthCalibration, DepthCalibrationError, calibrate_depth, fit_floor
from jostle.cli import calibrate as calibrate_cli
from jostle.performer.truth import read_cameras
from sensors.base import DepthImage
from sensors.recording.source import iter_payloads

FIXTURE = Path(__file__).parent / "fixtures" / "crossing2.mcap"


def _empty_frames(n: int = 8) -> list[DepthImage]:
    """The fixture's first frames: the stage is empty for its first second."""
    frames = [p for _, _, p in iter_payloads(FIXTURE, "oak") if isinstance(p, DepthImage)]
    return frames[:n]


def _angle_deg(a: np.ndarray, b: np.ndarray) -> float:
    """The angle of the rotation taking a to b."""
    c = (np.trace(a.T @ b) - 1) / 2
    return math.degrees(math.acos(max(-1.0, min(1.0, c))))


def test_one_empty_frame_gives_the_true_camera_pose() -> None:
    frame = _empty_frames(1)[0]
    fit = fit_floor(frame.depth_mm, (frame.fx, frame.fy, frame.cx, frame.cy))
    cam = read_cameras(FIXTURE)["oak"]
    cal = calibrate_depth(fit, (cam.position[0], cam.position[1]), 0.0, frame.size)
    assert _angle_deg(cal.matrix, cam.rotation.T) < 0.5
    assert np.abs(cal.centre - np.array(cam.position)).max() < 0.02
    # a floor point seen by the camera lands on z = 0, a point 1 m above the floor at z = 1
    for stage in (np.array([0.3, 1.0, 0.0]), np.array([-1.0, 0.5, 1.0])):
        assert np.abs(cal.to_stage(cam.to_camera(stage)) - stage).max() < 0.02
    assert 0 < fit.rms_m < 0.05
    assert fit.inliers > 0.4 * fit.valid


def test_heading_turns_the_stage_about_the_vertical() -> None:
    frame = _empty_frames(1)[0]
    fit = fit_floor(frame.depth_mm, (frame.fx, frame.fy, frame.cx, frame.cy))
    straight = calibrate_depth(fit, (0.0, -4.0), 0.0)
    turned = calibrate_depth(fit, (0.0, -4.0), 30.0)
    assert _angle_deg(straight.matrix, turned.matrix) == pytest.approx(30.0, abs=0.01)
    ahead = straight.to_camera(np.array([0.0, 0.0, 0.0]))  # the stage origin, 4 m ahead of the camera
    moved = turned.to_stage(ahead)
    assert moved[2] == pytest.approx(0.0, abs=1e-9)
    # the stage's y axis turned 30° toward the audience's left: the point ahead now lies to its right
    expected = np.array([4 * math.sin(math.radians(30)), -4 + 4 * math.cos(math.radians(30))])
    assert np.abs(moved[:2] - expected).max() < 0.02


def test_toml_round_trip_and_bad_files(tmp_path: Path) -> None:
    frame = _empty_frames(1)[0]
    fit = fit_floor(frame.depth_mm, (frame.fx, frame.fy, frame.cx, frame.cy))
    cal = calibrate_depth(fit, (0.25, -4.0), 3.0, frame.size)
    path = tmp_path / "depth.toml"
    cal.save(path)
    assert DepthCalibration.load(path) == cal
    path.write_text(cal.to_toml() + "colour = 3\n")
    with pytest.raises(DepthCalibrationError, match="colour: unknown key"):
        DepthCalibration.load(path)
    path.write_text(cal.to_toml().replace("translation = [", "translation = [1.0, "))
    with pytest.raises(DepthCalibrationError, match="translation: expected 3 numbers"):
        DepthCalibration.load(path)
    with pytest.raises(DepthCalibrationError, match="no such file"):
        DepthCalibration.load(tmp_path / "missing.toml")


def test_a_wall_alone_is_not_taken_for_the_floor() -> None:
    """A depth image of only an upright wall 3 m ahead: no plane below the camera, a clear error."""
    h, w = 100, 160
    wall = np.full((h, w), 3000, dtype=np.uint16)
    with pytest.raises(DepthCalibrationError, match="no plane below the camera"):
        fit_floor(wall, (110.0, 110.0, 80.0, 50.0))


def _parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="jostle")
    calibrate_cli.add(p.add_subparsers(dest="command", required=True))
    return p


def test_cli_headless_from_a_recording(tmp_path: Path) -> None:
    from jostle.errors import UsageError

    config = tmp_path / "install.toml"
    config.write_text("# not read\n")
    argv = ["calibrate", "depth", "--from", str(FIXTURE), "--origin=0,-4", "--config", str(config)]
    args = _parser().parse_args(argv)
    assert args.func(args) == 0
    cal = DepthCalibration.load(tmp_path / calibrate_cli.DEFAULT_DEPTH_NAME)
    cam = read_cameras(FIXTURE)["oak"]
    assert _angle_deg(cal.matrix, cam.rotation.T) < 0.5
    assert np.abs(cal.centre - np.array(cam.position)).max() < 0.02
    assert cal.image_size == (160, 100)
    again = _parser().parse_args(argv)
    with pytest.raises(UsageError, match="exists; pass --force"):
        again.func(again)
    strict = _parser().parse_args([*argv, "--force", "--max-error", "0.005"])
    with pytest.raises(UsageError, match="calibration refused: .*record the stage empty"):
        strict.func(strict)
    colour = _parser().parse_args([*argv, "--force", "--channel", "webcam"])
    with pytest.raises(UsageError, match="expected depth frames"):
        colour.func(colour)
