"""Pushes on an articulated character's links: each a world-frame force on one link's centre of mass,
applied every physics step until its duration has run out."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pybullet as p

from sim.articulated.readout import BodyReadout


@dataclass
class LinkPush:
    link: int  # skeleton link index (0: the root)
    force: np.ndarray  # N, world frame
    remaining: float  # s


class LinkPushes:
    """The pushes acting on one multibody now."""

    def __init__(self, client: int, body: int, readout: BodyReadout) -> None:
        self._client = client
        self._body = body
        self._readout = readout
        self._pushes: list[LinkPush] = []

    def __bool__(self) -> bool:
        return bool(self._pushes)

    def add(self, link: int, force: np.ndarray, duration: float) -> None:
        self._pushes.append(LinkPush(link, force, duration))

    def apply(self, dt: float) -> float:
        """Apply every push for one physics step of ``dt`` s; the largest force applied (N, 0 if none)."""
        strongest = 0.0
        for push in self._pushes:
            j = push.link - 1
            pos = self._readout.base_com() if j < 0 else p.getLinkState(self._body, j, physicsClientId=self._client)[0]
            p.applyExternalForce(self._body, j, push.force.tolist(), pos, p.WORLD_FRAME, physicsClientId=self._client)
            push.remaining -= dt
            strongest = max(strongest, float(np.linalg.norm(push.force)))
        self._pushes = [x for x in self._pushes if x.remaining > 1e-9]
        return strongest
