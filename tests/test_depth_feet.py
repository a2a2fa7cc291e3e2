"""Feet on ray-cast depth images (a floor and upright boxes for legs, each answer known exactly), and
the velocity ceiling the frame rate sets (``jostle bench interaction``'s sampled-truth figure)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from interaction.depth_calibration import DepthCalibration
from interaction.depth_parts import FineDepth, find_feet
from jostle.bench_interaction import sampled_truth_angles
from jostle.synth.truth import PersonTruth, TruthFrame
from sensors.base import DepthImage
from sim.motion.mocap import HUMANOID

W, H, F = 640, 400, 440.0
CAMERA = np.array([0.0, -4.0, 2.4])  # stage metres, looking along +y, pitched down 25°


@pytest.fixture(scope="module")
def cal() -> DepthCalibration:
    pitch = math.radians(25.0)
    forward = np.array([0.0, math.cos(pitch), -math.sin(pitch)])
    right = np.array([1.0, 0.0, 0.0])
    down = np.cross(forward, right)
    r = np.stack([right, down, forward], axis=1)
    return DepthCalibration(tuple(r.reshape(-1).tolist()), tuple(CAMERA.tolist()), (*r[2].tolist(), float(CAMERA[2])))


def _render(cal: DepthCalibration, boxes: list[tuple[tuple[float, float, float], tuple[float, float, float]]]) -> DepthImage:
    """Depth (mm) of the floor (z = 0) and axis-aligned boxes (low corner, high corner), nearest first."""
    v, u = np.mgrid[0:H, 0:W].astype(np.float64)
    rays = np.stack([(u - W / 2) / F, (v - H / 2) / F, np.ones_like(u)], axis=-1) @ cal.matrix.T
    with np.errstate(divide="ignore", invalid="ignore"):
        depth = np.where(rays[..., 2] < 0, -CAMERA[2] / rays[..., 2], np.inf)
        for lo, hi in boxes:  # slabs: the ray is inside all three between t_near and t_far
            t0 = (np.array(lo) - CAMERA) / rays
            t1 = (np.array(hi) - CAMERA) / rays
            near = np.nanmax(np.minimum(t0, t1), axis=-1)
            far = np.nanmin(np.maximum(t0, t1), axis=-1)
            hit = (near <= far) & (near > 0)
            depth = np.where(hit & (near < depth), near, depth)
    mm = np.where(np.isfinite(depth), np.rint(depth * 1000.0), 0).astype(np.uint16)
    return DepthImage(depth_mm=mm, fx=F, fy=F, cx=W / 2, cy=H / 2)


def _leg_points(fine: FineDepth) -> np.ndarray:
    """The person's sampled points: every 4th full-resolution point over the floor near the leg."""
    return fine.points_near(np.array([0.0, 0.0, 0.4]), 0.6, 0.03)[::4]


def test_a_leg_down_to_the_floor_has_a_foot_where_it_stands(cal: DepthCalibration) -> None:
    fine = FineDepth(cal)
    fine.set_frame(_render(cal, [((-0.05, -0.05, 0.0), (0.05, 0.05, 0.8))]))  # a leg standing on the floor
    feet = find_feet(_leg_points(fine), fine)
    assert len(feet) == 1
    assert float(np.hypot(feet[0][0], feet[0][1])) < 0.06
    assert feet[0][2] < 0.1


def test_a_leg_whose_lowest_part_seen_is_high_has_no_foot_guessed(cal: DepthCalibration) -> None:
    # the same leg seen only from 17 cm up (its foot hidden): a shin, not a shoe
    fine = FineDepth(cal)
    fine.set_frame(_render(cal, [((-0.05, -0.05, 0.17), (0.05, 0.05, 0.8))]))
    q = _leg_points(fine)
    assert np.count_nonzero(q[:, 2] < 0.2) >= 4  # low points there are (the cluster is found) …
    assert find_feet(q, fine) == []  # … but what is seen of it is a shin


def _person(pid: int, joints: np.ndarray, velocities: np.ndarray) -> PersonTruth:
    return PersonTruth(id=pid, size=1.0, mass_kg=70.0, present=True, joints=joints, velocities=velocities)


def test_the_sampled_truth_ceiling_is_the_turn_within_a_frame() -> None:
    rng = np.random.default_rng(3)
    body = rng.normal(0.0, 0.3, (len(HUMANOID.names), 3))  # a rigid body, 10 m from a vertical axis
    body[:, 0] += 10.0
    omega, dt = 0.5, 1 / 15  # rad/s: every joint moves at ≈ 5 m/s along its circle

    def frame(t: float, pid: int = 7) -> TruthFrame:
        c, s = math.cos(omega * t), math.sin(omega * t)
        rot = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
        joints = body @ rot.T
        velocities = omega * np.stack([-joints[:, 1], joints[:, 0], np.zeros(len(joints))], axis=1)
        return TruthFrame(t=t, seq=round(t * 15), people=(_person(pid, joints, velocities),))

    angles = sampled_truth_angles(frame(1.0), frame(1.0 + dt))
    assert len(angles) == 4  # two hands, two feet
    # a chord of a circle is off the tangent at its end by half the angle it spans (the hand centre is
    # 2 cm off the wrist whose velocity it is given: ≈ 0.1° more at 10 m)
    assert np.allclose(angles, math.degrees(omega * dt / 2), atol=0.2)
    assert sampled_truth_angles(frame(1.0, pid=8), frame(1.0 + dt)) == []  # not the same person before
    still = TruthFrame(t=1.0 + dt, seq=16, people=(_person(7, body, np.zeros_like(body)),))
    assert sampled_truth_angles(TruthFrame(t=1.0, seq=15, people=(_person(7, body, np.zeros_like(body)),)), still) == []
