"""The DeepMimic humanoid in its own pybullet DIRECT client, posed kinematically and drawn with
pybullet's CPU renderer (ER_TINY_RENDERER): colour plus a per-link segmentation mask.

pybullet joint indices of ``humanoid/humanoid.urdf``: 0 root (fixed to the base), 1 chest,
2 neck, 3 right_shoulder, 4 right_elbow, 5 right_wrist (fixed), 6 left_shoulder, 7 left_elbow,
8 left_wrist (fixed), 9 right_hip, 10 right_knee, 11 right_ankle, 12 left_hip, 13 left_knee,
14 left_ankle. Knees and elbows are revolute about z (one angle); the rest are spherical and take
the clips' local quaternions (x y z w) as they are. The humanoid is drawn in the clothes of
``jostle.synth.dress`` (same links, fuller shapes). The base carries no mass or offset, so the base
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

from jostle.synth.camera import PinholeCamera
from jostle.synth.choreography import StagePose
from jostle.synth.dress import dressed_urdf
from render.mocap import JOINTS, REVOLUTE, URDF_SCALE
from sensors.base import SensorUnavailable


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
    parts: np.ndarray  # (H, W) int16: pybullet link index of the humanoid at each pixel, -1 = not the person


class HumanoidPuppet:
    """One humanoid in one pybullet DIRECT client (its own, so several can live side by side)."""

    def __init__(self) -> None:
        import pybullet as pb
        import pybullet_data

        self._pb = pb
        self._client = pb.connect(pb.DIRECT)
        if self._client < 0:
            raise SensorUnavailable("pybullet: could not start a DIRECT client for the virtual performer")
        source = Path(pybullet_data.getDataPath()) / "humanoid" / "humanoid.urdf"
        try:
            with tempfile.TemporaryDirectory(prefix="jostle-performer-") as folder:
                path = Path(folder) / "dressed_humanoid.urdf"
                path.write_text(dressed_urdf(source), encoding="utf-8")
                with _stdout_hushed():
                    self._body = pb.loadURDF(
                        str(path), globalScaling=URDF_SCALE, useFixedBase=True, physicsClientId=self._client
                    )
        except (OSError, ValueError, pb.error) as e:
            pb.disconnect(self._client)
            raise SensorUnavailable(f"{source}: cannot load the DeepMimic humanoid ({e})") from None
        cid = self._client
        self.link_names: tuple[str, ...] = tuple(
            pb.getJointInfo(self._body, j, physicsClientId=cid)[12].decode()
            for j in range(pb.getNumJoints(self._body, physicsClientId=cid))
        )
        index = {name: j for j, name in enumerate(self.link_names)}
        self._joint_indices = [index[name] for name in JOINTS]
        self._revolute = [name in REVOLUTE for name in JOINTS]

    def set_pose(self, pose: StagePose) -> None:
        pb = self._pb
        pb.resetBasePositionAndOrientation(
            self._body, pose.position.tolist(), pose.rotation.tolist(), physicsClientId=self._client
        )
        values: list[list[float]] = []
        for q, revolute in zip(pose.joint_rots, self._revolute, strict=True):
            if revolute:  # the clips store these as a rotation about the joint's z axis
                values.append([2.0 * math.atan2(float(q[2]), float(q[3]))])
            else:
                values.append([float(v) for v in q])
        pb.resetJointStatesMultiDof(self._body, self._joint_indices, values, physicsClientId=self._client)

    def link_positions(self) -> dict[str, np.ndarray]:
        """World positions of every link frame (the joints), as pybullet computes them."""
        pb = self._pb
        out = {}
        for j, name in enumerate(self.link_names):
            state = pb.getLinkState(self._body, j, computeForwardKinematics=True, physicsClientId=self._client)
            out[name] = np.array(state[4])
        return out

    def render(self, camera: PinholeCamera) -> PuppetImage:
        pb = self._pb
        _, _, rgba, _, seg = pb.getCameraImage(
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
        parts = np.where(body == self._body, link, -1).astype(np.int16)
        return PuppetImage(np.ascontiguousarray(rgba[..., :3]), parts)

    def close(self) -> None:
        if self._client >= 0:
            self._pb.disconnect(physicsClientId=self._client)
            self._client = -1
