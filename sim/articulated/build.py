"""Build a pybullet multibody from an ``ArticulatedSkeleton`` (any source: the DeepMimic URDF, a BVH).

The skeleton is written out as URDF (``urdf_text``) and loaded with ``loadURDF``: only the URDF loader gives
pybullet's spherical joints their limits (``createMultiBody`` and ``changeDynamics`` cannot; measured).
Skeleton link 0 is the base, skeleton link i is pybullet link i − 1. Ball and universal joints become
spherical joints with ``<limit lower upper twist effort>`` (``sim.articulated.joint_limit``), hinges revolute
joints with their range, fixed links fixed joints. The body is built in its source frame;
``source_to_stage(skeleton)`` is the turn that puts its ``up_axis`` on stage z, and the base orientation
passed here already includes it.

Measured: ``basePosition`` is the root's link (joint) frame — pybullet adds the inertial offsets itself —
while ``getBasePositionAndOrientation`` reports the base's com. Without ``URDF_MAINTAIN_LINK_ORDER`` pybullet
reorders the links of a branching tree (link i would no longer be skeleton link i + 1); without
``URDF_USE_INERTIA_FROM_FILE`` it recomputes inertia from the shapes. Built from ``deepmimic_humanoid()``,
every link frame and com matches ``loadURDF(humanoid.urdf, globalScaling=0.25)`` to 1e-5 m
(tests/test_articulated_body.py), and the walk is the one the former ``createMultiBody`` body walked.
"""

from __future__ import annotations

import math
import tempfile
from pathlib import Path
from xml.sax.saxutils import quoteattr

import numpy as np
import pybullet as p

from interaction.types import Vec3
from sim.articulated.joint_limit import limit_ranges
from sim.articulated.skeleton import ArticulatedLink, ArticulatedSkeleton, Quat
from sim.motion import quaternion as quat
from sim.physics import GROUP_CHARACTER, MASK_CHARACTER

_Y_UP_TO_Z_UP: Quat = (math.sqrt(0.5), 0.0, 0.0, math.sqrt(0.5))  # +90° about x: source y → stage z


def source_to_stage(skeleton: ArticulatedSkeleton) -> np.ndarray:
    """The rotation (x, y, z, w) that turns the skeleton's source frame into the stage frame."""
    return np.array(_Y_UP_TO_Z_UP if skeleton.up_axis == "y" else (0.0, 0.0, 0.0, 1.0))


_URDF_JOINTS = {"ball": "spherical", "universal": "spherical", "hinge": "revolute", "fixed": "fixed"}
LIMIT_IMPULSE = 1000.0  # N·m·s per physics step a spherical joint's limit may apply: never the binding bound


def _num(v: float) -> str:
    return repr(float(v))


def _xyz(v: np.ndarray | tuple[float, ...]) -> str:
    return " ".join(_num(x) for x in v)


def _rpy(q: np.ndarray) -> str:
    return _xyz(p.getEulerFromQuaternion([float(v) for v in quat.normalize(np.asarray(q, dtype=float))]))


def _geometry(link: ArticulatedLink) -> str:
    if link.shape == "sphere":
        return f'<sphere radius="{_num(link.size[0])}"/>'
    if link.shape == "capsule":
        return f'<capsule radius="{_num(link.size[0])}" length="{_num(link.size[1])}"/>'
    return f'<box size="{_xyz(2.0 * np.asarray(link.size, dtype=float))}"/>'


def urdf_text(skeleton: ArticulatedSkeleton) -> str:
    """The skeleton as URDF: links with their inertia and collision shape, joints with their limits
    (ball/universal: pybullet's spherical limit, see ``sim.articulated.joint_limit``)."""
    parts = [f'<robot name={quoteattr(skeleton.name)}>']
    for i, link in enumerate(skeleton.links):
        inertia = link.inertia
        parts.append(
            f'<link name={quoteattr(link.name)}><inertial><origin xyz="{_xyz(link.com)}" rpy="0 0 0"/>'
            f'<mass value="{_num(link.mass)}"/><inertia ixx="{_num(inertia[0])}" iyy="{_num(inertia[1])}" '
            f'izz="{_num(inertia[2])}" ixy="0" ixz="0" iyz="0"/></inertial><collision><origin '
            f'xyz="{_xyz(link.shape_offset)}" rpy="{_rpy(np.array(link.shape_rotation))}"/><geometry>'
            f'{_geometry(link)}</geometry></collision></link>')
        if i == 0:
            continue
        joint = (f'<joint name={quoteattr(link.name + "_joint")} type="{_URDF_JOINTS[link.kind]}">'
                 f'<parent link={quoteattr(skeleton.links[link.parent].name)}/><child link={quoteattr(link.name)}/>'
                 f'<origin xyz="{_xyz(link.joint_offset)}" rpy="0 0 0"/>')
        if link.kind == "hinge":
            joint += (f'<axis xyz="{_xyz(link.axis)}"/><limit lower="{_num(link.lower)}" upper="{_num(link.upper)}" '
                      f'effort="{_num(LIMIT_IMPULSE)}" velocity="0"/>')
        elif link.kind in ("ball", "universal"):
            x, y, z = limit_ranges(link, skeleton.up_axis)
            joint += (f'<axis xyz="0 0 1"/><limit lower="{_num(x)}" upper="{_num(y)}" twist="{_num(z)}" '
                      f'effort="{_num(LIMIT_IMPULSE)}"/>')
        parts.append(joint + "</joint>")
    parts.append("</robot>")
    return "\n".join(parts)


def build_multibody(client: int, skeleton: ArticulatedSkeleton, root_position: Vec3,
                    root_orientation: Quat, friction: float = 0.9) -> int:
    """Create the multibody with its root joint at stage ``root_position`` turned by ``root_orientation``
    (stage frame, x y z w; include ``source_to_stage``). Collides with the floor, characters and contactors
    (not with itself). Returns the pybullet body id."""
    with tempfile.TemporaryDirectory(prefix="jostle-urdf-") as tmp:
        path = Path(tmp) / "body.urdf"
        path.write_text(urdf_text(skeleton), encoding="utf-8")
        body = p.loadURDF(str(path), basePosition=root_position, baseOrientation=root_orientation,
                          flags=p.URDF_MAINTAIN_LINK_ORDER | p.URDF_USE_INERTIA_FROM_FILE,
                          physicsClientId=client)
    for j, link in enumerate(skeleton.links):
        pj = j - 1
        p.setCollisionFilterGroupMask(body, pj, GROUP_CHARACTER, MASK_CHARACTER, physicsClientId=client)
        p.changeDynamics(body, pj, lateralFriction=friction, linearDamping=0.0, angularDamping=0.0,
                         restitution=0.0, physicsClientId=client)
        if link.kind in ("ball", "universal", "hinge"):  # switch off pybullet's default velocity motors
            if link.kind == "hinge":
                p.setJointMotorControl2(body, pj, p.VELOCITY_CONTROL, force=0.0, physicsClientId=client)
            else:
                p.setJointMotorControlMultiDof(body, pj, p.POSITION_CONTROL, targetPosition=[0, 0, 0, 1],
                                               positionGain=0.0, velocityGain=0.0, force=[0.0, 0.0, 0.0],
                                               physicsClientId=client)
    return int(body)
