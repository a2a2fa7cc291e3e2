"""Depth calibrations from outside: every invalid one is a user error (one line naming the file and
the key; 16 of 16 used to be internal errors), and a calibration made for another image size is
refused at the first frame instead of being used silently."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from interaction.depth import DepthObserver, DepthObserverConfig
from interaction.depth.calibration import DepthCalibration
from jostle.errors import user_facing
from sensors.base import DepthImage, Frame

GOOD = {
    "rotation": "[[1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, -1.0, 0.0]]",
    "translation": "[0.0, -3.0, 1.5]",
    "floor": "[0.0, -1.0, 0.0, 1.5]",
    "image_size": "[64, 48]",
}

# key → (bad TOML value, words of the one-line error)
BAD = [
    ("rotation", "[[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]", "rotation: expected 9 numbers"),
    ("rotation", "[[2.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]", "rotation: expected a rotation matrix"),
    ("rotation", "[[-1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]", "determinant +1"),
    ("rotation", "[[nan, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]", "rotation: expected 9 finite numbers"),
    ("rotation", '"identity"', "rotation: expected 9 numbers"),
    ("translation", "[1e300, 0.0, 0.0]", "translation: expected a camera within 1000 m"),
    ("translation", "[inf, 0.0, 0.0]", "translation: expected [x, y, z]"),
    ("translation", "[0.0, 0.0]", "translation: expected 3 numbers"),
    ("translation", '["a", "b", "c"]', "translation: expected 3 numbers"),
    ("floor", "[0.0, 0.0, 0.0, 0.0]", "floor: expected a unit normal"),
    ("floor", "[0.0, -1.0, 0.0, 1e9]", "floor: expected a unit normal (a, b, c) and |d|"),
    ("floor", "[0.0, -1.0, 0.0]", "floor: expected 4 numbers"),
    ("image_size", "[0, 48]", "image_size: expected [width, height]"),
    ("image_size", "[64.5, 48]", "image_size: expected [width, height] in whole pixels"),
    ("floor_rms_m", "-1.0", "floor_rms_m: expected a number >= 0"),
    ("extra_key", "1", "extra_key: unknown key"),
]


def _write(path: Path, values: dict[str, str]) -> Path:
    path.write_text("".join(f"{k} = {v}\n" for k, v in values.items()), encoding="utf-8")
    return path


@pytest.mark.parametrize(("key", "value", "said"), BAD)
def test_every_invalid_depth_calibration_is_a_user_error(key: str, value: str, said: str, tmp_path: Path) -> None:
    path = _write(tmp_path / "depth.toml", {**GOOD, key: value})
    with pytest.raises(Exception) as caught:
        DepthCalibration.load(path)
    message = user_facing(caught.value)
    assert message is not None, f"internal error: {type(caught.value).__name__}: {caught.value}"
    assert "\n" not in message and str(path) in message and said in message, message


def test_a_calibration_for_another_image_size_is_refused(tmp_path: Path) -> None:
    calibration = DepthCalibration.load(_write(tmp_path / "depth.toml", GOOD))  # made for 64 × 48
    observer = DepthObserver(DepthObserverConfig(), calibration)
    frame = DepthImage(np.full((40, 80), 1500, np.uint16), 60.0, 60.0, 40.0, 20.0)
    with pytest.raises(ValueError, match="is 80×40, but the calibration was made for 64×48"):
        observer.observe(Frame("oak", 0.0, 0, frame))
    right = DepthImage(np.full((48, 64), 1500, np.uint16), 60.0, 60.0, 32.0, 24.0)
    observer.observe(Frame("oak", 0.1, 1, right))  # the size it was made for is taken
