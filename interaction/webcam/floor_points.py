"""A floor calibration from points an installer marks: four or more floor points, each a pixel and
the stage (x, y) metres where it lies (tape marks, tile corners, the stage's corners).

:func:`parse_points` reads ``"u,v=x,y u,v=x,y ..."``; :func:`fit_floor_points` refuses, one line
each, too few points, points outside the image, two points at one place, points with three on one
line (in the image or on the floor), a mirrored set (two points swapped), and a fit whose
reprojection error exceeds the limit (naming the worst point: a typo?). The floor homography is
fitted by least squares (OpenCV), the camera recovered from it (:func:`camera_from_floor`: the
focal length found, or given as the horizontal field of view), and the reprojection error reported
through that camera, in pixels and in metres on the floor. Four points fit exactly: a fifth checks.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass

import cv2
import numpy as np

from interaction.webcam.calibration import CalibrationError
from interaction.webcam.floor_calibration import FloorCalibration, camera_from_floor
from sensors.untrusted import shorten

__all__ = ["FloorFit", "MAX_POINTS", "fit_floor_points", "parse_points"]

MAX_POINTS = 64
_NUMBER = r"\s*([-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?)\s*"
_POINT = re.compile(rf"{_NUMBER},{_NUMBER}={_NUMBER},{_NUMBER}")
_SAME_PX = 2.0  # two marks nearer than this (pixels) are one place
_SAME_M = 0.02  # two stage points nearer than this (metres) are one place
_FLAT = 0.03  # a triangle of three points whose area is under this share of its longest side squared: a line


@dataclass(frozen=True, eq=False)
class FloorFit:
    """The calibration and how well the points fit it: reprojection error in pixels (the stage
    points through the camera, against the marks) and metres (the marks through the floor, against
    the stage points), RMS and worst, and which point was worst (1-based)."""

    calibration: FloorCalibration
    rms_px: float
    max_px: float
    rms_m: float
    max_m: float
    worst: int
    points: int
    focal_px: float
    focal_given: bool

    def describe(self) -> str:
        w = self.calibration.image_size[0] if self.calibration.image_size else 0
        hfov = math.degrees(2 * math.atan(w / 2 / self.focal_px)) if w else float("nan")
        c = self.calibration.camera_centre
        check = "" if self.points > 4 else " (4 points fit exactly: add a fifth to check them)"
        return (f"reprojection error {self.rms_px:.2f} px RMS, {self.max_px:.2f} px worst (point {self.worst}); "
                f"{self.rms_m:.3f} m RMS, {self.max_m:.3f} m worst on the floor, over {self.points} points{check}; "
                f"focal length {self.focal_px:.0f} px ({hfov:.1f}° wide, {'given' if self.focal_given else 'found'}); "
                f"camera at ({c[0]:.2f}, {c[1]:.2f}, {c[2]:.2f}) m")


def parse_points(text: str, source: str = "--points") -> tuple[np.ndarray, np.ndarray]:
    """``"u,v=x,y u,v=x,y ..."`` (spaces or semicolons between points, none within one) → pixels (N, 2)
    and stage (x, y) metres (N, 2). Raises CalibrationError naming ``source`` and the bad point."""
    items = [s for s in re.split(r"[;\s]+", text.strip()) if s]
    if len(items) > MAX_POINTS:
        raise CalibrationError(f"{source}: expected at most {MAX_POINTS} points, got {len(items)}")
    uv, xy = [], []
    for k, item in enumerate(items, 1):
        m = _POINT.fullmatch(item)
        if m is None:
            raise CalibrationError(f"{source}: point {k}: expected u,v=x,y (pixels = stage metres), got {shorten(item)}")
        values = [float(g) for g in m.groups()]
        if not all(math.isfinite(v) and abs(v) < 1e6 for v in values):
            raise CalibrationError(f"{source}: point {k}: expected finite numbers, got {shorten(item)}")
        uv.append(values[:2])
        xy.append(values[2:])
    return np.array(uv, dtype=np.float64).reshape(-1, 2), np.array(xy, dtype=np.float64).reshape(-1, 2)


def fit_floor_points(
    image_uv: np.ndarray, floor_xy: np.ndarray, image_size: tuple[int, int], *, hfov_deg: float | None = None,
    half_depth: float = 0.25, max_rms_px: float = 2.0, source: str = "--points",
) -> FloorFit:
    """The floor calibration from marks ``image_uv`` (N, 2 pixels) at stage ``floor_xy`` (N, 2 metres)
    in an image of ``image_size`` (width, height); ``hfov_deg`` the camera's horizontal field of view
    when known. Raises CalibrationError (one line, naming ``source`` and the point) when refused."""
    uv = np.asarray(image_uv, dtype=np.float64).reshape(-1, 2)
    xy = np.asarray(floor_xy, dtype=np.float64).reshape(-1, 2)
    w, h = image_size
    if len(uv) < 4:
        raise CalibrationError(f"{source}: expected 4 or more floor points, got {len(uv)}")
    for k, (u, v) in enumerate(uv, 1):
        if not (-0.5 <= u <= w - 0.5 and -0.5 <= v <= h - 0.5):
            raise CalibrationError(f"{source}: point {k}: pixel ({u:g}, {v:g}) is outside the {w}×{h} image")
    _refuse_same_place(uv, _SAME_PX, "at the same pixel", source)
    _refuse_same_place(xy, _SAME_M, "at the same stage point", source)
    _refuse_lines(xy, "on the floor", source)
    _refuse_lines(uv, "in the image", source)
    floor_to_image, _ = cv2.findHomography(xy, uv, 0)
    if floor_to_image is None or not np.isfinite(floor_to_image).all():
        raise CalibrationError(f"{source}: the points give no homography (are they marked in the right order?)")
    focal = None
    if hfov_deg is not None:
        if not (math.isfinite(hfov_deg) and 5.0 <= hfov_deg <= 170.0):
            raise CalibrationError(f"--hfov: expected degrees from 5 to 170, got {hfov_deg:g}")
        focal = (w / 2) / math.tan(math.radians(hfov_deg) / 2)
    try:
        p, f = camera_from_floor(floor_to_image, image_size, focal)
        cal = FloorCalibration(tuple(float(x) for x in p.ravel()), half_depth, (w, h))
    except (CalibrationError, ValueError, np.linalg.LinAlgError) as e:
        hint = ": give the camera's field of view with --hfov" if focal is None and "focal" in str(e) else ""
        raise CalibrationError(f"{source}: {e}{hint}") from None
    hfov = math.degrees(2 * math.atan(w / 2 / f))
    if not 10.0 <= hfov <= 160.0:
        raise CalibrationError(f"{source}: the points fit no plausible camera (a field of view of {hfov:.0f}°): "
                               "check them, or give the camera's field of view with --hfov")
    ground = np.column_stack([xy, np.zeros(len(xy))])
    seen = np.column_stack([ground, np.ones(len(xy))]) @ cal.matrix.T
    behind = np.flatnonzero(seen[:, 2] <= 0)
    if len(behind):
        raise CalibrationError(f"{source}: point {behind[0] + 1} would be behind the camera: check it (two points swapped?)")
    err_px = np.linalg.norm(cal.stage_to_image(ground) - uv, axis=1)
    err_m = np.linalg.norm(np.nan_to_num(cal.image_to_floor(uv)[:, :2], nan=1e9) - xy, axis=1)
    worst = int(np.argmax(err_px))
    fit = FloorFit(cal, float(np.sqrt(np.mean(err_px**2))), float(err_px[worst]), float(np.sqrt(np.mean(err_m**2))),
                   float(err_m.max()), worst + 1, len(uv), f, focal is not None)
    if fit.rms_px > max_rms_px:
        u, v = uv[worst]
        raise CalibrationError(
            f"{source}: reprojection error {fit.rms_px:.1f} px RMS exceeds {max_rms_px:g} px; point {worst + 1} "
            f"(pixel {u:g},{v:g}) is {err_px[worst]:.1f} px from where the camera puts it: a typo, or a point "
            "not on the floor? (or accept it with a larger --max-error)")
    return fit


def _refuse_same_place(p: np.ndarray, tol: float, what: str, source: str) -> None:
    d = np.linalg.norm(p[:, None] - p[None], axis=2) + np.eye(len(p)) * 1e18
    i, j = np.unravel_index(int(np.argmin(d)), d.shape)
    if d[i, j] < tol:
        a, b = sorted((int(i) + 1, int(j) + 1))
        raise CalibrationError(f"{source}: points {a} and {b} are {what}: each point must be a different place")


def _refuse_lines(p: np.ndarray, where: str, source: str) -> None:
    """Refuse points among which no four have every three off one line (the homography is then not
    determined). Greedy: the farthest pair, the point farthest from their line, then the point that
    makes the smallest triangle largest."""
    d = np.linalg.norm(p[:, None] - p[None], axis=2)
    a, b = np.unravel_index(int(np.argmax(d)), d.shape)
    chosen = [int(a), int(b)]
    for _ in range(2):
        rest = [k for k in range(len(p)) if k not in chosen]
        score = [min(_flatness(p[i], p[j], p[k]) for i in chosen for j in chosen if i < j) for k in rest]
        chosen.append(rest[int(np.argmax(score))])
    flat = [(i, j, k) for i in chosen for j in chosen for k in chosen if i < j < k and _flatness(p[i], p[j], p[k]) < _FLAT]
    if flat:
        names = ", ".join(str(n + 1) for n in sorted(flat[0]))
        more = "" if len(p) == 4 else " (and no four points are free of three on a line)"
        raise CalibrationError(f"{source}: points {names} lie on one line {where}{more}: mark points that span the "
                               "floor, like the corners of a rectangle")


def _flatness(a: np.ndarray, b: np.ndarray, c: np.ndarray) -> float:
    """Twice the triangle's area over its longest side squared: 0 on a line, ~0.87 equilateral."""
    area2 = abs(float((b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])))
    longest = max(float(np.sum((b - a) ** 2)), float(np.sum((c - b) ** 2)), float(np.sum((a - c) ** 2)))
    return area2 / longest if longest > 0 else 0.0
