"""Building poses for the HUMANOID skeleton: joint rotations by name, mass, centre of mass, body frames.

Skeleton axes (as the DeepMimic clips): x forward, y up, z to the character's right. Useful signs
for limbs hanging down: about +z flexes a hip or shoulder forward and bends an elbow; about −z
bends a knee; about −x raises the right arm or leg sideways, about +x the left one. For the
trunk and neck about −z leans forward and about +x leans right.
"""

from __future__ import annotations

import functools
import math

import numpy as np

from render.keyframes.skeletons import HUMANOID_FIGURE, Figure
from sim.motion import quaternion as quat
from sim.motion.mocap import JOINTS

X = np.array([1.0, 0.0, 0.0])
Y = np.array([0.0, 1.0, 0.0])
Z = np.array([0.0, 0.0, 1.0])

SOLE_BELOW_ANKLE = 0.05  # metres from the ankle joint to the sole (the URDF foot box)


def rot(axis: np.ndarray, degrees: float) -> np.ndarray:
    return quat.from_axis_angle(axis, math.radians(degrees))


def chain(*qs: np.ndarray) -> np.ndarray:
    """Product q1·q2·…: apply the last first."""
    out = quat.IDENTITY.copy()
    for q in qs:
        out = quat.multiply(out, q)
    return out


def joints(**by_name: np.ndarray) -> np.ndarray:
    """Joint rotations (J, 4) in JOINTS order; joints not named stay unrotated."""
    out = np.tile(quat.IDENTITY, (len(JOINTS), 1))
    for name, q in by_name.items():
        out[JOINTS.index(name)] = q
    return out


def centre_of_mass(
    root_pos: np.ndarray, root_rot: np.ndarray, joint_rots: np.ndarray, figure: Figure = HUMANOID_FIGURE
) -> np.ndarray:
    """The skeleton's centre of mass (..., 3) (the figure's link masses; the humanoid's from the URDF)."""
    pos, r = figure.skeleton.forward_kinematics(root_pos, root_rot, joint_rots)
    p = pos[..., figure.mass_idx, :] + quat.rotate(r[..., figure.mass_idx, :], figure.mass_off)
    return np.einsum("...bc,b->...c", p, figure.mass_kg) / figure.mass_kg.sum()


def standing_height(figure: Figure = HUMANOID_FIGURE) -> float:
    """Soles to head top of the unrotated skeleton, metres."""
    skel = figure.skeleton
    pos, _ = skel.forward_kinematics(np.zeros(3), quat.IDENTITY, np.tile(quat.IDENTITY, (len(JOINTS), 1)))
    head = pos[skel.names.index("head_top"), 1]
    ankle = pos[skel.names.index("right_ankle"), 1]
    return float(head - ankle + SOLE_BELOW_ANKLE * figure.radii[-1] / HUMANOID_FIGURE.radii[-1])


def tilt_rotation(theta_x: float, theta_z: float) -> np.ndarray:
    """The rigid body's tilt in skeleton axes: lean forward by θx, then right by θz."""
    return chain(rot(Z, -math.degrees(theta_x)), rot(X, math.degrees(theta_z)))


def yaw_rotation(heading: float) -> np.ndarray:
    """Turn about the vertical so that skeleton +x points along ``heading`` (radians, from +x toward −z)."""
    return rot(Y, math.degrees(heading))


def in_body_frame(
    body_rot: np.ndarray, root_rot_world: np.ndarray, joint_rots: np.ndarray, figure: Figure = HUMANOID_FIGURE
) -> tuple[np.ndarray, np.ndarray]:
    """(root_offset, root_rotation) of a pose in a body frame rotated by ``body_rot`` from the world,
    with the body's origin at the skeleton's centre of mass."""
    root_rot = quat.multiply(quat.conjugate(body_rot), root_rot_world)
    return -centre_of_mass(np.zeros(3), root_rot, joint_rots, figure), quat.normalize(root_rot)


def mirror(root_offset: np.ndarray, rotations: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The left-right mirror image of a pose (rotations (1 + J, 4), root first): z → −z, sides swapped."""
    m = rotations * np.array([-1.0, -1.0, 1.0, 1.0])
    out = m.copy()
    for i, name in enumerate(JOINTS):
        other = name.replace("right", "@").replace("left", "right").replace("@", "left")
        out[1 + JOINTS.index(other)] = m[1 + i]
    return root_offset * np.array([1.0, 1.0, -1.0]), out


@functools.cache
def com_fraction(figure: Figure = HUMANOID_FIGURE) -> float:
    """Height of the standing skeleton's centre of mass above its soles, as a fraction of its height."""
    rest = np.tile(quat.IDENTITY, (len(JOINTS), 1))
    skel = figure.skeleton
    pos, _ = skel.forward_kinematics(np.zeros(3), quat.IDENTITY, rest)
    height = standing_height(figure)
    sole = pos[skel.names.index("head_top"), 1] - height
    return float((centre_of_mass(np.zeros(3), quat.IDENTITY, rest, figure)[1] - sole) / height)
