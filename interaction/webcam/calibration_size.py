"""A webcam calibration against the size of the images it will be used on, checked before a run.

A calibration that names its ``image_size`` maps pixels of images of that size. Images of another
size with the same aspect ratio (within a pixel: 640×480 and 768×576) show the same view scaled, so
the homography is rescaled and a :class:`CalibrationRescaled` warning says so. Another aspect ratio
(640×480 and 640×360) is another view: :func:`fit_to_image_size` refuses it with a
:class:`~interaction.webcam.calibration.CalibrationError` naming the file, both sizes and what to do.
"""

from __future__ import annotations

import dataclasses
import warnings
from pathlib import Path

import numpy as np

from interaction.webcam.calibration import Calibration, CalibrationError
from interaction.webcam.floor_calibration import FloorCalibration

__all__ = ["CalibrationRescaled", "fit_to_image_size"]


class CalibrationRescaled(UserWarning):
    """A calibration made for another image size of the same shape was rescaled to the images' size."""


def fit_to_image_size(calibration: Calibration | FloorCalibration, size: tuple[int, int], *, file: Path | str,
                      images: str) -> Calibration | FloorCalibration:
    """``calibration`` for images of ``size`` (width, height in pixels) from ``images`` (e.g. "sensor
    'cam'"): itself when it names no size or this one; rescaled, with a warning, when only the scale
    differs; otherwise a CalibrationError naming ``file``."""
    made = calibration.image_size
    if made is None or made == size:
        return calibration
    (w0, h0), (w1, h1) = made, size
    if abs(h0 * w1 / w0 - h1) > 1.0 or abs(w0 * h1 / h0 - w1) > 1.0:  # another shape, not a scale
        raise CalibrationError(
            f"{file}: made for {w0}×{h0} images, but {images} gives {w1}×{h1} (another aspect ratio); "
            f"calibrate again for {w1}×{h1} (jostle calibrate webcam) or set the camera to {w0}×{h0}")
    sx, sy = w1 / w0, h1 / h0
    warnings.warn(
        f"{file}: made for {w0}×{h0} images, {images} gives {w1}×{h1}: the same view scaled ×{sx:.4g}, "
        f"so the calibration is rescaled (calibrate again at {w1}×{h1} to end this warning)",
        CalibrationRescaled, stacklevel=2)
    if isinstance(calibration, FloorCalibration):  # stage → pixels: the new pixel is (sx·u, sy·v)
        p = np.diag([sx, sy, 1.0]) @ np.asarray(calibration.projection, dtype=np.float64).reshape(3, 4)
        return dataclasses.replace(calibration, projection=tuple(float(x) for x in p.ravel()), image_size=size)
    h = calibration.matrix @ np.diag([1.0 / sx, 1.0 / sy, 1.0])  # a new pixel (u, v) was (u / sx, v / sy)
    return dataclasses.replace(calibration, homography=tuple(float(x) for x in h.ravel()),
                               image_size=size)
