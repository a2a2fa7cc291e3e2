"""The Mitake character body in pybullet: one rigid convex body, its shape, and its readouts.

The body is a pybullet *multibody* with no links (``useMaximalCoordinates=False``): measured here,
a maximal-coordinates base misapplies ``applyExternalTorque`` and ignores the velocity of a
zero-mass body in contacts, while the multibody base does both right.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import pybullet as p

from sim.config import CharacterSpec
from sim.frames import Quat, Vec3

# collision groups: bit masks (group, mask); a pair collides when each one's group is in the other's mask
GROUP_FLOOR = 1
GROUP_CHARACTER = 2
GROUP_CONTACTOR = 4
MASK_FLOOR = GROUP_CHARACTER
MASK_CHARACTER = GROUP_FLOOR | GROUP_CHARACTER | GROUP_CONTACTOR
MASK_CONTACTOR = GROUP_CHARACTER

_AROUND = 16  # vertices per horizontal ring of the hull
_RINGS_BELOW = 9
_RINGS_ABOVE = 7


def _profile(u: float, exponent: float) -> float:
    """Superellipse profile: 1 at u=0 (widest), 0 at u=1 (bottom or top tip)."""
    return max(0.0, 1.0 - u**exponent) ** (1.0 / exponent)


def hull_vertices(spec: CharacterSpec) -> list[Vec3]:
    """Vertices of the body's convex hull, relative to its centre of mass (body frame).

    Horizontal sections are ellipses (half_depth along x, half_width along y) scaled by a
    superellipse profile of the height: ``bottom_exponent`` below the widest section (< 2: a narrower,
    pointier bottom), ``top_exponent`` above. Rings are denser towards the tips, where contact happens.
    """
    verts: list[Vec3] = []
    below = spec.widest_height
    above = spec.height - spec.widest_height
    rings: list[tuple[float, float]] = []  # (height above floor, profile scale)
    for k in range(_RINGS_BELOW):
        u = math.sin(0.5 * math.pi * k / _RINGS_BELOW)
        rings.append((spec.widest_height - u * below, _profile(u, spec.bottom_exponent)))
    for k in range(1, _RINGS_ABOVE):
        u = math.sin(0.5 * math.pi * k / _RINGS_ABOVE)
        rings.append((spec.widest_height + u * above, _profile(u, spec.top_exponent)))
    for zh, s in rings:
        for j in range(_AROUND):
            a = 2.0 * math.pi * j / _AROUND
            verts.append(
                (spec.half_depth * s * math.cos(a), spec.half_width * s * math.sin(a), zh - spec.com_height)
            )
    verts.append((0.0, 0.0, -spec.com_height))
    verts.append((0.0, 0.0, spec.height - spec.com_height))
    return verts


@dataclass(frozen=True, slots=True)
class Kinematics:
    """What one read of a body gives: centre of mass, orientation and velocities (stage frame)."""

    position: Vec3
    orientation: Quat
    velocity: Vec3
    angular_velocity: Vec3

    def is_finite(self) -> bool:
        # a sum of floats is finite only if every term is (an overflow to inf also counts as bad)
        return math.isfinite(sum(self.position) + sum(self.orientation) + sum(self.velocity)
                             + sum(self.angular_velocity))


class CharacterBody:
    """One character's rigid body in a pybullet client."""

    def __init__(self, client: int, spec: CharacterSpec, position: Vec3, orientation: Quat,
                 shape: int) -> None:
        self._client = client
        self.spec = spec
        self.body_id: int = p.createMultiBody(
            baseMass=spec.mass,
            baseCollisionShapeIndex=shape,
            basePosition=position,
            baseOrientation=orientation,
            useMaximalCoordinates=False,
            physicsClientId=client,
        )
        i = spec.inertia
        p.changeDynamics(
            self.body_id, -1,
            localInertiaDiagonal=[i, i, i],
            lateralFriction=0.0,
            spinningFriction=0.0,
            rollingFriction=0.0,
            restitution=0.0,
            linearDamping=0.0,
            angularDamping=0.0,
            physicsClientId=client,
        )
        p.setCollisionFilterGroupMask(self.body_id, -1, GROUP_CHARACTER, MASK_CHARACTER,
                                      physicsClientId=client)
        self._friction = 0.0

    @staticmethod
    def create_shape(client: int, spec: CharacterSpec) -> int:
        """The convex hull collision shape for ``spec`` (share it between bodies of one spec)."""
        shape: int = p.createCollisionShape(p.GEOM_MESH, vertices=hull_vertices(spec), physicsClientId=client)
        if shape < 0:
            raise RuntimeError(f"character {spec.name!r}: pybullet refused the body's convex hull")
        return shape

    def read(self) -> Kinematics:
        pos, orn = p.getBasePositionAndOrientation(self.body_id, physicsClientId=self._client)
        vel, ang = p.getBaseVelocity(self.body_id, physicsClientId=self._client)
        return Kinematics(position=pos, orientation=orn, velocity=vel, angular_velocity=ang)

    def set_floor_friction(self, mu: float) -> None:
        """Friction of this body against everything (the floor's own coefficient is 1).

        Upright, the legs supply all horizontal floor force through the controller (friction 0);
        on the ground the body itself rubs on the floor (friction μ).
        """
        if mu != self._friction:
            p.changeDynamics(self.body_id, -1, lateralFriction=mu, physicsClientId=self._client)
            self._friction = mu

    def apply(self, force: Vec3, at: Vec3, torque: Vec3) -> None:
        """Apply a world-frame force at a world point and a world-frame torque for the next physics step."""
        if force != (0.0, 0.0, 0.0):
            p.applyExternalForce(self.body_id, -1, force, at, p.WORLD_FRAME, physicsClientId=self._client)
        if torque != (0.0, 0.0, 0.0):
            p.applyExternalTorque(self.body_id, -1, torque, p.WORLD_FRAME, physicsClientId=self._client)

    def reset(self, position: Vec3, orientation: Quat) -> None:
        p.resetBasePositionAndOrientation(self.body_id, position, orientation, physicsClientId=self._client)
        p.resetBaseVelocity(self.body_id, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0), physicsClientId=self._client)
