"""Real recordings and videos for the sensor tests, drawn frame by frame (small: 160×120)."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np

from sensors.base import ColorImage, DepthImage, Frame, PadSample
from sensors.recording.codec import ColorFormat
from sensors.recording.writer import RecordingWriter

W, H = 160, 120
INTRINSICS = (141.25, 140.5, 79.5, 59.75)  # fx, fy, cx, cy


def drawn_color(i: int) -> np.ndarray:
    """A smooth scene with a disc moving right and a bar moving down, different every frame."""
    y, x = np.mgrid[0:H, 0:W]
    img = np.stack([(x * 255 // W), (y * 255 // H), np.full_like(x, 60)], axis=-1).astype(np.uint8)
    cv2.circle(img, (10 + (3 * i) % (W - 20), H // 2), 14, (30, 200, 250), -1)
    cv2.rectangle(img, (100, (2 * i) % (H - 10)), (140, (2 * i) % (H - 10) + 10), (250, 40, 40), -1)
    return img


def drawn_depth(i: int) -> np.ndarray:
    """A floor at 3 m with a 'person' (1.5 m away) moving across, a hole of no data (0)."""
    y, x = np.mgrid[0:H, 0:W]
    depth = (3000 + 4 * y + x).astype(np.uint16)
    cx = 20 + (2 * i) % (W - 40)
    depth[(np.abs(x - cx) < 12) & (y > 20)] = 1500 + i
    depth[:8, :8] = 0
    return depth


def sample_frames(seconds: float = 1.0, fps: float = 30.0, pads_hz: float = 100.0) -> list[Frame]:
    """Colour "cam" and depth "depth" at ``fps``, 4 pads "pads" at ``pads_hz``, in time order.

    Times are whole nanoseconds (as MCAP stores them), so a round trip is exact.
    """
    frames: list[Frame] = []
    for i in range(round(seconds * fps)):
        t = round(i * 1e9 / fps) / 1e9
        frames.append(Frame("cam", t, i, ColorImage(drawn_color(i))))
        color = drawn_color(i + 100) if i % 3 == 0 else None
        frames.append(Frame("depth", t, i, DepthImage(drawn_depth(i), *INTRINSICS, color=color)))
    for i in range(round(seconds * pads_hz)):
        t = round(i * 1e9 / pads_hz) / 1e9
        newtons = (0.5 * i, 12.25, 100.0 / (i + 1), -0.125)
        frames.append(Frame("pads", t, i, PadSample(newtons, (i, 512, 1023 - i, 3))))
    frames.sort(key=lambda f: f.t)
    return frames


def write_recording(
    path: Path,
    frames: list[Frame],
    *,
    color_format: ColorFormat = "jpeg",
    chunk_size: int = 512 * 1024,
    metadata: dict[str, str] | None = None,
) -> Path:
    with RecordingWriter(path, color_format=color_format, chunk_size=chunk_size, metadata=metadata) as w:
        for f in frames:
            w.write(f)
    return path


def write_video(path: Path, frames: int = 30, fps: float = 30.0) -> Path:
    """An MP4 (mp4v) of drawn, changing frames."""
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter.fourcc(*"mp4v"), fps, (W, H))
    if not writer.isOpened():
        raise RuntimeError(f"cv2.VideoWriter cannot write {path}")
    for i in range(frames):
        writer.write(drawn_color(i))
    writer.release()
    return path
