"""A webcam calibration made for another image size: rescaled with one warning when only the scale
differs, refused at start (one line, exit 2) when the shape differs — on the real clip as a source."""

from __future__ import annotations

import json
import warnings
from pathlib import Path

import numpy as np
import pytest
from video_source import CLIP_SIZE, EXAMPLE, calibration_for, video_config

from interaction.webcam.calibration import Calibration, CalibrationError
from interaction.webcam.calibration_size import CalibrationRescaled, fit_to_image_size
from jostle.cli import main


def test_the_same_size_or_none_is_kept_as_it_is() -> None:
    cal = Calibration.load(EXAMPLE)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert fit_to_image_size(cal, (640, 480), file=EXAMPLE, images="sensor 'cam'") is cal
        bare = Calibration(cal.homography)
        assert fit_to_image_size(bare, (320, 200), file=EXAMPLE, images="sensor 'cam'") is bare


@pytest.mark.parametrize("size", [(768, 576), (320, 240), (1280, 960), (854, 640)])
def test_a_scaled_image_gets_a_rescaled_calibration_and_a_warning(size: tuple[int, int]) -> None:
    cal = Calibration.load(EXAMPLE)
    with pytest.warns(CalibrationRescaled, match=rf"made for 640×480 images, sensor 'cam' gives {size[0]}×{size[1]}"):
        fitted = fit_to_image_size(cal, size, file=EXAMPLE, images="sensor 'cam'")
    assert fitted.image_size == size
    # the same place in the picture lands on the same stage point: a pixel of the new size is the old one scaled
    old_px = np.array([[0.0, 0.0], [640.0, 480.0], [320.0, 240.0], [100.0, 400.0]])
    new_px = old_px * np.array([size[0] / 640, size[1] / 480])
    np.testing.assert_allclose(fitted.image_to_stage(new_px), cal.image_to_stage(old_px), atol=1e-9)


@pytest.mark.parametrize("size", [(640, 360), (720, 576), (480, 640)])
def test_another_shape_is_refused_naming_the_file_both_sizes_and_what_to_do(size: tuple[int, int]) -> None:
    with pytest.raises(CalibrationError) as refused:
        fit_to_image_size(Calibration.load(EXAMPLE), size, file=EXAMPLE, images="sensor 'cam'")
    text = str(refused.value)
    assert text.startswith(f"{EXAMPLE}: made for 640×480 images, but sensor 'cam' gives {size[0]}×{size[1]}")
    assert "jostle calibrate webcam" in text and "\n" not in text


def test_jostle_run_refuses_a_calibration_of_another_shape_at_start(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    wrong = calibration_for((640, 360), tmp_path)  # a 16:9 calibration, a 4:3 video
    status = main(["run", str(video_config(tmp_path, wrong)), "--headless", "--no-video", "--quiet",
                   "--out", str(tmp_path / "out")])
    err = capsys.readouterr().err.strip().splitlines()
    assert status == 2
    assert err[-1] == (f"jostle: error: {wrong}: made for 640×360 images, but sensor 'cam' gives 320×240 (another "
                       "aspect ratio); calibrate again for 320×240 (jostle calibrate webcam) or set the camera to "
                       "640×360")
    assert not any("Traceback" in line or "crashed" in line for line in err)
    assert not (tmp_path / "out").exists()  # refused before the run began


def test_jostle_run_rescales_a_calibration_of_the_same_shape_with_one_warning(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    config = video_config(tmp_path, EXAMPLE)  # made for 640×480, the clip is 320×240
    assert CLIP_SIZE == (320, 240)
    status = main(["run", str(config), "--headless", "--no-video", "--quiet", "--duration", "1.2",
                   "--out", str(tmp_path / "out")])
    err = capsys.readouterr().err
    assert status == 0, err
    warned = [line for line in err.splitlines() if "warning" in line.lower()]
    assert warned == [f"jostle: warning: {EXAMPLE}: made for 640×480 images, sensor 'cam' gives 320×240: the same "
                      "view scaled ×0.5, so the calibration is rescaled (calibrate again at 320×240 to end this "
                      "warning)"]
    summary = json.loads((tmp_path / "out" / "summary.json").read_text())
    assert summary["sensor_frames"] == 37 and summary["observed_frames_with_people"] > 0  # the person is seen


def test_a_floor_calibration_of_the_same_shape_is_rescaled_too() -> None:
    """A floor calibration (stage → pixels, a 3×4 camera matrix) made at 640×480, for 320×240 images:
    every stage point lands at half its pixel coordinates."""
    from interaction.webcam.floor_calibration import FloorCalibration
    from jostle.performer.camera import PinholeCamera

    camera = PinholeCamera(640, 480, (0.0, -3.5, 3.0), 30.0, 72.0)  # 3 m high, 30° down
    made = FloorCalibration(tuple(camera.camera_matrix().ravel().tolist()), 0.25, (640, 480))
    with pytest.warns(CalibrationRescaled):
        fitted = fit_to_image_size(made, (320, 240), file="floor.toml", images="sensor 'cam'")
    assert isinstance(fitted, FloorCalibration) and fitted.image_size == (320, 240)
    stage = np.array([[0.0, 1.0, 0.0], [0.5, 2.0, 1.2], [-1.0, 0.5, 0.3]])
    np.testing.assert_allclose(fitted.stage_to_image(stage), made.stage_to_image(stage) / 2, atol=1e-9)
    np.testing.assert_allclose(fitted.image_to_floor(made.stage_to_image(stage[:1]) / 2)[0, :2], stage[0, :2],
                               atol=1e-9)
