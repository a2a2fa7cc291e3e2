"""Single unit quaternions (x, y, z, w) in plain float arithmetic: the control loop's hot path.

``sim.motion.quaternion`` is vectorised numpy; on one quaternion each of its calls costs tens of
microseconds of array overhead, and the balance update makes dozens of them. Same conventions.
"""

from __future__ import annotations

import numpy as np


def mul(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Hamilton product a·b (b first, then a)."""
    ax, ay, az, aw = float(a[0]), float(a[1]), float(a[2]), float(a[3])
    bx, by, bz, bw = float(b[0]), float(b[1]), float(b[2]), float(b[3])
    return np.array([aw * bx + ax * bw + ay * bz - az * by, aw * by - ax * bz + ay * bw + az * bx,
                     aw * bz + ax * by - ay * bx + az * bw, aw * bw - ax * bx - ay * by - az * bz])


def conj(q: np.ndarray) -> np.ndarray:
    return np.array([-float(q[0]), -float(q[1]), -float(q[2]), float(q[3])])


def rot(q: np.ndarray, v: np.ndarray) -> np.ndarray:
    """``v`` turned by ``q``."""
    x, y, z, w = float(q[0]), float(q[1]), float(q[2]), float(q[3])
    vx, vy, vz = float(v[0]), float(v[1]), float(v[2])
    tx, ty, tz = 2.0 * (y * vz - z * vy), 2.0 * (z * vx - x * vz), 2.0 * (x * vy - y * vx)
    return np.array([vx + w * tx + y * tz - z * ty, vy + w * ty + z * tx - x * tz, vz + w * tz + x * ty - y * tx])
