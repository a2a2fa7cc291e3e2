"""The full-resolution look at one body part in a depth frame (stage metres, floor at z = 0).

The depth observer finds people and their extremities on a sampled image; :class:`FineDepth` then
measures a part on every pixel of the full image near it: its points (optionally on the depth's 3×3
median), a column of them over the floor, whether the image shows something nearer beyond an arm's
tip (:meth:`FineDepth.hidden_beyond`) or around a shoe (:meth:`FineDepth.nearer_share`), the floor
area a pixel sees, and a point moved back along its viewing ray from the surface seen. The rays of
every pixel are made once per image size (one outer sum); a part costs a crop of the image around it.
"""

from __future__ import annotations

import math

import cv2
import numpy as np

from interaction.depth.calibration import DepthCalibration
from sensors.base import DepthImage

__all__ = ["FineDepth"]


_BEYOND_STEPS = np.linspace(0.3, 1.0, 5)  # where FineDepth.hidden_beyond looks, as shares of its reach
_PATCH_ROWS = np.repeat(np.arange(-1, 2), 3)[None, :]  # a 3×3 patch's row and column offsets
_PATCH_COLS = np.tile(np.arange(-1, 2), 3)[None, :]


class FineDepth:
    """Stage points of the full-resolution depth image near a point (the calibration maps camera →
    stage; the rays of every pixel are kept for the image size last seen)."""

    def __init__(self, calibration: DepthCalibration) -> None:
        self._cal = calibration
        self._matrix, self._centre = calibration.matrix, calibration.centre
        self._centre32 = self._centre.astype(np.float32)[:, None, None]
        self._key: tuple[int, int, tuple[float, ...]] | None = None
        # a pixel's stage direction per metre of depth, M @ (across(u), down(v), 1), is a part that depends
        # on its column only plus one that depends on its row only: the table (3, h, w) for the whole image
        # is one outer sum (≈ 1 ms at 640×400, on the first frame of a size)
        self._rays = np.zeros((3, 0, 0), np.float32)
        self._image: DepthImage | None = None

    @property
    def camera(self) -> np.ndarray:
        """The camera's position (stage metres)."""
        return self._centre

    def set_frame(self, p: DepthImage) -> None:
        h, w = p.depth_mm.shape
        key = (w, h, (p.fx, p.fy, p.cx, p.cy))
        if self._key != key:
            across = (np.arange(w, dtype=np.float64) - p.cx) / p.fx  # the camera's x / z per pixel column
            down = (np.arange(h, dtype=np.float64) - p.cy) / p.fy  # … and y / z per pixel row
            m = self._matrix
            by_column = (m[:, 0:1] * across[None, :] + m[:, 2:3]).astype(np.float32)
            by_row = (m[:, 1:2] * down[None, :]).astype(np.float32)
            self._rays = by_row[:, :, None] + by_column[:, None, :]
            self._key = key
        self._image = p

    def points_near(self, centre: np.ndarray, radius: float, min_height: float, smooth: bool = False) -> np.ndarray:
        """The stage points (N, 3) of the image's pixels within ``radius`` of ``centre`` and higher than
        ``min_height`` above the floor; ``smooth``: of the depth's 3×3 median (a third of the noise,
        so that the floor's noise stays under ``min_height`` near a foot)."""
        pts, seen = self._crop_points(centre, radius, smooth)
        off = pts - centre.astype(np.float32)[:, None]
        keep = seen & (pts[2] > min_height) & (np.einsum("ij,ij->j", off, off) < radius * radius)
        return np.asarray(pts[:, keep].T, dtype=np.float64)

    def column_near(self, centre: np.ndarray, radius: float, low: float, high: float, smooth: bool = False) -> np.ndarray:
        """The stage points (N, 3) of the image's pixels within ``radius`` across of ``centre`` (x, y) and
        between ``low`` and ``high`` above the floor (``smooth`` as for :meth:`points_near`)."""
        middle = np.array([centre[0], centre[1], 0.5 * (low + high)])
        pts, seen = self._crop_points(middle, math.hypot(radius, 0.5 * (high - low)), smooth)
        dx, dy = pts[0] - np.float32(centre[0]), pts[1] - np.float32(centre[1])
        keep = seen & (pts[2] > low) & (pts[2] < high) & (dx * dx + dy * dy < radius * radius)
        return np.asarray(pts[:, keep].T, dtype=np.float64)

    def _crop_points(self, centre: np.ndarray, radius: float, smooth: bool) -> tuple[np.ndarray, np.ndarray]:
        """The stage points (3, N) of the pixels in the image's square around a ball of ``radius`` at
        ``centre``, and which of them have a depth (N,)."""
        p = self._image
        if p is None:
            return np.zeros((3, 0), np.float32), np.zeros(0, dtype=bool)
        across, down, ahead = ((centre - self._centre) @ self._matrix).tolist()
        if ahead <= 0.05:
            return np.zeros((3, 0), np.float32), np.zeros(0, dtype=bool)
        u, v = p.fx * across / ahead + p.cx, p.fy * down / ahead + p.cy
        half = radius * p.fx / ahead + 2.0
        h, w = p.depth_mm.shape
        u0, u1 = max(0, int(u - half)), min(w, int(u + half) + 1)
        v0, v1 = max(0, int(v - half)), min(h, int(v + half) + 1)
        if u0 >= u1 or v0 >= v1:
            return np.zeros((3, 0), np.float32), np.zeros(0, dtype=bool)
        crop = p.depth_mm[v0:v1, u0:u1]
        if smooth and min(crop.shape) >= 3:
            crop = cv2.medianBlur(np.ascontiguousarray(crop), 3)
        z = crop.astype(np.float32) * np.float32(0.001)
        pts = (self._rays[:, v0:v1, u0:u1] * z + self._centre32).reshape(3, -1)
        return pts, z.reshape(-1) > 0

    def hidden_beyond(self, point: np.ndarray, direction: np.ndarray, reach: float, margin: float) -> bool:
        """Whether the image shows something nearer than the line from ``point`` on along ``direction``
        (a unit vector) over ``reach`` by more than ``margin`` metres, at 3 or more of 5 places along it
        (each the median of the 3×3 pixels around it that have a depth): a limb seen to end there may
        go on behind that."""
        p = self._image
        if p is None:
            return False
        cam = (point[None, :] + direction[None, :] * (reach * _BEYOND_STEPS)[:, None] - self._centre) @ self._matrix
        ahead = cam[:, 2]
        h, w = p.depth_mm.shape
        with np.errstate(divide="ignore", invalid="ignore"):
            u = np.floor(p.fx * cam[:, 0] / ahead + p.cx)
            v = np.floor(p.fy * cam[:, 1] / ahead + p.cy)
        ok = (ahead > 0.05) & (u >= 1) & (u < w - 1) & (v >= 1) & (v < h - 1)
        if np.count_nonzero(ok) < 3:
            return False
        rows = v[ok].astype(np.intp)[:, None] + _PATCH_ROWS
        cols = u[ok].astype(np.intp)[:, None] + _PATCH_COLS
        patches = np.sort(p.depth_mm[rows, cols], axis=1)  # (k, 9), the pixels with no depth (0) first
        valid = np.count_nonzero(patches, axis=1)
        k = np.arange(len(patches))
        upper = patches[k, np.minimum(9 - valid + valid // 2, 8)].astype(np.float64)
        median = 0.5 * (upper + patches[k, np.minimum(9 - valid + (valid - 1) // 2, 8)])
        nearer = (valid >= 3) & (median < (ahead[ok] - margin) * 1000.0)
        return bool(np.count_nonzero(nearer) >= 3)

    def nearer_share(self, centre: np.ndarray, radius: float, margin: float, min_height: float) -> float:
        """The share of the pixels of the image's square around a ball of ``radius`` at ``centre`` that
        show something higher than ``min_height`` over the floor and more than ``margin`` metres nearer
        the camera than ``centre`` (what hides a part there: not the floor in front of it)."""
        pts, seen = self._crop_points(centre, radius, False)
        if not len(seen):
            return 0.0
        off = pts - self._centre32[:, :, 0]
        reach = float(np.linalg.norm(centre - self._centre)) - margin
        nearer = seen & (pts[2] > min_height) & (np.einsum("ij,ij->j", off, off) < reach * reach)
        return float(np.count_nonzero(nearer)) / len(seen)

    def pixel_area(self, point: np.ndarray) -> float:
        """The area (m²) one pixel covers, square to its ray, at ``point``'s distance."""
        p = self._image
        if p is None:
            return 0.0
        ray = point - self._centre
        return float(ray.dot(ray)) / (p.fx * p.fy)

    def inset(self, point: np.ndarray, distance: float) -> np.ndarray:
        """``point`` moved ``distance`` farther along its viewing ray (into the part seen)."""
        ray = point - self._centre
        return np.asarray(point + ray / max(math.sqrt(float(ray.dot(ray))), 1e-9) * distance, dtype=np.float64)
