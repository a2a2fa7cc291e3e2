"""Webcam calibration from an ArUco or ChArUco board: board corners in view → the image → stage homography.

Two placements (:class:`BoardPlacement`):

- ``"screen"``: the board hangs (or is shown) upright in the stage plane ``y = plane_y``. Its corners
  give pixel ↔ stage (x, z) pairs directly: the fitted homography *is* the calibration.
- ``"floor"``: the board lies flat on the stage floor, its top edge toward the screen. The homography
  floor → image is fitted, the camera's focal length found from it (square pixels, principal point at
  the image centre), and from that the camera's pose; the homography of the upright plane
  ``y = plane_y`` follows. Less exact than ``"screen"`` (it leans on that camera model, and one
  board's focal length is sensitive to corner noise: docs/notes/webcam.md); the focal length is reported.

Board frame: OpenCV's, metres from the board's top-left corner, x to the right, y down the board.
The fit pools the corners of every frame where the board was found (the board must not move), drops
outliers (RANSAC, 3 px), then fits by least squares. The reprojection error (pixels, RMS and worst)
is reported; a fit above ``max_rms_px`` is refused with a message that says what to do.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass
from typing import Literal

import cv2
import numpy as np

from interaction.webcam.calibration import Calibration, CalibrationError, round_off_zeros
from interaction.webcam.floor_calibration import camera_from_floor

__all__ = [
    "BoardPlacement",
    "BoardSpec",
    "BoardView",
    "CalibrationFit",
    "CalibrationRefused",
    "board_image",
    "detect_board",
    "fit_calibration",
    "floor_to_upright",
]

BoardKind = Literal["charuco", "grid"]
Plane = Literal["screen", "floor"]
_RANSAC_PX = 3.0
_MIN_POINTS = 8
_MIN_AGREEING = 0.8  # refuse when more than a fifth of the corners disagree with the fit


class CalibrationRefused(CalibrationError):
    """The board was not seen well enough, or the fit is too poor to use; the message says what to do."""


@dataclass(frozen=True)
class BoardSpec:
    """The printed (or displayed) board.

    ``charuco``: a chessboard of ``columns`` × ``rows`` squares of ``square_m`` metres, with markers
    of ``marker_m`` in the white squares (its inner corners are what is fitted). ``grid``: ``columns``
    × ``rows`` markers of ``square_m`` metres, ``marker_m`` apart (their four corners are fitted).
    ``dictionary``: the ArUco dictionary's OpenCV name, e.g. ``DICT_4X4_50``.
    """

    kind: BoardKind = "charuco"
    columns: int = 5
    rows: int = 7
    square_m: float = 0.04
    marker_m: float = 0.03
    dictionary: str = "DICT_4X4_50"

    def __post_init__(self) -> None:
        if self.kind not in ("charuco", "grid"):
            raise ValueError(f"kind: expected 'charuco' or 'grid', got {self.kind!r}")
        for name in ("columns", "rows"):
            v = getattr(self, name)
            if type(v) is not int or not 2 <= v <= 100:
                raise ValueError(f"{name}: expected a whole number from 2 to 100, got {v!r}")
        if not (_finite(self.square_m) and 0 < self.square_m <= 10):
            raise ValueError(f"square_m: expected metres > 0, got {self.square_m!r}")
        if not (_finite(self.marker_m) and 0 < self.marker_m <= 10):
            raise ValueError(f"marker_m: expected metres > 0, got {self.marker_m!r}")
        if self.kind == "charuco" and self.marker_m >= self.square_m:
            raise ValueError(f"marker_m: expected less than square_m ({self.square_m}) on a ChArUco board, "
                             f"got {self.marker_m}")
        names = sorted(n for n in dir(cv2.aruco) if n.startswith("DICT_"))
        if not self.dictionary.startswith("DICT_") or not hasattr(cv2.aruco, self.dictionary):
            raise ValueError(f"dictionary: expected one of {', '.join(names)}, got {self.dictionary!r}")
        need = (self.columns * self.rows) // 2 if self.kind == "charuco" else self.columns * self.rows
        have = cv2.aruco.getPredefinedDictionary(getattr(cv2.aruco, self.dictionary)).bytesList.shape[0]
        if need > have:
            raise ValueError(f"dictionary: {self.dictionary} has {have} markers, the board needs {need}")

    @property
    def size_m(self) -> tuple[float, float]:
        """(width, height) of the board in metres."""
        if self.kind == "charuco":
            return self.columns * self.square_m, self.rows * self.square_m
        pitch = self.square_m + self.marker_m
        return self.columns * pitch - self.marker_m, self.rows * pitch - self.marker_m

    def board(self) -> cv2.aruco.Board:
        d = cv2.aruco.getPredefinedDictionary(getattr(cv2.aruco, self.dictionary))
        if self.kind == "charuco":
            return cv2.aruco.CharucoBoard((self.columns, self.rows), self.square_m, self.marker_m, d)
        return cv2.aruco.GridBoard((self.columns, self.rows), self.square_m, self.marker_m, d)


@dataclass(frozen=True)
class BoardPlacement:
    """Where the board is on the stage.

    ``origin``: the stage position of the board's top-left corner — (x, z) metres for ``"screen"``
    (the board upright in the plane y = ``plane_y``, its top edge up), (x, y) for ``"floor"`` (the
    board flat, its top edge toward the screen). ``plane_y`` and ``half_depth`` go into the
    calibration (where people stand, and how deep a webcam contactor reaches).
    """

    plane: Plane = "screen"
    origin: tuple[float, float] = (0.0, 0.0)
    plane_y: float = 0.0
    half_depth: float = 1.0

    def __post_init__(self) -> None:
        if self.plane not in ("screen", "floor"):
            raise ValueError(f"plane: expected 'screen' or 'floor', got {self.plane!r}")
        if len(self.origin) != 2 or not all(_finite(v) for v in self.origin):
            raise ValueError(f"origin: expected two numbers (metres), got {self.origin!r}")
        if not _finite(self.plane_y):
            raise ValueError(f"plane_y: expected a number, got {self.plane_y!r}")
        if not (_finite(self.half_depth) and self.half_depth >= 0):
            raise ValueError(f"half_depth: expected metres ≥ 0, got {self.half_depth!r}")

    def board_to_stage(self, board_xy: np.ndarray) -> np.ndarray:
        """Board metres (N, 2) → stage (x, z) for a screen board, stage (x, y) for a floor board."""
        p = np.asarray(board_xy, dtype=np.float64).reshape(-1, 2)
        return np.column_stack([self.origin[0] + p[:, 0], self.origin[1] - p[:, 1]])


@dataclass(frozen=True, eq=False)
class BoardView:
    """The board's corners found in one image: pixels (N, 2) and board metres (N, 2)."""

    image_uv: np.ndarray
    board_xy: np.ndarray
    frame: int = 0


@dataclass(frozen=True, eq=False)
class CalibrationFit:
    """A fitted calibration and how well it fits: the reprojection error of the board's corners in
    pixels (RMS and worst, over the inliers), how many corners and frames it used."""

    calibration: Calibration
    rms_px: float
    max_px: float
    points: int
    inliers: int
    frames: int
    focal_px: float | None = None  # floor boards: the focal length found on the way

    def describe(self) -> str:
        focal = f", focal length {self.focal_px:.0f} px" if self.focal_px is not None else ""
        return (f"reprojection error {self.rms_px:.2f} px RMS, {self.max_px:.2f} px worst, over {self.inliers} of "
                f"{self.points} corners in {self.frames} frame(s){focal}")


def detect_board(bgr: np.ndarray, spec: BoardSpec, frame: int = 0) -> BoardView | None:
    """The board's corners in one uint8 image (BGR or grey), or None if fewer than 4 were found."""
    grey = bgr if bgr.ndim == 2 else cv2.cvtColor(bgr, cv2.COLOR_BGR2GRAY)
    board = spec.board()
    if spec.kind == "charuco":
        assert isinstance(board, cv2.aruco.CharucoBoard)
        corners, ids, _, _ = cv2.aruco.CharucoDetector(board).detectBoard(grey)
        if ids is None or len(ids) < 4:
            return None
        obj = np.asarray(board.getChessboardCorners(), dtype=np.float64)[np.asarray(ids).ravel()]
        return BoardView(np.asarray(corners, np.float64).reshape(-1, 2), obj[:, :2], frame)
    params = cv2.aruco.DetectorParameters()
    params.cornerRefinementMethod = cv2.aruco.CORNER_REFINE_SUBPIX
    detector = cv2.aruco.ArucoDetector(board.getDictionary(), params)
    marker_corners, marker_ids, _ = detector.detectMarkers(grey)
    if marker_ids is None or len(marker_ids) == 0:
        return None
    obj_pts, img_pts = board.matchImagePoints(marker_corners, marker_ids)
    if obj_pts is None or len(obj_pts) < 4:
        return None
    return BoardView(np.asarray(img_pts, np.float64).reshape(-1, 2),
                     np.asarray(obj_pts, np.float64).reshape(-1, 3)[:, :2], frame)


def fit_calibration(
    views: Iterable[BoardView],
    placement: BoardPlacement,
    image_size: tuple[int, int],
    *,
    max_rms_px: float = 2.0,
) -> CalibrationFit:
    """The calibration from the board seen in one or more frames (pooled: the board must not move).

    Raises :class:`CalibrationRefused` when too few corners were seen, when they do not fit one
    plane, or when the reprojection error exceeds ``max_rms_px``.
    """
    views = list(views)
    if not views:
        raise CalibrationRefused(
            "the board was not found in any frame: check --board/--dictionary match the printed board, "
            "that it is in view, flat, lit evenly, and big enough (a square at least ~20 px wide)"
        )
    uv = np.concatenate([v.image_uv for v in views])
    stage = placement.board_to_stage(np.concatenate([v.board_xy for v in views]))
    if len(uv) < _MIN_POINTS:
        raise CalibrationRefused(f"only {len(uv)} board corners were found (need ≥ {_MIN_POINTS}): "
                                 "bring the board closer or show more of it")
    # stage → image, robustly, to drop wrong corners; then a least-squares fit on the inliers
    _, inl = cv2.findHomography(stage, uv, cv2.RANSAC, _RANSAC_PX)
    keep = np.ones(len(uv), bool) if inl is None else inl.ravel().astype(bool)
    if keep.sum() < max(_MIN_POINTS, _MIN_AGREEING * len(uv)):
        raise CalibrationRefused(f"the {len(uv)} corners found do not lie on one flat board (only {int(keep.sum())} "
                                 "agree): the board is bent or moved; flatten it and keep it still")
    try:
        plane_fit = Calibration.from_correspondences(uv[keep], stage[keep])  # image → board plane
    except CalibrationError as e:
        raise CalibrationRefused(f"the board's corners cannot give a homography ({e})") from None
    err = np.linalg.norm(_apply(np.linalg.inv(plane_fit.matrix), stage[keep]) - uv[keep], axis=1)
    rms, worst = float(np.sqrt(np.mean(err**2))), float(err.max())
    focal: float | None = None
    if placement.plane == "screen":
        h = plane_fit.matrix
    else:
        h, focal = floor_to_upright(plane_fit.matrix, image_size, placement.plane_y)
    try:
        cal = Calibration(tuple(float(x) for x in round_off_zeros(h / h[2, 2]).ravel()), placement.plane_y, placement.half_depth,
                          image_size)
    except ValueError as e:
        raise CalibrationRefused(f"the fitted homography cannot be used ({e}): move the camera or the board so "
                                 "the board is seen at a less grazing angle") from None
    fit = CalibrationFit(cal, rms, worst, len(uv), int(keep.sum()), len({v.frame for v in views}), focal)
    if rms > max_rms_px:
        raise CalibrationRefused(
            f"{fit.describe()}: above the limit of {max_rms_px:g} px. The board is probably bent, moving, "
            "blurred or too small in view: flatten it, keep it still, light it evenly, fill more of the frame "
            "with it, and check --square-m/--marker-m; or accept it with a larger --max-error"
        )
    return fit


def floor_to_upright(image_to_floor: np.ndarray, image_size: tuple[int, int], plane_y: float) -> tuple[np.ndarray, float]:
    """From the homography image → floor (x, y), the homography image → upright plane (x, z) at
    y = ``plane_y``, and the focal length (pixels) found on the way. Assumes square pixels and the
    principal point at the image centre. Raises CalibrationRefused when the view is degenerate
    (looking straight down, or the board seen edge-on). The camera: :func:`camera_from_floor`."""
    try:
        p, f = camera_from_floor(np.linalg.inv(image_to_floor), image_size)
    except CalibrationError as e:
        raise CalibrationRefused(f"the board: {e}: tilt the camera toward the stage, or hang the board upright "
                                 "(--plane screen)") from None
    upright = np.column_stack([p[:, 0], p[:, 2], p[:, 3] + plane_y * p[:, 1]])  # (x, z, 1) → image
    return np.linalg.inv(upright), f


def board_image(spec: BoardSpec, px_per_m: float = 2500.0, margin_px: int = 40) -> np.ndarray:
    """The board as a grey image to print or show (white margin around it), ``px_per_m`` pixels a metre."""
    bw, bh = spec.size_m
    size = (round(bw * px_per_m) + 2 * margin_px, round(bh * px_per_m) + 2 * margin_px)
    return np.asarray(spec.board().generateImage(size, marginSize=margin_px, borderBits=1))


def _apply(m: np.ndarray, pts: np.ndarray) -> np.ndarray:
    p = np.column_stack([pts, np.ones(len(pts))]) @ m.T
    return p[:, :2] / p[:, 2:3]


def _finite(x: object) -> bool:
    return isinstance(x, int | float) and not isinstance(x, bool) and math.isfinite(x)
