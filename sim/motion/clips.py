"""A clip wherever one is asked for: a pybullet_data clip by name, or a file (DeepMimic JSON or BVH).

``load_motion(ref, key)``: ``ref`` is a name like ``walk`` (``pybullet_data``'s DeepMimic clips) or a
path ending in ``.bvh``, ``.txt`` or ``.json`` (relative to ``base`` when given). A BVH file is
mapped (``sim.motion.joint_map``) and retargeted onto the DeepMimic humanoid (``sim.motion.retarget``),
its root path scaled by the humanoid's leg length over the file's (so its feet meet the floor). ``cycle=True`` (a walk to loop): a BVH clip is cut to its best cycle
(``best_cycle``) and marked looping. Every error is one ``MotionFileError`` that starts with ``key`` (when given).
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np

from sim.motion.bvh import BvhMotion
from sim.motion.mocap import HUMANOID, MotionClip, MotionFileError, pybullet_motion_path

__all__ = ["best_cycle", "is_motion_file", "load_motion"]

_SUFFIXES = (".bvh", ".txt", ".json")


def is_motion_file(ref: str) -> bool:
    """True when ``ref`` names a file (a path or a motion file suffix) rather than a pybullet clip."""
    return "/" in ref or ref.lower().endswith(_SUFFIXES)


def load_motion(ref: str, key: str, base: Path | None = None, *, cycle: bool = False) -> MotionClip:
    """The clip ``ref`` names (see the module docstring); errors start with ``key``."""
    try:
        if not is_motion_file(ref):
            return MotionClip.load(pybullet_motion_path(ref))
        path = Path(ref) if base is None or Path(ref).is_absolute() else base / ref
        if path.suffix.lower() != ".bvh":
            return MotionClip.load(path)
        from sim.motion.bvh import read_bvh  # the BVH parts load only for a BVH file
        from sim.motion.joint_map import beside, map_joints
        from sim.motion.retarget import retarget

        motion = read_bvh(path)
        jm = map_joints(motion, beside(path), source=str(path))
        clip = retarget(motion, name=path.stem, joint_map=jm)
        clip = replace(clip, root_pos=clip.root_pos * _leg_ratio(motion, jm.roles))
        return best_cycle(clip) if cycle else clip
    except MotionFileError as e:
        raise MotionFileError(f"{key}: {e}" if key else str(e)) from None


def _leg_ratio(motion: BvhMotion, roles: dict[str, int]) -> float:
    """The DeepMimic humanoid's leg (hip → knee → ankle) over the file's, both sides averaged."""
    want = float(sum(np.linalg.norm(HUMANOID.offsets[HUMANOID.names.index(j)]) for j in ("right_knee", "right_ankle")))
    p = motion.positions[0]
    have = np.mean([np.linalg.norm(p[roles[f"{s}_shin"]] - p[roles[f"{s}_thigh"]])
                    + np.linalg.norm(p[roles[f"{s}_foot"]] - p[roles[f"{s}_shin"]]) for s in ("left", "right")])
    return want / max(float(have), 1e-12)


def best_cycle(clip: MotionClip, shortest_s: float = 0.7, longest_s: float = 3.0) -> MotionClip:
    """The clip cut to frames i..j (``shortest_s`` ≤ t_j − t_i ≤ ``longest_s``) whose poses and root
    speeds match best, marked looping; the whole clip when it is too short to hold one. Frame 0 is
    skipped (CMU conversions put a T-pose there)."""
    t = clip.times
    n = len(t)
    if n < 4 or t[-1] - t[1] < shortest_s:
        return replace(clip, loop=True)
    step = max(1, n // 400)  # compare at most ~400 frames
    idx = np.arange(1, n, step)
    q = clip.joint_rots[idx]  # (K, J, 4)
    pose = np.sum(1.0 - np.abs(np.einsum("ajk,bjk->abj", q, q)), axis=-1)  # (K, K)
    vel = np.gradient(clip.root_pos[:, [0, 2]], t, axis=0)[idx]
    pose += 0.5 * np.linalg.norm(vel[:, None] - vel[None], axis=-1)
    dt = t[idx][None, :] - t[idx][:, None]
    pose[(dt < shortest_s) | (dt > longest_s)] = np.inf
    a, b = np.unravel_index(int(np.argmin(pose)), pose.shape)
    i, j = int(idx[a]), int(idx[b])
    return MotionClip(clip.name, True, t[i:j + 1] - t[i], clip.root_pos[i:j + 1], clip.root_rot[i:j + 1],
                      clip.joint_rots[i:j + 1])
