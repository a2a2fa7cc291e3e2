"""An installation config in a test's folder whose webcam sensor plays the real clip
``tests/fixtures/walk-320x240.mp4`` (1.5 s, 30 fps, 320×240), with a calibration made for a given size."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from interaction.webcam.calibration import Calibration

ROOT = Path(__file__).resolve().parent.parent
CLIP = ROOT / "tests" / "fixtures" / "walk-320x240.mp4"
CLIP_FRAMES, CLIP_FPS, CLIP_SIZE = 45, 30.0, (320, 240)
EXAMPLE = ROOT / "configs" / "calibration" / "webcam-example.toml"  # made for 640×480


def calibration_for(size: tuple[int, int], folder: Path) -> Path:
    """The example calibration's view, made for images of ``size`` (pixels scaled per axis), saved."""
    example = Calibration.load(EXAMPLE)
    assert example.image_size is not None
    sx, sy = size[0] / example.image_size[0], size[1] / example.image_size[1]
    h = example.matrix @ np.diag([1.0 / sx, 1.0 / sy, 1.0])
    path = folder / f"calibration-{size[0]}x{size[1]}.toml"
    Calibration(tuple(float(x) for x in h.ravel()), example.plane_y, example.half_depth, size).save(path)
    return path


def video_config(folder: Path, calibration: Path, *, tail_s: float = 1.0) -> Path:
    """``folder/video.toml``: the clip as a webcam, its observer, three characters, a small render."""
    configs = ROOT / "configs"
    text = f"""
[run]
seed = 3
tail_s = {tail_s}

[sensors.cam]
type = "webcam"
source = "{CLIP}"

[observers.cam]
type = "webcam"
sensor = "cam"
calibration = "{calibration}"
learn_frames = 5
pose = false

[[characters]]
spec = "{configs / 'characters' / 'default.toml'}"
count = 3
intent = "approach"

[render]
keyframes = "{configs / 'keyframes' / 'humanoid' / 'keyframes.toml'}"
width = 160
height = 90
fps = 15
"""
    path = folder / "video.toml"
    path.write_text(text, encoding="utf-8")
    return path
