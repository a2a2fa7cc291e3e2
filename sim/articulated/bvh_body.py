"""An articulated body and its source motion from a BVH file (the seed's "skeleton from a source file").

``bvh_body(motion)`` reads the hierarchy of a parsed BVH (``sim.motion.bvh``) and returns a ``BvhBody``:

- ``skeleton``: an ``ArticulatedSkeleton`` with one link per BVH joint (end sites are not links). The
  file is first turned into the skeletons' canonical frame — y up (hips → head), x forward, z to the
  character's right (left → right thigh), both taken from the motion — and scaled to metres by the
  joint map's unit (``sim.motion.joint_map``: detected, or given as a unit or a height). Every link frame is parallel to its
  parent's at rest, as in BVH, so a BVH joint's rotation *is* its link's rotation.
- shapes: a capsule from each joint to its child's joint (to the end site at a leaf; the pelvis spans
  the two hip joints), radii by body part scaled with the figure's height; feet are boxes (a flat sole
  to stand on, as the DeepMimic humanoid's).
- ``clip``: the motion as a ``MotionClip`` in ``sim.motion.mocap.JOINTS`` order, ready for the same PD
  tracking as a DeepMimic clip. A moving joint's channel is the product of the BVH rotations from just
  below its nearest moving ancestor down to it, so every moving link's orientation is exact; fixed joints
  in between keep their rest pose (their own bend is carried by the next moving joint below them).

Limb, neck and head joints come from ``sim.motion.joint_map`` (any common rig, or a ``--joint-map``);
the other joints take a body part by name for their mass and radius.
"""

from __future__ import annotations

import dataclasses
import math
import re
from dataclasses import dataclass
from pathlib import Path
from typing import Literal

import numpy as np

from sim.articulated.skeleton import HUMANOID_JOINTS, ArticulatedLink, ArticulatedSkeleton, JointKind
from sim.motion import quaternion as quat
from sim.motion.bvh import BvhMotion
from sim.motion.joint_map import JointMap, beside, map_joints, words
from sim.motion.mocap import JOINTS, MotionClip, MotionFileError

__all__ = ["BvhBody", "SEED_MASSES_KG", "bvh_body", "bvh_character", "body_part"]

# the seed's table 4.1 (kg, for 70 kg), plus hands and toes, which it does not list
SEED_MASSES_KG: dict[str, float] = {
    "hip": 4.3, "upper_leg": 6.6, "lower_leg": 3.2, "foot": 1.0, "hip_to_torso": 4.3, "torso": 15.0,
    "neck": 2.5, "head": 5.2, "shoulder": 2.5, "upper_arm": 2.2, "lower_arm": 1.7, "hand": 0.4, "toe": 0.2,
}
# capsule radius as a fraction of the standing height, by part
_RADIUS: dict[str, float] = {
    "hip": 0.055, "upper_leg": 0.04, "lower_leg": 0.032, "foot": 0.028, "hip_to_torso": 0.07, "torso": 0.075,
    "neck": 0.03, "head": 0.06, "shoulder": 0.03, "upper_arm": 0.028, "lower_arm": 0.024, "hand": 0.022,
    "toe": 0.022,
}
# body part → (motion channel for the right side, joint kind)
_MOVING: dict[str, tuple[str, JointKind]] = {
    "hip_to_torso": ("chest", "ball"), "neck": ("neck", "ball"), "upper_leg": ("right_hip", "universal"),
    "lower_leg": ("right_knee", "hinge"), "foot": ("right_ankle", "universal"),
    "upper_arm": ("right_shoulder", "universal"), "lower_arm": ("right_elbow", "hinge"),
}
_HINGE_LIMITS = {"lower_leg": (0.0, 2.5), "lower_arm": (-2.7, 0.0)}  # the seed's table 4.3, about the left
_GAIN = {"hip_to_torso": "torso", "neck": "neck", "upper_leg": "hip", "lower_leg": "knee", "foot": "ankle",
         "upper_arm": "shoulder", "lower_arm": "elbow"}
# name patterns, most specific first
_PARTS: tuple[tuple[str, str], ...] = (
    ("toe", "toe"), ("hipjoint", "hip"), ("upleg|thigh|upperleg|femur", "upper_leg"),
    ("foot|ankle", "foot"), ("leg|shin|knee|calf|tibia", "lower_leg"),
    ("hand|wrist|finger|thumb|index|pinky|ring|middle", "hand"),
    ("forearm|lowerarm|radius|elbow|lowarm", "lower_arm"), ("arm|humerus|uparm", "upper_arm"),
    ("shoulder|clavicle|collar", "shoulder"), ("head", "head"), ("neck", "neck"),
    ("spine|chest|back|torso|abdomen|waist", "torso"), ("hip|pelvis|root", "hip"),
)


@dataclass(frozen=True, eq=False)
class BvhBody:
    """A body built from a BVH file and its motion (see the module docstring)."""

    skeleton: ArticulatedSkeleton
    clip: MotionClip
    scale: float  # metres per file unit
    to_canonical: np.ndarray  # (4,) the turn from the file's axes into y up, x forward, z right
    links: tuple[int, ...]  # for each skeleton link, the BVH joint index it is made from
    parts: tuple[str, ...]  # the body part of each skeleton link


def _plain(name: str) -> str:
    return re.sub(r"[^a-z0-9]", "", name.lower().split(":")[-1])


def _side(name: str) -> Literal["", "right", "left"]:
    """"right"/"left" from RightUpLeg, right_hip, RThigh, r_foot, CC_Base_L_Thigh, …; "" for neither."""
    side = words(name)[0]
    return "right" if side == "right" else "left" if side == "left" else ""


def body_part(name: str, is_root: bool = False) -> str:
    """The seed's body part a BVH joint name stands for (``hip`` for the root), or "" when unknown."""
    if is_root:
        return "hip"
    plain = _plain(name)
    for pattern, part in _PARTS:
        if re.search(pattern, plain):
            return part
    return ""


_ROLE_PART = {"clavicle": "shoulder", "upper_arm": "upper_arm", "forearm": "lower_arm", "hand": "hand",
              "thigh": "upper_leg", "shin": "lower_leg", "foot": "foot", "toe": "toe", "head": "head", "neck": "neck"}


def _role_channels(jm: JointMap) -> dict[str, str]:
    """Joint-map role → the motion channel its joint drives (the chest channel is the first spine joint)."""
    out = {"neck": "neck"}
    for side in ("left", "right"):
        out |= {f"{side}_thigh": f"{side}_hip", f"{side}_shin": f"{side}_knee", f"{side}_foot": f"{side}_ankle",
                f"{side}_upper_arm": f"{side}_shoulder", f"{side}_forearm": f"{side}_elbow"}
    return out


def _unit(v: np.ndarray) -> np.ndarray:
    return v / np.maximum(np.linalg.norm(v, axis=-1, keepdims=True), 1e-12)


def _frame_from(up: np.ndarray, right: np.ndarray) -> np.ndarray:
    """The rotation taking the file's (forward, up, right) directions onto x, y, z."""
    y = up / np.linalg.norm(up)
    z = right - np.dot(right, y) * y
    z /= np.linalg.norm(z)
    x = np.cross(y, z)
    m = np.stack([x, y, z])  # rows: file vectors → canonical
    return _matrix_quat(m)


def _matrix_quat(m: np.ndarray) -> np.ndarray:
    """The unit quaternion (x y z w) of a rotation matrix (Shepperd: from its largest component)."""
    t = float(np.trace(m))
    big = int(np.argmax([m[0, 0], m[1, 1], m[2, 2], t]))
    if big == 3:
        s = 2.0 * math.sqrt(1.0 + t)
        q = [(m[2, 1] - m[1, 2]) / s, (m[0, 2] - m[2, 0]) / s, (m[1, 0] - m[0, 1]) / s, s / 4]
    else:
        i, j, k = big, (big + 1) % 3, (big + 2) % 3
        s = 2.0 * math.sqrt(max(1.0 + m[i, i] - m[j, j] - m[k, k], 1e-12))
        q = [0.0, 0.0, 0.0, (m[k, j] - m[j, k]) / s]
        q[i], q[j], q[k] = s / 4, (m[j, i] + m[i, j]) / s, (m[k, i] + m[i, k]) / s
    return quat.normalize(np.array(q))


def bvh_body(motion: BvhMotion, *, total_mass: float = 70.0, name: str = "bvh", loop: bool = False,
             link_names: Literal["bvh", "channels"] = "bvh", joint_map: JointMap | None = None) -> BvhBody:
    """Build the body and its clip from a parsed BVH (``sim.motion.bvh.read_bvh``); ``loop``: the clip is
    a cycle (BVH cannot say so). ``link_names="channels"`` names each moving link after its motion channel
    ("right_hip", …; the others keep their BVH names), for code that finds links by the DeepMimic names.

    - masses: the seed's table 4.1 for a 70 kg adult (hip 4.3, upper leg 6.6, lower leg 3.2, foot 1.0, hip-to-
      torso 4.3, torso 15, neck 2.5, head 5.2 — the table's "Hand" row, 20 cm long, is the head —, shoulder
      2.5, upper arm 2.2, lower arm 1.7 kg) shared among the links of each part by length, hands 0.4 kg and
      toes 0.2 kg (not in the table), then all scaled to ``total_mass``.
    - joint kinds (the seed's §3.2): ball at the first spine joint ("chest" channel) and the neck, universal at
      the hips, ankles and shoulders, hinge at the knees (0 … 2.5 rad) and elbows (−2.7 … 0 rad) about the
      character's left; every other joint (extra spine joints, clavicles, head, toes, hands) is fixed.
      Swing/twist/side limits of ball and universal joints are the DeepMimic humanoid's (``HUMANOID_JOINTS``).
    """
    if not total_mass > 0:
        raise ValueError(f"total_mass: expected > 0 kg, got {total_mass}")
    if motion.local_rotations is None:
        raise MotionFileError(f"{name}: the BVH motion carries no joint rotations (parse it with sim.motion.bvh)")
    jm = joint_map or map_joints(motion, source=name)
    joints = [b for b in range(len(motion.names)) if not motion.is_end(b)]
    parts = {b: body_part(motion.names[b], motion.parents[b] < 0) for b in joints}
    sides = {b: _side(motion.names[b]) for b in joints}
    for role, b in jm.roles.items():  # the joint map decides what the names alone cannot (an ASF upper arm)
        side, _, what = role.partition("_") if role.startswith(("left_", "right_")) else ("", "", role)
        if what in _ROLE_PART and b in parts and motion.parents[b] >= 0:
            parts[b], sides[b] = _ROLE_PART[what], side or sides[b]  # type: ignore[assignment]
    role_channel = {jm.roles[r]: ch for r, ch in _role_channels(jm).items()}
    rest = motion.positions[0] * 0.0
    for b in range(len(motion.names)):  # the rest pose: offsets only
        if motion.parents[b] >= 0:
            rest[b] = rest[motion.parents[b]] + motion.offsets[b]

    def find(part: str, side: str = "") -> int:
        role = {"upper_leg": "thigh", "neck": "neck"}[part]
        return jm.roles[f"{side}_{role}" if side else role]

    root = joints[0]
    up = rest[jm.roles["head"]] - rest[jm.roles["hips"]]
    right = rest[find("upper_leg", "right")] - rest[find("upper_leg", "left")]
    p = motion.positions  # the file's up in the motion: the offsets alone may lie down (iClone's rig)
    moving_up = np.median(_unit(p[:, jm.roles["head"]] - p[:, jm.roles["hips"]]), axis=0)
    if float(np.dot(_unit(up), _unit(moving_up))) < math.cos(math.radians(30.0)):
        up = moving_up  # then the person's up and right as they move
        right = np.median(_unit(p[:, jm.roles["right_thigh"]] - p[:, jm.roles["left_thigh"]]), axis=0)
    to_c = _frame_from(up, right)
    scale, height = jm.scale, jm.height_m
    offsets = quat.rotate(to_c, motion.offsets) * scale
    # the first spine joint above the root carries the "chest" channel (the seed's hip-to-torso)
    torso = [b for b in joints if parts[b] == "torso"]
    if torso:
        parts[torso[0]] = "hip_to_torso"
    kids = {b: [c for c, p in enumerate(motion.parents) if p == b] for b in joints}
    raw_mass = _part_masses(joints, kids, parts, offsets)
    k_mass = total_mass / sum(raw_mass.values())
    rest_c = quat.rotate(to_c, rest) * scale
    hips = (rest_c[find("upper_leg", "right")] - rest_c[root], rest_c[find("upper_leg", "left")] - rest_c[root])
    links: list[ArticulatedLink] = []
    index: dict[int, int] = {}
    channel_of: dict[int, str] = {}
    for b in joints:
        part = parts[b]
        side = sides[b] or "right"
        channel, kind = _MOVING.get(part, ("", "fixed"))
        channel = channel.replace("right", side) if channel.startswith("right") else channel
        if channel and channel != "chest" and role_channel.get(b) != channel:
            kind, channel = "fixed", ""  # a twist or extra joint of a moving part: the map's joint moves
        if b == root:
            kind, channel = "root", ""
        elif channel and channel in channel_of.values():
            kind, channel = "fixed", ""  # a second joint of the same part (e.g. Neck1): rigid
        if channel:
            channel_of[b] = channel
        mass = raw_mass[b] * k_mass
        link = _link(motion, b, kids[b], offsets, part, kind, channel, mass, height, index, sides, hips)
        if link_names == "channels" and channel:
            link = dataclasses.replace(link, name=channel)
        index[b] = len(links)
        links.append(link)
    skeleton = ArticulatedSkeleton(name, tuple(links), up_axis="y")
    clip = _clip(motion, joints, channel_of, to_c, scale, name, loop)
    return BvhBody(skeleton, clip, scale, to_c, tuple(joints), tuple(parts[b] for b in joints))


def bvh_character(path: str, total_mass: float = 45.0) -> tuple[ArticulatedSkeleton, MotionClip]:
    """A ragdoll spec's ``skeleton = "FILE.bvh"``: the file's own body (moving links named after their
    channels, ``total_mass`` kg like the DeepMimic humanoid's 45) and its motion cut to its best loop."""
    from sim.motion.bvh import read_bvh
    from sim.motion.clips import best_cycle

    try:
        motion = read_bvh(path)
        jm = map_joints(motion, beside(Path(path)), source=path)
        body = bvh_body(motion, total_mass=total_mass, name=Path(path).stem, loop=True, link_names="channels",
                        joint_map=jm)
    except MotionFileError as e:
        raise MotionFileError(f"skeleton: {e}") from None
    return body.skeleton, best_cycle(body.clip)


def _part_masses(joints: list[int], kids: dict[int, list[int]], parts: dict[int, str],
                 offsets: np.ndarray) -> dict[int, float]:
    """Unscaled masses: each part's table mass shared among its links by length (both sides together)."""
    present = set(parts.values())
    kg_part = dict(SEED_MASSES_KG)
    if "torso" not in present:  # one spine link: it is the whole trunk
        kg_part["hip_to_torso"] += kg_part["torso"]
    if "shoulder" not in present:  # no clavicles: their mass is the chest's
        kg_part["torso" if "torso" in present else "hip_to_torso"] += 2 * kg_part["shoulder"]
    lengths = {b: max((float(np.linalg.norm(offsets[c])) for c in kids[b]), default=0.0) for b in joints}
    others = joints[1:]
    share = {part: sum(lengths[b] for b in others if parts[b] == part) for part in present}
    counts = {part: sum(1 for b in others if parts[b] == part) for part in present}
    out = {joints[0]: kg_part["hip"]}  # the root is the pelvis
    for b in others:
        part = parts[b]
        if part == "hip":  # CMU's LHipJoint / RHipJoint: short links inside the pelvis
            out[b] = 0.3
            continue
        kg = kg_part.get(part, 0.3)
        if part in ("upper_leg", "lower_leg", "foot", "shoulder", "upper_arm", "lower_arm", "hand", "toe"):
            kg *= 2.0  # the table is per limb; the share runs over both sides
        frac = lengths[b] / share[part] if share[part] > 0 else 1.0 / counts[part]
        out[b] = max(kg * frac, 0.05)
    return out


def _link(motion: BvhMotion, b: int, kids: list[int], offsets: np.ndarray, part: str, kind: JointKind,
          channel: str, mass: float, height: float, index: dict[int, int],
          sides: dict[int, Literal["", "right", "left"]], hips: tuple[np.ndarray, np.ndarray]) -> ArticulatedLink:
    """One link: its joint and a capsule (a box for a foot) from the joint to its child."""
    radius = _RADIUS.get(part, 0.03) * height
    if motion.parents[b] < 0:  # the pelvis spans the two hip joints
        a, e = hips
    else:
        a = np.zeros(3)
        e = max((offsets[c] for c in kids), key=lambda v: float(np.linalg.norm(v)), default=np.array([0.0, -0.05, 0.0]))
    seg = e - a
    length = float(np.linalg.norm(seg))
    direction = seg / length if length > 1e-9 else np.array([0.0, -1.0, 0.0])
    centre = tuple(float(v) for v in (a + e) / 2.0)
    turn = _z_to(direction)
    shape: Literal["capsule", "box"] = "capsule"
    size: tuple[float, ...] = (radius, max(length - radius, 1e-3))
    inertia = _capsule_inertia(mass, radius, size[1], direction)
    if part == "foot":  # a box from the heel past the toe joint, from the ankle down to the sole
        shape = "box"  # (proportions of the DeepMimic humanoid's foot when built from its own skeleton)
        sole = min(float(e[1]), 0.0) - 0.6 * radius
        heel, toe = -radius, abs(float(e[0])) + 0.5 * radius
        size = ((toe - heel) / 2.0, -sole / 2.0, radius)
        turn = np.array([0.0, 0.0, 0.0, 1.0])
        dx, dy, dz = (2 * v for v in size)
        inertia = (mass * (dy * dy + dz * dz) / 12, mass * (dx * dx + dz * dz) / 12, mass * (dx * dx + dy * dy) / 12)
        centre = ((toe + heel) / 2.0, sole / 2.0, 0.0)
    parent = -1 if motion.parents[b] < 0 else index[motion.parents[b]]
    offset = (0.0, 0.0, 0.0) if parent < 0 else tuple(float(v) for v in offsets[b])
    kw: dict[str, object] = {}
    if kind == "hinge":
        lower, upper = _HINGE_LIMITS[part]
        kw = {"axis": (0.0, 0.0, -1.0), "lower": lower, "upper": upper}
    elif kind in ("ball", "universal"):
        swing, twist, side = HUMANOID_JOINTS[channel][2:5]
        kw = {"twist_axis": tuple(float(v) for v in direction), "swing_limit": math.radians(swing),
              "twist_limit": math.radians(twist), "side_limit": math.radians(side)}
    foot: Literal["", "right", "left"] = (sides[b] or "right") if part == "foot" and kind != "fixed" else ""
    return ArticulatedLink(
        motion.names[b], parent, kind, offset,  # type: ignore[arg-type]
        mass, centre, inertia, shape, size, centre, tuple(float(v) for v in turn),  # type: ignore[arg-type]
        motion_channel=channel, gain_group=_GAIN.get(part, "") if channel else "", foot=foot, **kw,  # type: ignore[arg-type]
    )


def _z_to(d: np.ndarray) -> np.ndarray:
    """The smallest rotation taking +z onto the unit vector d (pybullet capsules lie along z)."""
    z = np.array([0.0, 0.0, 1.0])
    c = np.cross(z, d)
    w = 1.0 + float(np.dot(z, d))
    if w < 1e-9:
        return np.array([1.0, 0.0, 0.0, 0.0])
    return quat.normalize(np.concatenate([c, [w]]))


def _capsule_inertia(mass: float, radius: float, length: float, direction: np.ndarray) -> tuple[float, float, float]:
    """Diagonal of a capsule's (as a cylinder of its full length) inertia in the link frame."""
    full = length + 2 * radius
    axial = 0.5 * mass * radius * radius
    across = mass * (3 * radius * radius + full * full) / 12
    tensor = across * np.eye(3) + (axial - across) * np.outer(direction, direction)
    d = np.diag(tensor)
    return (float(d[0]), float(d[1]), float(d[2]))


def _clip(motion: BvhMotion, joints: list[int], channel_of: dict[int, str], to_c: np.ndarray, scale: float,
          name: str, loop: bool) -> MotionClip:
    """The motion in JOINTS order, canonical axes, metres (see the module docstring for folding)."""
    assert motion.local_rotations is not None and motion.local_translations is not None
    local = motion.local_rotations
    inv = quat.conjugate(to_c)
    frames = motion.frames
    rots = np.tile(quat.IDENTITY, (frames, len(JOINTS), 1))
    moving = set(channel_of) | {joints[0]}
    for b, channel in channel_of.items():
        q = local[:, b]
        a = motion.parents[b]
        while a >= 0 and a not in moving:  # fold the fixed joints above it into it
            q = quat.multiply(local[:, a], q)
            a = motion.parents[a]
        rots[:, JOINTS.index(channel)] = quat.multiply(quat.multiply(to_c, q), inv)
    root = joints[0]
    root_rot = quat.normalize(quat.multiply(quat.multiply(to_c, local[:, root]), inv))
    root_pos = quat.rotate(to_c, motion.positions[:, root]) * scale
    for i in range(1, frames):
        root_rot[i] = quat.align(root_rot[i], root_rot[i - 1])
        rots[i] = quat.align(rots[i], rots[i - 1])
    frame_time = motion.frame_time if motion.frame_time > 0 and math.isfinite(motion.frame_time) else 1 / 30
    if frames < 2:
        raise MotionFileError(f"{name}: a clip needs at least 2 frames, the BVH has {frames}")
    return MotionClip(name, loop, np.arange(frames) * frame_time, root_pos, root_rot, rots)
