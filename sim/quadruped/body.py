"""The quadruped's body in pybullet: driven kinematically from the procedural legs, physical when knocked over.

While it walks the body is kinematic: each control tick the chassis is reset to the pose of
``Locomotion`` and every leg joint to the angles of closed-form IK (``skeleton.LegGeometry.solve``),
with the chassis velocity set so characters and contactors that touch it feel it move. It then collides
with characters and contactors only (the feet are placed, not simulated), which makes "feet never in a
cube" and "stance feet never slip" exact readings of pybullet's own toe links (``toes``).

A strong shove knocks it over: it joins the floor's collision group, its joints hold their angles with
weak motors, and pybullet takes it (gravity, floor, cubes). After ``lie_s`` it gets up: chassis and
joints are interpolated from where it lies to standing at that spot (``getup_s``), then it walks again.
"""

from __future__ import annotations

import math
from enum import StrEnum

import numpy as np
import pybullet as p
from numpy.typing import NDArray

from sim.physics import GROUP_CHARACTER, MASK_CHARACTER
from sim.quadruped.gait import Pose
from sim.quadruped.skeleton import LEGS, Skeleton

Array = NDArray[np.float64]

_MASK_KINEMATIC = MASK_CHARACTER & ~1  # everything a character meets but the floor group (floor, cubes)
_HOLD_FORCE = 40.0  # N·m per joint while fallen: limp but not a rag


class BodyMode(StrEnum):
    KINEMATIC = "kinematic"
    FALLEN = "fallen"
    GETTING_UP = "getting_up"


class QuadrupedBody:
    def __init__(self, client: int, skeleton: Skeleton) -> None:
        self.client = client
        self.skeleton = skeleton
        self.body = skeleton.body
        self.mode = BodyMode.KINEMATIC
        self.mode_since = 0.0
        self.joints = [j for leg in LEGS for j in skeleton.legs[leg].joints]
        self.toe_links = [skeleton.legs[leg].toe_link for leg in LEGS]
        self.unreached = 0  # IK targets out of reach (the leg went as far as it could)
        self.mass = sum(p.getDynamicsInfo(self.body, link, physicsClientId=client)[0]
                        for link in range(-1, p.getNumJoints(self.body, physicsClientId=client)))
        self._set_mask(_MASK_KINEMATIC)
        self._getup_from: tuple[Array, tuple[float, ...], list[float]] | None = None
        self._getup_to: tuple[Array, tuple[float, ...], list[float]] | None = None
        self.angles = [0.0] * len(self.joints)

    def _set_mask(self, mask: int) -> None:
        for link in range(-1, p.getNumJoints(self.body, physicsClientId=self.client)):
            p.setCollisionFilterGroupMask(self.body, link, GROUP_CHARACTER, mask, physicsClientId=self.client)

    # ------------------------------------------------------------------ walking: kinematic
    def solve(self, pose: Pose) -> list[float]:
        """Joint angles (LEGS order, 3 per leg) putting the toes of ``pose`` where it says."""
        inv_pos, inv_orn = p.invertTransform(pose.position.tolist(), pose.orientation)
        angles: list[float] = []
        for k, leg in enumerate(LEGS):
            local = np.array(p.multiplyTransforms(inv_pos, inv_orn, pose.toes[k].tolist(), (0, 0, 0, 1))[0])
            q, ok = self.skeleton.legs[leg].solve(local)
            self.unreached += not ok
            angles.extend(q)
        return angles

    def apply(self, pose: Pose) -> None:
        """Put the body in ``pose`` (kinematic mode)."""
        c = self.client
        self.angles = self.solve(pose)
        p.resetBasePositionAndOrientation(self.body, pose.position.tolist(), pose.orientation, physicsClientId=c)
        p.resetBaseVelocity(self.body, pose.velocity.tolist(), (0.0, 0.0, 0.0), physicsClientId=c)
        for j, q in zip(self.joints, self.angles, strict=True):
            p.resetJointState(self.body, j, q, 0.0, physicsClientId=c)

    def toes(self) -> Array:
        """pybullet's toe-link centres now, (4, 3) in LEGS order."""
        states = p.getLinkStates(self.body, self.toe_links, computeForwardKinematics=True, physicsClientId=self.client)
        return np.array([s[4] for s in states])

    def base(self) -> tuple[Array, tuple[float, float, float, float]]:
        pos, orn = p.getBasePositionAndOrientation(self.body, physicsClientId=self.client)
        return np.array(pos), orn

    # ------------------------------------------------------------------ knocked over: physical
    def knock(self, dv: tuple[float, float, float], t: float) -> None:
        """Let pybullet take it, moving with the extra velocity ``dv``."""
        c = self.client
        self.mode, self.mode_since = BodyMode.FALLEN, t
        self._set_mask(MASK_CHARACTER)
        lin, ang = p.getBaseVelocity(self.body, physicsClientId=c)
        p.resetBaseVelocity(self.body, [lin[i] + dv[i] for i in range(3)], ang, physicsClientId=c)
        p.setJointMotorControlArray(self.body, self.joints, p.POSITION_CONTROL, targetPositions=self.angles,
                                    forces=[_HOLD_FORCE * self.skeleton.scale**4] * len(self.joints),
                                    physicsClientId=c)

    def settled(self) -> bool:
        lin, ang = p.getBaseVelocity(self.body, physicsClientId=self.client)
        return math.hypot(*lin) < 0.1 and math.hypot(*ang) < 0.3

    def start_getup(self, stand: Pose, t: float) -> None:
        """From where it lies to ``stand`` (a standing pose at its spot), kinematically."""
        c = self.client
        pos, orn = self.base()
        now = [p.getJointState(self.body, j, physicsClientId=c)[0] for j in self.joints]
        p.setJointMotorControlArray(self.body, self.joints, p.VELOCITY_CONTROL, forces=[0.0] * len(self.joints),
                                    physicsClientId=c)
        self._set_mask(_MASK_KINEMATIC)
        self._getup_from = (pos, orn, now)
        self._getup_to = (stand.position, stand.orientation, self.solve(stand))
        self.mode, self.mode_since = BodyMode.GETTING_UP, t

    def getup(self, t: float, duration: float) -> bool:
        """One tick of getting up; True when it stands."""
        assert self._getup_from is not None and self._getup_to is not None
        u = min(max((t - self.mode_since) / duration, 0.0), 1.0)
        e = u * u * (3.0 - 2.0 * u)
        (p0, o0, q0), (p1, o1, q1) = self._getup_from, self._getup_to
        lift = 0.25 * self.skeleton.stand_height * math.sin(math.pi * e)  # rise clear of the ground, then down
        pos = (1.0 - e) * p0 + e * p1 + np.array([0.0, 0.0, lift])
        orn = p.getQuaternionSlerp(o0, o1, e)
        c = self.client
        p.resetBasePositionAndOrientation(self.body, pos.tolist(), orn, physicsClientId=c)
        p.resetBaseVelocity(self.body, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0), physicsClientId=c)
        self.angles = [a + e * math.remainder(b - a, math.tau) for a, b in zip(q0, q1, strict=True)]
        for j, q in zip(self.joints, self.angles, strict=True):
            p.resetJointState(self.body, j, q, 0.0, physicsClientId=c)
        if u >= 1.0:
            self.mode, self.mode_since = BodyMode.KINEMATIC, t
            self._getup_from = self._getup_to = None
            return True
        return False

    def remove(self) -> None:
        p.removeBody(self.body, physicsClientId=self.client)
