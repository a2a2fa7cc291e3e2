"""FineDepth, the full-resolution look at a part: its points, a column over the floor, and whether a
limb seen to end goes on behind something nearer. On depth images ray-cast here from known planes
(a floor, a box top, an upright board), so every answer is known exactly."""

from __future__ import annotations

import math

import numpy as np
import pytest

from interaction.depth.calibration import DepthCalibration
from interaction.depth.fine_depth import FineDepth
from sensors.base import DepthImage

W, H, F = 640, 400, 440.0
CAMERA = np.array([0.0, -4.0, 2.4])  # stage metres, looking along +y, pitched down 25°


def _calibration() -> DepthCalibration:
    pitch = math.radians(25.0)
    forward = np.array([0.0, math.cos(pitch), -math.sin(pitch)])  # the camera's z in stage axes
    right = np.array([1.0, 0.0, 0.0])  # its x
    down = np.cross(forward, right)  # its y (x × y = z)
    r = np.stack([right, down, forward], axis=1)  # columns: camera axes in stage coordinates
    floor = (*r[2].tolist(), float(CAMERA[2]))  # stage z in camera coordinates, + the camera's height
    return DepthCalibration(tuple(r.reshape(-1).tolist()), tuple(CAMERA.tolist()), floor)


def _rays(cal: DepthCalibration) -> np.ndarray:
    """Each pixel's stage direction per metre of depth (H, W, 3), computed pixel by pixel's formula."""
    v, u = np.mgrid[0:H, 0:W].astype(np.float64)
    cam = np.stack([(u - W / 2) / F, (v - H / 2) / F, np.ones_like(u)], axis=-1)
    return np.asarray(cam @ cal.matrix.T)


def _render(cal: DepthCalibration, *, box_top: bool = False, board: bool = False) -> DepthImage:
    """Depth (mm) of a floor (z = 0), optionally a box top (z = 0.1 over |x| < 0.2, 0.3 < y < 0.7) and an
    upright board (y = 0.6, |x| < 0.3, z < 1.2) nearer the camera than the box."""
    rays = _rays(cal)
    depth = np.full((H, W), np.inf)

    def hit(axis: int, level: float, bounds: list[tuple[int, float, float]]) -> None:
        with np.errstate(divide="ignore", invalid="ignore"):
            t = (level - CAMERA[axis]) / rays[..., axis]
        p = CAMERA + rays * t[..., None]
        ok = t > 0
        for i, lo, hi in bounds:
            ok &= (p[..., i] > lo) & (p[..., i] < hi)
        depth[ok] = np.minimum(depth[ok], t[ok])

    hit(2, 0.0, [])
    if box_top:
        hit(2, 0.1, [(0, -0.2, 0.2), (1, 0.3, 0.7)])
    if board:
        hit(1, 0.6, [(0, -0.3, 0.3), (2, 0.0, 1.2)])
    mm = np.where(np.isfinite(depth), np.rint(depth * 1000.0), 0).astype(np.uint16)
    return DepthImage(depth_mm=mm, fx=F, fy=F, cx=W / 2, cy=H / 2)


@pytest.fixture(scope="module")
def cal() -> DepthCalibration:
    return _calibration()


def test_points_near_are_the_pixels_within_the_ball_each_on_its_own_ray(cal: DepthCalibration) -> None:
    image = _render(cal)
    fine = FineDepth(cal)
    fine.set_frame(image)
    centre = np.array([0.3, 0.5, 0.0])
    pts = fine.points_near(centre, 0.2, -1.0)
    # the same points, pixel by pixel: depth × the pixel's ray, from the camera's centre
    every = CAMERA + _rays(cal) * (image.depth_mm.astype(np.float64) / 1000.0)[..., None]
    near = every[(image.depth_mm > 0) & (np.linalg.norm(every - centre, axis=-1) < 0.2)]
    assert len(pts) > 300
    assert abs(len(pts) - len(near)) <= 0.01 * len(near)  # only points at the ball's edge may differ (float32)
    assert float(np.abs(pts[:, 2]).max()) < 0.005  # on the floor: each pixel is on its own ray
    assert float(np.linalg.norm(pts - centre, axis=1).max()) < 0.2
    assert np.allclose(np.sort(pts[:, 0])[[0, -1]], np.sort(near[:, 0])[[0, -1]], atol=0.005)
    assert len(fine.points_near(centre, 0.2, 0.05)) == 0  # nothing over the floor there


def test_column_near_keeps_the_points_over_a_floor_circle_between_two_heights(cal: DepthCalibration) -> None:
    fine = FineDepth(cal)
    fine.set_frame(_render(cal, box_top=True))
    column = fine.column_near(np.array([0.0, 0.5]), 0.12, 0.05, 0.3)
    assert len(column) > 100
    assert np.allclose(column[:, 2], 0.1, atol=0.01)  # the box's top, not the floor around it
    assert float(np.hypot(column[:, 0], column[:, 1] - 0.5).max()) < 0.12
    # its area seen from above: the circle, all of it on the box top
    assert float(np.ptp(column[:, 0])) > 0.2 and float(np.ptp(column[:, 1])) > 0.2
    assert len(fine.column_near(np.array([0.0, 0.5]), 0.12, 0.15, 0.3)) == 0
    ring = fine.column_near(np.array([0.0, 0.5]), 0.3, -1.0, 0.05)  # the floor beside the box
    assert len(ring) > 0 and float(np.abs(ring[:, 2]).max()) < 0.01


def test_a_limb_going_on_behind_something_nearer_is_told_from_one_that_ends(cal: DepthCalibration) -> None:
    down = np.array([0.0, 0.0, -1.0])
    tip = np.array([0.0, 1.0, 1.1])  # a forearm's end seen over the board, 0.4 m behind it
    fine = FineDepth(cal)
    fine.set_frame(_render(cal))
    assert not fine.hidden_beyond(tip, down, 0.3, 0.1)  # the floor far behind: the limb ends there
    fine.set_frame(_render(cal, board=True))
    assert fine.hidden_beyond(tip, down, 0.3, 0.1)  # the board in front of where it would go on
    assert not fine.hidden_beyond(tip, down, 0.3, 0.5)  # … but less than 0.5 m in front of it
    beside = np.array([0.6, 1.0, 1.1])  # the same limb beside the board
    assert not fine.hidden_beyond(beside, down, 0.3, 0.1)
