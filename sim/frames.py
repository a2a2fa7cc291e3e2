"""The character's frames (Mitake et al. 2009 §4.1), for every character at once.

Character local frame S_r: x forward, y to its left, z up along the body.
Heading frame S_c: the floor-plane frame that turns with the character's heading ψ
(forward f = (cos ψ, sin ψ, 0), right r = f × z = (sin ψ, −cos ψ, 0), up z).

ψ is the *twist* of the body orientation about the world z axis (swing-twist decomposition),
well defined upright and lying face up/down. The tilt is the paper's θ:
``sin θx = e_up · f`` (lean forward +, backward −) and ``sin θz = e_up · r`` (lean right +).

Everything here works on arrays with one row per character (numpy, no Python loop), because it
runs for every character every control tick.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

Quat = tuple[float, float, float, float]  # x, y, z, w
Array = NDArray[np.float64]


def wrap_angle(a: float) -> float:
    """``a`` wrapped into [−π, π)."""
    return (a + math.pi) % (2.0 * math.pi) - math.pi


def wrap_angles(a: Array) -> Array:
    """Element-wise ``wrap_angle``."""
    out: Array = (a + math.pi) % (2.0 * math.pi) - math.pi
    return out


def clamp(x: Array, lo: Array | float, hi: Array | float) -> Array:
    """Element-wise min(max(x, lo), hi) (np.clip costs several times more on small arrays)."""
    out: Array = np.minimum(np.maximum(x, lo), hi)
    return out


def yaw_quaternion(heading: float) -> Quat:
    """The upright orientation whose forward axis points along ``heading`` (from stage +x)."""
    return (0.0, 0.0, math.sin(heading / 2.0), math.cos(heading / 2.0))


@dataclass(frozen=True, slots=True)
class Frames:
    """Axes and angles of N body orientations, in stage coordinates (one row per character)."""

    heading: Array  # (N,) ψ, radians from stage +x
    cos_h: Array  # (N,) cos ψ: forward f = (cos ψ, sin ψ, 0)
    sin_h: Array  # (N,) sin ψ: right r = (sin ψ, −cos ψ, 0)
    up: Array  # (N, 3) e_up, the body's own z axis
    body_forward: Array  # (N, 3) the body's own x axis (points down when lying face down)
    tilt_x: Array  # (N,) θx, lean forward (+) / backward (−)
    tilt_z: Array  # (N,) θz, lean right (+) / left (−)
    tilt: Array  # (N,) angle between e_up and world z

    @property
    def face_up(self) -> NDArray[np.bool_]:
        """Lying face up when the body's forward (face) axis points up."""
        out: NDArray[np.bool_] = self.body_forward[:, 2] >= 0.0
        return out

    def rotation(self) -> Array:
        """(N, 3, 3) body-to-stage rotation matrices (columns: body forward, left, up)."""
        left = np.cross(self.up, self.body_forward)
        return np.stack([self.body_forward, left, self.up], axis=2)


def frames(quats: Array) -> Frames:
    """Frames of the orientations ``quats`` ((N, 4), x y z w; non-finite or zero rows read as upright)."""
    q = np.asarray(quats, dtype=np.float64)
    norm2 = np.einsum("ij,ij->i", q, q)
    if not (np.isfinite(norm2).all() and (norm2 > 0.0).all()):
        bad = ~(np.isfinite(norm2) & (norm2 > 0.0))
        q = q.copy()
        q[bad] = (0.0, 0.0, 0.0, 1.0)
        norm2 = np.where(bad, 1.0, norm2)
    q = q / np.sqrt(norm2)[:, None]
    x, y, z, w = q[:, 0], q[:, 1], q[:, 2], q[:, 3]
    n = q.shape[0]
    up = np.empty((n, 3))
    up[:, 0] = 2.0 * (x * z + w * y)
    up[:, 1] = 2.0 * (y * z - w * x)
    up[:, 2] = 1.0 - 2.0 * (x * x + y * y)
    body_forward = np.empty((n, 3))
    body_forward[:, 0] = 1.0 - 2.0 * (y * y + z * z)
    body_forward[:, 1] = 2.0 * (x * y + w * z)
    body_forward[:, 2] = 2.0 * (x * z - w * y)
    heading = wrap_angles(2.0 * np.arctan2(z, w))
    c, s = np.cos(heading), np.sin(heading)
    ux, uy = up[:, 0], up[:, 1]
    return Frames(
        heading=heading,
        cos_h=c,
        sin_h=s,
        up=up,
        body_forward=body_forward,
        tilt_x=np.arcsin(clamp(ux * c + uy * s, -1.0, 1.0)),
        tilt_z=np.arcsin(clamp(ux * s - uy * c, -1.0, 1.0)),
        tilt=np.arccos(clamp(up[:, 2], -1.0, 1.0)),
    )


def tilt_rates(f: Frames, angular_velocity: Array) -> tuple[Array, Array]:
    """(θ̇x, θ̇z) from the angular velocities: d(e_up)/dt = ω × e_up, projected on f and r.

    The heading frame's own turning (ψ̇ e_up·left) is left out: it vanishes near upright, where the
    rates feed the balance controller.
    """
    wx, wy, wz = angular_velocity[:, 0], angular_velocity[:, 1], angular_velocity[:, 2]
    ux, uy, uz = f.up[:, 0], f.up[:, 1], f.up[:, 2]
    dx = wy * uz - wz * uy
    dy = wz * ux - wx * uz
    along_f = dx * f.cos_h + dy * f.sin_h
    along_r = dx * f.sin_h - dy * f.cos_h
    return along_f / np.maximum(np.cos(f.tilt_x), 0.2), along_r / np.maximum(np.cos(f.tilt_z), 0.2)
