"""BVH motion capture: read a file's hierarchy and motion, write one back (no dependency: the format is small).

A BVH file is a joint hierarchy (OFFSET, CHANNELS, nested JOINT / End Site) and a MOTION block of
frames, each the channel values in hierarchy order (positions in the file's units, rotations in
degrees, applied in the order the channels are listed: ``Zrotation Yrotation Xrotation`` means
R = Rz·Ry·Rx, the X turn applied to a vector first). Nothing here assumes an up axis, units or rest
pose; that is for the user of the motion (``render.keyframes.bvh`` retargets it onto a figure,
``sim.articulated.bvh_body`` builds a body from it).

End sites are kept as joints named ``<parent>_end`` with no channels.
"""

from __future__ import annotations

import math
import re
import warnings
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from sensors.untrusted import MissingInput, UntrustedInput, one_line, read_bytes, shorten, write_owned
from sensors.untrusted.limits import BVH
from sim.motion import quaternion as quat
from sim.motion.mocap import MotionFileError

__all__ = ["BvhMotion", "euler_to_quat", "parse_bvh", "quat_to_euler", "read_bvh", "write_bvh"]

_AXES = {"x": np.array([1.0, 0.0, 0.0]), "y": np.array([0.0, 1.0, 0.0]), "z": np.array([0.0, 0.0, 1.0])}


@dataclass(frozen=True, eq=False)
class BvhMotion:
    """A parsed BVH file. Index b runs over joints and end sites in file order; parents[b] < b.

    ``channels[b]``: the joint's channel names, lower case (``xposition`` … ``zrotation``), () for end
    sites. ``local_rotations``: each joint's rotation relative to its parent from its rotation channels
    (x y z w); ``local_translations``: its offset, or its position channels where it has them.
    ``positions`` / ``rotations``: world (file-frame) positions and rotations of every joint.
    """

    names: tuple[str, ...]
    parents: tuple[int, ...]
    offsets: np.ndarray  # (B, 3) file units
    frame_time: float
    positions: np.ndarray  # (F, B, 3)
    channels: tuple[tuple[str, ...], ...] = ()
    values: np.ndarray | None = None  # (F, C) the raw channel values
    local_rotations: np.ndarray | None = None  # (F, B, 4)
    local_translations: np.ndarray | None = None  # (F, B, 3)
    rotations: np.ndarray | None = None  # (F, B, 4)

    @property
    def frames(self) -> int:
        return int(self.positions.shape[0])

    def is_end(self, b: int) -> bool:
        return not self.channels[b] and self.names[b].endswith("_end")

    def children(self, b: int) -> list[int]:
        return [c for c, p in enumerate(self.parents) if p == b]


def euler_to_quat(order: str, degrees: np.ndarray) -> np.ndarray:
    """Quaternions (..., 4) x y z w from Euler angles (..., len(order)) in degrees, applied as BVH does:
    R = R[order[0]]·R[order[1]]·… (the last listed axis turns a vector first)."""
    degrees = np.asarray(degrees, dtype=float)
    out = np.broadcast_to(quat.IDENTITY, degrees.shape[:-1] + (4,)).copy()
    for k, axis in enumerate(order.lower()):
        out = quat.multiply(out, quat.from_axis_angle(_AXES[axis], np.radians(degrees[..., k])))
    return out


def quat_to_euler(q: np.ndarray, order: str = "ZYX") -> np.ndarray:
    """Euler angles (..., 3) in degrees with ``euler_to_quat(order, angles) == ±q``, for the six
    orders of three distinct axes (the middle angle in [−90°, 90°])."""
    order = order.lower()
    if sorted(order) != ["x", "y", "z"]:
        raise ValueError(f"order: expected three distinct axes like 'ZYX', got {order!r}")
    i, j, k = ("xyz".index(a) for a in order)
    m = quat.to_matrix(q)
    # R = Ri(a)·Rj(b)·Rk(c); sign s of the permutation (i, j, k)
    s = 1.0 if (j - i) % 3 == 1 else -1.0
    b = np.arcsin(np.clip(s * m[..., i, k], -1.0, 1.0))
    a = np.arctan2(-s * m[..., j, k], m[..., k, k])
    c = np.arctan2(-s * m[..., i, j], m[..., i, i])
    gimbal = np.abs(np.cos(b)) < 1e-7  # near ±90° the other two angles are noise: only their sum counts
    if np.any(gimbal):  # put the whole turn into the first angle
        a = np.where(gimbal, np.arctan2(s * m[..., k, j], m[..., j, j]), a)
        c = np.where(gimbal, 0.0, c)
    return np.degrees(np.stack([a, b, c], axis=-1))


def read_bvh(path: str | Path) -> BvhMotion:
    """Parse a BVH file and run its forward kinematics; MotionFileError (one line) when it is not BVH."""
    path = Path(path)
    try:
        data = read_bytes(path, BVH.max_bytes, "BVH file")
    except MissingInput:
        raise MotionFileError(f"{path}: no such BVH file") from None
    except UntrustedInput as e:
        raise MotionFileError(str(e)) from None
    return parse_bvh(data.decode("utf-8", errors="replace"), str(path))


def parse_bvh(text: str, source: str = "<bvh>") -> BvhMotion:
    """Parse BVH text; errors name ``source``. The hierarchy is bounded (``limits.BVH``: joints and
    nesting), the frame values are read by numpy straight from the text (no token per number)."""
    motion_at = _MOTION.search(text)
    tokens = text[:motion_at.start()].split() + ["MOTION"] if motion_at else text.split()
    motion_text = text[motion_at.end():] if motion_at else ""
    names: list[str] = []
    parents: list[int] = []
    offsets: list[list[float]] = []
    channels: list[list[str]] = []
    stack: list[int] = []

    def fail(msg: str) -> MotionFileError:
        return MotionFileError(f"{source}: not a BVH file I can read ({msg})")

    if not tokens or tokens[0].upper() != "HIERARCHY":
        raise fail("it does not start with HIERARCHY")
    i = 1
    try:
        while tokens[i].upper() != "MOTION":
            t = tokens[i].upper()
            if t in ("ROOT", "JOINT", "END"):
                if t == "END" and not stack:
                    raise fail("End Site outside a joint")
                names.append(f"{names[stack[-1]]}_end" if t == "END" else tokens[i + 1])
                parents.append(stack[-1] if stack else -1)
                offsets.append([0.0, 0.0, 0.0])
                channels.append([])
                i += 2
            elif t == "{":
                if len(stack) >= BVH.max_depth or len(names) > BVH.max_items:
                    raise fail(f"more than {BVH.max_depth} levels or {BVH.max_items} joints")
                stack.append(len(names) - 1)
                i += 1
            elif t == "}":
                stack.pop()
                i += 1
            elif t == "OFFSET":
                offsets[stack[-1]] = [float(x) for x in tokens[i + 1 : i + 4]]
                i += 4
            elif t == "CHANNELS":
                n = int(tokens[i + 1])
                chans = [c.lower() for c in tokens[i + 2 : i + 2 + n]]
                bad = [c for c in chans if c[:1] not in _AXES or c[1:] not in ("position", "rotation")]
                if bad:
                    raise fail(f"unknown channel {shorten(bad[0])}")
                channels[stack[-1]] = chans
                i += 2 + n
            else:
                raise fail(f"unexpected {shorten(tokens[i])}")
        header = _MOTION_HEADER.match(motion_text)
        if header is None:
            raise fail("expected 'Frames: N' and 'Frame Time: SECONDS' after MOTION")
        frames = int(header.group(1))
        frame_time = float(header.group(2))
        values = _numbers(motion_text[header.end():])
    except MotionFileError:
        raise
    except (IndexError, ValueError) as e:
        raise fail(one_line(str(e), 120)) from None
    if not (math.isfinite(frame_time) and frame_time > 0):
        raise fail(f"Frame Time: expected seconds > 0, got {frame_time!r}")
    if not names or parents[0] != -1 or parents.count(-1) != 1:
        raise fail("expected exactly one ROOT")
    width = sum(len(c) for c in channels)
    if frames < 1 or values.size != frames * width:
        raise fail(f"expected {frames} frames of {width} numbers, got {values.size} numbers")
    if not np.all(np.isfinite(values)):
        raise fail("a channel value is not a finite number")
    data = values.reshape(frames, width)
    off = np.array(offsets)
    count = len(names)
    local_t = np.tile(off, (frames, 1, 1))
    local_r = np.tile(quat.IDENTITY, (frames, count, 1))
    col = 0
    for b, chans in enumerate(channels):
        for c in chans:
            v = data[:, col]
            col += 1
            if c.endswith("position"):
                local_t[:, b, "xyz".index(c[0])] = v
            else:
                local_r[:, b] = quat.multiply(local_r[:, b], quat.from_axis_angle(_AXES[c[0]], np.radians(v)))
    pos = np.zeros((frames, count, 3))
    rot = np.zeros((frames, count, 4))
    for b in range(count):
        p = parents[b]
        if p < 0:
            pos[:, b], rot[:, b] = local_t[:, b], local_r[:, b]
        else:
            pos[:, b] = pos[:, p] + quat.rotate(rot[:, p], local_t[:, b])
            rot[:, b] = quat.multiply(rot[:, p], local_r[:, b])
    return BvhMotion(tuple(names), tuple(parents), off, frame_time, pos, tuple(tuple(c) for c in channels), data,
                     local_r, local_t, rot)


_MOTION = re.compile(r"(?:^|(?<=\s))MOTION(?=\s|$)", re.IGNORECASE)
_MOTION_HEADER = re.compile(r"\s*Frames:\s*(\d{1,9})\s+Frame\s+Time:\s*(\S{1,64})\s", re.IGNORECASE)


def _numbers(text: str) -> np.ndarray:
    """The whitespace-separated numbers of ``text`` as floats; ValueError at the first that is not one."""
    with warnings.catch_warnings():
        warnings.simplefilter("error", DeprecationWarning)  # numpy's way of saying "stopped early"
        try:
            values = np.fromstring(text, dtype=float, sep=" ")
        except DeprecationWarning:
            raise ValueError("a frame value is not a number") from None
    return values


def write_bvh(
    path: str | Path,
    names: Sequence[str],
    parents: Sequence[int],
    offsets: np.ndarray,
    root_positions: np.ndarray,
    local_rotations: np.ndarray,
    frame_time: float,
    *,
    order: str = "ZYX",
    end_sites: Mapping[int, Sequence[float] | np.ndarray] | None = None,
    precision: int = 6,
) -> Path:
    """Write a BVH file: joints ``names`` with ``parents`` (−1 for the one root) and ``offsets`` (B, 3)
    from their parent in the parent's frame; per frame the root's position (F, 3) and every joint's
    rotation relative to its parent (F, B, 4) x y z w, as Euler channels in ``order`` (degrees).

    Joints without children get an End Site at ``end_sites[b]`` (default: a tenth of the bone into it,
    continued). The file's joints are in depth-first order of the hierarchy.
    """
    count = len(names)
    offsets = np.asarray(offsets, dtype=float)
    root_positions = np.asarray(root_positions, dtype=float)
    local_rotations = np.asarray(local_rotations, dtype=float)
    if list(parents).count(-1) != 1 or offsets.shape != (count, 3) or local_rotations.shape[1:] != (count, 4):
        raise ValueError(f"write_bvh: expected one root and {count} offsets and rotations per frame")
    if not (frame_time > 0 and math.isfinite(frame_time)):
        raise ValueError(f"frame_time: expected a number > 0, got {frame_time}")
    if sorted(order.lower()) != ["x", "y", "z"]:
        raise ValueError(f"order: expected three distinct axes like 'ZYX', got {order!r}")
    kids: dict[int, list[int]] = {b: [] for b in range(count)}
    for b, p in enumerate(parents):
        if p >= 0:
            kids[p].append(b)
    rot_chans = " ".join(f"{a.upper()}rotation" for a in order)
    lines = ["HIERARCHY"]
    dfs: list[int] = []
    fmt = f"{{:.{precision}f}}"

    def vec(v: Sequence[float] | np.ndarray) -> str:
        return " ".join(fmt.format(float(x)) for x in v)

    def emit(b: int, depth: int) -> None:
        pad = "  " * depth
        lines.append(f"{pad}{'ROOT' if parents[b] < 0 else 'JOINT'} {names[b]}")
        lines.append(pad + "{")
        lines.append(f"{pad}  OFFSET {vec(offsets[b])}")
        chans = f"6 Xposition Yposition Zposition {rot_chans}" if parents[b] < 0 else f"3 {rot_chans}"
        lines.append(f"{pad}  CHANNELS {chans}")
        dfs.append(b)
        for c in kids[b]:
            emit(c, depth + 1)
        if not kids[b]:
            given = end_sites.get(b) if end_sites else None
            end = 0.1 * offsets[b] if given is None else np.asarray(given, dtype=float)
            lines.extend([f"{pad}  End Site", pad + "  {", f"{pad}    OFFSET {vec(end)}", pad + "  }"])
        lines.append(pad + "}")

    root = list(parents).index(-1)
    emit(root, 0)
    angles = quat_to_euler(local_rotations, order)  # (F, B, 3)
    frames = len(local_rotations)
    lines += ["MOTION", f"Frames: {frames}", f"Frame Time: {frame_time:.9g}"]
    for f in range(frames):
        row = [vec(root_positions[f])] + [vec(angles[f, b]) for b in dfs]
        lines.append(" ".join(row))
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    write_owned(path, "\n".join(lines) + "\n")
    return path
