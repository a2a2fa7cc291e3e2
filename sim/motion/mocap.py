"""Motion capture in DeepMimic's format (shipped in ``pybullet_data/data/motions``) and the
humanoid skeleton it drives (``pybullet_data/humanoid/humanoid.urdf`` at ``globalScaling=0.25``).

A frame is 44 floats: duration, root position (3, metres, **Y up**, x forward, z to the right),
root rotation (w x y z), then per joint a quaternion (w x y z) or, for knees and elbows, one
angle about the joint's z axis. The last frame's duration is 0; quaternion signs flip between
frames and are aligned here. Nothing here trusts the file: it is parsed as JSON and checked.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from sensors.untrusted import MissingInput, UntrustedInput, load_json
from sensors.untrusted.limits import MOTION_JSON
from sim.motion import quaternion as quat

JOINTS: tuple[str, ...] = (
    "chest",
    "neck",
    "right_hip",
    "right_knee",
    "right_ankle",
    "right_shoulder",
    "right_elbow",
    "left_hip",
    "left_knee",
    "left_ankle",
    "left_shoulder",
    "left_elbow",
)
REVOLUTE = frozenset({"right_knee", "right_elbow", "left_knee", "left_elbow"})
REVOLUTE_AXIS = np.array([0.0, 0.0, 1.0])
FRAME_FLOATS = 1 + 3 + 4 + sum(1 if j in REVOLUTE else 4 for j in JOINTS)  # 44

URDF_SCALE = 0.25  # the DeepMimic humanoid URDF is loaded at globalScaling=0.25 (metres)


class MotionFileError(ValueError):
    """A motion file that cannot be used; the message names the file and what is wrong."""


def pybullet_motion_path(name: str) -> Path:
    """Path of a clip shipped with pybullet, e.g. ``walk`` → ``.../humanoid3d_walk.txt``."""
    import pybullet_data

    path = Path(pybullet_data.getDataPath()) / "data" / "motions" / f"humanoid3d_{name}.txt"
    if not path.exists():
        known = sorted(
            p.stem.removeprefix("humanoid3d_")
            for p in path.parent.glob("humanoid3d_*.txt")
        )
        raise MotionFileError(f"no pybullet motion clip {name!r}; known clips: {', '.join(known)}")
    return path


@dataclass(frozen=True, eq=False)
class MotionClip:
    """A clip: per frame its start time, root position, root rotation and joint rotations (x y z w)."""

    name: str
    loop: bool
    times: np.ndarray  # (N,) start time of each frame, seconds, times[0] == 0
    root_pos: np.ndarray  # (N, 3) Y up
    root_rot: np.ndarray  # (N, 4) x y z w, signs aligned frame to frame
    joint_rots: np.ndarray  # (N, J, 4) x y z w, J = len(JOINTS), signs aligned frame to frame

    @property
    def duration(self) -> float:
        return float(self.times[-1])

    @property
    def cycle_offset(self) -> np.ndarray:
        """Horizontal root displacement over one pass of the clip (for looping without snapping back)."""
        d = self.root_pos[-1] - self.root_pos[0]
        return np.array([d[0], 0.0, d[2]])

    @classmethod
    def load(cls, path: str | Path) -> MotionClip:
        path = Path(path)
        try:
            doc = load_json(path, MOTION_JSON, "motion file")
        except MissingInput:
            raise MotionFileError(f"{path}: no such motion file") from None
        except UntrustedInput as e:
            raise MotionFileError(f"{path}: not a DeepMimic motion file ({e.problem})") from None
        if not isinstance(doc, dict) or not isinstance(doc.get("Frames"), list) or len(doc["Frames"]) < 2:
            raise MotionFileError(f"{path}: expected an object with a 'Frames' list of at least 2 frames")
        rows = doc["Frames"]
        for i, row in enumerate(rows):
            if not isinstance(row, list) or len(row) != FRAME_FLOATS:
                got = len(row) if isinstance(row, list) else type(row).__name__
                raise MotionFileError(f"{path}: frame {i}: expected {FRAME_FLOATS} numbers, got {got}")
        try:
            data = np.asarray(rows, dtype=float)
        except (TypeError, ValueError):
            raise MotionFileError(f"{path}: frames must hold numbers only") from None
        if not np.all(np.isfinite(data)):
            bad = int(np.argwhere(~np.isfinite(data))[0][0])
            raise MotionFileError(f"{path}: frame {bad}: not a finite number")
        durations = data[:, 0]
        if np.any(durations[:-1] <= 0):
            bad = int(np.argwhere(durations[:-1] <= 0)[0][0])
            raise MotionFileError(f"{path}: frame {bad}: duration must be > 0")
        times = np.concatenate([[0.0], np.cumsum(durations[:-1])])
        root_pos = data[:, 1:4]
        root_rot = quat.normalize(quat.from_wxyz(data[:, 4:8]))
        joints = []
        col = 8
        for name in JOINTS:
            if name in REVOLUTE:
                joints.append(quat.from_axis_angle(REVOLUTE_AXIS, data[:, col]))
                col += 1
            else:
                joints.append(quat.normalize(quat.from_wxyz(data[:, col : col + 4])))
                col += 4
        joint_rots = np.stack(joints, axis=1)
        for i in range(1, len(times)):  # signs flip between frames in the files: align to the previous
            root_rot[i] = quat.align(root_rot[i], root_rot[i - 1])
            joint_rots[i] = quat.align(joint_rots[i], joint_rots[i - 1])
        loop = str(doc.get("Loop", "none")).lower() == "wrap"
        return cls(path.stem.removeprefix("humanoid3d_"), loop, times, root_pos, root_rot, joint_rots)

    def sample(self, t: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(root_pos, root_rot, joint_rots) at time t, interpolated between frames.

        A looping clip wraps and carries its root forward by ``cycle_offset`` per pass; a
        non-looping one holds its last frame.
        """
        offset = np.zeros(3)
        if self.loop and self.duration > 0:
            cycles = np.floor(t / self.duration)
            t = t - cycles * self.duration
            offset = cycles * self.cycle_offset
        t = float(np.clip(t, 0.0, self.duration))
        i = int(np.clip(np.searchsorted(self.times, t, side="right") - 1, 0, len(self.times) - 2))
        span = self.times[i + 1] - self.times[i]
        u = 0.0 if span <= 0 else (t - self.times[i]) / span
        pos = (1 - u) * self.root_pos[i] + u * self.root_pos[i + 1] + offset
        rot = quat.slerp(self.root_rot[i], self.root_rot[i + 1], u)
        joints = quat.slerp(self.joint_rots[i], self.joint_rots[i + 1], u)
        return pos, rot, joints


# ------------------------------------------------------------------------------ skeleton


@dataclass(frozen=True, eq=False)
class Skeleton:
    """Bones as (name, parent index, offset from the parent's joint in the parent's frame, metres).

    Index 0 is the root (pelvis). Entries whose name is in ``JOINTS`` are rotated by the pose;
    the others (head top, wrists, toes) are fixed end points.
    """

    names: tuple[str, ...]
    parents: tuple[int, ...]
    offsets: np.ndarray  # (B, 3)

    def forward_kinematics(
        self, root_pos: np.ndarray, root_rot: np.ndarray, joint_rots: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        """World positions (..., B, 3) and rotations (..., B, 4) of every bone's joint.

        Vectorised over leading axes: ``root_pos`` (..., 3), ``root_rot`` (..., 4), ``joint_rots``
        (..., J, 4) in ``JOINTS`` order.
        """
        lead = np.shape(root_pos)[:-1]
        n = len(self.names)
        pos = np.zeros((*lead, n, 3))
        rot = np.zeros((*lead, n, 4))
        pos[..., 0, :] = root_pos
        rot[..., 0, :] = root_rot
        for b in range(1, n):
            p = self.parents[b]
            pos[..., b, :] = pos[..., p, :] + quat.rotate(rot[..., p, :], self.offsets[b])
            name = self.names[b]
            if name in JOINTS:
                local = joint_rots[..., JOINTS.index(name), :]
                rot[..., b, :] = quat.multiply(rot[..., p, :], local)
            else:
                rot[..., b, :] = rot[..., p, :]
        return pos, rot

    def bones(self) -> list[tuple[int, int]]:
        """(parent, child) index pairs: the segments to draw."""
        return [(self.parents[b], b) for b in range(1, len(self.names))]


def _humanoid() -> Skeleton:
    s = URDF_SCALE
    table: list[tuple[str, str | None, tuple[float, float, float]]] = [
        ("root", None, (0.0, 0.0, 0.0)),
        ("chest", "root", (0.0, 0.944604, 0.0)),
        ("neck", "chest", (0.0, 0.895576, 0.0)),
        ("head_top", "neck", (0.0, 1.1, 0.0)),
        ("right_hip", "root", (0.0, 0.0, 0.339548)),
        ("right_knee", "right_hip", (0.0, -1.686184, 0.0)),
        ("right_ankle", "right_knee", (0.0, -1.639480, 0.0)),
        ("right_toe", "right_ankle", (0.45, -0.09, 0.0)),
        ("right_shoulder", "chest", (-0.0962, 0.974, 0.73244)),
        ("right_elbow", "right_shoulder", (0.0, -1.099152, 0.0)),
        ("right_wrist", "right_elbow", (0.0, -1.035788, 0.0)),
        ("left_hip", "root", (0.0, 0.0, -0.339548)),
        ("left_knee", "left_hip", (0.0, -1.686184, 0.0)),
        ("left_ankle", "left_knee", (0.0, -1.639480, 0.0)),
        ("left_toe", "left_ankle", (0.45, -0.09, 0.0)),
        ("left_shoulder", "chest", (-0.0962, 0.974, -0.73244)),
        ("left_elbow", "left_shoulder", (0.0, -1.099152, 0.0)),
        ("left_wrist", "left_elbow", (0.0, -1.035788, 0.0)),
    ]
    names = tuple(t[0] for t in table)
    parents = tuple(-1 if t[1] is None else names.index(t[1]) for t in table)
    offsets = np.array([t[2] for t in table]) * s
    return Skeleton(names, parents, offsets)


HUMANOID = _humanoid()
