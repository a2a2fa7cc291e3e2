"""A hand chosen across the view: the depth's noise along the viewing ray does not choose which points
are the hand's (a known answer: points along an arm, each off along its ray by a known error); and
followed past the arm's end found, not down a leg beside it (ray-cast scenes of boxes)."""

from __future__ import annotations

import math

import numpy as np
import pytest

import interaction.depth.hand_fit as hand_fit
from interaction.depth.calibration import DepthCalibration
from interaction.depth.fine_depth import FineDepth
from interaction.depth.hand_fit import follow_hand, hand_points
from sensors.base import DepthImage

CAMERA = np.array([0.0, -4.0, 2.4])
SHOULDER = np.array([0.0, 0.0, 1.4])
TIP = np.array([0.3, 0.5, 1.1])  # an arm reaching away from the camera and down: half of it along the ray


def _arm(noise_m: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Points along the arm (their share of its length), each moved along its ray by ±``noise_m``
    (alternately: no mean error), and those errors."""
    share = np.repeat(np.linspace(0.0, 1.0, 401), 2)
    true = SHOULDER + share[:, None] * (TIP - SHOULDER)
    rays = (true - CAMERA) / np.linalg.norm(true - CAMERA, axis=1)[:, None]
    error = noise_m * np.tile([1.0, -1.0], 401)
    return true + error[:, None] * rays, share, error


def test_a_hand_is_its_arm_s_last_hand_s_size_whatever_the_depth_s_noise() -> None:
    length = float(np.linalg.norm(TIP - SHOULDER))
    pts, share, error = _arm(0.0)
    chosen = hand_points(pts, TIP, SHOULDER, CAMERA, 0.1)
    assert abs(float(share[np.isin(pts[:, 0], chosen[:, 0])].min()) - (0.95 - 0.1 / length)) < 0.01
    noisy, share, error = _arm(0.06)  # 6 cm along the ray: an OAK at 5 m
    picked = np.isin(noisy[:, 0], hand_points(noisy, TIP, SHOULDER, CAMERA, 0.1)[:, 0])
    assert abs(float(error[picked].mean())) < 0.002  # as many pushed nearer as farther: the average is unbiased
    # chosen on the 3D positions, the points pushed farther along the ray (out along this arm) are taken
    along = (noisy - SHOULDER) @ ((TIP - SHOULDER) / length)
    k = (len(along) * 19) // 20
    in_3d = along > float(np.partition(along, k)[k]) - 0.1
    assert float(error[in_3d].mean()) > 0.01


def test_an_arm_pointing_at_the_camera_has_its_hand_chosen_in_3d() -> None:
    tip = SHOULDER + 0.5 * (CAMERA - SHOULDER) / np.linalg.norm(CAMERA - SHOULDER)  # straight at the camera
    pts = SHOULDER + np.linspace(0.0, 1.0, 101)[:, None] * (tip - SHOULDER)
    chosen = hand_points(pts, tip, SHOULDER, CAMERA, 0.1)
    assert 20 <= len(chosen) <= 26  # the last 0.1 m of 0.5 m (the 95th percentile's end left out)


# ray-cast scenes: a camera 4 m back and 2.4 m up, pitched down 25°, over a floor and upright boxes
W, H, F = 640, 400, 440.0
ARM = ((0.27, -0.03, 0.72), (0.33, 0.03, 1.4))  # an arm hanging straight down, its hand the last 10 cm
HAND_MIDDLE = np.array([0.3, 0.0, 0.77])
ARM_SHOULDER = np.array([0.3, 0.0, 1.4])
TORSO = ((-0.2, -0.1, 0.9), (0.2, 0.1, 1.5))
LEG = ((0.06, -0.07, 0.0), (0.2, 0.07, 0.95))  # a leg right beside the hand, its line foot to hips:
LEG_LINE = (np.array([0.13, 0.0, 0.04]), np.array([0.0, 0.0, 0.8]))


def _fine(boxes: list[tuple[tuple[float, float, float], tuple[float, float, float]]]) -> FineDepth:
    pitch = math.radians(25.0)
    forward = np.array([0.0, math.cos(pitch), -math.sin(pitch)])
    right = np.array([1.0, 0.0, 0.0])
    r = np.stack([right, np.cross(forward, right), forward], axis=1)
    cal = DepthCalibration(tuple(r.reshape(-1).tolist()), tuple(CAMERA.tolist()), (*r[2].tolist(), float(CAMERA[2])))
    v, u = np.mgrid[0:H, 0:W].astype(np.float64)
    rays = np.stack([(u - W / 2) / F, (v - H / 2) / F, np.ones_like(u)], axis=-1) @ cal.matrix.T
    with np.errstate(divide="ignore", invalid="ignore"):
        depth = np.where(rays[..., 2] < 0, -CAMERA[2] / rays[..., 2], np.inf)  # the floor
        for lo, hi in boxes:  # slabs: the ray is inside all three between t_near and t_far
            t0, t1 = (np.array(lo) - CAMERA) / rays, (np.array(hi) - CAMERA) / rays
            near, far = np.nanmax(np.minimum(t0, t1), axis=-1), np.nanmin(np.maximum(t0, t1), axis=-1)
            depth = np.where((near <= far) & (near > 0) & (near < depth), near, depth)
    mm = np.where(np.isfinite(depth), np.rint(depth * 1000.0), 0).astype(np.uint16)
    fine = FineDepth(cal)
    fine.set_frame(DepthImage(depth_mm=mm, fx=F, fy=F, cx=W / 2, cy=H / 2))
    return fine


def _follow(fine: FineDepth, tip: np.ndarray, legs: list[tuple[np.ndarray, np.ndarray]]) -> np.ndarray:
    middle = follow_hand(lambda centre: fine.points_near(centre, 0.14, 0.05, smooth=True), tip, ARM_SHOULDER,
                         fine.camera, 0.1, 0.05, legs, 0.16)
    assert middle is not None
    return middle


def test_a_hand_beyond_the_arm_s_end_found_is_followed_down_the_arm(monkeypatch: pytest.MonkeyPatch) -> None:
    fine = _fine([ARM, TORSO])
    tip = np.array([0.3, -0.03, 1.0])  # the arm found to end 28 cm up (its hand under where hands are looked for)
    hand = _follow(fine, tip, [])
    assert abs(hand[0] - HAND_MIDDLE[0]) < 0.01 and abs(hand[2] - HAND_MIDDLE[2]) < 0.02  # its seen face: y -0.03
    monkeypatch.setattr(hand_fit, "LOOKS", 1)
    assert _follow(fine, tip, [])[2] > HAND_MIDDLE[2] + 0.1  # looked for once: on the forearm, 10+ cm short


def test_a_hand_found_beside_a_leg_is_not_followed_down_the_leg(monkeypatch: pytest.MonkeyPatch) -> None:
    fine = _fine([ARM, LEG, TORSO])
    tip = np.array([0.3, -0.03, 0.74])  # the arm found to its end, by the thigh
    followed = _follow(fine, tip, [LEG_LINE])
    assert followed[2] > 0.7
    monkeypatch.setattr(hand_fit, "LOOKS", 1)
    assert np.allclose(followed, _follow(fine, tip, [LEG_LINE]))  # as looked for once
    monkeypatch.undo()
    assert _follow(fine, tip, [])[2] < 0.6  # not told where the leg is: drawn on down it
