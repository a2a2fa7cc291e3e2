"""A hand chosen across the view: the depth's noise along the viewing ray does not choose which points
are the hand's (a known answer: points along an arm, each off along its ray by a known error)."""

from __future__ import annotations

import numpy as np

from interaction.hand_fit import hand_points

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
