"""Unit quaternions as numpy arrays in (x, y, z, w) order (pybullet's), vectorised over leading axes."""

from __future__ import annotations

import numpy as np

IDENTITY = np.array([0.0, 0.0, 0.0, 1.0])


def normalize(q: np.ndarray) -> np.ndarray:
    n = np.linalg.norm(q, axis=-1, keepdims=True)
    return q / np.where(n > 0, n, 1.0)


def from_wxyz(q: np.ndarray) -> np.ndarray:
    """Reorder (w, x, y, z) — DeepMimic's and glTF-unlike order — into (x, y, z, w)."""
    q = np.asarray(q, dtype=float)
    return np.concatenate([q[..., 1:4], q[..., :1]], axis=-1)


def from_axis_angle(axis: np.ndarray, angle: np.ndarray | float) -> np.ndarray:
    axis = np.asarray(axis, dtype=float)
    axis = axis / np.linalg.norm(axis, axis=-1, keepdims=True)
    half = np.asarray(angle, dtype=float)[..., None] / 2.0
    return np.concatenate([axis * np.sin(half), np.cos(half)], axis=-1)


def multiply(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Hamilton product a·b (apply b first, then a)."""
    ax, ay, az, aw = np.moveaxis(np.asarray(a, dtype=float), -1, 0)
    bx, by, bz, bw = np.moveaxis(np.asarray(b, dtype=float), -1, 0)
    return np.stack(
        [
            aw * bx + ax * bw + ay * bz - az * by,
            aw * by - ax * bz + ay * bw + az * bx,
            aw * bz + ax * by - ay * bx + az * bw,
            aw * bw - ax * bx - ay * by - az * bz,
        ],
        axis=-1,
    )


def conjugate(q: np.ndarray) -> np.ndarray:
    q = np.asarray(q, dtype=float)
    return np.concatenate([-q[..., :3], q[..., 3:]], axis=-1)


def rotate(q: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Rotate vectors v (..., 3) by unit quaternions q (..., 4)."""
    q = np.asarray(q, dtype=float)
    v = np.asarray(v, dtype=float)
    u = q[..., :3]
    w = q[..., 3:4]
    t = 2.0 * _cross(u, v)
    return v + w * t + _cross(u, t)


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """np.cross for (..., 3) arrays without its per-call overhead (it dominates for small batches)."""
    a, b = np.broadcast_arrays(a, b)
    out = np.empty(a.shape)
    out[..., 0] = a[..., 1] * b[..., 2] - a[..., 2] * b[..., 1]
    out[..., 1] = a[..., 2] * b[..., 0] - a[..., 0] * b[..., 2]
    out[..., 2] = a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]
    return out


def align(q: np.ndarray, reference: np.ndarray) -> np.ndarray:
    """Flip the sign of each q that points away from its reference (q and −q are one rotation)."""
    q = np.asarray(q, dtype=float)
    dot = np.sum(q * np.asarray(reference, dtype=float), axis=-1, keepdims=True)
    return np.where(dot < 0, -q, q)


def slerp(a: np.ndarray, b: np.ndarray, t: np.ndarray | float) -> np.ndarray:
    """Spherical interpolation, shortest arc, vectorised; t broadcasts against the leading axes."""
    a = normalize(np.asarray(a, dtype=float))
    b = align(normalize(np.asarray(b, dtype=float)), a)
    t = np.asarray(t, dtype=float)[..., None] if np.ndim(t) else np.asarray(t, dtype=float)
    dot = np.clip(np.sum(a * b, axis=-1, keepdims=True), -1.0, 1.0)
    theta = np.arccos(dot)
    sin = np.sin(theta)
    small = sin < 1e-6
    safe = np.where(small, 1.0, sin)
    wa = np.where(small, 1.0 - t, np.sin((1.0 - t) * theta) / safe)
    wb = np.where(small, t, np.sin(t * theta) / safe)
    return normalize(wa * a + wb * b)


def blend(qs: np.ndarray, weights: np.ndarray) -> np.ndarray:
    """Weighted mean of quaternions (..., K, 4) with weights (..., K) that are ≥ 0 and sum to 1.

    Signs are aligned to the heaviest quaternion first, then the weighted sum is normalised: exact
    when one weight is 1, and for weights in the hull the result stays between the inputs.
    """
    qs = np.asarray(qs, dtype=float)
    weights = np.asarray(weights, dtype=float)
    ref_idx = np.argmax(weights, axis=-1)
    ref = np.take_along_axis(qs, ref_idx[..., None, None], axis=-2)
    aligned = align(qs, ref)
    return normalize(np.sum(aligned * weights[..., None], axis=-2))


def to_matrix(q: np.ndarray) -> np.ndarray:
    """Rotation matrices (..., 3, 3) from unit quaternions (..., 4)."""
    x, y, z, w = np.moveaxis(normalize(np.asarray(q, dtype=float)), -1, 0)
    return np.stack(
        [
            np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)], axis=-1),
            np.stack([2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)], axis=-1),
            np.stack([2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)], axis=-1),
        ],
        axis=-2,
    )
