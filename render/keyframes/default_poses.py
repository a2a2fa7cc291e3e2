"""The poses of the shipped keyframe sets: motion capture from pybullet_data, and hand-made poses.

Every pose is (root_offset, rotations (1 + J, 4)) in the rigid body's frame, with the skeleton's
centre of mass at the body origin (the sim's centre of mass), computed with the figure's own masses.

- walk / run cycles: a looping clip sampled at evenly spaced phases, root translation removed, mean
  heading turned to +x;
- the side step: ``humanoid3d_dance_b`` frames 18–48, where the dancer steps right (right foot out,
  left foot follows, 0.62 m); keys at evenly spaced fractions of the sideways distance (Dx is
  distance, not time), heading removed. Layered on a walk key it changes only the legs: each leg
  joint turns by the side step's change from its first key, in the joint's own frame;
- staggers: the cycles with the upper body fighting the lean (arms out, trunk against the push);
- falls: hand-posed by rotating joints (falling forward the arms come forward to catch; falling
  backward the body folds, sits and rolls onto its back; falling sideways the hands flutter);
- get-ups: frames of ``humanoid3d_getup_faceup`` / ``_facedown`` placed at the tilt where a rigid body
  rising about its base would hold its centre of mass at the frame's height.
"""

from __future__ import annotations

import math

import numpy as np

from render.keyframes.skeleton_pose import (
    X,
    Z,
    centre_of_mass,
    chain,
    in_body_frame,
    joints,
    rot,
    tilt_rotation,
    yaw_rotation,
)
from render.keyframes.skeletons import Figure
from sim.motion import quaternion as quat
from sim.motion.mocap import HUMANOID, JOINTS, MotionClip, pybullet_motion_path

Posed = tuple[np.ndarray, np.ndarray]  # (root_offset (3,), rotations (1 + J, 4))
Raw = tuple[np.ndarray, np.ndarray]  # (root_rot, joint_rots) before placing in the body frame

SIDE_STEP = ("dance_b", 18, 48)  # clip, first and last frame of one step to the right
GETUP_TILTS = (1.35, 1.15, 0.95, 0.75, 0.55, 0.38, 0.22, 0.1)
# (animation, clip, face up, lying frame, frame the final rise starts from). Face up, the clip lies
# still (frame 0), rocks back with the legs over the head (frames 10–100, centre of mass up to
# 0.36 m) and rises from its lowest point after that (frame 102); face down it pushes up from frame 28.
GETUPS = (
    ("stand_up_faceup", "getup_faceup", True, 0, 102),
    ("stand_up_facedown", "getup_facedown", False, 28, 28),
)
_LEGS = [JOINTS.index(j) for j in ("right_hip", "right_knee", "right_ankle", "left_hip", "left_knee", "left_ankle")]


def posed(root_offset: np.ndarray, root_rot: np.ndarray, joint_rots: np.ndarray) -> Posed:
    return np.asarray(root_offset, dtype=float), np.concatenate([root_rot[None], joint_rots], axis=0)


def upright(raw: Raw, figure: Figure) -> Posed:
    off, rr = in_body_frame(quat.IDENTITY, raw[0], raw[1], figure)
    return posed(off, rr, raw[1])


def authored(root_rot: np.ndarray, joint_rots: np.ndarray, figure: Figure) -> Posed:
    """A hand-made pose, already relative to the body (root_rot relative to the tilted body)."""
    off = -centre_of_mass(np.zeros(3), root_rot, joint_rots, figure)
    return posed(off, quat.normalize(root_rot), joint_rots)


# ------------------------------------------------------------------------------ cycles (mocap)


def cycle_keys(clip_name: str, count: int) -> list[Raw]:
    """(root_rot, joint_rots) of a looping clip at phases k / count, mean heading turned to +x."""
    clip = MotionClip.load(pybullet_motion_path(clip_name))
    samples = [clip.sample(clip.duration * k / count) for k in range(count)]
    return _facing_x([(r, j) for _, r, j in samples])


def _facing_x(raws: list[Raw]) -> list[Raw]:
    fwd = np.array([quat.rotate(r, X) for r, _ in raws])
    turn = quat.conjugate(yaw_rotation(math.atan2(-float(fwd[:, 2].mean()), float(fwd[:, 0].mean()))))
    return [(quat.multiply(turn, r), j) for r, j in raws]


def side_step_keys(phases: list[float]) -> list[Raw]:
    """One step to the right at fractions ``phases`` of its sideways distance (see the module doc)."""
    name, first, last = SIDE_STEP
    clip = MotionClip.load(pybullet_motion_path(name))
    side = clip.root_pos[first : last + 1, 2]
    side = np.maximum.accumulate(side)  # the distance never turns back
    times = clip.times[first : last + 1]
    out = []
    for phase in phases:
        level = side[0] + (side[-1] - side[0]) * phase
        t = float(np.interp(level, side, times))
        _, r, j = clip.sample(t)
        out.append((r, j))
    return _facing_x(out)


def layered(base: Raw, step: Raw, step0: Raw) -> Raw:
    """``base`` with its legs turned by the side step's change from its first key."""
    joints_out = base[1].copy()
    delta = quat.multiply(quat.conjugate(step0[1][_LEGS]), step[1][_LEGS])
    joints_out[_LEGS] = quat.normalize(quat.multiply(base[1][_LEGS], delta))
    return base[0], joints_out


# ------------------------------------------------------------------------------ hand-posed pieces


def arms(flex_r: float, abd_r: float, elbow_r: float, flex_l: float, abd_l: float, elbow_l: float) -> dict:
    return {
        "right_shoulder": chain(rot(X, -abd_r), rot(Z, flex_r)),
        "right_elbow": rot(Z, elbow_r),
        "left_shoulder": chain(rot(X, abd_l), rot(Z, flex_l)),
        "left_elbow": rot(Z, elbow_l),
    }


def legs(hip_r: float, knee_r: float, hip_l: float, knee_l: float, abd_r: float = 0.0, abd_l: float = 0.0) -> dict:
    return {
        "right_hip": chain(rot(X, -abd_r), rot(Z, hip_r)),
        "right_knee": rot(Z, -knee_r),
        "right_ankle": rot(Z, 0.3 * knee_r),
        "left_hip": chain(rot(X, abd_l), rot(Z, hip_l)),
        "left_knee": rot(Z, -knee_l),
        "left_ankle": rot(Z, 0.3 * knee_l),
    }


def trunk(lean_fwd: float, neck_fwd: float, lean_right: float = 0.0, neck_right: float = 0.0) -> dict:
    return {
        "chest": chain(rot(X, lean_right), rot(Z, -lean_fwd)),
        "neck": chain(rot(X, neck_right), rot(Z, -neck_fwd)),
    }


def staggered(raw: Raw, upper: dict) -> Raw:
    """A cycle key with its upper body replaced (trunk, neck, arms from ``upper``)."""
    j = raw[1].copy()
    for name, q in upper.items():
        j[JOINTS.index(name)] = q
    return raw[0], j


STAGGER_FORWARD = trunk(-12, -10) | arms(-25, 45, 30, -20, 50, 35)  # leaning into the push: arms fly back
STAGGER_BACKWARD = trunk(18, 12) | arms(60, 25, 40, 65, 25, 45)  # pushed back: reaching forward
STAGGER_RIGHT = trunk(0, 0, -12, -10) | arms(5, 50, 30, 10, 85, 40)  # pushed right: the left arm flies up


def fall_forward_keys() -> list[tuple[float, str, dict, float]]:
    """(Θx, name, joints, pelvis forward tilt in degrees)."""
    return [
        (0.5, "fall_forward_stumble", trunk(8, -15) | arms(62, 15, 40, 55, 15, 45) | legs(45, 55, -12, 15), 0.0),
        (0.8, "fall_forward_reach", trunk(5, -30) | arms(88, 12, 15, 84, 12, 18) | legs(25, 20, -5, 45), 0.0),
        (1.2, "fall_forward_brace", trunk(0, -38) | arms(118, 15, 35, 114, 15, 35) | legs(8, 20, -4, 32), 0.0),
    ]


def fall_backward_keys() -> list[tuple[float, str, dict, float]]:
    return [
        # folding: hips and knees bend, the pelvis stays nearer upright than the body
        (-0.7, "fall_backward_fold", trunk(25, 15) | arms(62, 18, 40, 58, 18, 45) | legs(85, 100, 80, 105), 25.0),
        # sitting on the floor, legs out in front, hands behind for support
        (-1.1, "fall_backward_sit", trunk(22, 10) | arms(-35, 15, 10, -32, 15, 12) | legs(52, 40, 48, 48), 33.0),
    ]


def fall_right_keys() -> list[tuple[float, str, dict, float]]:
    return [
        # the hands flutter: up, out, up again; the left leg lifts out
        (0.5, "fall_right_flutter", trunk(0, 0, -8, -15) | arms(10, 60, 25, 15, 120, 35) | legs(5, 15, 5, 25, 0, 25), 0.0),
        (0.75, "fall_right_reach", trunk(0, 0, -10, -20) | arms(15, 85, 15, 10, 55, 60) | legs(5, 20, 8, 20, 0, 35), 0.0),
        (1.1, "fall_right_catch", trunk(0, 0, -6, -22) | arms(15, 120, 25, 20, 100, 30) | legs(10, 25, 12, 15, 0, 20), 0.0),
        (math.pi / 2, "lying_right_side", trunk(5, 0, 0, -15) | arms(10, 160, 20, 30, 10, 40) | legs(22, 32, 30, 45), 0.0),
    ]


def hand_posed(keys: list[tuple[float, str, dict, float]], figure: Figure) -> list[tuple[float, str, Posed]]:
    return [(t, name, authored(rot(Z, -pelvis), joints(**j), figure)) for t, name, j, pelvis in keys]


# ------------------------------------------------------------------------------ get-ups (mocap)


def getup_keys(clip_name: str, face_up: bool, lying: int, rise: int, figure: Figure) -> list[tuple[float, Posed]]:
    """(Θx, pose) keys of a get-up clip: the lying frame at ±π/2, then one frame per GETUP_TILTS."""
    clip = MotionClip.load(pybullet_motion_path(clip_name))
    com = centre_of_mass(clip.root_pos, clip.root_rot, clip.joint_rots)[:, 1]  # the performer's own masses
    h_lie, h_up = float(com[lying]), float(com[-1])
    envelope = np.maximum.accumulate(com[rise:])  # keys follow the running maximum: Θ never turns back
    sign = -1.0 if face_up else 1.0
    out = [(sign * math.pi / 2, _clip_pose(clip, clip.times[lying], sign * math.pi / 2, face_up, figure))]
    for mag in GETUP_TILTS:
        level = h_lie + math.cos(mag) * (h_up - h_lie)
        i = int(np.argmax(envelope >= level))
        if envelope[i] < level or i == 0:
            raise ValueError(f"{clip_name}: the rise from frame {rise} does not pass {level:.3f} m")
        u = (level - envelope[i - 1]) / (envelope[i] - envelope[i - 1])
        t = clip.times[rise + i - 1] + u * (clip.times[rise + i] - clip.times[rise + i - 1])
        out.append((sign * mag, _clip_pose(clip, t, sign * mag, face_up, figure)))
    return sorted(out, key=lambda k: k[0])


def _clip_pose(clip: MotionClip, t: float, theta_x: float, face_up: bool, figure: Figure) -> Posed:
    """A clip frame in the body frame at tilt θx, its heading from the trunk and the pelvis."""
    root_pos, root_rot, joint_rots = clip.sample(float(t))
    pos, _ = HUMANOID.forward_kinematics(root_pos, root_rot, joint_rots)
    trunk_dir = pos[HUMANOID.names.index("neck")] - pos[0]
    trunk_dir = trunk_dir / np.linalg.norm(trunk_dir)
    h = quat.rotate(root_rot, X) + (-1.0 if face_up else 1.0) * trunk_dir
    body = quat.multiply(yaw_rotation(math.atan2(-float(h[2]), float(h[0]))), tilt_rotation(theta_x, 0.0))
    off, rr = in_body_frame(body, root_rot, joint_rots, figure)
    return posed(off, rr, joint_rots)
