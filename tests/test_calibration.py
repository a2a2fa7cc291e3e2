"""Calibration: the homography image → stage plane, its TOML file and its errors."""

from __future__ import annotations

import tomllib
from pathlib import Path

import numpy as np
import pytest

from interaction.webcam.calibration import Calibration, CalibrationError

W, H = 640, 480
# Image corners → a stage trapezoid (the camera looks a little down: the floor row is narrower).
CORNERS_UV = np.array([[0, 0], [W, 0], [W, H], [0, H]], dtype=np.float64)
CORNERS_XZ = np.array([[-2.0, 3.0], [2.0, 3.0], [1.7, 0.0], [-1.7, 0.0]])


def _calibration(plane_y: float = 0.0, half_depth: float = 1.0) -> Calibration:
    return Calibration.from_correspondences(
        CORNERS_UV, CORNERS_XZ, plane_y=plane_y, half_depth=half_depth, image_size=(W, H)
    )


def test_the_fit_maps_the_correspondences_onto_the_stage_plane() -> None:
    cal = _calibration(plane_y=0.7, half_depth=0.4)
    xyz = cal.image_to_stage(CORNERS_UV)
    np.testing.assert_allclose(xyz[:, [0, 2]], CORNERS_XZ, atol=1e-9)
    assert np.all(xyz[:, 1] == 0.7)
    # image up is stage up: the top row is higher than the bottom row
    top, bottom = cal.image_to_stage(np.array([[W / 2, 0.0], [W / 2, H]]))
    assert top[2] > bottom[2]


def test_the_fit_recovers_a_known_homography_from_many_noisy_free_points() -> None:
    h_true = np.array([[0.011, 0.0004, -2.1], [0.0002, -0.0098, 2.9], [0.00001, 0.00025, 1.0]])
    rng = np.random.default_rng(3)
    uv = rng.uniform([0, 0], [W, H], size=(30, 2))
    ph = np.column_stack([uv, np.ones(30)]) @ h_true.T
    xz = ph[:, :2] / ph[:, 2:]
    cal = Calibration.from_correspondences(uv, xz)
    np.testing.assert_allclose(cal.matrix / cal.matrix[2, 2], h_true, rtol=1e-6, atol=1e-12)


def test_image_to_stage_and_back_is_the_identity() -> None:
    cal = _calibration(plane_y=-0.3)
    rng = np.random.default_rng(0)
    uv = rng.uniform([0, 0], [W, H], size=(500, 2))
    np.testing.assert_allclose(cal.stage_to_image(cal.image_to_stage(uv)), uv, atol=1e-8)
    xyz = np.column_stack([rng.uniform(-1.5, 1.5, 200), rng.uniform(-1, 1, 200), rng.uniform(0.1, 2.8, 200)])
    back = cal.image_to_stage(cal.stage_to_image(xyz))
    np.testing.assert_allclose(back[:, [0, 2]], xyz[:, [0, 2]], atol=1e-10)
    assert np.all(back[:, 1] == -0.3)  # projected along y onto the calibrated plane


def test_jacobian_and_scale_match_finite_differences() -> None:
    cal = _calibration()
    uv = np.array([[10.0, 20.0], [320.0, 240.0], [600.0, 470.0]])
    eps = 1e-3
    jac = cal.jacobian(uv)
    for k, (du, dv) in enumerate([(eps, 0.0), (0.0, eps)]):
        d = (cal.image_to_stage(uv + [du, dv]) - cal.image_to_stage(uv - [du, dv]))[:, [0, 2]] / (2 * eps)
        np.testing.assert_allclose(jac[:, :, k], d, rtol=1e-6, atol=1e-12)
    # the stage is 4 m wide over 640 px at the top: about 6 mm per pixel there
    assert cal.metres_per_pixel(np.array([[W / 2, 0.0]]))[0] == pytest.approx(4.0 / W, rel=0.1)


def test_toml_round_trip_is_exact(tmp_path: Path) -> None:
    cal = _calibration(plane_y=0.25, half_depth=0.6)
    path = tmp_path / "webcam.toml"
    cal.save(path)
    assert tomllib.loads(path.read_text())["image_size"] == [W, H]
    again = Calibration.load(path)
    assert again == cal
    assert again.homography == cal.homography  # bit for bit
    no_size = Calibration(cal.homography)
    no_size.save(path)
    assert Calibration.load(path) == no_size


def _write(tmp_path: Path, text: str) -> Path:
    path = tmp_path / "cal.toml"
    path.write_text(text)
    return path


GOOD_H = "homography = [[0.01, 0.0, -2.0], [0.0, -0.01, 3.0], [0.0, 0.0, 1.0]]\n"


@pytest.mark.parametrize(
    ("text", "key"),
    [
        ("homography = [[1, 2, 3]\n", "TOML"),  # not TOML at all
        ("plane_y = 0.0\n", "homography"),  # missing key
        ("homography = [[1, 0, 0], [0, 1, 0]]\n", "homography"),  # 2 rows
        ("homography = [[1, 0, 0], [0, 1, 0], [0, 0, 'x']]\n", "homography"),
        ("homography = [[1, 2, 3], [2, 4, 6], [0, 0, 1]]\n", "homography"),  # singular
        ("homography = [[1, 0, 0], [0, 1, 0], [0, 0, nan]]\n", "homography"),
        (GOOD_H + "plane_y = 'front'\n", "plane_y"),
        (GOOD_H + "half_depth = -1.0\n", "half_depth"),
        (GOOD_H + "image_size = [640]\n", "image_size"),
        (GOOD_H + "imagesize = [640, 480]\n", "imagesize"),  # unknown key
        # the horizon (w = 0) runs through the image: half of it maps behind the camera
        ("homography = [[1, 0, 0], [0, 1, 0], [-0.01, 0, 1]]\nimage_size = [640, 480]\n", "homography"),
    ],
)
def test_bad_files_give_one_line_naming_file_and_key(tmp_path: Path, text: str, key: str) -> None:
    path = _write(tmp_path, text)
    with pytest.raises(CalibrationError) as info:  # a ValueError the CLI prints as one line
        Calibration.load(path)
    msg = str(info.value)
    assert "\n" not in msg
    assert msg.startswith(f"{path}: ")
    assert key in msg


def test_a_missing_file_is_named(tmp_path: Path) -> None:
    with pytest.raises(CalibrationError, match=r"nowhere\.toml: no such calibration file"):
        Calibration.load(tmp_path / "nowhere.toml")


def test_direct_construction_validates() -> None:
    with pytest.raises(ValueError, match=r"^homography: expected 9"):
        Calibration((1.0, 0.0, 0.0))
    with pytest.raises(ValueError, match=r"^homography: expected an invertible"):
        Calibration((1.0, 2.0, 3.0, 2.0, 4.0, 6.0, 0.0, 0.0, 1.0))
    with pytest.raises(ValueError, match=r"^image_size"):
        Calibration((1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0), image_size=(0, 480))
    with pytest.raises(ValueError, match=r"^image_uv: the points are degenerate"):
        Calibration.from_correspondences(np.array([[0, 0], [1, 1], [2, 2], [3, 3]]), CORNERS_XZ)
