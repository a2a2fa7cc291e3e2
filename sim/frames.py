"""The character's frames (Mitake et al. 2009 §4.1) computed from a pybullet quaternion.

Character local frame S_r: x forward, y to its left, z up along the body.
Heading frame S_c: the floor-plane frame that turns with the character's heading ψ
(forward f = (cos ψ, sin ψ, 0), right r = f × z = (sin ψ, −cos ψ, 0), up z).

ψ is the *twist* of the body orientation about the world z axis (swing-twist decomposition),
well defined upright and lying face up/down. The tilt is the paper's θ:
``sin θx = e_up · f`` (lean forward +, backward −) and ``sin θz = e_up · r`` (lean right +).

Plain-float math on purpose: it runs per character per control tick, where numpy's per-call
overhead on 3-vectors costs more than the arithmetic.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

Vec3 = tuple[float, float, float]
Quat = tuple[float, float, float, float]  # x, y, z, w


def wrap_angle(a: float) -> float:
    """``a`` wrapped into [−π, π)."""
    return (a + math.pi) % (2.0 * math.pi) - math.pi


def yaw_quaternion(heading: float) -> Quat:
    """The upright orientation whose forward axis points along ``heading`` (from stage +x)."""
    return (0.0, 0.0, math.sin(heading / 2.0), math.cos(heading / 2.0))


def cross(a: Vec3, b: Vec3) -> Vec3:
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def dot(a: Vec3, b: Vec3) -> float:
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def _asin(v: float) -> float:
    return math.asin(max(-1.0, min(1.0, v)))


@dataclass(frozen=True, slots=True)
class BodyFrame:
    """Axes and angles of one body orientation, in stage coordinates."""

    heading: float  # ψ, radians from stage +x
    forward: Vec3  # f, heading-frame forward (horizontal)
    right: Vec3  # r, heading-frame right (horizontal)
    up: Vec3  # e_up, the body's own z axis
    body_forward: Vec3  # the body's own x axis (points down when lying face down)
    tilt_x: float  # θx, lean forward (+) / backward (−)
    tilt_z: float  # θz, lean right (+) / left (−)
    tilt: float  # total tilt: angle between e_up and world z

    @property
    def left(self) -> Vec3:
        return (-self.right[0], -self.right[1], 0.0)

    @property
    def face_up(self) -> bool:
        """Lying face up when the body's forward (face) axis points up."""
        return self.body_forward[2] >= 0.0


def body_frame(q: Quat) -> BodyFrame:
    x, y, z, w = q
    n = math.sqrt(x * x + y * y + z * z + w * w)
    if not n > 0.0 or not math.isfinite(n):
        x, y, z, w, n = 0.0, 0.0, 0.0, 1.0, 1.0
    x, y, z, w = x / n, y / n, z / n, w / n
    up = (2.0 * (x * z + w * y), 2.0 * (y * z - w * x), 1.0 - 2.0 * (x * x + y * y))
    body_forward = (1.0 - 2.0 * (y * y + z * z), 2.0 * (x * y + w * z), 2.0 * (x * z - w * y))
    heading = wrap_angle(2.0 * math.atan2(z, w))
    c, s = math.cos(heading), math.sin(heading)
    forward = (c, s, 0.0)
    right = (s, -c, 0.0)
    return BodyFrame(
        heading=heading,
        forward=forward,
        right=right,
        up=up,
        body_forward=body_forward,
        tilt_x=_asin(up[0] * c + up[1] * s),
        tilt_z=_asin(up[0] * s - up[1] * c),
        tilt=math.acos(max(-1.0, min(1.0, up[2]))),
    )


def tilt_rates(frame: BodyFrame, angular_velocity: Vec3) -> tuple[float, float]:
    """(θ̇x, θ̇z) from the angular velocity: d(e_up)/dt = ω × e_up, projected on f and r.

    The heading frame's own turning (ψ̇ e_up·left) is left out: it vanishes near upright, where the
    rates feed the balance controller.
    """
    d_up = cross(angular_velocity, frame.up)
    cx = max(math.cos(frame.tilt_x), 0.2)
    cz = max(math.cos(frame.tilt_z), 0.2)
    return dot(d_up, frame.forward) / cx, dot(d_up, frame.right) / cz
