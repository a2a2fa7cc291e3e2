"""Getting up: the two get-up clips (loaded when first needed) and where the root should be over the feet.

Rising from the face-up get-up's crouch, the tracked body pivots forward over its feet (only the root's
height and orientation are helped), and ended with the feet ~0.5 m behind the root, leaning ~20° forward at
0.74 m instead of upright at the clip's 0.84 m: it then sank back and fell within ~2 s of walking off
(measured, every time). ``root_offset`` measures how far the root is from where the clip has it relative
to the clip's stance foot, so ``sim.articulated.assist`` can hold it there with a bounded horizontal force
while the clip's pelvis is near upright (``ArticulatedSpec.getup_place_force_n``).
"""

from __future__ import annotations

import math

import numpy as np

from sim.articulated import balance as bal
from sim.articulated.readout import BodyReadout
from sim.articulated.reference import MotionReference, ReferencePose
from sim.articulated.skeleton import ArticulatedSkeleton
from sim.articulated.spec import ArticulatedSpec
from sim.articulated.tracking import JointLimits
from sim.motion.clips import load_motion


class GetUpClips:
    """The face-up and face-down get-up clips on one skeleton, inside its joint limits, loaded once each."""

    def __init__(self, skeleton: ArticulatedSkeleton, spec: ArticulatedSpec, limits: JointLimits) -> None:
        self._skeleton = skeleton
        self._names = (spec.getup_facedown_clip, spec.getup_faceup_clip)
        self._limits = limits
        self._refs: dict[bool, MotionReference] = {}

    def clip(self, face_up: bool) -> MotionReference:
        if face_up not in self._refs:
            key = "getup_faceup_clip" if face_up else "getup_facedown_clip"
            clip = load_motion(self._names[int(face_up)], key)
            self._refs[face_up] = MotionReference(clip, self._skeleton).limit(self._limits.clamp)
        return self._refs[face_up]


def root_offset(readout: BodyReadout, feet: tuple[int, int], r: ReferencePose, desired_root: np.ndarray,
                tilt_max_deg: float) -> tuple[np.ndarray, np.ndarray, float] | None:
    """(place error, speed error, heading) of the root relative to the clip's stance foot, in the heading
    frame of the clip's pelvis ((forward, right), m and m/s, as ``MotionReference.d_ref`` / ``v_ref``);
    None while the clip's pelvis is more than ``tilt_max_deg`` from upright (lying, sitting up: no
    heading frame to speak of)."""
    if math.degrees(bal.tilt_of(desired_root)) >= tilt_max_deg:
        return None
    root, _ = readout.root()
    ankle = readout.joint_position(feet[1] if r.stance_left else feet[0])
    heading = bal.heading_of(desired_root)
    vel, _ = readout.base_velocity()
    dd = np.array(bal.heading_frame(heading, root - ankle)) - r.d_ref
    dv = np.array(bal.heading_frame(heading, np.asarray(vel))) - r.v_ref
    return dd, dv, heading
