"""What the virtual performer does, as a pure function of time: a path across the stage made of
walking segments (straight lines and turning arcs) and actions (whole mocap clips played in place
of walking), with short cross-fades where one clip hands over to another.

The clips are DeepMimic's (Y up, x forward, z to the right). The walking clip's own horizontal
travel is replaced by the path (its vertical bob and sway of the hips are kept) and the body turns
to face along the path. An action clip keeps its own horizontal travel and turning, rotated so that
it starts facing along the path; the path continues from wherever the action ends.

Stage frame: metres, z up, x to the audience's right, y away from the audience. A heading ψ is the
walking direction's angle from +x toward +y (counter-clockwise seen from above).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from sim.motion import quaternion as quat
from sim.motion.mocap import HUMANOID, MotionClip

Y_UP_TO_Z_UP = quat.from_axis_angle(np.array([1.0, 0.0, 0.0]), math.pi / 2)
"""Rotation taking the clips' Y-up frame (x forward, z right) to the stage's z-up frame (x, y = left)."""

MOCAP_UP = np.array([0.0, 1.0, 0.0])


def yaw_quat(angle: float) -> np.ndarray:
    """Rotation about the clips' vertical (+y) axis: positive turns x toward −z (to the left)."""
    return quat.from_axis_angle(MOCAP_UP, angle)


def yaw_of(rot: np.ndarray) -> float:
    """Heading of a Y-up root rotation: the angle of its forward (+x) axis about +y."""
    f = quat.rotate(rot, np.array([1.0, 0.0, 0.0]))
    return math.atan2(-float(f[2]), float(f[0]))


def mocap_to_stage(points: np.ndarray) -> np.ndarray:
    """Y-up clip coordinates (..., 3) to stage coordinates (z up): (a, b, c) → (a, −c, b)."""
    p = np.asarray(points, dtype=float)
    return np.stack([p[..., 0], -p[..., 2], p[..., 1]], axis=-1)


@dataclass(frozen=True, eq=False)
class StagePose:
    """The humanoid posed on the stage.

    ``rotation`` (x y z w) is the root's stage orientation — the value for pybullet's
    ``resetBasePositionAndOrientation`` of the Y-up DeepMimic URDF. ``joint_rots`` are the clips'
    local joint rotations in ``sim.motion.mocap.JOINTS`` order.
    """

    position: np.ndarray  # (3,) root (pelvis) joint, stage metres
    rotation: np.ndarray  # (4,)
    joint_rots: np.ndarray  # (J, 4)
    mocap_rotation: np.ndarray  # (4,) the same root rotation expressed in the Y-up frame
    scale: float = 1.0  # body size: every bone of ``sim.motion.mocap.HUMANOID`` times this

    def joint_positions(self) -> np.ndarray:
        """Stage positions (B, 3) of every bone of ``sim.motion.mocap.HUMANOID``, in its ``names`` order."""
        return stage_joint_positions([self])[0]


def stage_joint_positions(poses: list[StagePose]) -> np.ndarray:
    """Stage positions (N, B, 3) of every bone for several poses at once (one vectorised FK)."""
    return stage_joint_frames(poses)[0]


def stage_joint_frames(poses: list[StagePose]) -> tuple[np.ndarray, np.ndarray]:
    """Stage positions (N, B, 3) of every bone and the Y-up rotations (N, B, 4) of their frames.

    A bone's local vector v (metres of the unscaled skeleton, Y-up link frame) lies at
    ``position + mocap_to_stage(quat.rotate(rotation, v)) * scale`` on the stage.
    """
    scales = np.array([p.scale for p in poses])
    heights = np.array([[0.0, float(p.position[2]) / p.scale, 0.0] for p in poses])
    rots = np.stack([p.mocap_rotation for p in poses])
    joints = np.stack([p.joint_rots for p in poses])
    pos, rot = HUMANOID.forward_kinematics(heights, rots, joints)
    out = mocap_to_stage(pos)
    if np.any(scales != 1.0):
        out *= scales[:, None, None]
    out[..., 0] += np.array([p.position[0] for p in poses])[:, None]
    out[..., 1] += np.array([p.position[1] for p in poses])[:, None]
    return out, rot


def scaled_clip(clip: MotionClip, scale: float) -> MotionClip:
    """The clip performed by a body ``scale`` times the size: the root's travel and height scale
    with it (so the feet still meet the floor and do not slide); rotations and timing are kept."""
    if scale == 1.0:
        return clip
    return MotionClip(clip.name, clip.loop, clip.times, clip.root_pos * scale, clip.root_rot, clip.joint_rots)


@dataclass(frozen=True)
class PoseSample:
    xy: np.ndarray  # (2,) stage position of the root
    height: float  # root height above the floor
    rot: np.ndarray  # (4,) root rotation in the Y-up frame, heading included
    joints: np.ndarray  # (J, 4)


@dataclass(frozen=True, eq=False)
class WalkSegment:
    """Walking along a straight line (curvature 0) or an arc (curvature 1/r, > 0 turns left).

    The clip plays ``rate`` times its own speed (a faster or slower walker); ``speed`` is the
    travel along the path in m/s (the clip's own pace times ``rate`` keeps the feet from sliding).
    """

    clip: MotionClip
    start: float
    duration: float
    x0: float
    y0: float
    heading0: float
    curvature: float
    speed: float
    phase0: float  # clip time at the start of the segment
    rate: float = 1.0

    def _place(self, s: float) -> tuple[float, float, float]:
        return walk_along(self.x0, self.y0, self.heading0, self.curvature, s)

    def sample(self, u: float) -> PoseSample:
        x, y, h = self._place(self.speed * u)
        pos, rot, joints = self.clip.sample(self.phase0 + (u if self.rate == 1.0 else self.rate * u))
        travel = self.clip.cycle_offset
        clip_heading = math.atan2(-float(travel[2]), float(travel[0]))
        full = quat.multiply(yaw_quat(h - clip_heading), rot)
        return PoseSample(np.array([x, y]), float(pos[1]), full, joints)

    def end_state(self) -> tuple[float, float, float]:
        return self._place(self.speed * self.duration)


@dataclass(frozen=True, eq=False)
class ActionSegment:
    """A whole clip played from its first frame, starting at (x0, y0) facing heading0."""

    clip: MotionClip
    start: float
    duration: float
    x0: float
    y0: float
    heading0: float

    def sample(self, u: float) -> PoseSample:
        pos, rot, joints = self.clip.sample(u)
        turn = yaw_quat(-yaw_of(self.clip.root_rot[0]))
        d = quat.rotate(turn, pos - self.clip.root_pos[0])  # in the clip's start frame
        forward, right = float(d[0]), float(d[2])
        h = self.heading0
        xy = np.array(
            [self.x0 + forward * math.cos(h) + right * math.sin(h),
             self.y0 + forward * math.sin(h) - right * math.cos(h)]
        )
        full = quat.multiply(yaw_quat(h), quat.multiply(turn, rot))
        return PoseSample(xy, float(pos[1]), full, joints)

    def end_state(self) -> tuple[float, float, float]:
        s = self.sample(self.duration)
        return float(s.xy[0]), float(s.xy[1]), yaw_of(s.rot)


Segment = WalkSegment | ActionSegment


def walk_along(x0: float, y0: float, h0: float, curvature: float, s: float) -> tuple[float, float, float]:
    """(x, y, heading) after walking a distance s from (x0, y0, h0) on a line or an arc."""
    h = h0 + curvature * s
    if abs(curvature) < 1e-9:
        return x0 + s * math.cos(h0), y0 + s * math.sin(h0), h0
    r = 1.0 / curvature
    return x0 + r * (math.sin(h) - math.sin(h0)), y0 - r * (math.cos(h) - math.cos(h0)), h


def _smoothstep(a: float) -> float:
    a = min(max(a, 0.0), 1.0)
    return a * a * (3.0 - 2.0 * a)


def _wrap(angle: float) -> float:
    return (angle + math.pi) % (2 * math.pi) - math.pi


class SegmentPath:
    """A person's path as a list of segments (walks and actions) in time, sampled by :meth:`pose`.

    Subclasses build the segments with the ``_add_walk``/``_arc``/``_action``/``_go_to`` steps,
    starting at time ``start_s`` in state ``(x, y, heading)``. ``walk`` is the locomotion clip (at
    the body's scale), played ``rate`` times its own pace. When ``periodic`` the path repeats with
    period ``period``; otherwise the person is absent before the first segment and after the last.
    """

    def __init__(
        self,
        walk: MotionClip,
        *,
        start_s: float,
        state: tuple[float, float, float],
        turn_radius: float,
        rate: float = 1.0,
        scale: float = 1.0,
        blend_s: float = 0.3,
        periodic: bool = False,
    ) -> None:
        travel = float(np.linalg.norm(walk.cycle_offset))
        if not walk.loop or walk.duration <= 0 or travel / walk.duration < 0.2 * scale:
            raise ValueError(
                f"clips: the first clip must be a looping clip that travels (walk, run), got {walk.name!r}"
            )
        self.walk = walk
        self.rate = rate
        self.speed = travel / walk.duration * rate
        self.scale = scale
        self.blend_s = blend_s
        self.radius = turn_radius
        self.periodic = periodic
        self.segments: list[Segment] = []
        self._t = start_s
        self._phase = 0.0
        self._state = state
        self.period = start_s

    # ------------------------------------------------------------ building

    def _add_walk(self, length: float, curvature: float) -> None:
        if length <= 1e-6:
            return
        x, y, h = self._state
        seg = WalkSegment(self.walk, self._t, length / self.speed, x, y, h, curvature, self.speed, self._phase,
                          self.rate)
        self.segments.append(seg)
        self._t += seg.duration
        self._phase += seg.duration if self.rate == 1.0 else seg.duration * self.rate
        self._state = seg.end_state()
        self.period = self._t

    def _straight_to_x(self, x_target: float) -> None:
        x, _, h = self._state
        along = (x_target - x) / math.cos(h) if abs(math.cos(h)) > 1e-6 else 0.0
        self._add_walk(max(along, 0.0), 0.0)

    def _arc(self, angle: float) -> None:
        curvature = math.copysign(1.0 / self.radius, angle)
        self._add_walk(abs(angle) * self.radius, curvature)

    def _action(self, clip: MotionClip) -> None:
        """Play a clip, turned so that its own net travel runs along the current heading."""
        x, y, h = self._state
        turn = yaw_quat(-yaw_of(clip.root_rot[0]))
        d = quat.rotate(turn, clip.root_pos[-1] - clip.root_pos[0])
        if math.hypot(float(d[0]), float(d[2])) > 0.3 * self.scale:
            h += math.atan2(float(d[2]), float(d[0]))
        seg = ActionSegment(clip, self._t, clip.duration, x, y, h)
        self.segments.append(seg)
        self._t += seg.duration
        self._state = seg.end_state()
        self.period = self._t

    def _go_to(self, x_target: float, y_target: float) -> None:
        """Turn on an arc toward the target, then walk straight to it."""
        x, y, h = self._state
        turn = 0.0
        for _ in range(8):  # the arc moves the start of the straight line: settle the angle
            curvature = math.copysign(1.0 / self.radius, turn)
            ex, ey, _ = walk_along(x, y, h, curvature, abs(turn) * self.radius)
            turn = _wrap(math.atan2(y_target - ey, x_target - ex) - h)
        if abs(turn) > 1e-3:
            self._arc(turn)
        x, y, _ = self._state
        self._add_walk(math.hypot(x_target - x, y_target - y), 0.0)

    # ------------------------------------------------------------ sampling

    def pose(self, t: float) -> StagePose | None:
        """The pose at time t (seconds from the start), or None while the person is not on the stage."""
        tau = t % self.period if self.periodic and self.period > 0 else t
        i = self._segment_at(tau)
        if i is None:
            return None
        seg = self.segments[i]
        s = seg.sample(tau - seg.start)
        u = tau - seg.start
        if i > 0 and u < self.blend_s and self._hands_over(i):
            prev = self.segments[i - 1]
            p = prev.sample(tau - prev.start)
            w = _smoothstep(u / self.blend_s)
            rot = quat.slerp(p.rot, s.rot, w)
            joints = quat.slerp(p.joints, s.joints, w)
            s = PoseSample(s.xy, (1 - w) * p.height + w * s.height, rot, joints)
        stage_rot = quat.multiply(Y_UP_TO_Z_UP, s.rot)
        position = np.array([s.xy[0], s.xy[1], s.height])
        return StagePose(position, stage_rot, s.joints, s.rot, self.scale)

    def _segment_at(self, tau: float) -> int | None:
        for i, seg in enumerate(self.segments):
            if seg.start <= tau < seg.start + seg.duration:
                return i
        return None

    def _hands_over(self, i: int) -> bool:
        return isinstance(self.segments[i], ActionSegment) or isinstance(self.segments[i - 1], ActionSegment)


class Choreography(SegmentPath):
    """The performer's round, repeated with period ``period``:

    1. the empty stage for ``empty_s`` seconds;
    2. walking in from ``entry_x`` (off to the left) along y = 0, facing +x;
    3. if there are action clips: at ``action_x`` each is played in turn, turned so that its own
       travel runs along the path (a punch steps forward and throws the fist along +x), then
       the performer walks back onto y = 0 toward ``turn_x``;
    4. a U-turn on an arc of ``turn_radius`` (away from the audience) at ``turn_x``;
    5. walking back and off the stage to the left, ending at (entry_x − 0.5, 0).
    """

    def __init__(
        self,
        walk: MotionClip,
        actions: tuple[MotionClip, ...],
        *,
        entry_x: float,
        turn_x: float,
        action_x: float,
        turn_radius: float,
        empty_s: float,
        blend_s: float = 0.3,
        scale: float = 1.0,
    ) -> None:
        super().__init__(walk, start_s=empty_s, state=(entry_x, 0.0, 0.0), turn_radius=turn_radius,
                         scale=scale, blend_s=blend_s, periodic=True)
        self.empty_s = empty_s
        if actions:
            self._straight_to_x(action_x)
            for clip in actions:
                self._action(clip)
            if self._state[0] < turn_x - 0.5:
                self._go_to(turn_x, 0.0)
        else:
            self._straight_to_x(turn_x)
        self._arc(math.pi)
        self._go_to(entry_x - 0.5, 0.0)
