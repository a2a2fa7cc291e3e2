"""The source motion as targets for a skeleton's joints: desired angles and angular velocities.

Between frames i and i+1 of a clip (seed eqs 3.2–3.3) the desired rotation of a ball joint is the slerp of
the two frames' rotations, and its desired angular velocity the constant one that carries frame i onto
frame i+1 over the frame's duration: ω = log(q_i⁻¹ q_{i+1}) / Δt, in the child link's frame (the frame
pybullet reports spherical joint velocities in). A hinge uses its angle about its axis, θ̇ = Δθ/Δt.

``stance_left`` per frame: which foot the clip stands on (the lower ankle in the clip's own kinematics).
Times are clip seconds in [0, duration]; looping and anchoring the clip to the character live in
``sim.articulated.character``.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from sim.articulated.skeleton import ArticulatedSkeleton
from sim.motion import quaternion as quat
from sim.motion.mocap import HUMANOID, JOINTS, MotionClip


def quat_log(q: np.ndarray) -> np.ndarray:
    """Rotation vector (axis·angle, radians) of unit quaternions (…, 4) x y z w, shortest way round."""
    q = np.where(q[..., 3:4] < 0, -q, q)
    v = q[..., :3]
    s = np.linalg.norm(v, axis=-1, keepdims=True)
    angle = 2.0 * np.arctan2(s, q[..., 3:4])
    scale = np.where(s > 1e-12, angle / np.where(s > 1e-12, s, 1.0), 2.0)
    out: np.ndarray = v * scale
    return out


def quat_exp(r: np.ndarray) -> np.ndarray:
    """Unit quaternion (…, 4) of a rotation vector (…, 3)."""
    angle = np.linalg.norm(r, axis=-1, keepdims=True)
    half = angle / 2.0
    scale = np.where(angle > 1e-12, np.sin(half) / np.where(angle > 1e-12, angle, 1.0), 0.5)
    return np.concatenate([r * scale, np.cos(half)], axis=-1)


@dataclass(frozen=True)
class ReferencePose:
    """The clip at one time: root (source frame, Y up as in the clip) and the driven joints' targets."""

    root_pos: np.ndarray  # (3,)
    root_rot: np.ndarray  # (4,) x y z w
    root_omega: np.ndarray  # (3,) root angular velocity, source world frame
    rots: np.ndarray  # (D, 4) local rotation per driven joint (hinges too, about their axis)
    omegas: np.ndarray  # (D, 3) local angular velocity per driven joint (child frame)
    stance_left: bool
    d_ref: np.ndarray  # (2,) root − stance ankle, (forward, right) in the clip's heading frame, metres
    v_ref: np.ndarray  # (2,) root velocity (forward, right), m/s


class MotionReference:
    """A clip mapped onto ``skeleton``'s driven joints (links with a ``motion_channel``), in link order."""

    def __init__(self, clip: MotionClip, skeleton: ArticulatedSkeleton) -> None:
        self.clip = clip
        self.driven = tuple(i for i, link in enumerate(skeleton.links) if link.motion_channel)
        channels = [JOINTS.index(skeleton.links[i].motion_channel) for i in self.driven]
        rots = clip.joint_rots[:, channels, :]  # (N, D, 4)
        hinge = np.array([skeleton.links[i].kind == "hinge" for i in self.driven])
        axes = np.array([skeleton.links[i].axis for i in self.driven], dtype=float)
        # hinges: keep only the rotation about the hinge axis (the clip's is about the same axis)
        r = quat_log(rots)
        along = np.sum(r * axes, axis=-1, keepdims=True) * axes
        r = np.where(hinge[None, :, None], along, r)
        self._rots = quat.normalize(quat_exp(r))
        for i in range(1, len(self._rots)):
            self._rots[i] = quat.align(self._rots[i], self._rots[i - 1])
        spans = np.diff(clip.times)
        spans = np.where(spans > 0, spans, 1.0)
        step = quat.multiply(quat.conjugate(self._rots[:-1]), self._rots[1:])
        self._omegas = quat_log(step) / spans[:, None, None]  # (N-1, D, 3)
        root_step = quat.multiply(clip.root_rot[1:], quat.conjugate(clip.root_rot[:-1]))
        self._root_omegas = quat_log(root_step) / spans[:, None]  # world frame
        self.hinge = hinge
        self.axes = axes
        pos, _ = HUMANOID.forward_kinematics(clip.root_pos, clip.root_rot, clip.joint_rots)
        right = pos[:, HUMANOID.names.index("right_ankle"), 1]
        left = pos[:, HUMANOID.names.index("left_ankle"), 1]
        self._stance_left = left < right
        # starts for walking off from a stand, on the right / on the left foot: the frame of that stance
        # with the feet closest together
        gap = np.linalg.norm((pos[:, HUMANOID.names.index("right_ankle")]
                              - pos[:, HUMANOID.names.index("left_ankle")])[:-1][:, [0, 2]], axis=-1)
        on_left = self._stance_left[:-1]
        self.feet_together_t = (float(clip.times[int(np.argmin(np.where(on_left, np.inf, gap)))]),
                                float(clip.times[int(np.argmin(np.where(on_left, gap, np.inf)))]))
        stance = np.where(self._stance_left[:, None], pos[:, HUMANOID.names.index("left_ankle")],
                          pos[:, HUMANOID.names.index("right_ankle")])
        f = quat.rotate(clip.root_rot, np.array([1.0, 0.0, 0.0]))[:, [0, 2]]
        f /= np.maximum(np.linalg.norm(f, axis=-1, keepdims=True), 1e-9)
        r = np.stack([-f[:, 1], f[:, 0]], axis=-1)
        d = (clip.root_pos - stance)[:, [0, 2]]
        self._d_ref = np.stack([np.sum(d * f, axis=-1), np.sum(d * r, axis=-1)], axis=-1)
        v = np.diff(clip.root_pos[:, [0, 2]], axis=0) / spans[:, None]
        self._v_ref = np.stack([np.sum(v * f[:-1], axis=-1), np.sum(v * r[:-1], axis=-1)], axis=-1)

    def limit(self, clamp: Callable[[np.ndarray], np.ndarray]) -> MotionReference:
        """Clamp every frame's joint rotations into the joint limits, once (``JointLimits.clamp``)."""
        self._rots = np.stack([clamp(frame) for frame in self._rots])
        for i in range(1, len(self._rots)):
            self._rots[i] = quat.align(self._rots[i], self._rots[i - 1])
        return self

    @property
    def duration(self) -> float:
        return self.clip.duration

    def hinge_angles(self, rots: np.ndarray) -> np.ndarray:
        """Angles (D,) about each hinge's axis of local rotations (D, 4) (0 for non-hinges)."""
        r = quat_log(rots)
        out: np.ndarray = np.where(self.hinge, np.sum(r * self.axes, axis=-1), 0.0)
        return out

    def sample(self, t: float) -> ReferencePose:
        """Targets at clip time ``t`` (clamped to [0, duration])."""
        times = self.clip.times
        t = float(np.clip(t, 0.0, self.duration))
        i = int(np.clip(np.searchsorted(times, t, side="right") - 1, 0, len(times) - 2))
        span = times[i + 1] - times[i]
        u = 0.0 if span <= 0 else (t - times[i]) / span
        clip = self.clip
        root_pos = (1 - u) * clip.root_pos[i] + u * clip.root_pos[i + 1]
        root_rot = quat.slerp(clip.root_rot[i], clip.root_rot[i + 1], u)
        rots = quat.slerp(self._rots[i], self._rots[i + 1], u)
        k = i if u < 0.5 else i + 1
        return ReferencePose(root_pos, root_rot, self._root_omegas[i], rots, self._omegas[i],
                             bool(self._stance_left[k]), (1 - u) * self._d_ref[i] + u * self._d_ref[i + 1],
                             self._v_ref[i])
