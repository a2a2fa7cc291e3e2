"""A depth frame as stage points, each with the floor area it stands for (for telling boxes' lids).

A step × step block of depth pixels at depth z, seen along the ray r (stage axes, per metre of depth,
so r's camera-axis component is 1), covers (step·z/f)² / |r·n| of a surface of unit normal n, and
``(step·z / f)² · |n_z| / |r·n|`` of the floor under it: on a level lid (n = z) ``(step·z/f)² / |r_z|``;
on a box's side facing the camera ~0, so the side's top rows, at the lid's height, add no lid to the
cell in front (summed over a cell, the areas of its lid's points tell how much of it the lid covers).

The normal comes from the neighbouring samples after a 3 × 3 smoothing of the valid depths; of the
differences to the two neighbours along each image axis the shorter is used (so a depth jump at an
edge is not taken for a slope); next to a hole, the surface is taken to be level. Grazing views are
capped (|r·n| ≥ |r| / 4).
"""

from __future__ import annotations

import numpy as np

from interaction.depth.calibration import DepthCalibration
from sensors.base import DepthImage

__all__ = ["StagePoints"]


class StagePoints:
    """Samples a depth frame every ``work_width``-th of its width; ``points(p)`` gives the stage points
    (N, 3) of the valid samples and their floor areas (N,) in m²."""

    def __init__(self, calibration: DepthCalibration, work_width: int) -> None:
        self.calibration = calibration
        self.work_width = work_width
        self._rays: tuple[tuple[object, ...], np.ndarray] | None = None

    def points(self, p: DepthImage) -> tuple[np.ndarray, np.ndarray]:
        h, w = p.depth_mm.shape
        step = max(1, w // self.work_width)
        key = (w, h, step, p.fx, p.fy, p.cx, p.cy)
        if self._rays is None or self._rays[0] != key:
            v, u = np.mgrid[0:h:step, 0:w:step].astype(np.float64)
            cam = np.stack([(u - p.cx) / p.fx, (v - p.cy) / p.fy, np.ones_like(u)], axis=-1)
            self._rays = (key, cam @ self.calibration.matrix.T)
        rays = self._rays[1]  # (h', w', 3)
        z = p.depth_mm[::step, ::step].astype(np.float64) * 0.001
        areas = _floor_areas(rays, z, step * step / (p.fx * p.fy))
        keep = z > 0
        return np.asarray(rays[keep] * z[keep, None] + self.calibration.centre), areas[keep]


def _smoothed(z: np.ndarray) -> np.ndarray:
    """The mean of the valid depths in each 3 × 3 neighbourhood (0 where the sample itself is invalid)."""
    valid = (z > 0).astype(np.float64)
    zp, vp = np.pad(z * valid, 1, mode="edge"), np.pad(valid, 1, mode="edge")
    h, w = z.shape
    total = sum(zp[i:i + h, j:j + w] for i in range(3) for j in range(3))
    count = sum(vp[i:i + h, j:j + w] for i in range(3) for j in range(3))
    return np.where(valid > 0, total / np.maximum(count, 1.0), 0.0)


def _shorter_difference(pts: np.ndarray, axis: int) -> np.ndarray:
    """Per sample, the shorter of the differences to its two neighbours along ``axis`` (at the image's
    border the one there is); NaN when a neighbour has no depth (a hole: often by an edge, so the
    surface there is better taken as level than guessed from the other side)."""
    d = np.diff(pts, axis=axis)
    pad = [(0, 0)] * 3
    pad[axis] = (0, 1)
    forward = np.pad(d, pad, constant_values=np.inf)
    pad[axis] = (1, 0)
    backward = np.pad(d, pad, constant_values=np.inf)
    with np.errstate(invalid="ignore"):
        lf = np.nan_to_num(np.einsum("hwi,hwi->hw", forward, forward), nan=0.0)  # squared lengths
        lb = np.nan_to_num(np.einsum("hwi,hwi->hw", backward, backward), nan=0.0)
    return np.where((lf <= lb)[..., None], forward, backward)


def _floor_areas(rays: np.ndarray, z: np.ndarray, scale: float) -> np.ndarray:
    """(h', w') floor areas of the samples: scale·z²·|n_z| / |r·n| (see the module notes)."""
    zs = _smoothed(z)
    pts = rays * zs[..., None]
    pts[zs <= 0] = np.nan
    n = np.cross(_shorter_difference(pts, 1), _shorter_difference(pts, 0))
    length = np.sqrt(np.einsum("hwi,hwi->hw", n, n))
    ok = np.isfinite(length) & (length > 0)
    n = np.where(ok[..., None], n / np.where(ok, length, 1.0)[..., None], np.array([0.0, 0.0, 1.0]))
    facing = np.abs(np.einsum("hwi,hwi->hw", rays, n))
    reach = 0.25 * np.sqrt(np.einsum("hwi,hwi->hw", rays, rays))
    return np.asarray(scale * np.square(z) * np.abs(n[..., 2]) / np.maximum(facing, reach))
