"""The Mitake character body in pybullet: one rigid convex body, its shape, and batched readouts.

Bodies are pybullet *maximal-coordinate* rigid bodies (faster than multibodies: docs/notes/mitake-body.md).
Two traps of that path, avoided here: ``changeDynamics(localInertiaDiagonal=…)`` without ``mass=`` zeroes a
rigid body's mass (NaN on the next step, which then spreads through the shared solver to its neighbours),
and ``applyExternalTorque`` uses the shape's own inertia, not the one set. The controller therefore never
applies torques: it adds its impulse to the body's velocities (``write_velocities``, one call per body per
control tick; ``sim.mitake.control``). Contactors stay zero-mass multibodies (``sim.contactors``): the
solver uses their velocity in contacts with these bodies.

Sleeping is disabled: a body that pybullet deactivated would ignore the next velocity write.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from itertools import repeat

import numpy as np
import pybullet as p
from numpy.typing import NDArray

from interaction.types import Vec3
from sim.config import CharacterSpec
from sim.frames import Quat
from sim.physics import GROUP_CHARACTER, MASK_CHARACTER

Array = NDArray[np.float64]

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


def figure_point(spec: CharacterSpec, azimuth: float, height: float) -> Vec3:
    """A point on the drawn figure's outline, body frame relative to the centre of mass.

    ``azimuth`` is measured from the body's front (its +x) toward its left; ``height`` is above the
    floor (upright). The figure's outline is the widest section's ellipse at every height — the legs
    and shoulders of the drawn character span it (their mass is neglected, Mitake §4.1) even where the
    collision hull narrows to its tip. A push there moves the rigid body as if applied to it.
    """
    c, s = math.cos(azimuth), math.sin(azimuth)
    r = 1.0 / math.sqrt((c / spec.half_depth) ** 2 + (s / spec.half_width) ** 2)
    return (r * c, r * s, height - spec.com_height)


def create_shape(client: int, spec: CharacterSpec) -> int:
    """The convex hull collision shape for ``spec`` (shared by the bodies of one spec)."""
    shape: int = p.createCollisionShape(p.GEOM_MESH, vertices=hull_vertices(spec), physicsClientId=client)
    if shape < 0:
        raise RuntimeError(f"character {spec.name!r}: pybullet refused the body's convex hull")
    return shape


def create_body(client: int, spec: CharacterSpec, shape: int, position: Vec3, orientation: Quat,
                friction: float = 0.0) -> int:
    """One character body: mass, inertia·I, no damping, no restitution, never asleep."""
    body: int = p.createMultiBody(
        baseMass=spec.mass,
        baseCollisionShapeIndex=shape,
        basePosition=position,
        baseOrientation=orientation,
        useMaximalCoordinates=True,
        physicsClientId=client,
    )
    i = spec.inertia
    p.changeDynamics(
        body, -1,
        mass=spec.mass,  # needed with localInertiaDiagonal on rigid bodies (else the mass becomes 0)
        localInertiaDiagonal=[i, i, i],
        lateralFriction=friction,
        spinningFriction=0.0,
        rollingFriction=0.0,
        restitution=0.0,
        linearDamping=0.0,
        angularDamping=0.0,
        activationState=p.ACTIVATION_STATE_DISABLE_SLEEPING,
        physicsClientId=client,
    )
    p.setCollisionFilterGroupMask(body, -1, GROUP_CHARACTER, MASK_CHARACTER, physicsClientId=client)
    return body


def read_states(client: int, bodies: Sequence[int]) -> tuple[Array, Array, Array, Array]:
    """Positions (N, 3), orientations (N, 4, x y z w), velocities and angular velocities (N, 3)."""
    if not bodies:
        z3, z4 = np.zeros((0, 3)), np.zeros((0, 4))
        return z3, z4, z3.copy(), z3.copy()
    pose = map(p.getBasePositionAndOrientation, bodies, repeat(client))
    vel = map(p.getBaseVelocity, bodies, repeat(client))
    m = np.array([a[0] + a[1] + v[0] + v[1] for a, v in zip(pose, vel, strict=True)])
    return m[:, 0:3], m[:, 3:7], m[:, 7:10], m[:, 10:13]


def write_velocities(client: int, bodies: Sequence[int], velocity: Array, angular_velocity: Array) -> None:
    """Set the velocities of ``bodies`` (rows of the arrays, stage frame) — one call per body."""
    reset = p.resetBaseVelocity
    for body, v, w in zip(bodies, velocity.tolist(), angular_velocity.tolist(), strict=True):
        reset(body, v, w, client)


def set_friction(client: int, body: int, mu: float) -> None:
    """Friction of a body against everything (the floor's own coefficient is 1).

    Upright, the legs supply all horizontal floor force through the controller (friction 0);
    on the ground the body itself rubs on the floor (friction μ).
    """
    p.changeDynamics(body, -1, lateralFriction=mu, physicsClientId=client)


def reset_body(client: int, body: int, position: Vec3, orientation: Quat) -> None:
    p.resetBasePositionAndOrientation(body, position, orientation, physicsClientId=client)
    p.resetBaseVelocity(body, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0), physicsClientId=client)
