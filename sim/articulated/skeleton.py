"""The articulated character's body as data: links, joints (kind, axes, limits), masses and shapes.

``ArticulatedSkeleton`` is the one description every articulated body is built from. Two sources make it:

- ``deepmimic_humanoid()`` (here): the DeepMimic humanoid of ``pybullet_data/humanoid/humanoid.urdf`` at
  ``globalScaling=0.25`` (metres), read from the URDF file itself (masses, joint offsets, shapes), with the
  seed's joint kinds and limits laid on top (``HUMANOID_JOINTS``).
- a BVH hierarchy (helper G2, ``sim/articulated/bvh_body.py``): capsules sized from the bone lengths, masses
  from the seed's table scaled to the total mass.

``sim/articulated/build.py: build_multibody(client, skeleton, position, orientation) -> body id`` turns any
skeleton into one pybullet multibody (``createMultiBody``; link i of the skeleton is pybullet link i − 1,
link 0 is the base). A BVH reader therefore only has to produce an ``ArticulatedSkeleton``.
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path
from typing import Literal

from interaction.types import Vec3

Quat = tuple[float, float, float, float]  # x, y, z, w

JointKind = Literal["root", "ball", "universal", "hinge", "fixed"]
ShapeKind = Literal["sphere", "capsule", "box"]
GAIN_GROUPS = ("hip", "knee", "ankle", "torso", "neck", "shoulder", "elbow")
_DOFS = {"root": 0, "ball": 3, "universal": 3, "hinge": 1, "fixed": 0}


@dataclass(frozen=True)
class ArticulatedLink:
    """One rigid link and the joint that attaches it to its parent (see the module docstring)."""

    name: str
    parent: int
    kind: JointKind
    joint_offset: Vec3
    mass: float
    com: Vec3
    inertia: Vec3
    shape: ShapeKind
    size: tuple[float, ...]
    shape_offset: Vec3 = (0.0, 0.0, 0.0)
    shape_rotation: Quat = (0.0, 0.0, 0.0, 1.0)
    axis: Vec3 = (0.0, 0.0, 1.0)  # hinge axis, link frame
    lower: float = -math.pi  # hinge limits
    upper: float = math.pi
    twist_axis: Vec3 = (0.0, -1.0, 0.0)  # ball/universal: the bone direction, link frame
    swing_limit: float = math.pi
    twist_limit: float = math.pi
    side_limit: float = math.pi
    motion_channel: str = ""
    gain_group: str = ""
    foot: Literal["", "right", "left"] = ""

    def __post_init__(self) -> None:
        if self.kind not in _DOFS:
            raise ValueError(f"kind: expected one of {', '.join(_DOFS)}, got {self.kind!r}")
        if not self.mass > 0:
            raise ValueError(f"mass: expected > 0 kg, got {self.mass!r} (link {self.name})")
        if self.gain_group not in ("", *GAIN_GROUPS):
            raise ValueError(f"gain_group: expected \"\" or one of {', '.join(GAIN_GROUPS)}, got {self.gain_group!r}")
        if self.kind == "hinge" and not self.lower <= self.upper:
            raise ValueError(f"lower: expected <= upper={self.upper}, got {self.lower} (link {self.name})")

    @property
    def dofs(self) -> int:
        """Degrees of freedom pybullet gives the joint (a universal joint is a spherical one: 3)."""
        return _DOFS[self.kind]


@dataclass(frozen=True)
class ArticulatedSkeleton:
    """A tree of links, root first.

    Conventions (follow them when building one from another source):

    - The skeleton is described in its **source frame** in the rest pose (all joint rotations identity):
      ``up_axis`` says which axis is up there ("y" for DeepMimic and BVH, "z" for stage-native bodies).
      The builder turns the whole body so that ``up_axis`` becomes stage z; the stage frame is metres, z up.
      Forward in the rest pose is source +x (the DeepMimic clips walk along +x).
    - Link 0 is the root (pelvis), ``parent == -1``, ``kind == "root"``: the free-floating base.
      Every other link has ``parent < its own index`` (parents before children).
    - ``joint_offset``: the joint's position in the **parent link's frame** (the parent's joint), metres.
      A link's frame has its origin at its joint and is parallel to the parent's frame in the rest pose.
    - ``com``: centre of mass in the link's frame; ``inertia``: diagonal of the inertia tensor about the com in
      the link frame (kg·m²). ``mass`` in kg.
    - ``shape``: collision shape: "sphere" (size = (radius,)), "capsule" (size = (radius, length between the
      cap centres)) or "box" (size = half extents (x, y, z)); centred at ``shape_offset`` in the link frame and
      turned by ``shape_rotation`` (x, y, z, w) — pybullet capsules lie along their local z.
    - Joint kinds (the seed's table 3.1): "ball" 3 DOF (pelvis–torso, neck), "universal" 2 DOF (hips, ankles,
      shoulders), "hinge" 1 DOF about ``axis`` (knees, elbows), "fixed" 0 DOF (wrists: a rigid end link).
      In pybullet ball and universal joints are both spherical joints; a universal joint is a ball joint
      whose twist about ``twist_axis`` (the bone direction) is held inside ``twist_limit``.
    - Limits (radians): hinge ``lower`` ≤ angle ≤ ``upper`` about ``axis``; ball/universal: the front-back swing
      within ±``swing_limit``, the twist about the bone (``twist_axis``) within ±``twist_limit`` and the
      sideways swing within ±``side_limit``, each as pybullet's spherical joint limit measures it
      (``sim.articulated.joint_limit``; pybullet enforces them).
    - ``motion_channel``: which channel of a source motion drives the joint, by name in
      ``sim.motion.mocap.JOINTS`` ("chest", "right_hip", …), or "" when none does (the joint holds its rest pose).
    - ``gain_group``: which row of the PD gain table applies ("hip", "knee", "ankle", "torso", "neck",
      "shoulder", "elbow"; the seed's groups), "" for none (fixed joints).
    - ``foot``: "right" / "left" for the two foot links (balance uses them), "" otherwise.
    """

    name: str
    links: tuple[ArticulatedLink, ...]
    up_axis: Literal["y", "z"] = "y"

    def __post_init__(self) -> None:
        if not self.links or self.links[0].parent != -1 or self.links[0].kind != "root":
            raise ValueError("links: expected the root link (parent -1, kind 'root') first")
        names = [link.name for link in self.links]
        if len(set(names)) != len(names):
            raise ValueError(f"links: link names must be unique, got {names}")
        for i, link in enumerate(self.links[1:], start=1):
            if not 0 <= link.parent < i:
                raise ValueError(f"links: {link.name}: parent must be an earlier link, got {link.parent}")
        feet = {link.foot for link in self.links if link.foot}
        if feet and feet != {"right", "left"}:
            raise ValueError(f"links: expected one right and one left foot, got {sorted(feet)}")

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(link.name for link in self.links)

    @property
    def total_mass(self) -> float:
        return sum(link.mass for link in self.links)

    def index(self, name: str) -> int:
        try:
            return self.names.index(name)
        except ValueError:
            raise KeyError(f"{self.name}: no link {name!r}; links: {', '.join(self.names)}") from None

    def foot(self, side: Literal["right", "left"]) -> int:
        for i, link in enumerate(self.links):
            if link.foot == side:
                return i
        raise KeyError(f"{self.name}: no {side} foot")


# ---------------------------------------------------------------------------- the DeepMimic humanoid

DEEPMIMIC_SCALE = 0.25

# Seed (Lu) joint kinds and limits laid over the URDF, per joint name: (kind, gain group, limits).
# Hinge limits come from the URDF (knee −3.14..0, elbow 0..3.14). swing/twist in degrees.
HUMANOID_JOINTS: dict[str, tuple[JointKind, str, float, float, float]] = {
    # name: (kind, gain group, swing (front-back) deg, twist (about the bone) deg, side (sideways swing) deg).
    # Wide enough for every frame of the walk and get-up clips (the get-ups flex the hips to 128°, turn the
    # shoulders 64° and roll the ankles 37°), and no wider than a person's joints allow by much.
    "chest": ("ball", "torso", 60.0, 45.0, 40.0),
    "neck": ("ball", "neck", 60.0, 70.0, 45.0),
    "right_hip": ("universal", "hip", 135.0, 40.0, 60.0),
    "right_ankle": ("universal", "ankle", 70.0, 30.0, 40.0),
    "right_shoulder": ("universal", "shoulder", 170.0, 80.0, 170.0),
    "left_hip": ("universal", "hip", 135.0, 40.0, 60.0),
    "left_ankle": ("universal", "ankle", 70.0, 30.0, 40.0),
    "left_shoulder": ("universal", "shoulder", 170.0, 80.0, 170.0),
    "right_knee": ("hinge", "knee", 0.0, 0.0, 0.0),
    "left_knee": ("hinge", "knee", 0.0, 0.0, 0.0),
    "right_elbow": ("hinge", "elbow", 0.0, 0.0, 0.0),
    "left_elbow": ("hinge", "elbow", 0.0, 0.0, 0.0),
}


def deepmimic_urdf_path() -> Path:
    import pybullet_data

    return Path(pybullet_data.getDataPath()) / "humanoid" / "humanoid.urdf"


def _vec(text: str | None, scale: float = 1.0) -> Vec3:
    parts = [float(v) * scale for v in (text or "0 0 0").split()]
    if len(parts) != 3:
        raise ValueError(f"expected 3 numbers, got {text!r}")
    return (parts[0], parts[1], parts[2])


def _attr(el: ET.Element, child: str, key: str, default: str) -> str:
    """Attribute ``key`` of ``el``'s first ``child`` element, ``default`` when either is missing."""
    found = el.find(child)
    return default if found is None else found.get(key, default)


def _rpy_quat(rpy: Vec3) -> Quat:
    r, p_, y = (v / 2.0 for v in rpy)
    cr, sr, cp, sp, cy, sy = math.cos(r), math.sin(r), math.cos(p_), math.sin(p_), math.cos(y), math.sin(y)
    return (sr * cp * cy - cr * sp * sy, cr * sp * cy + sr * cp * sy, cr * cp * sy - sr * sp * cy,
            cr * cp * cy + sr * sp * sy)


def _box_inertia(mass: float, half: Vec3) -> Vec3:
    x, y, z = (2 * h for h in half)
    return (mass * (y * y + z * z) / 12, mass * (x * x + z * z) / 12, mass * (x * x + y * y) / 12)


def _shape_inertia(mass: float, shape: ShapeKind, size: tuple[float, ...], along_y: bool) -> Vec3:
    """Inertia of a solid shape about its centre (a capsule as a cylinder of its full length)."""
    if shape == "sphere":
        i = 0.4 * mass * size[0] ** 2
        return (i, i, i)
    if shape == "box":
        return _box_inertia(mass, (size[0], size[1], size[2]))
    r, length = size
    full = length + 2 * r
    axial = 0.5 * mass * r * r
    across = mass * (3 * r * r + full * full) / 12
    return (across, axial, across) if along_y else (across, across, axial)


def deepmimic_humanoid(path: Path | None = None) -> ArticulatedSkeleton:
    """The DeepMimic humanoid (15 links, 45 kg) read from its URDF at ``globalScaling=0.25``.

    The URDF's dummy ``base`` link (0.1 g, fixed to ``root``) is dropped: ``root`` is the base.
    Inertias are computed from the collision shapes, as pybullet does when it loads this URDF.
    """
    path = path or deepmimic_urdf_path()
    s = DEEPMIMIC_SCALE
    # the shipped file ends in a NUL byte, which XML parsers refuse
    robot = ET.fromstring(path.read_text(encoding="utf-8").rstrip("\x00\r\n\t "))
    link_xml = {el.get("name"): el for el in robot.findall("link")}
    joints: dict[str, ET.Element] = {}
    for el in robot.findall("joint"):
        child = el.find("child")
        if child is not None:
            joints[child.get("link", "")] = el
    order = [name for name in link_xml if name not in ("base", None)]
    links: list[ArticulatedLink] = []
    for name in order:
        assert name is not None
        el = link_xml[name]
        inertial = el.find("inertial")
        coll = el.find("collision")
        mass_el = inertial.find("mass") if inertial is not None else None
        if coll is None or inertial is None or mass_el is None:
            raise ValueError(f"{path}: link {name}: expected <inertial> with <mass>, and <collision>")
        mass = float(mass_el.get("value", "0"))
        origin = coll.find("origin")
        offset = _vec(origin.get("xyz") if origin is not None else None, s)
        rotation = _rpy_quat(_vec(origin.get("rpy") if origin is not None else None))
        geom = coll.find("geometry")
        shape: ShapeKind
        size: tuple[float, ...]
        if geom is not None and geom.find("sphere") is not None:
            shape, size = "sphere", (float(_attr(geom, "sphere", "radius", "0")) * s,)
        elif geom is not None and geom.find("capsule") is not None:
            cap = geom.find("capsule")
            assert cap is not None
            shape, size = "capsule", (float(cap.get("radius", "0")) * s, float(cap.get("length", "0")) * s)
        elif geom is not None and geom.find("box") is not None:
            box = _vec(_attr(geom, "box", "size", "0 0 0"), s / 2.0)
            shape, size = "box", box
        else:
            raise ValueError(f"{path}: link {name}: expected a sphere, capsule or box collision shape")
        com = _vec(_attr(inertial, "origin", "xyz", "0 0 0"), s)
        inertia = _shape_inertia(mass, shape, size, along_y=shape == "capsule")
        joint = joints[name]
        parent_el = joint.find("parent")
        parent_name = parent_el.get("link", "") if parent_el is not None else ""
        j_origin = joint.find("origin")
        joint_offset = _vec(j_origin.get("xyz") if j_origin is not None else None, s)
        if name == "root":
            links.append(ArticulatedLink(name, -1, "root", (0.0, 0.0, 0.0), mass, com, inertia, shape, size,
                                         offset, rotation))
            continue
        parent = order.index(parent_name)
        if name not in HUMANOID_JOINTS:  # wrists: fixed end links
            links.append(ArticulatedLink(name, parent, "fixed", joint_offset, mass, com, inertia, shape, size,
                                         offset, rotation))
            continue
        kind, group, swing, twist, side = HUMANOID_JOINTS[name]
        foot: Literal["", "right", "left"] = ""
        if name.endswith("_ankle"):
            foot = "right" if name.startswith("right") else "left"
        if kind == "hinge":
            limit = joint.find("limit")
            lower = float(limit.get("lower", "-3.14")) if limit is not None else -math.pi
            upper = float(limit.get("upper", "3.14")) if limit is not None else math.pi
            axis = _vec(_attr(joint, "axis", "xyz", "0 0 1"))
            links.append(ArticulatedLink(name, parent, kind, joint_offset, mass, com, inertia, shape, size,
                                         offset, rotation, axis=axis, lower=lower, upper=upper,
                                         motion_channel=name, gain_group=group, foot=foot))
        else:
            twist_axis: Vec3 = (0.0, 1.0, 0.0) if name in ("chest", "neck") else (0.0, -1.0, 0.0)
            links.append(ArticulatedLink(name, parent, kind, joint_offset, mass, com, inertia, shape, size,
                                         offset, rotation, twist_axis=twist_axis,
                                         swing_limit=math.radians(swing), twist_limit=math.radians(twist),
                                         side_limit=math.radians(side), motion_channel=name, gain_group=group,
                                         foot=foot))
    return ArticulatedSkeleton("deepmimic_humanoid", tuple(links), up_axis="y")
