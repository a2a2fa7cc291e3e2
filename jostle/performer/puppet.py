"""The DeepMimic humanoid in its own pybullet DIRECT client, posed kinematically and drawn with
pybullet's CPU renderer (ER_TINY_RENDERER): colour plus a per-link segmentation mask.

pybullet joint indices of ``humanoid/humanoid.urdf``: 0 root (fixed to the base), 1 chest,
2 neck, 3 right_shoulder, 4 right_elbow, 5 right_wrist (fixed), 6 left_shoulder, 7 left_elbow,
8 left_wrist (fixed), 9 right_hip, 10 right_knee, 11 right_ankle, 12 left_hip, 13 left_knee,
14 left_ankle (the same on every body). Knees and elbows are revolute about z (one angle); the rest are spherical and take
the clips' local quaternions (x y z w) as they are. The humanoid is drawn in the clothes of
``jostle.performer.dress`` (same links, fuller shapes). The base carries no mass or offset, so the base
position is the root (pelvis) joint. The URDF lacks joint axes and pybullet says so on loading
(harmless; those lines are kept off stdout).
"""

from __future__ import annotations

import ctypes
import math
import os
import sys
import tempfile
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from jostle.performer.camera import PinholeCamera
from jostle.performer.choreography import StagePose
from jostle.performer.dress import PALETTES, dressed_urdf
from sensors.base import SensorUnavailable
from sim.motion.mocap import JOINTS, REVOLUTE, URDF_SCALE


@contextmanager
def _stdout_hushed() -> Iterator[None]:
    """Send file descriptor 1 to /dev/null for a moment: pybullet's URDF loader prints one warning per
    joint without an axis straight to it (C stdio), which would litter a command's output."""
    try:
        sys.stdout.flush()
        saved = os.dup(1)
    except (OSError, ValueError):
        yield
        return
    libc = ctypes.CDLL(None)
    devnull = os.open(os.devnull, os.O_WRONLY)
    try:
        os.dup2(devnull, 1)
        yield
    finally:
        libc.fflush(None)  # C buffers hold the warnings until flushed: flush them into /dev/null
        os.dup2(saved, 1)
        os.close(saved)
        os.close(devnull)


@dataclass(frozen=True, eq=False)
class PuppetImage:
    rgb: np.ndarray  # (H, W, 3) uint8, RGB as pybullet gives it
    parts: np.ndarray  # (H, W) int16: pybullet link index of the humanoid at each pixel, -1 = not a person
    person: np.ndarray  # (H, W) int8: which puppet (person index) is seen at each pixel, -1 = none
    depth_m: np.ndarray | None = None  # (H, W) float32 distance along the optical axis, inf = no person


HIDDEN_AT = (0.0, 0.0, -1000.0)  # far below the floor, outside every view: where absent people wait


class HumanoidPuppet:
    """Humanoids in one pybullet DIRECT client (its own, so several puppets can live side by side):
    one body per entry of ``scales`` (body size; 1.0 = the 1.6 m humanoid), each dressed in
    ``dress.PALETTES[i % len(PALETTES)]``. ``set_pose(pose, i)`` places body i, ``hide(i)`` takes it
    out of sight; ``render`` draws them all at once, so nearer people hide farther ones."""

    def __init__(self, scales: tuple[float, ...] = (1.0,)) -> None:
        import pybullet as pb
        import pybullet_data

        self._pb = pb
        self._client = pb.connect(pb.DIRECT)
        if self._client < 0:
            raise SensorUnavailable("pybullet: could not start a DIRECT client for the virtual performer")
        source = Path(pybullet_data.getDataPath()) / "humanoid" / "humanoid.urdf"
        self._bodies: list[int] = []
        try:
            with tempfile.TemporaryDirectory(prefix="jostle-performer-") as folder:
                for i, scale in enumerate(scales):
                    path = Path(folder) / f"dressed_humanoid_{i}.urdf"
                    path.write_text(dressed_urdf(source, PALETTES[i % len(PALETTES)]), encoding="utf-8")
                    with _stdout_hushed():
                        self._bodies.append(pb.loadURDF(
                            str(path), globalScaling=URDF_SCALE * scale, useFixedBase=True,
                            physicsClientId=self._client,
                        ))
        except (OSError, ValueError, pb.error) as e:
            pb.disconnect(self._client)
            raise SensorUnavailable(f"{source}: cannot load the DeepMimic humanoid ({e})") from None
        cid = self._client
        body = self._bodies[0]
        self.link_names: tuple[str, ...] = tuple(
            pb.getJointInfo(body, j, physicsClientId=cid)[12].decode()
            for j in range(pb.getNumJoints(body, physicsClientId=cid))
        )
        index = {name: j for j, name in enumerate(self.link_names)}
        self._joint_indices = [index[name] for name in JOINTS]
        self._revolute = [name in REVOLUTE for name in JOINTS]
        self._person_of_body = {b: i for i, b in enumerate(self._bodies)}
        self._visible = [True] * len(self._bodies)
        for i in range(1, len(self._bodies)):
            self.hide(i)

    def set_pose(self, pose: StagePose, person: int = 0) -> None:
        pb = self._pb
        body = self._bodies[person]
        pb.resetBasePositionAndOrientation(
            body, pose.position.tolist(), pose.rotation.tolist(), physicsClientId=self._client
        )
        values: list[list[float]] = []
        for q, revolute in zip(pose.joint_rots, self._revolute, strict=True):
            if revolute:  # the clips store these as a rotation about the joint's z axis
                values.append([2.0 * math.atan2(float(q[2]), float(q[3]))])
            else:
                values.append([float(v) for v in q])
        pb.resetJointStatesMultiDof(body, self._joint_indices, values, physicsClientId=self._client)
        self._visible[person] = True

    def hide(self, person: int) -> None:
        if self._visible[person]:
            self._pb.resetBasePositionAndOrientation(self._bodies[person], HIDDEN_AT, (0.0, 0.0, 0.0, 1.0),
                                                     physicsClientId=self._client)
            self._visible[person] = False

    def link_positions(self, person: int = 0) -> dict[str, np.ndarray]:
        """World positions of every link frame (the joints), as pybullet computes them."""
        pb = self._pb
        out = {}
        for j, name in enumerate(self.link_names):
            state = pb.getLinkState(self._bodies[person], j, computeForwardKinematics=True,
                                    physicsClientId=self._client)
            out[name] = np.array(state[4])
        return out

    def render(self, camera: PinholeCamera, *, depth: bool = False) -> PuppetImage:
        """Colour, segmentation and (if asked) depth along the optical axis of everyone visible."""
        pb = self._pb
        _, _, rgba, zbuf, seg = pb.getCameraImage(
            camera.width,
            camera.height,
            camera.view_matrix(),
            camera.projection_matrix(),
            lightDirection=[-2.0, -3.0, 4.0],
            lightColor=[1.0, 0.97, 0.92],
            lightAmbientCoeff=0.55,
            lightDiffuseCoeff=0.5,
            lightSpecularCoeff=0.04,
            shadow=0,
            renderer=pb.ER_TINY_RENDERER,
            flags=pb.ER_SEGMENTATION_MASK_OBJECT_AND_LINKINDEX,
            physicsClientId=self._client,
        )
        rgba = np.asarray(rgba, dtype=np.uint8).reshape(camera.height, camera.width, 4)
        seg = np.asarray(seg, dtype=np.int64).reshape(camera.height, camera.width)
        body = np.where(seg >= 0, seg & ((1 << 24) - 1), -1)
        link = np.where(seg >= 0, (seg >> 24) - 1, -2)
        person = np.full(body.shape, -1, dtype=np.int8)
        for b, i in self._person_of_body.items():
            person[body == b] = i
        parts = np.where(person >= 0, link, -1).astype(np.int16)
        depth_m = None
        if depth:  # OpenGL depth buffer → eye-space distance along the axis (exact to µm, measured)
            d = np.asarray(zbuf, dtype=np.float64).reshape(camera.height, camera.width)
            n, f = camera.near, camera.far
            z = (f * n) / (f - (f - n) * d)
            depth_m = np.where(person >= 0, z, np.inf).astype(np.float32)
        return PuppetImage(np.ascontiguousarray(rgba[..., :3]), parts, person, depth_m)

    def close(self) -> None:
        if self._client >= 0:
            self._pb.disconnect(physicsClientId=self._client)
            self._client = -1
