"""Build a pybullet multibody from an ``ArticulatedSkeleton`` (any source: the DeepMimic URDF, a BVH).

One ``createMultiBody`` call with link arrays: skeleton link 0 is the base, skeleton link i is pybullet
link i − 1. Ball and universal joints become spherical joints, hinges revolute joints (their limits set with
``changeDynamics(jointLowerLimit=…, jointUpperLimit=…)``), fixed links fixed joints. The body is built in
its source frame; ``source_to_stage(skeleton)`` is the turn that puts its ``up_axis`` on stage z, and the
base orientation passed here already includes it.

Measured: ``createMultiBody``'s ``basePosition`` and ``linkPositions`` are link (joint) frames — pybullet
adds the inertial offsets itself — while ``getBasePositionAndOrientation`` reports the base's com. Without
``flags=URDF_MAINTAIN_LINK_ORDER`` pybullet reorders the links of a branching tree (link i would no longer
be skeleton link i + 1). Built from ``deepmimic_humanoid()``, every link frame and com matches
``loadURDF(humanoid.urdf, globalScaling=0.25)`` to 1e-5 m (tests/test_articulated_body.py).
"""

from __future__ import annotations

import math

import numpy as np
import pybullet as p

from sim.articulated.skeleton import ArticulatedLink, ArticulatedSkeleton, Quat, Vec3
from sim.body import GROUP_CHARACTER, MASK_CHARACTER

_Y_UP_TO_Z_UP: Quat = (math.sqrt(0.5), 0.0, 0.0, math.sqrt(0.5))  # +90° about x: source y → stage z


def source_to_stage(skeleton: ArticulatedSkeleton) -> np.ndarray:
    """The rotation (x, y, z, w) that turns the skeleton's source frame into the stage frame."""
    return np.array(_Y_UP_TO_Z_UP if skeleton.up_axis == "y" else (0.0, 0.0, 0.0, 1.0))


def _collision_shape(client: int, link: ArticulatedLink) -> int:
    kw: dict[str, object] = {"collisionFramePosition": link.shape_offset,
                             "collisionFrameOrientation": link.shape_rotation, "physicsClientId": client}
    if link.shape == "sphere":
        return int(p.createCollisionShape(p.GEOM_SPHERE, radius=link.size[0], **kw))
    if link.shape == "capsule":
        return int(p.createCollisionShape(p.GEOM_CAPSULE, radius=link.size[0], height=link.size[1], **kw))
    return int(p.createCollisionShape(p.GEOM_BOX, halfExtents=link.size, **kw))


_JOINT_TYPES = {"ball": p.JOINT_SPHERICAL, "universal": p.JOINT_SPHERICAL, "hinge": p.JOINT_REVOLUTE,
                "fixed": p.JOINT_FIXED}


def build_multibody(client: int, skeleton: ArticulatedSkeleton, root_position: Vec3,
                    root_orientation: Quat, friction: float = 0.9) -> int:
    """Create the multibody with its root joint at stage ``root_position`` turned by ``root_orientation``
    (stage frame, x y z w; include ``source_to_stage``). Collides with the floor, characters and contactors
    (not with itself). Returns the pybullet body id."""
    root = skeleton.links[0]
    rest = skeleton.links[1:]
    body = p.createMultiBody(
        baseMass=root.mass,
        baseCollisionShapeIndex=_collision_shape(client, root),
        basePosition=root_position,  # the root joint: pybullet adds the inertial offset itself
        baseOrientation=root_orientation,
        baseInertialFramePosition=root.com,
        linkMasses=[link.mass for link in rest],
        linkCollisionShapeIndices=[_collision_shape(client, link) for link in rest],
        linkVisualShapeIndices=[-1] * len(rest),
        linkPositions=[link.joint_offset for link in rest],  # from the parent's link (joint) frame
        linkOrientations=[(0.0, 0.0, 0.0, 1.0)] * len(rest),
        linkInertialFramePositions=[link.com for link in rest],
        linkInertialFrameOrientations=[(0.0, 0.0, 0.0, 1.0)] * len(rest),
        linkParentIndices=[link.parent for link in rest],  # skeleton index i → pybullet i − 1; base is 0
        linkJointTypes=[_JOINT_TYPES[link.kind] for link in rest],
        linkJointAxis=[link.axis for link in rest],
        flags=p.URDF_MAINTAIN_LINK_ORDER,  # without it pybullet reorders the links of a branching tree
        physicsClientId=client,
    )
    for j, link in enumerate(skeleton.links):
        pj = j - 1
        p.setCollisionFilterGroupMask(body, pj, GROUP_CHARACTER, MASK_CHARACTER, physicsClientId=client)
        p.changeDynamics(body, pj, lateralFriction=friction, linearDamping=0.0, angularDamping=0.0,
                         restitution=0.0, physicsClientId=client)
        if j > 0:
            p.changeDynamics(body, pj, localInertiaDiagonal=link.inertia, physicsClientId=client)
            if link.kind == "hinge":
                p.changeDynamics(body, pj, jointLowerLimit=link.lower, jointUpperLimit=link.upper,
                                 physicsClientId=client)
        else:
            p.changeDynamics(body, -1, localInertiaDiagonal=link.inertia, physicsClientId=client)
        if link.kind in ("ball", "universal", "hinge"):  # switch off pybullet's default velocity motors
            if link.kind == "hinge":
                p.setJointMotorControl2(body, pj, p.VELOCITY_CONTROL, force=0.0, physicsClientId=client)
            else:
                p.setJointMotorControlMultiDof(body, pj, p.POSITION_CONTROL, targetPosition=[0, 0, 0, 1],
                                               positionGain=0.0, velocityGain=0.0, force=[0.0, 0.0, 0.0],
                                               physicsClientId=client)
    return int(body)
