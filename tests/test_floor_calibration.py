"""The floor calibration (a raised camera looking down): its geometry against the virtual performer's
exact camera, its file beside the upright one, a calibration from typed floor points and their
refusals, and ``jostle calibrate webcam --points``."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from interaction.webcam.calibration import Calibration, CalibrationError
from interaction.webcam.floor_calibration import FloorCalibration, camera_from_floor, load_webcam_calibration
from interaction.webcam.floor_points import fit_floor_points, parse_points
from jostle.cli import main
from jostle.performer.camera import PinholeCamera

W, H = 320, 240
CAMERA = PinholeCamera(W, H, (0.0, -3.5, 3.0), 30.0, 72.0)  # 3 m high, 30° down, 3.5 m before the plane y = 0
MARKS = np.array([[-2.5, -1.0], [2.5, -1.0], [2.0, 2.5], [-2.0, 2.5], [0.0, 0.5], [1.0, 1.5]])  # stage x, y


def exact() -> FloorCalibration:
    return FloorCalibration(tuple(CAMERA.camera_matrix().ravel().tolist()), 0.25, (W, H))


def marks_px(xy: np.ndarray = MARKS) -> np.ndarray:
    return CAMERA.project(np.column_stack([xy, np.zeros(len(xy))]))


def test_the_exact_floor_calibration_puts_floor_points_and_heads_where_they_are() -> None:
    cal = exact()
    assert np.allclose(cal.camera_centre, CAMERA.position, atol=1e-9)
    rng = np.random.default_rng(3)
    floor = np.column_stack([rng.uniform(-2.5, 2.5, 50), rng.uniform(-1.0, 2.5, 50), np.zeros(50)])
    # built from the same matrix: only round-off apart (1e-9 m)
    assert np.allclose(cal.image_to_floor(CAMERA.project(floor)), floor, atol=1e-9)
    raised = floor + [0.0, 0.0, 0.04]
    assert np.allclose(cal.image_to_floor(CAMERA.project(raised), 0.04), raised, atol=1e-9)
    # a head 1.7 m above a person's ground point, 0.2 m to the side, on the person's upright plane
    for x, y in ((-1.5, -0.5), (0.0, 0.0), (2.0, 2.0)):
        plane = cal.person((x, y))
        head = np.array([[x, y, 1.7]])
        assert np.allclose(plane.image_to_stage(CAMERA.project(head)), head, atol=1e-9)
        side = np.array([x, y, 1.2]) + 0.2 * np.cross([0.0, 0.0, 1.0], plane.normal)
        assert np.allclose(plane.image_to_stage(CAMERA.project(side[None])), side, atol=1e-9)
        assert 0.005 < float(plane.metres_per_pixel(CAMERA.project(head))[0]) < 0.05
    # -P is the same camera
    flipped = FloorCalibration(tuple((-CAMERA.camera_matrix()).ravel().tolist()), 0.25, (W, H))
    assert np.allclose(flipped.image_to_floor(CAMERA.project(floor)), floor, atol=1e-9)
    # above the horizon there is no floor
    assert np.isnan(cal.image_to_floor(np.array([[160.0, -400.0]]))).all()
    # its upright plane is the camera's upright homography (same maths, round-off apart)
    upright = cal.upright(0.0)
    assert np.allclose(upright.matrix, CAMERA.plane_homography(0.0), rtol=1e-9, atol=1e-12)


def test_the_camera_comes_back_from_the_floor_homography_alone() -> None:
    p = CAMERA.camera_matrix()
    found, focal = camera_from_floor(p[:, [0, 1, 3]], (W, H))
    # the renderer's principal point is (W/2, H/2 - 1), half a pixel from the centre assumed: ~0.2 %
    assert focal == pytest.approx(CAMERA.focal_px, rel=0.005)
    centre = -np.linalg.inv(found[:, :3]) @ found[:, 3]
    assert np.allclose(centre, CAMERA.position, atol=0.02)
    with pytest.raises(CalibrationError, match="from below"):
        camera_from_floor(p[:, [0, 1, 3]] @ np.diag([-1.0, 1.0, 1.0]), (W, H))  # x mirrored


def test_files_of_both_kinds_load_and_say_which_they_are(tmp_path: Path) -> None:
    cal = exact()
    path = tmp_path / "floor.toml"
    cal.save(path)
    assert 'kind = "floor"' in path.read_text()
    again = load_webcam_calibration(path)
    assert isinstance(again, FloorCalibration) and again == cal  # floats written with repr: exact
    # an upright file, old style (no kind) or saying so, loads exactly as before
    upright = Calibration(tuple(CAMERA.plane_homography(0.0).ravel().tolist()), 0.0, 1.0, (W, H))
    old = tmp_path / "upright.toml"
    upright.save(old)
    assert load_webcam_calibration(old) == Calibration.load(old) == upright
    said = tmp_path / "said.toml"
    said.write_text('kind = "upright"\n' + old.read_text())
    assert load_webcam_calibration(said) == Calibration.load(said) == upright
    with pytest.raises(CalibrationError, match=r"floor\.toml: kind: expected 'upright' here, got 'floor'"):
        Calibration.load(path)  # the upright reader does not take a floor file for one


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ('kind = "wall"\n', r"bad\.toml: kind: expected 'floor' or 'upright', got 'wall'"),
        ('kind = "floor"\nprojection = [[1, 2, 3], [4, 5, 6], [7, 8, 9]]\n', r"bad\.toml: projection: expected 3 rows of 4"),
        ('kind = "floor"\nprojection = [[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 1]]\n', r"bad\.toml: projection: .*below the floor"),
        ('kind = "floor"\nprojection = [[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, -1]]\nhalf_depth = -1\n',
         r"bad\.toml: half_depth: expected a number"),
        ('kind = "floor"\nprojection = [[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, -1]]\nplane_y = 0\n',
         r"bad\.toml: plane_y: unknown key"),
        ('kind = "floor"\nprojection = [[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, "x"]]\n', r"bad\.toml: projection: expected a number"),
    ],
)
def test_a_bad_floor_file_is_refused_in_one_line(tmp_path: Path, text: str, message: str) -> None:
    path = tmp_path / "bad.toml"
    path.write_text(text)
    with pytest.raises(CalibrationError, match=message) as info:
        load_webcam_calibration(path)
    assert "\n" not in str(info.value)


def test_a_calibration_that_is_not_a_regular_file_is_refused(tmp_path: Path) -> None:
    with pytest.raises(CalibrationError, match=r"nowhere\.toml: no such calibration file"):
        load_webcam_calibration(tmp_path / "nowhere.toml")
    (tmp_path / "folder.toml").mkdir()
    with pytest.raises(CalibrationError, match=r"folder\.toml") as info:
        load_webcam_calibration(tmp_path / "folder.toml")
    assert "\n" not in str(info.value)


def test_a_person_right_under_the_camera_still_has_a_plane() -> None:
    down = PinholeCamera(W, H, (0.0, 0.0, 3.0), 90.0, 72.0)  # looking straight down
    cal = FloorCalibration(tuple(down.camera_matrix().ravel().tolist()), 0.25, (W, H))
    plane = cal.person((0.0, 0.0))
    assert np.allclose(plane.normal, [0.0, 1.0, 0.0])
    beside = cal.person((1.0, 0.0))
    assert np.allclose(beside.normal, [1.0, 0.0, 0.0])  # facing the camera, laid flat


def test_typed_floor_points_give_the_floor_within_centimetres() -> None:
    uv = np.round(marks_px())  # typed as whole pixels
    fit = fit_floor_points(uv, MARKS, (W, H))
    assert fit.rms_px < 0.5 and fit.max_m < 0.03 and fit.points == 6
    cal = fit.calibration
    rng = np.random.default_rng(5)
    floor = np.column_stack([rng.uniform(-2.5, 2.5, 200), rng.uniform(-1.0, 2.5, 200), np.zeros(200)])
    err = np.linalg.norm(cal.image_to_floor(CAMERA.project(floor))[:, :2] - floor[:, :2], axis=1)
    assert float(np.percentile(err, 95)) < 0.03  # whole-pixel marks: ~2 cm a pixel on the far floor
    assert np.allclose(cal.camera_centre, CAMERA.position, atol=0.1)
    head = np.array([[0.5, 1.0, 1.7]])
    assert np.linalg.norm(cal.person((0.5, 1.0)).image_to_stage(CAMERA.project(head)) - head) < 0.05
    given = fit_floor_points(uv, MARKS, (W, H), hfov_deg=72.0)
    assert given.focal_given and given.focal_px == pytest.approx(CAMERA.focal_px)
    assert "px RMS" in fit.describe() and "m RMS" in fit.describe()


def _text(uv: np.ndarray, xy: np.ndarray) -> str:
    return " ".join(f"{u:g},{v:g}={x:g},{y:g}" for (u, v), (x, y) in zip(uv, xy, strict=True))


def _refusal(uv: np.ndarray, xy: np.ndarray) -> str:
    with pytest.raises(CalibrationError) as info:
        fit_floor_points(uv, xy, (W, H))
    assert "\n" not in str(info.value)
    return str(info.value)


def test_bad_floor_points_are_refused_one_line_each() -> None:
    uv, xy = np.round(marks_px()), MARKS
    assert "expected 4 or more floor points, got 3" in _refusal(uv[:3], xy[:3])
    off = uv.copy()
    off[2] = (400.0, 100.0)
    assert "point 3: pixel (400, 100) is outside the 320×240 image" in _refusal(off, xy)
    twice = uv.copy()
    twice[4] = uv[1] + 0.5
    assert "points 2 and 5 are at the same pixel" in _refusal(twice, xy)
    same = xy.copy()
    same[5] = xy[0]
    assert "points 1 and 6 are at the same stage point" in _refusal(uv, same)
    line = np.array([[-2.0, 0.0], [0.0, 0.0], [2.0, 0.0], [0.0, 2.0]])
    assert "lie on one line on the floor" in _refusal(np.round(marks_px(line)), line)
    typo = uv.copy()
    typo[4, 1] += 15
    assert "point 5 (pixel 160," in _refusal(typo, xy) and "a typo" in _refusal(typo, xy)
    assert "point 3 would be behind the camera: check it (two points swapped?)" in _refusal(uv[[1, 0, 2, 3]], xy[:4])
    assert "the points are mirrored" in _refusal(uv[[1, 0, 3, 2]], xy[:4])  # left and right exchanged
    with pytest.raises(CalibrationError, match=r"--points: point 2: expected u,v=x,y .*got '1,2=3'"):
        parse_points("1,2=3,4 1,2=3 5,6=7,8")
    a, b = parse_points(_text(uv, xy))
    assert np.array_equal(a, uv) and np.allclose(b, xy)


def test_calibrate_webcam_from_typed_points(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "webcam.toml"
    uv = np.round(marks_px())
    assert main(["calibrate", "webcam", "--size", f"{W}x{H}", "--points", _text(uv, MARKS), "--out", str(out)]) == 0
    said = capsys.readouterr().out
    assert "reprojection error" in said and "px RMS" in said and "m RMS" in said and str(out) in said
    cal = load_webcam_calibration(out)
    assert isinstance(cal, FloorCalibration) and cal.image_size == (W, H) and cal.half_depth == 0.25
    # refused: exit 2, one line naming the flag and the point; nothing written
    bad = tmp_path / "bad.toml"
    assert main(["calibrate", "webcam", "--size", f"{W}x{H}", "--points", _text(uv[:3], MARKS[:3]),
                 "--out", str(bad)]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("jostle: error:") and "--points" in err and "got 3" in err and "\n" not in err
    assert not bad.exists()
    assert main(["calibrate", "webcam", "--points", _text(uv, MARKS), "--out", str(bad)]) == 2
    assert "--size" in capsys.readouterr().err
