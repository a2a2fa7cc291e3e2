"""Following hands, feet and people from frame to frame (interaction.depth.limb_tracks, interaction.people)."""

from __future__ import annotations

import math

import cv2
import numpy as np
import pytest

from interaction.depth.limb_tracks import LimbTracker
from interaction.people import PeopleTracker, find_blobs, outline_points, split_merged

DT = 1 / 15


def _tracker(**kw: float) -> LimbTracker:
    settings = {"gate_m": 0.3, "steady_m": 0.1, "confirm_frames": 2, "steady_frames": 3, "memory_frames": 3,
                "consistent_deg": 20.0, "min_speed": 0.4}
    settings.update(kw)
    return LimbTracker(**settings)  # type: ignore[arg-type]


def test_a_hand_is_reported_from_its_second_frame_on() -> None:
    tracks = _tracker()
    hand = np.array([0.5, 0.0, 1.0])
    assert tracks.update(0, "hand", [hand], 0.0, born=True) == []
    out = tracks.update(0, "hand", [hand + 0.01], DT, born=False)
    assert len(out) == 1 and np.allclose(out[0][1], hand + 0.01)  # the frame's own measurement, no lag


def test_a_steady_hand_claims_its_velocity_exactly_and_a_jump_withdraws_it() -> None:
    tracks = _tracker()
    v = np.array([1.2, -0.3, 0.4])
    start = np.array([0.0, 0.0, 1.0])
    claimed = []
    for k in range(6):
        out = tracks.update(0, "hand", [start + v * k * DT], k * DT, born=k == 0)
        claimed.append(out[0][2] if out else np.full(3, np.nan))
    assert np.isnan(claimed[0]).all()  # not yet confirmed
    assert np.allclose(claimed[1], 0.0)  # confirmed; one step only: nothing to check its direction against
    assert np.allclose(claimed[2], v) and np.allclose(claimed[5], v)  # three frames without a jump
    jumped = tracks.update(0, "hand", [start + v * 6 * DT + np.array([0.2, 0.0, 0.0])], 6 * DT, born=False)
    assert len(jumped) == 1 and np.allclose(jumped[0][2], 0.0)  # within the gate, but no longer steady


def test_a_slow_or_wavering_hand_claims_no_velocity() -> None:
    tracks = _tracker()
    for k in range(8):  # 0.2 m/s: below min_speed
        out = tracks.update(0, "foot", [np.array([0.2 * k * DT, 0.0, 0.05])], k * DT, born=k == 0)
    assert np.allclose(out[0][2], 0.0)
    tracks = _tracker()
    for k in range(8):  # 1.5 m/s, turning 60° each frame: the last two steps disagree
        angle = math.radians(60 * k)
        p = np.array([0.1 * math.cos(angle), 0.1 * math.sin(angle), 1.0])
        out = tracks.update(0, "hand", [p], k * DT, born=k == 0)
    assert np.allclose(out[0][2], 0.0)


def test_two_hands_keep_their_slots_and_a_far_detection_starts_a_new_track() -> None:
    tracks = _tracker()
    left, right = np.array([-0.4, 0.0, 1.0]), np.array([0.4, 0.0, 1.0])
    tracks.update(0, "hand", [left, right], 0.0, born=True)
    out = tracks.update(0, "hand", [right + 0.02, left - 0.02], DT, born=False)  # found in the other order
    slots = {tuple(np.round(p, 2)): slot for slot, p, _ in out}
    first = tracks.update(0, "hand", [left - 0.04, right + 0.04], 2 * DT, born=False)
    assert {tuple(np.round(p, 2)): s for s, p, _ in first} == {
        tuple(np.round(left - 0.04, 2)): slots[tuple(np.round(left - 0.02, 2))],
        tuple(np.round(right + 0.04, 2)): slots[tuple(np.round(right + 0.02, 2))]}
    far = tracks.update(0, "hand", [left + np.array([0.0, 0.0, -0.8])], 3 * DT, born=False)
    assert far == []  # a new track: not reported before its second frame


def test_people_are_predicted_ahead_and_found_again_after_being_hidden() -> None:
    tracker = PeopleTracker(max_distance=0.6, memory_frames=30)
    walker = [(0.1 * k, 0.0) for k in range(5)]
    for k in range(5):
        ids = tracker.assign([walker[k], (3.0, 0.0)])
    assert ids == [0, 1]
    (place, unseen), = [v for pid, v in tracker.predicted().items() if pid == 0]
    assert unseen == 0 and place == pytest.approx((0.5, 0.0))
    for _ in range(4):  # hidden for four frames
        tracker.assign([(3.0, 0.0)])
    # back 1.0 m from where it was last seen: beyond max_distance of its prediction, within twice that
    assert tracker.assign([(1.45, 0.0), (3.0, 0.0)]) == [0, 1]
    assert tracker.born == frozenset()


def _silhouette(arm: str) -> np.ndarray:
    """A person 200 px tall facing the camera: head, torso, legs, and the right arm as asked."""
    mask = np.zeros((260, 240), np.uint8)
    cv2.circle(mask, (120, 45), 17, 255, -1)
    cv2.rectangle(mask, (100, 62), (140, 140), 255, -1)  # torso, shoulders at v = 62
    cv2.rectangle(mask, (102, 140), (117, 230), 255, -1)  # legs
    cv2.rectangle(mask, (123, 140), (138, 230), 255, -1)
    cv2.rectangle(mask, (86, 64), (99, 135), 255, -1)  # left arm, hanging against the body
    if arm == "out":
        cv2.rectangle(mask, (140, 64), (215, 76), 255, -1)  # held out at the shoulder
    elif arm == "down":
        cv2.rectangle(mask, (141, 64), (153, 135), 255, -1)
    elif arm == "knee":  # arm down, right knee raised forward
        cv2.rectangle(mask, (141, 64), (153, 135), 255, -1)
        cv2.rectangle(mask, (123, 140), (185, 152), 255, -1)
        cv2.rectangle(mask, (173, 150), (185, 210), 255, -1)
    return mask


@pytest.mark.parametrize(("arm", "hands"), [("out", [(215, 70)]), ("down", []), ("knee", [])])
def test_webcam_hands_are_arms_held_out_never_knees(arm: str, hands: list[tuple[int, int]]) -> None:
    mask = _silhouette(arm)
    (blob,) = find_blobs(mask, 100, 4)
    uv, parts = outline_points(blob.contour, 6.0, (mask.shape[1], mask.shape[0]))
    found = [tuple(p) for p, part in zip(uv.tolist(), parts, strict=True) if part == "hand"]
    assert len(found) == len(hands)
    for (u, v), (hu, hv) in zip(found, hands, strict=True):
        assert abs(u - hu) <= 2 and abs(v - hv) <= 8


def test_a_blob_of_two_people_is_cut_where_each_was_predicted() -> None:
    mask = np.zeros((240, 320), np.uint8)
    for left in (100, 130):  # two people 30 px apart, overlapping: one blob
        cv2.circle(mask, (left + 20, 40), 15, 255, -1)
        cv2.rectangle(mask, (left, 55), (left + 40, 200), 255, -1)
    (blob,) = find_blobs(mask, 100, 4)
    parts = split_merged([blob], [(120.0, 120.0), (150.0, 120.0), (300.0, 120.0)], 500)
    assert len(parts) == 2
    assert sorted(round(p.centroid[0]) for p in parts) == pytest.approx([117, 153], abs=4)
    assert sum(p.area for p in parts) == pytest.approx(blob.area, rel=0.05)
    assert split_merged([blob], [(120.0, 120.0)], 500) == [blob]  # one person known there: left whole
