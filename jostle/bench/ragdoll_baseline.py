"""The pybullet client ``jostle bench ragdoll`` runs on, and its baseline: pybullet's own DeepMimic humanoid
tracking the walk clip with ``STABLE_PD_CONTROL`` (see :mod:`jostle.bench.ragdoll`)."""

from __future__ import annotations

import contextlib
import math
import os
import sys
import time
from collections.abc import Iterator
from dataclasses import dataclass

import numpy as np


def log(msg: str) -> None:
    print(f"bench ragdoll: {msg}", file=sys.stderr)


@dataclass
class BenchSim:
    """One pybullet client on the world's physics settings."""

    client: int
    dt: float

    @classmethod
    def open(cls) -> BenchSim:
        from sim.config import WorldConfig
        from sim.physics import open_client

        cfg = WorldConfig()
        client, _ = open_client(cfg)
        return cls(client, cfg.physics_dt)

    def close(self) -> None:
        import pybullet as p

        p.disconnect(physicsClientId=self.client)


def baseline_slices(n: int, seconds: float, slices: int) -> Iterator[float]:
    """n DeepMimic humanoids tracking the walk clip with pybullet's stable PD for ``seconds``, in ``slices``
    parts: the wall seconds of each part, one per ``next`` (so that the bench can run it turn about with
    what it compares it with, and a machine busier for a while slows both alike)."""
    import pybullet as p

    from sim.articulated.build import source_to_stage
    from sim.articulated.skeleton import deepmimic_humanoid, deepmimic_urdf_path
    from sim.articulated.spec import ArticulatedSpec
    from sim.motion import quaternion as quat
    from sim.motion.mocap import JOINTS, REVOLUTE, MotionClip, pybullet_motion_path

    sim = BenchSim.open()
    try:
        c = sim.client
        clip = MotionClip.load(pybullet_motion_path(ArticulatedSpec().walk_clip))
        spec = ArticulatedSpec()
        up = source_to_stage(deepmimic_humanoid())
        urdf = str(deepmimic_urdf_path())
        with quiet_stderr():  # the URDF has no axes for its spherical joints: pybullet warns per joint
            bodies = [p.loadURDF(urdf, [0.0, 2.0 * i, 1.0], up.tolist(), globalScaling=0.25,
                                 flags=p.URDF_MAINTAIN_LINK_ORDER, physicsClientId=c) for i in range(n)]
        index = {p.getJointInfo(bodies[0], j, physicsClientId=c)[1].decode(): j
                 for j in range(p.getNumJoints(bodies[0], physicsClientId=c))}
        joints = [index[name] for name in JOINTS]
        group = {"chest": "torso", "neck": "neck"}
        gains = [spec.gains(group.get(name, name.split("_")[-1])) for name in JOINTS]
        kp, kd = [g[0] for g in gains], [g[1] for g in gains]
        forces = [[g[2]] if name in REVOLUTE else [g[2]] * 3 for g, name in zip(gains, JOINTS, strict=True)]
        rest_v = [[0.0] if name in REVOLUTE else [0.0, 0.0, 0.0] for name in JOINTS]

        def targets(t: float) -> tuple[np.ndarray, np.ndarray, list[list[float]]]:
            pos, rot, rots = clip.sample(t)
            out = [[2.0 * math.atan2(q[2], q[3])] if name in REVOLUTE else q.tolist()
                   for q, name in zip(rots, JOINTS, strict=True)]
            return pos, rot, out

        pos, rot, start = targets(0.0)
        for i, b in enumerate(bodies):
            root = quat.rotate(up, pos) + np.array([0.0, 2.0 * i, 0.0])
            p.resetBasePositionAndOrientation(b, root.tolist(), quat.multiply(up, rot).tolist(), physicsClientId=c)
            for j, q in zip(joints, start, strict=True):
                p.resetJointStateMultiDof(b, j, q, physicsClientId=c)
        steps = round(seconds / sim.dt)
        fell_at: float | None = None
        spent = 0.0
        ends = {round(steps * (k + 1) / slices) for k in range(slices)}
        for s in range(steps):
            if s in ends:
                yield spent
                spent = 0.0
            mark = time.perf_counter()
            _, _, target = targets(s * sim.dt)
            for b in bodies:
                p.setJointMotorControlMultiDofArray(b, joints, p.STABLE_PD_CONTROL, targetPositions=target,
                                                    targetVelocities=rest_v, positionGains=kp, velocityGains=kd,
                                                    forces=forces, physicsClientId=c)
            p.stepSimulation(physicsClientId=c)
            spent += time.perf_counter() - mark
            if fell_at is None and p.getBasePositionAndOrientation(bodies[0], physicsClientId=c)[0][2] < 0.45:
                fell_at = s * sim.dt
        log("baseline: " + (f"fell after {fell_at:.1f} s (no balance, as expected)" if fell_at is not None
                            else "stayed up"))
        yield spent
    finally:
        sim.close()


@contextlib.contextmanager
def quiet_stderr() -> Iterator[None]:
    """File descriptors 1 and 2 to /dev/null (pybullet's C-level warnings go to both), restored after."""
    sys.stdout.flush()
    sys.stderr.flush()
    saved = [os.dup(1), os.dup(2)]
    try:
        with open(os.devnull, "wb") as null:
            os.dup2(null.fileno(), 1)
            os.dup2(null.fileno(), 2)
            yield
    finally:
        for fd, keep in zip((1, 2), saved, strict=True):
            os.dup2(keep, fd)
            os.close(keep)
