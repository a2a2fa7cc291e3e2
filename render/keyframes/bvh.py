"""BVH motion capture retargeted onto a jostle figure's skeleton (``sim.motion.retarget`` does the work;
the file is parsed by ``sim.motion.bvh``, its joints found by ``sim.motion.joint_map``)."""

from __future__ import annotations

from render.keyframes.skeletons import HUMANOID_FIGURE, Figure
from sim.motion.bvh import BvhMotion, read_bvh
from sim.motion.joint_map import JointMap
from sim.motion.mocap import MotionClip
from sim.motion.retarget import bone_ends, retarget

__all__ = ["BvhMotion", "bone_ends", "bvh_to_clip", "read_bvh"]


def bvh_to_clip(motion: BvhMotion, figure: Figure = HUMANOID_FIGURE, name: str = "bvh",
                joint_map: JointMap | None = None) -> MotionClip:
    """The motion as a MotionClip of ``figure``'s skeleton (Y up, x forward), by direction retargeting;
    joints by ``joint_map`` (default: ``map_joints`` of the file, which raises MotionFileError)."""
    return retarget(motion, figure.skeleton, name, joint_map)
