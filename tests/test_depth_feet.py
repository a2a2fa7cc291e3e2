"""Feet on ray-cast depth images (a floor and upright boxes for legs, each answer known exactly), and
the velocity ceiling the frame rate sets (``jostle bench interaction``'s sampled-truth figure)."""

from __future__ import annotations

import math

import numpy as np
import pytest

import interaction.depth.parts as depth_parts
from interaction.depth.calibration import DepthCalibration
from interaction.depth.fine_depth import FineDepth
from interaction.depth.limb_tracks import LimbTracker
from interaction.depth.parts import FLOOR_CUT_M, find_feet
from interaction.depth.shoe_fit import HANGING_FROM_M, SHOE_HEIGHT_M, lies_flat, shoe_middle_height
from jostle.bench.truth import sampled_truth_angles
from jostle.performer.truth import PersonTruth, TruthFrame
from sensors.base import DepthImage
from sim.motion.mocap import HUMANOID

W, H, F = 640, 400, 440.0
CAMERA = np.array([0.0, -4.0, 2.4])  # stage metres, looking along +y, pitched down 25°
LEG = ((-0.05, -0.05, 0.0), (0.05, 0.05, 1.6))  # a 1.6 m person as a box from its low corner to its high one
SHOE = ((-0.05, -0.12, 0.0), (0.05, 0.14, 0.08))  # 26 × 10 × 8 cm, its middle 1 cm ahead of the leg's


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
    return fine.points_near(np.array([0.0, 0.0, 0.8]), 0.9, 0.03)[::4]


def test_a_leg_down_to_the_floor_has_a_foot_where_it_stands(cal: DepthCalibration) -> None:
    fine = FineDepth(cal)
    fine.set_frame(_render(cal, [LEG, SHOE]))  # a leg standing on the floor in its shoe
    feet = find_feet(_leg_points(fine), fine)
    assert len(feet) == 1
    assert float(np.hypot(feet[0][0], feet[0][1] - 0.01)) < 0.06  # the shoe's middle
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


def _board(edge_x: float) -> tuple[tuple[float, float, float], tuple[float, float, float]]:
    """A board 2.5 m in front of the leg hiding all left of ``edge_x`` (in line with x = 1.6·edge_x at the leg)."""
    return (-0.5, -1.55, 0.0), (edge_x, -1.45, 1.6)


@pytest.mark.parametrize("edge_x", [0.01875, 0.0])  # all but 2–3 cm of the shoe hidden; half of it
def test_a_shoe_seen_on_a_sliver_or_half_is_not_measured(cal: DepthCalibration, edge_x: float,
                                                         monkeypatch: pytest.MonkeyPatch) -> None:
    fine = FineDepth(cal)
    fine.set_frame(_render(cal, [LEG, SHOE, _board(edge_x)]))
    q = _leg_points(fine)
    assert find_feet(q, fine) == []  # not measured …
    monkeypatch.setattr(depth_parts, "MIN_SHOE_SEEN_M2", 0.0)
    monkeypatch.setattr(depth_parts, "HIDDEN_SHOE_SEEN_M2", 0.0)
    seen = find_feet(q, fine)
    assert len(seen) == 1 and float(seen[0][0]) > 0.02  # … where it would be put off its middle


def test_a_shoe_seen_on_little_is_measured_in_the_open_not_beside_something_nearer(cal: DepthCalibration) -> None:
    # seen toe-on, a whole 26 × 10 × 8 cm shoe shows 0.0135 m²: more than MIN_SHOE_SEEN_M2, less than
    # HIDDEN_SHOE_SEEN_M2, so it is measured only when nothing nearer fills its surroundings (beside a board
    # that leaves it whole, it is left out too: the rule's price)
    fine = FineDepth(cal)
    fine.set_frame(_render(cal, [LEG, SHOE]))
    assert len(find_feet(_leg_points(fine), fine)) == 1
    fine.set_frame(_render(cal, [LEG, SHOE, _board(-0.03)]))
    assert find_feet(_leg_points(fine), fine) == []


def test_a_foot_is_reported_from_its_first_frame_a_hand_from_its_second() -> None:
    tracks = LimbTracker(gate_m=0.3, steady_m=0.1, confirm_frames=2, steady_frames=3, memory_frames=3,
                         consistent_deg=20.0, min_speed=0.5, confirm_by_part={"foot": 1})
    foot, hand = np.array([0.0, 0.0, 0.03]), np.array([0.4, 0.0, 1.2])
    assert [slot for slot, _, _ in tracks.update(0, "foot", [foot], 0.0, born=True)] == [0]
    assert tracks.update(0, "hand", [hand], 0.0, born=True) == []
    assert len(tracks.update(0, "hand", [hand], 1 / 15, born=False)) == 1



def _leg(bottom: float) -> tuple[tuple[float, float, float], tuple[float, float, float]]:
    return (-0.05, -0.05, bottom), (0.05, 0.05, 1.6)


# 26 × 10 × 8 cm shoes, the leg over the heel's half: flat across the view (side-on) or along it (toe-on),
# and hanging toe-down (26 cm tall, its toe 8 cm up) whichever way it faces
SIDE_ON_FLAT = ((-0.2, -0.05, 0.0), (0.06, 0.05, 0.08))
TOE_ON_RAISED = ((-0.05, -0.2, 0.12), (0.05, 0.06, 0.2))
HANGING = [((-0.05, -0.04, 0.08), (0.05, 0.04, 0.34)), ((-0.04, -0.05, 0.08), (0.04, 0.05, 0.34))]


def test_a_shoe_flat_on_the_floor_has_its_middle_half_a_shoe_up(cal: DepthCalibration) -> None:
    fine = FineDepth(cal)
    fine.set_frame(_render(cal, [_leg(0.08), SIDE_ON_FLAT]))  # seen: its top at 8 cm, its side down to the cut
    feet = find_feet(_leg_points(fine), fine)
    assert feet and all(abs(float(f[2]) - 0.5 * SHOE_HEIGHT_M) < 1e-9 for f in feet)


@pytest.mark.parametrize("shoe", HANGING)
def test_a_shoe_hanging_toe_down_is_put_up_along_it_not_at_its_toe(cal: DepthCalibration, shoe: tuple[
        tuple[float, float, float], tuple[float, float, float]], monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(depth_parts, "MIN_SHOE_SEEN_M2", 0.0)  # seen end-on, the box shows less than a shoe's area
    fine = FineDepth(cal)
    fine.set_frame(_render(cal, [_leg(0.34), shoe]))
    q = _leg_points(fine)
    feet = find_feet(q, fine)
    middle = 0.21  # the shoe's middle; a generic shoe pitched 45° (the least a hanging foot is) puts it 2–3 cm low
    assert len(feet) == 1 and abs(float(feet[0][2]) - middle) < 0.03
    monkeypatch.setattr(depth_parts, "shoe_middle_height", lambda column, floor_cut, camera: None)
    seen = find_feet(q, fine)  # the points seen alone: the toe's end of the shoe
    assert len(seen) == 1 and middle - float(seen[0][2]) > abs(float(feet[0][2]) - middle) + 0.03


def test_a_shoe_seen_alone_is_one_foot_at_its_middle_not_its_heel_and_its_toe(cal: DepthCalibration,
                                                                           monkeypatch: pytest.MonkeyPatch) -> None:
    # a shoe side-on, 26 cm long, its other foot not seen: its low points split in two, heel and toe
    fine = FineDepth(cal)
    fine.set_frame(_render(cal, [_leg(0.08), SIDE_ON_FLAT]))
    feet = find_feet(_leg_points(fine), fine)
    assert len(feet) == 1 and abs(float(feet[0][0]) + 0.07) < 0.02 and abs(float(feet[0][1])) < 0.02
    monkeypatch.setattr(depth_parts, "one_per_shoe", lambda feet, measured=None: feet)
    assert len(find_feet(_leg_points(fine), fine)) == 2  # without the rule: two feet on the one shoe


def _lowest(column: np.ndarray) -> float:
    k = len(column) * 5 // 100
    return float(np.partition(column[:, 2], k)[k])


def test_a_flat_shoe_seen_on_its_top_alone_stands_a_hanging_one_does_not(cal: DepthCalibration) -> None:
    # a flat shoe whose sides are lost in the floor's noise shows its top a little over the cut, ahead of its
    # leg; a shoe hanging toe-down a little over the floor shows its toe at that height, under its leg
    fine = FineDepth(cal)
    fine.set_frame(_render(cal, [_leg(0.08), SIDE_ON_FLAT]))
    column = fine.column_near(np.array([-0.07, 0.0]), 0.12, FLOOR_CUT_M, 0.3, smooth=True)
    top = column[column[:, 2] > 0.06]  # its sides not seen
    assert FLOOR_CUT_M + 0.01 < _lowest(top) < FLOOR_CUT_M + 0.025
    assert lies_flat(top, _lowest(top)) and shoe_middle_height(top, FLOOR_CUT_M, fine.camera) == 0.5 * SHOE_HEIGHT_M
    lowest = []
    for low, high in ((-0.05, -0.04), (0.05, 0.04)), ((-0.04, -0.05), (0.04, 0.05)):  # both ways round
        fine.set_frame(_render(cal, [_leg(0.29), ((low[0], low[1], 0.03), (high[0], high[1], 0.29))]))
        column = fine.column_near(np.zeros(2), 0.12, FLOOR_CUT_M, 0.3, smooth=True)
        lowest.append(_lowest(column) - FLOOR_CUT_M)
        assert 0.01 < lowest[-1] < 0.025 and not lies_flat(column, _lowest(column))
        height = shoe_middle_height(column, FLOOR_CUT_M, fine.camera)
        if lowest[-1] < HANGING_FROM_M:
            assert height is None  # measured where its points are
        else:
            assert height is not None and abs(height - 0.16) < 0.01  # put up along it (its middle 16 cm up)
    assert min(lowest) < HANGING_FROM_M <= max(lowest)  # one of each


def test_a_flat_shoe_in_the_air_seen_toe_on_is_measured_where_its_points_are(cal: DepthCalibration) -> None:
    # as narrow across the view as a hanging shoe, but its top is seen behind its toe
    fine = FineDepth(cal)
    fine.set_frame(_render(cal, [_leg(0.2), TOE_ON_RAISED]))
    feet = find_feet(_leg_points(fine), fine)
    assert len(feet) == 1 and abs(float(feet[0][2]) - 0.16) < 0.01
    column = fine.column_near(np.array([0.0, -0.07]), 0.12, FLOOR_CUT_M, 0.3, smooth=True)
    assert shoe_middle_height(column, FLOOR_CUT_M, fine.camera) is None


def test_a_foot_is_followed_on_its_points_seen_and_reported_at_its_shoe_s_middle() -> None:
    # a foot moving steadily along x whose height from the shoe's shape jumps (standing, hanging, …):
    # its velocity is claimed from the points seen, its position is the shoe's middle
    tracks = LimbTracker(gate_m=0.3, steady_m=0.1, confirm_frames=1, steady_frames=3, memory_frames=3,
                         consistent_deg=20.0, min_speed=0.5)
    out: list[tuple[int, np.ndarray, np.ndarray]] = []
    for i in range(5):
        seen = np.array([0.1 * i, 0.0, 0.1])
        middle = np.array([0.1 * i, 0.0, (0.04, 0.19)[i % 2]])
        out = tracks.update(0, "foot", [middle], i / 15, born=i == 0, moving=[seen])
    assert np.allclose(out[0][1], [0.4, 0.0, 0.04])
    assert np.allclose(out[0][2], [1.5, 0.0, 0.0])
    jumpy = LimbTracker(gate_m=0.3, steady_m=0.1, confirm_frames=1, steady_frames=3, memory_frames=3,
                        consistent_deg=20.0, min_speed=0.5)
    for i in range(5):
        out = jumpy.update(0, "foot", [np.array([0.1 * i, 0.0, (0.04, 0.19)[i % 2]])], i / 15, born=i == 0)
    assert np.allclose(out[0][2], 0.0)  # followed at the jumping heights, no velocity could be claimed
