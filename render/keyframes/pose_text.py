"""One pose as TOML text: reading a pose table (checked) and writing one.

A pose table holds ``root_offset`` (3 numbers, metres), ``root_rotation`` and a ``joints`` table;
a rotation is a quaternion ``[x, y, z, w]``, an axis-angle ``{ axis = [x, y, z], degrees = d }``, or
for hinges (knees, elbows) a number of degrees about the hinge's z axis. See ``render.keyframes.set_file``.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from sim.motion import quaternion as quat
from sim.motion.mocap import JOINTS, REVOLUTE, REVOLUTE_AXIS

_POSE_KEYS = {"root_offset", "root_rotation", "joints"}


def number(v: Any) -> float | None:
    if isinstance(v, bool) or not isinstance(v, int | float):
        return None
    f = float(v)
    return f if math.isfinite(f) else None


def vector(v: Any, n: int) -> np.ndarray | None:
    if not isinstance(v, list) or len(v) != n:
        return None
    vals = [number(x) for x in v]
    return None if any(x is None for x in vals) else np.array(vals, dtype=float)


def parse_rotation(v: Any, hinge: bool) -> np.ndarray:
    """A rotation written as degrees about the hinge (hinges only), [x, y, z, w] or {axis, degrees}.

    Raises ValueError with what was expected (the caller puts file and key in front).
    """
    expected = "a quaternion [x, y, z, w] or { axis = [x, y, z], degrees = d }" + (
        " or a number of degrees about the hinge" if hinge else ""
    )
    if hinge and number(v) is not None:
        return quat.from_axis_angle(REVOLUTE_AXIS, math.radians(float(v)))
    if isinstance(v, list):
        q = vector(v, 4)
        if q is None:
            raise ValueError(f"expected 4 finite numbers (x, y, z, w), got {v!r}")
        if np.linalg.norm(q) < 1e-9:
            raise ValueError("a quaternion of length 0 is no rotation")
        return quat.normalize(q)
    if isinstance(v, dict):
        if set(v) != {"axis", "degrees"}:
            raise ValueError(f"expected exactly the keys axis and degrees, got {sorted(v)}")
        axis = vector(v["axis"], 3)
        deg = number(v["degrees"])
        if axis is None or deg is None:
            raise ValueError(f"expected axis = 3 finite numbers and degrees = a finite number, got {v!r}")
        if np.linalg.norm(axis) < 1e-9:
            return quat.IDENTITY.copy() if deg == 0 else _raise("the axis has length 0")
        return quat.from_axis_angle(axis, math.radians(deg))
    raise ValueError(f"expected {expected}, got {v!r}")


def _raise(msg: str) -> np.ndarray:
    raise ValueError(msg)


def parse_pose(doc: Any) -> tuple[np.ndarray, np.ndarray]:
    """(root_offset (3,), rotations (1 + J, 4)) from one pose table; ValueError names the bad key."""
    if not isinstance(doc, dict):
        raise ValueError(f"expected a table, got {type(doc).__name__}")
    unknown = set(doc) - _POSE_KEYS
    if unknown:
        raise ValueError(f"{sorted(unknown)[0]}: unknown key; expected {', '.join(sorted(_POSE_KEYS))}")
    offset = np.zeros(3)
    if "root_offset" in doc:
        got = vector(doc["root_offset"], 3)
        if got is None:
            raise ValueError(f"root_offset: expected 3 finite numbers (metres), got {doc['root_offset']!r}")
        offset = got
    rots = np.tile(quat.IDENTITY, (1 + len(JOINTS), 1))
    if "root_rotation" in doc:
        try:
            rots[0] = parse_rotation(doc["root_rotation"], hinge=False)
        except ValueError as e:
            raise ValueError(f"root_rotation: {e}") from None
    joints = doc.get("joints", {})
    if not isinstance(joints, dict):
        raise ValueError(f"joints: expected a table of joint = rotation, got {type(joints).__name__}")
    for name, value in joints.items():
        if name not in JOINTS:
            raise ValueError(f"joints.{name}: unknown joint; expected one of {', '.join(JOINTS)}")
        try:
            rots[1 + JOINTS.index(name)] = parse_rotation(value, hinge=name in REVOLUTE)
        except ValueError as e:
            raise ValueError(f"joints.{name}: {e}") from None
    return offset, rots


def format_rotation(q: np.ndarray, hinge: bool) -> str:
    """TOML text for a rotation: degrees for a pure hinge rotation, else axis-angle in degrees."""
    q = quat.normalize(np.asarray(q, dtype=float))
    q = -q if q[3] < 0 else q
    v = q[:3]
    s = float(np.linalg.norm(v))
    deg = math.degrees(2.0 * math.atan2(s, float(q[3])))
    if s < 1e-9:
        return "0.0" if hinge else "{ axis = [0.0, 1.0, 0.0], degrees = 0.0 }"
    axis = v / s
    if hinge and abs(axis[0]) < 1e-9 and abs(axis[1]) < 1e-9:
        return f"{deg * float(np.sign(axis[2])):.4f}"
    return f"{{ axis = [{axis[0]:.6f}, {axis[1]:.6f}, {axis[2]:.6f}], degrees = {deg:.4f} }}"


def format_pose(name: str, offset: np.ndarray, rotations: np.ndarray, comment: str = "") -> str:
    """TOML text of one pose table (rotations: (1 + J, 4), root first)."""
    lines = [f"# {comment}"] if comment else []
    lines += [
        f"[{name}]",
        "root_offset = [{:.5f}, {:.5f}, {:.5f}]".format(*offset),
        f"root_rotation = {format_rotation(rotations[0], hinge=False)}",
        f"[{name}.joints]",
    ]
    lines += [f"{j} = {format_rotation(rotations[1 + i], hinge=j in REVOLUTE)}" for i, j in enumerate(JOINTS)]
    return "\n".join(lines) + "\n"
