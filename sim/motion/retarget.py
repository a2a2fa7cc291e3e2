"""BVH motion capture retargeted onto a DeepMimic-jointed skeleton (``HUMANOID`` or a figure's), by bone
directions. Nothing is assumed about the file's up axis, units or rest pose: the retarget works from
joint *positions* only —

- the up axis is the first frame's direction from the hips to the head;
- the pelvis takes the frame spanned by (hips → chest) and (left thigh → right thigh), the chest the
  frame spanned by (chest → neck) and (left → right upper arm); every other bone turns from its parent
  by the smallest rotation that points it at its BVH counterpart (no twist about the bone, which
  capsules cannot show anyway; the foot points at the toes).

Joints come from ``sim.motion.joint_map`` (any common rig, or a ``--joint-map`` file). Root positions
stay in the file's units, the height measured from the floor (the lowest sole, 2nd percentile of frames).
"""

from __future__ import annotations

import math

import numpy as np

from sim.motion import quaternion as quat
from sim.motion.bvh import BvhMotion
from sim.motion.joint_map import JointMap, map_joints
from sim.motion.mocap import HUMANOID, JOINTS, MotionClip, Skeleton

__all__ = ["bone_ends", "retarget"]


def bone_ends(motion: BvhMotion, jm: JointMap) -> dict[str, tuple[int, int]]:
    """Our bone → (BVH joint where it starts, BVH joint it points at), from the joint map's roles."""
    r = jm.roles
    head_tip = next(iter(motion.children(r["head"])), r["head"])
    ends = {"chest": (r["chest"], r["neck"]), "neck": (r["neck"], r["head"] if r["neck"] != r["head"] else head_tip)}
    for side in ("left", "right"):
        for bone, (a, b) in {"hip": ("thigh", "shin"), "knee": ("shin", "foot"), "ankle": ("foot", "toe"),
                             "shoulder": ("upper_arm", "forearm"), "elbow": ("forearm", "hand")}.items():
            ends[f"{side}_{bone}"] = (r[f"{side}_{a}"], r[f"{side}_{b}"])
    return ends


def _min_rotation(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """The smallest rotations (..., 4) taking unit vectors a to unit vectors b."""
    c = np.cross(a, b)
    w = 1.0 + np.sum(a * b, axis=-1, keepdims=True)
    q = np.concatenate([c, w], axis=-1)
    flip = w[..., 0] < 1e-9  # opposite: any half turn about a perpendicular axis
    if np.any(flip):
        perp = np.cross(a, np.array([1.0, 0.0, 0.0]))
        perp = np.where(np.linalg.norm(perp, axis=-1, keepdims=True) < 1e-6, np.cross(a, [0.0, 1.0, 0.0]), perp)
        q = np.where(flip[..., None], np.concatenate([perp, np.zeros_like(w)], axis=-1), q)
    return quat.normalize(q)


def retarget(motion: BvhMotion, skel: Skeleton = HUMANOID, name: str = "bvh",
             joint_map: JointMap | None = None) -> MotionClip:
    """The motion as a MotionClip of ``skel`` (Y up, x forward; the DeepMimic joints), by direction
    retargeting; joints by ``joint_map`` (default: ``map_joints`` of the file, which raises MotionFileError)."""
    jm = joint_map or map_joints(motion, source=name)
    hips, head = jm.roles["hips"], jm.roles["head"]
    ends = bone_ends(motion, jm)
    p = motion.positions
    rest_up = p[0, head] - p[0, hips]
    to_y = _min_rotation(rest_up / np.linalg.norm(rest_up), np.array([0.0, 1.0, 0.0]))
    p = quat.rotate(to_y, p)
    n = len(p)
    world: dict[str, np.ndarray] = {}
    # pelvis: up along the spine, z to the right thigh; chest: up to the neck, z to the right shoulder
    world["root"] = _frame(p[:, ends["chest"][0]] - p[:, hips], p[:, ends["right_hip"][0]] - p[:, ends["left_hip"][0]])
    chest = _frame(p[:, ends["chest"][1]] - p[:, ends["chest"][0]],
                   p[:, ends["right_shoulder"][0]] - p[:, ends["left_shoulder"][0]])
    local: dict[str, np.ndarray] = {}
    for b in range(1, len(skel.names)):
        bone = skel.names[b]
        if bone not in JOINTS:
            continue
        parent = skel.names[skel.parents[b]]
        child = next(c for c in range(len(skel.names)) if skel.parents[c] == b)
        rest_dir = skel.offsets[child] / np.linalg.norm(skel.offsets[child])
        start, end = ends[bone]
        target = p[:, end] - p[:, start]
        target /= np.maximum(np.linalg.norm(target, axis=-1, keepdims=True), 1e-12)
        current = quat.rotate(world[parent], np.broadcast_to(rest_dir, (n, 3)))
        world[bone] = quat.normalize(quat.multiply(_min_rotation(current, target), world[parent]))
        if bone == "chest":
            world[bone] = chest
        local[bone] = quat.multiply(quat.conjugate(world[parent]), world[bone])
    joint_rots = np.stack([local[j] for j in JOINTS], axis=1)
    for i in range(1, n):
        joint_rots[i] = quat.align(joint_rots[i], joint_rots[i - 1])
    frame_time = motion.frame_time if motion.frame_time > 0 and math.isfinite(motion.frame_time) else 1 / 30
    soles = [ends[f"{side}_ankle"][k] for side in ("left", "right") for k in (0, 1)]
    floor = float(np.percentile(p[:, soles, 1].min(axis=1), 2))  # the lowest sole, past a stray frame
    root = p[:, hips] - np.array([0.0, floor, 0.0])
    return MotionClip(name, False, np.arange(n) * frame_time, root, world["root"], joint_rots)


def _frame(up: np.ndarray, right: np.ndarray) -> np.ndarray:
    """Rotations (N, 4) whose y axis is ``up`` and whose z axis is ``right`` made square to it."""
    y = up / np.linalg.norm(up, axis=-1, keepdims=True)
    z = right - np.sum(right * y, axis=-1, keepdims=True) * y
    z /= np.linalg.norm(z, axis=-1, keepdims=True)
    return _matrix_to_quat(np.stack([np.cross(y, z), y, z], axis=-1))


def _matrix_to_quat(m: np.ndarray) -> np.ndarray:
    """Unit quaternions (..., 4) x y z w from rotation matrices (..., 3, 3) (Shepperd's method)."""
    t = m[..., 0, 0] + m[..., 1, 1] + m[..., 2, 2]
    q = np.stack([
        1 + m[..., 0, 0] - m[..., 1, 1] - m[..., 2, 2],
        1 - m[..., 0, 0] + m[..., 1, 1] - m[..., 2, 2],
        1 - m[..., 0, 0] - m[..., 1, 1] + m[..., 2, 2],
        1 + t,
    ], axis=-1)
    k = np.argmax(q, axis=-1)
    out = np.empty(m.shape[:-2] + (4,))
    for case in range(4):
        sel = k == case
        if not np.any(sel):
            continue
        mm = m[sel]
        s = np.sqrt(np.maximum(q[sel, case], 1e-12)) * 2.0
        if case == 3:
            v = [mm[:, 2, 1] - mm[:, 1, 2], mm[:, 0, 2] - mm[:, 2, 0], mm[:, 1, 0] - mm[:, 0, 1], s * s / 4]
        elif case == 0:
            v = [s * s / 4, mm[:, 0, 1] + mm[:, 1, 0], mm[:, 0, 2] + mm[:, 2, 0], mm[:, 2, 1] - mm[:, 1, 2]]
        elif case == 1:
            v = [mm[:, 0, 1] + mm[:, 1, 0], s * s / 4, mm[:, 1, 2] + mm[:, 2, 1], mm[:, 0, 2] - mm[:, 2, 0]]
        else:
            v = [mm[:, 0, 2] + mm[:, 2, 0], mm[:, 1, 2] + mm[:, 2, 1], s * s / 4, mm[:, 1, 0] - mm[:, 0, 1]]
        out[sel] = np.stack(v, axis=-1) / s[:, None]
    return quat.normalize(out)
