"""Ball and universal joint limits as pybullet measures and enforces them.

pybullet limits a spherical joint only in a body loaded from a URDF whose joint carries
``<limit lower=… upper=… twist=… effort=…/>``: a ``btMultiBodySphericalJointLimit``, solved with the contacts
as one-sided constraint rows (not a torque), so no push, fall or clip drives a joint far past it. It
measures the joint's rotation q (child link frame against parent link frame, in the child's frame) as

- a **twist** about the frame's z axis, with q = cone · twist and cone the shortest arc taking z to q·z;
- two **swing** angles x, y: the Euler XYZ angles of twist⁻¹ · cone⁻¹ · twist (``matrixToEulerXYZ`` of
  ``btGeneric6DofSpring2Constraint``: x = atan2(−m₂₁, m₂₂), y = asin(m₂₀));

each held inside ± its range (x: ``lower``, y: ``upper``, twist: ``twist``). ``limit_angles`` is that
measure, written out in numpy; on 300 random rotations it agrees with the engine on which are outside
(tests/test_articulated_limits.py).

In the skeleton's frames (source frame at rest; y up for DeepMimic and BVH bodies: x forward, z across the
body) a bone points along ±y, so the engine's three angles are: x, the sideways swing (abduction, side
bend, ankle roll); y (an asin, so within ±90°), the turn about the bone; z, the front-back swing (flexion,
ankle pitch; to ±180°). ``limit_ranges`` gives them ``side_limit``, ``twist_limit`` and ``swing_limit``.
"""

from __future__ import annotations

import math

import numpy as np

from sim.articulated import quat1 as q1
from sim.articulated.reference import quat_exp, quat_log
from sim.articulated.skeleton import ArticulatedLink
from sim.motion import quaternion as quat

_Z = np.array([0.0, 0.0, 1.0])
CLAMP_MARGIN = 1e-3  # radians: targets are clamped this far inside, so the PD never pulls on the stop


def limit_ranges(link: ArticulatedLink, up_axis: str = "y") -> np.ndarray:
    """(x, y, z) ranges in radians of a ball/universal joint as pybullet measures it (π: free). Up axis y
    (x forward, z across): x the sideways swing, y the twist about the bone, z the front-back swing."""
    swing = min(float(link.swing_limit), math.pi)
    twist = min(float(link.twist_limit), math.pi)
    side = min(float(link.side_limit), math.pi)
    return np.array([side, twist, swing]) if up_axis == "y" else np.array([side, swing, twist])


def _cone_twist(q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(cone, twist angle) of rotations q (N, 4) in pybullet's frame: q = cone · twist(z)."""
    v = quat.rotate(q, _Z)
    v = v / np.maximum(np.linalg.norm(v, axis=-1, keepdims=True), 1e-12)
    d = v[:, 2]
    s = np.sqrt(np.maximum(2.0 * (1.0 + d), 1e-18))
    cone = np.stack([-v[:, 1] / s, v[:, 0] / s, np.zeros_like(d), 0.5 * s], axis=-1)
    flipped = d < -1.0 + 1e-9  # pointing straight back: bullet turns about −y
    cone[flipped] = np.array([0.0, -1.0, 0.0, 0.0])
    tw = quat.multiply(quat.conjugate(cone), q)
    twist = 2.0 * np.arctan2(tw[:, 2], tw[:, 3])
    twist = (twist + math.pi) % (2.0 * math.pi) - math.pi
    return cone, twist


def _swing_angles(cone: np.ndarray, twist: np.ndarray) -> np.ndarray:
    """(N, 2): the x and y angles pybullet limits, from the cone and the twist angle."""
    tq = quat.from_axis_angle(np.broadcast_to(_Z, cone.shape[:-1] + (3,)), twist)
    rel = quat.multiply(quat.conjugate(tq), quat.multiply(quat.conjugate(cone), tq))
    m = quat.to_matrix(rel)
    fi = m[:, 2, 0]
    x = np.arctan2(-m[:, 2, 1], m[:, 2, 2])
    y = np.arcsin(np.clip(fi, -1.0, 1.0))
    edge = np.abs(fi) >= 1.0  # gimbal lock, as bullet resolves it
    x = np.where(edge, np.sign(fi) * np.arctan2(m[:, 0, 1], m[:, 1, 1]), x)
    return np.stack([x, y], axis=-1)


def limit_angles(rots: np.ndarray) -> np.ndarray:
    """(N, 3): the (x, y, z-twist) angles pybullet's spherical limit measures of joint rotations (N, 4)."""
    q = quat.normalize(np.asarray(rots, dtype=float).reshape(-1, 4))
    cone, twist = _cone_twist(q)
    return np.concatenate([_swing_angles(cone, twist), twist[:, None]], axis=-1)


def limit_angles_one(q: np.ndarray) -> tuple[float, float, float]:
    """``limit_angles`` of one rotation, in float arithmetic (the per-update path: a few µs, not 100)."""
    x, y, z, w = (float(v) for v in q)
    n = math.sqrt(x * x + y * y + z * z + w * w)
    x, y, z, w = x / n, y / n, z / n, w / n
    vx, vy, vz = 2.0 * (x * z + w * y), 2.0 * (y * z - w * x), 1.0 - 2.0 * (x * x + y * y)
    if vz < -1.0 + 1e-9:
        cone = (0.0, -1.0, 0.0, 0.0)
    else:
        s = math.sqrt(2.0 * (1.0 + vz))
        cone = (-vy / s, vx / s, 0.0, 0.5 * s)
    tz = cone[3] * z - cone[0] * y + cone[1] * x  # z and w of cone⁻¹ · q
    tw = cone[3] * w + cone[0] * x + cone[1] * y
    twist = math.remainder(2.0 * math.atan2(tz, tw), 2.0 * math.pi)
    h = 0.5 * twist
    t = (0.0, 0.0, math.sin(h), math.cos(h))
    rx, ry, rz, rw = (float(v) for v in q1.mul(np.array([0.0, 0.0, -t[2], t[3]]),
                                                q1.mul(np.array([-cone[0], -cone[1], 0.0, cone[3]]), np.array(t))))
    m20 = 2.0 * (rx * rz - ry * rw)
    if abs(m20) >= 1.0:
        ex = math.copysign(1.0, m20) * math.atan2(2.0 * (rx * ry - rz * rw), 1.0 - 2.0 * (rx * rx + rz * rz))
    else:
        ex = math.atan2(-2.0 * (ry * rz + rx * rw), 1.0 - 2.0 * (rx * rx + ry * ry))
    return ex, math.asin(max(-1.0, min(1.0, m20))), twist


def limit_excess(rots: np.ndarray, ranges: np.ndarray) -> np.ndarray:
    """(N,): radians by which each rotation is outside its (x, y, twist) ranges (N, 3) (0 inside)."""
    out: np.ndarray = np.max(np.maximum(np.abs(limit_angles(rots)) - ranges, 0.0), axis=-1)
    return out


def clamp_inside(rots: np.ndarray, ranges: np.ndarray, margin: float = CLAMP_MARGIN) -> np.ndarray:
    """Joint rotations (N, 4) brought inside their ranges (N, 3), ``margin`` short of each:
    the twist clamped, then the cone shortened along its own arc (bisection) until both swing angles fit.
    Rotations already inside come back unchanged."""
    q = quat.normalize(np.asarray(rots, dtype=float).reshape(-1, 4))
    inner = np.maximum(ranges - margin, 0.0)
    cone, twist = _cone_twist(q)
    twist_c = np.clip(twist, -inner[:, 2], inner[:, 2])
    swing = _swing_angles(cone, twist_c)
    out_swing = np.any(np.abs(swing) > inner[:, :2], axis=-1)
    changed = out_swing | (twist_c != twist)
    if not changed.any():
        return q
    cone_log = quat_log(cone)
    scale = np.ones(len(q))
    if out_swing.any():
        lo, hi = np.zeros(len(q)), np.ones(len(q))
        for _ in range(20):
            mid = 0.5 * (lo + hi)
            fits = np.all(np.abs(_swing_angles(quat_exp(cone_log * mid[:, None]), twist_c)) <= inner[:, :2], axis=-1)
            lo = np.where(fits, mid, lo)
            hi = np.where(fits, hi, mid)
        scale = np.where(out_swing, lo, 1.0)
    tq = quat.from_axis_angle(np.broadcast_to(_Z, (len(q), 3)), twist_c)
    made = quat.multiply(quat_exp(cone_log * scale[:, None]), tq)
    out: np.ndarray = np.where(changed[:, None], made, q)
    return out
