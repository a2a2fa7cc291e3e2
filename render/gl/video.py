"""Frames out: MP4 through OpenCV (``mp4v``; the OpenCV wheel has no H.264 encoder) and GIF through Pillow."""

from __future__ import annotations

from collections.abc import Iterable
from pathlib import Path

import cv2
import numpy as np
from PIL import Image


class VideoError(RuntimeError):
    """A video that cannot be written; the message names the file."""


class VideoOut:
    """An MP4 file written frame by frame: ``write(bgr)`` takes (height, width, 3) uint8 BGR frames."""

    def __init__(self, path: Path, fps: float, size: tuple[int, int]) -> None:
        """``size`` is (width, height) in pixels, as OpenCV has it."""
        self.path = Path(path)
        if not fps > 0:
            raise ValueError(f"fps: expected a number > 0, got {fps!r}")
        width, height = size
        if width <= 0 or height <= 0:
            raise ValueError(f"size: expected (width, height) > 0, got {size!r}")
        self.size = (int(width), int(height))
        if not self.path.parent.is_dir():
            raise VideoError(f"{self.path}: cannot write a video there: no folder {self.path.parent}")
        fourcc = cv2.VideoWriter.fourcc(*"mp4v")
        self._writer: cv2.VideoWriter | None = cv2.VideoWriter(str(self.path), fourcc, float(fps), self.size)
        if not self._writer.isOpened():
            self._writer = None
            raise VideoError(
                f"{self.path}: OpenCV cannot open an mp4v video for writing ({width}x{height} @ {fps} fps)"
            )
        self.frames = 0

    def write(self, bgr: np.ndarray) -> None:
        if self._writer is None:
            raise VideoError(f"{self.path}: write() after close()")
        w, h = self.size
        if bgr.dtype != np.uint8 or bgr.shape != (h, w, 3):
            raise ValueError(f"frame: expected ({h}, {w}, 3) uint8 BGR, got {bgr.dtype} {bgr.shape}")
        self._writer.write(np.ascontiguousarray(bgr))
        self.frames += 1

    def close(self) -> None:
        """Finish the file; closing twice is fine."""
        if self._writer is not None:
            self._writer.release()
            self._writer = None

    def __enter__(self) -> VideoOut:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def save_gif(frames: Iterable[np.ndarray], path: Path, fps: float) -> Path:
    """Write BGR frames as a looping GIF (Pillow, adaptive palette per frame)."""
    if not fps > 0:
        raise ValueError(f"fps: expected a number > 0, got {fps!r}")
    images = [Image.fromarray(np.ascontiguousarray(f[:, :, ::-1])) for f in frames]
    if not images:
        raise ValueError("frames: expected at least one frame")
    path = Path(path)
    images[0].save(
        path,
        save_all=True,
        append_images=images[1:],
        duration=max(1, round(1000.0 / fps)),
        loop=0,
        optimize=True,
    )
    return path
