"""What an articulated body is doing, read from pybullet: root, centre of mass, link poses, foot contacts.

Skeleton link i is pybullet link i − 1 (link 0 is the base, ``sim.articulated.build``).
"""

from __future__ import annotations

import numpy as np
import pybullet as p

from sim.articulated import quat1 as q1
from sim.articulated.skeleton import ArticulatedSkeleton
from sim.snapshot import LinkPose


class BodyReadout:
    def __init__(self, client: int, body: int, skeleton: ArticulatedSkeleton) -> None:
        self._client = client
        self._body = body
        self._skeleton = skeleton
        self._mass = np.array([link.mass for link in skeleton.links])
        self._links = list(range(len(skeleton.links) - 1))
        self._root_com = np.array(skeleton.links[0].com)

    def root(self) -> tuple[np.ndarray, np.ndarray]:
        """Root joint position and orientation (stage; pybullet reports the base's com)."""
        pos, orn = p.getBasePositionAndOrientation(self._body, physicsClientId=self._client)
        q = np.array(orn)
        return np.array(pos) - q1.rot(q, self._root_com), q

    def base_com(self) -> tuple[float, float, float]:
        pos = p.getBasePositionAndOrientation(self._body, physicsClientId=self._client)[0]
        return (float(pos[0]), float(pos[1]), float(pos[2]))

    def base_velocity(self) -> tuple[np.ndarray, np.ndarray]:
        v, w = p.getBaseVelocity(self._body, physicsClientId=self._client)
        return np.array(v), np.array(w)

    def link_coms(self) -> np.ndarray:
        """Centre of mass of every link (L, 3), root first."""
        states = p.getLinkStates(self._body, self._links, physicsClientId=self._client)
        return np.array([self.base_com()] + [s[0] for s in states])

    def com_state(self) -> tuple[np.ndarray, np.ndarray]:
        """Whole-body centre of mass and its velocity (stage)."""
        c = self._client
        states = p.getLinkStates(self._body, self._links, computeLinkVelocity=1, physicsClientId=c)
        pos = np.array([self.base_com()] + [s[0] for s in states])
        v0, _ = p.getBaseVelocity(self._body, physicsClientId=c)
        vel = np.array([v0] + [s[6] for s in states])
        m = self._mass
        return (m @ pos) / m.sum(), (m @ vel) / m.sum()

    def link_poses(self) -> tuple[LinkPose, ...]:
        """Every link's frame (its joint) in the stage: what render/ draws and export/ writes."""
        root, orn = self.root()
        names = self._skeleton.names
        out = [LinkPose(names[0], (float(root[0]), float(root[1]), float(root[2])),
                        (float(orn[0]), float(orn[1]), float(orn[2]), float(orn[3])))]
        # forward kinematics now: without it every link but the root lags one physics step (5 mm at walking pace)
        states = p.getLinkStates(self._body, self._links, computeForwardKinematics=1, physicsClientId=self._client)
        for j, s in enumerate(states):
            pos, q = s[4], s[5]
            out.append(LinkPose(names[j + 1], (pos[0], pos[1], pos[2]), (q[0], q[1], q[2], q[3])))
        return tuple(out)

    def joint_position(self, link: int) -> np.ndarray:
        """World position of a link's frame (its joint); link 0 is the root."""
        if link == 0:
            return self.root()[0]
        return np.array(p.getLinkState(self._body, link - 1, physicsClientId=self._client)[4])

    def touches(self, link: int) -> bool:
        """Whether a link touches anything (floor, another body, a contactor)."""
        return bool(p.getContactPoints(bodyA=self._body, linkIndexA=link - 1, physicsClientId=self._client))

    def nearest_link(self, at: tuple[float, float, float]) -> int:
        """The link whose centre of mass is nearest the stage point ``at``."""
        d = np.linalg.norm(self.link_coms() - np.asarray(at, dtype=float), axis=-1)
        return int(np.argmin(d))
