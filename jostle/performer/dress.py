"""Clothes for the DeepMimic humanoid: visual shapes of a person's proportions on its links.

``humanoid/humanoid.urdf`` carries only collision shapes, and pybullet draws those when a link has
no visual: a thin figure (0.22 m across the chest, 0.11 m thighs) with gaps at the waist and the
neck, about half the silhouette of a real person. ``dressed_urdf`` returns the same robot (same
links, joints and indices, so the poses and the segmentation are unchanged) with ``<visual>``
shapes added: a continuous torso with shoulders, fuller limbs, a head with hair, shoes, each with
its colour. Sizes here are real metres at ``URDF_SCALE``; the URDF itself is in unscaled units.
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path

from sim.motion.mocap import URDF_SCALE

RGBA = tuple[float, float, float, float]

SKIN = "skin"
HAIR = "hair"
SHIRT = "shirt"
JEANS = "jeans"
SHOES = "shoes"


@dataclass(frozen=True)
class Palette:
    """The colours of one person's skin, hair and clothes."""

    skin: RGBA
    hair: RGBA
    shirt: RGBA
    jeans: RGBA
    shoes: RGBA

    def colour(self, role: str) -> RGBA:
        return {SKIN: self.skin, HAIR: self.hair, SHIRT: self.shirt, JEANS: self.jeans, SHOES: self.shoes}[role]


PALETTES: tuple[Palette, ...] = (
    Palette((0.87, 0.69, 0.57, 1.0), (0.23, 0.15, 0.10, 1.0), (0.70, 0.17, 0.14, 1.0), (0.22, 0.31, 0.52, 1.0),
            (0.86, 0.86, 0.83, 1.0)),  # red shirt, blue jeans (the demo's performer)
    Palette((0.62, 0.45, 0.33, 1.0), (0.08, 0.07, 0.06, 1.0), (0.20, 0.55, 0.30, 1.0), (0.15, 0.15, 0.17, 1.0),
            (0.25, 0.20, 0.18, 1.0)),  # green shirt, black trousers
    Palette((0.93, 0.78, 0.68, 1.0), (0.78, 0.62, 0.32, 1.0), (0.88, 0.78, 0.25, 1.0), (0.45, 0.45, 0.47, 1.0),
            (0.15, 0.15, 0.18, 1.0)),  # yellow shirt, grey trousers
    Palette((0.45, 0.32, 0.24, 1.0), (0.12, 0.10, 0.09, 1.0), (0.25, 0.40, 0.78, 1.0), (0.42, 0.30, 0.20, 1.0),
            (0.90, 0.90, 0.90, 1.0)),  # blue shirt, brown trousers
)

ALONG_Y = (-math.pi / 2, 0.0, 0.0)  # turns a URDF capsule (axis z) to lie along the link's y axis
ALONG_Z = (0.0, 0.0, 0.0)


@dataclass(frozen=True)
class Shape:
    """One visual: 'sphere' (radius), 'capsule' (radius, length between the cap centres) or 'box'
    (full sizes), at ``xyz`` in the link frame (metres, y along the bone toward the parent)."""

    kind: str
    size: tuple[float, ...]
    xyz: tuple[float, float, float]
    colour: str  # a role of ``Palette``: skin, hair, shirt, jeans, shoes
    rpy: tuple[float, float, float] = ALONG_Y


def _limb(centre_y: float, length: float, radius: float, colour: str) -> Shape:
    return Shape("capsule", (radius, length), (0.0, centre_y, 0.0), colour)


_ARM = [_limb(-0.135, 0.17, 0.052, SHIRT)]
_FOREARM = [_limb(-0.12, 0.13, 0.043, SHIRT)]
_HAND = [Shape("sphere", (0.048,), (0.0, -0.02, 0.0), SKIN)]
_THIGH = [_limb(-0.205, 0.27, 0.075, JEANS)]
_SHIN = [_limb(-0.2, 0.3, 0.058, JEANS)]
_FOOT = [Shape("box", (0.24, 0.06, 0.1), (0.05, -0.0225, 0.0), SHOES, ALONG_Z)]

CLOTHES: dict[str, list[Shape]] = {
    "root": [
        Shape("capsule", (0.125, 0.06), (0.0, 0.1, 0.0), JEANS),  # hips, up to the belt
        Shape("capsule", (0.085, 0.17), (0.0, 0.0, 0.0), JEANS, ALONG_Z),  # across the hip joints
    ],
    "chest": [
        Shape("capsule", (0.13, 0.09), (0.0, 0.07, 0.0), SHIRT),  # trunk, from the waist up
        Shape("capsule", (0.07, 0.25), (-0.01, 0.2, 0.0), SHIRT, ALONG_Z),  # shoulders
    ],
    "neck": [
        _limb(0.04, 0.05, 0.05, SKIN),
        Shape("sphere", (0.102,), (0.0, 0.175, 0.0), SKIN),
        Shape("sphere", (0.1,), (-0.022, 0.192, 0.0), HAIR),
    ],
    "right_shoulder": _ARM,
    "left_shoulder": _ARM,
    "right_elbow": _FOREARM,
    "left_elbow": _FOREARM,
    "right_wrist": _HAND,
    "left_wrist": _HAND,
    "right_hip": _THIGH,
    "left_hip": _THIGH,
    "right_knee": _SHIN,
    "left_knee": _SHIN,
    "right_ankle": _FOOT,
    "left_ankle": _FOOT,
}


def _fmt(values: tuple[float, ...]) -> str:
    return " ".join(f"{v:.6f}" for v in values)


def dressed_urdf(source: Path, palette: Palette = PALETTES[0]) -> str:
    """The URDF at ``source`` (pybullet_data's DeepMimic humanoid) with ``CLOTHES`` added as visuals,
    coloured from ``palette``."""
    text = source.read_bytes().rstrip(b"\x00").decode("utf-8")  # the shipped file ends with a NUL
    robot = ET.fromstring(text)
    links = {link.get("name"): link for link in robot.iter("link")}
    missing = sorted(set(CLOTHES) - set(links))
    if missing:
        raise ValueError(f"{source}: not the DeepMimic humanoid (no links {', '.join(missing)})")
    s = 1.0 / URDF_SCALE
    for name, shapes in CLOTHES.items():
        for shape in shapes:
            visual = ET.SubElement(links[name], "visual")
            xyz = tuple(v * s for v in shape.xyz)
            ET.SubElement(visual, "origin", rpy=_fmt(shape.rpy), xyz=_fmt(xyz))
            geometry = ET.SubElement(visual, "geometry")
            size = tuple(v * s for v in shape.size)
            if shape.kind == "sphere":
                ET.SubElement(geometry, "sphere", radius=_fmt(size))
            elif shape.kind == "capsule":
                ET.SubElement(geometry, "capsule", radius=_fmt(size[:1]), length=_fmt(size[1:]))
            else:
                ET.SubElement(geometry, "box", size=_fmt(size))
            material = ET.SubElement(visual, "material", name=f"{name}_{len(links[name])}")
            ET.SubElement(material, "color", rgba=_fmt(palette.colour(shape.colour)))
    return ET.tostring(robot, encoding="unicode")
