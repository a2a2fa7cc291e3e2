"""Webcam calibration from rendered boards: a board image warped into a camera view by a known
homography (upright on the screen plane) or by a known pinhole camera (flat on the floor), noise
added; the fit must recover the known image → stage map. Then ``jostle calibrate webcam`` headless
on an MCAP recording of such frames, and the refusals."""

from __future__ import annotations

import argparse
import math
from pathlib import Path

import cv2
import numpy as np
import pytest
from recording_fixtures import write_recording

from interaction.webcam.calibrate import (
    BoardPlacement,
    BoardSpec,
    BoardView,
    CalibrationRefused,
    board_image,
    detect_board,
    fit_calibration,
)
from interaction.webcam.calibration import Calibration
from jostle.cli import calibrate as calibrate_cli
from sensors.base import ColorImage, Frame

W, H = 640, 480
PPM, MARGIN = 1000.0, 40  # the board image: pixels per metre, white margin


def board_px_to_metres() -> np.ndarray:
    """Board image pixel (OpenCV centres) → board metres (x right, y down from the top-left corner)."""
    s = 1.0 / PPM
    return np.array([[s, 0, (0.5 - MARGIN) * s], [0, s, (0.5 - MARGIN) * s], [0, 0, 1.0]])


def scene(seed: int = 0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    img = np.full((H, W, 3), 90, np.float32) + np.linspace(0, 60, W, dtype=np.float32)[None, :, None]
    for _ in range(8):
        x, y = int(rng.integers(0, W)), int(rng.integers(0, H))
        cv2.rectangle(img, (x, y), (x + 80, y + 50), [float(c) for c in rng.uniform(30, 200, 3)], -1)
    return img


def render(board: np.ndarray, board_px_to_image: np.ndarray, seed: int = 0) -> np.ndarray:
    """The board warped into a camera frame over a cluttered scene, with camera noise and a light blur."""
    img = scene(seed)
    warped = cv2.warpPerspective(board, board_px_to_image, (W, H), flags=cv2.INTER_LINEAR, borderValue=0)
    mask = cv2.warpPerspective(np.full(board.shape, 255, np.uint8), board_px_to_image, (W, H), flags=cv2.INTER_LINEAR)
    a = (mask.astype(np.float32) / 255.0)[..., None]
    img = img * (1 - a) + warped.astype(np.float32)[..., None] * 0.8 * a + 25 * a
    img += np.random.default_rng(seed + 1).normal(0, 2.0, img.shape)
    return np.clip(cv2.GaussianBlur(img, (3, 3), 0.6), 0, 255).astype(np.uint8)


SPEC = BoardSpec("charuco", 5, 7, 0.25, 0.19, "DICT_4X4_50")  # 1.25 × 1.75 m (shown on the screen)
SCREEN = BoardPlacement("screen", origin=(-0.4, 1.9), plane_y=0.3, half_depth=0.7)


def screen_truth() -> np.ndarray:
    """stage (x, z) → image: a webcam a little to the left and below, looking slightly up."""
    xz = np.array([[-2.0, 2.6], [2.0, 2.6], [2.0, 0.0], [-2.0, 0.0]])
    uv = np.array([[40.0, 20.0], [600.0, 45.0], [585.0, 470.0], [55.0, 440.0]])
    return cv2.getPerspectiveTransform(xz.astype(np.float32), uv.astype(np.float32)).astype(np.float64)


def board_metres_to_stage_screen() -> np.ndarray:
    ox, oz = SCREEN.origin
    return np.array([[1.0, 0, ox], [0, -1.0, oz], [0, 0, 1.0]])


def test_screen_board_recovers_the_known_homography() -> None:
    board = board_image(SPEC, PPM, MARGIN)
    to_image = screen_truth() @ board_metres_to_stage_screen() @ board_px_to_metres()
    frame = render(board, to_image)
    view = detect_board(frame, SPEC)
    assert view is not None and len(view.image_uv) == (SPEC.columns - 1) * (SPEC.rows - 1)
    fit = fit_calibration([view], SCREEN, (W, H))
    assert fit.rms_px < 0.5 and fit.inliers == fit.points
    cal = fit.calibration
    assert (cal.plane_y, cal.half_depth, cal.image_size) == (0.3, 0.7, (W, H))
    # across the whole frame (not only where the board is), the map agrees with the truth
    grid = np.stack(np.meshgrid(np.linspace(0, W - 1, 9), np.linspace(0, H - 1, 7)), -1).reshape(-1, 2)
    truth = cv2.perspectiveTransform(grid[None], np.linalg.inv(screen_truth()))[0]
    got = cal.image_to_stage(grid)
    err = np.linalg.norm(got[:, [0, 2]] - truth, axis=1)
    assert err.max() < 0.02  # metres, over a 4 m × 2.6 m view; the board covers 0.6 × 0.84 m of it
    near = np.linalg.norm(truth - np.array([-0.1, 1.5]), axis=1) < 0.8
    assert err[near].max() < 0.005


def test_grid_board_works_too() -> None:
    spec = BoardSpec("grid", 4, 5, 0.2, 0.05, "DICT_5X5_100")
    board = board_image(spec, PPM, MARGIN)
    to_image = screen_truth() @ board_metres_to_stage_screen() @ board_px_to_metres()
    view = detect_board(render(board, to_image, seed=3), spec)
    assert view is not None and len(view.image_uv) == 4 * spec.columns * spec.rows
    fit = fit_calibration([view], SCREEN, (W, H))
    assert fit.rms_px < 1.0  # marker corners are less precise than ChArUco's chessboard corners
    inside = np.array([[200.0, 150.0], [400.0, 300.0]])
    truth = cv2.perspectiveTransform(inside[None], np.linalg.inv(screen_truth()))[0]
    assert np.abs(fit.calibration.image_to_stage(inside)[:, [0, 2]] - truth).max() < 0.01


def camera(f: float = 560.0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """K, R (stage → camera), t: a webcam 3.5 m in front of the stage, 1.5 m up, tilted 25° down."""
    k = np.array([[f, 0, (W - 1) / 2], [0, f, (H - 1) / 2], [0, 0, 1.0]])
    tilt = math.radians(25)
    # camera axes in stage coordinates: x right, y down (image), z forward (into the stage, down a bit)
    fwd = np.array([0.0, math.cos(tilt), -math.sin(tilt)])
    right = np.array([1.0, 0.0, 0.0])
    down = np.cross(fwd, right)
    r = np.stack([right, down, fwd])
    centre = np.array([0.2, -3.5, 1.5])
    return k, r, -r @ centre


def test_floor_board_gives_the_upright_plane_of_a_known_camera() -> None:
    k, r, t = camera()
    floor = BoardPlacement("floor", origin=(-0.3, -1.0), plane_y=0.0, half_depth=1.0)
    ox, oy = floor.origin
    metres_to_floor = np.array([[1.0, 0, ox], [0, -1.0, oy], [0, 0, 1.0]])  # board (x, y down) → floor (x, y)
    floor_to_image = k @ np.column_stack([r[:, 0], r[:, 1], t])
    spec = BoardSpec("charuco", 5, 7, 0.12, 0.09)
    frame = render(board_image(spec, PPM, MARGIN), floor_to_image @ metres_to_floor @ board_px_to_metres(), seed=5)
    upright_to_image = k @ np.column_stack([r[:, 0], r[:, 2], t + floor.plane_y * r[:, 1]])
    xz = np.stack(np.meshgrid(np.linspace(-1.5, 1.5, 7), np.linspace(0.0, 2.0, 5)), -1).reshape(-1, 2)
    uv_true = cv2.perspectiveTransform(xz[None], upright_to_image)[0]
    xyz = np.column_stack([xz[:, 0], np.zeros(len(xz)), xz[:, 1]])

    # the geometry is exact: the corners projected without an image give the camera back
    board = spec.board()
    assert isinstance(board, cv2.aruco.CharucoBoard)
    obj = np.asarray(board.getChessboardCorners(), np.float64)[:, :2]
    exact = cv2.perspectiveTransform(floor.board_to_stage(obj)[None], floor_to_image)[0]
    fit = fit_calibration([BoardView(exact, obj)], floor, (W, H))
    assert fit.focal_px == pytest.approx(560.0, rel=1e-6)
    assert np.abs(fit.calibration.stage_to_image(xyz) - uv_true).max() < 1e-3

    # from the rendered image: corner detection errors of 0.1–0.5 px cost ~5 % of the focal length
    # (one small, foreshortened board), so the upright plane is good to ~3 % of the image — the
    # limit of a floor board, stated in the module's notes
    view = detect_board(frame, spec)
    assert view is not None
    fit = fit_calibration([view], floor, (W, H))
    assert fit.focal_px == pytest.approx(560.0, rel=0.08)
    assert np.linalg.norm(fit.calibration.stage_to_image(xyz) - uv_true, axis=1).max() < 20.0


def test_a_poor_fit_is_refused_with_what_to_do() -> None:
    board = board_image(SPEC, PPM, MARGIN)
    frame = render(board, screen_truth() @ board_metres_to_stage_screen() @ board_px_to_metres())
    view = detect_board(frame, SPEC)
    assert view is not None
    with pytest.raises(CalibrationRefused, match=r"reprojection error .* above the limit of 0.01 px.*--max-error"):
        fit_calibration([view], SCREEN, (W, H), max_rms_px=0.01)
    # a board bent along its middle (its lower half tilted back): the corners no longer fit one plane
    bent = view.image_uv.copy()
    low = view.board_xy[:, 1] > 0.8
    bent[low, 1] += (view.board_xy[low, 1] - 0.8) * 40.0  # up to 28 px at the bottom edge
    with pytest.raises(CalibrationRefused, match="flatten|bent"):
        fit_calibration([BoardView(bent, view.board_xy)], SCREEN, (W, H))
    assert detect_board(scene().astype(np.uint8), SPEC) is None
    with pytest.raises(CalibrationRefused, match="not found in any frame"):
        fit_calibration([], SCREEN, (W, H))


def _parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="jostle")
    calibrate_cli.add(p.add_subparsers(dest="command", required=True))
    return p


def test_cli_headless_from_a_recording(tmp_path: Path) -> None:
    board = board_image(SPEC, PPM, MARGIN)
    to_image = screen_truth() @ board_metres_to_stage_screen() @ board_px_to_metres()
    frames = [Frame("webcam", k / 15, k, ColorImage(render(board, to_image, seed=k))) for k in range(4)]
    rec = write_recording(tmp_path / "board.mcap", frames, color_format="png")
    config = tmp_path / "install.toml"
    config.write_text("# not read\n")
    argv = ["calibrate", "webcam", "--from", str(rec), "--square-m", "0.25", "--marker-m", "0.19",
            "--origin=-0.4,1.9", "--plane-y", "0.3", "--half-depth", "0.7", "--config", str(config),
            "--preview", str(tmp_path / "fit.png")]
    args = _parser().parse_args(argv)
    assert args.func(args) == 0
    cal = Calibration.load(tmp_path / calibrate_cli.DEFAULT_NAME)
    truth = cv2.perspectiveTransform(np.array([[[320.0, 240.0]]]), np.linalg.inv(screen_truth()))[0]
    assert np.abs(cal.image_to_stage(np.array([[320.0, 240.0]]))[:, [0, 2]] - truth).max() < 0.01
    preview = cv2.imread(str(tmp_path / "fit.png"))
    assert preview is not None and preview.shape == (H, W, 3)
    from jostle.errors import UsageError

    again = _parser().parse_args(argv)
    with pytest.raises(UsageError, match="exists; pass --force"):
        again.func(again)
    strict = _parser().parse_args([*argv, "--force", "--max-error", "0.01"])
    with pytest.raises(UsageError, match="calibration refused: reprojection error"):
        strict.func(strict)


def test_cli_writes_the_board_image(tmp_path: Path) -> None:
    args = _parser().parse_args(["calibrate", "board", "--out", str(tmp_path / "b.png"), "--px-per-m", "1000"])
    assert args.func(args) == 0
    img = cv2.imread(str(tmp_path / "b.png"), cv2.IMREAD_GRAYSCALE)
    assert img is not None
    assert img.shape == (280 + 80, 200 + 80)
    assert detect_board(img, BoardSpec()) is not None
