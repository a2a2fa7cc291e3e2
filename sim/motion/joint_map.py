"""Which BVH joint is which body part, for any common rig, and the file's unit and standing height.

``map_joints(motion, explicit=None, unit=None, height=None)`` returns a ``JointMap``: ``roles`` (role →
joint index; ``ROLES`` lists them) found by structure first and names second — per side, the hand
(a joint named wrist, else hand) and the foot (ankle, else foot); walking up from them past twist/roll
and zero-length joints, the forearm, upper arm, and a clavicle only when the next joint up is still of
that side; the shin and thigh; the hips where the two legs meet, the chest where the two arms meet, the
head by name. So CMU ASF-style ``LeftShoulder`` (the upper arm, under ``LeftCollar``) and Mixamo's
``LeftShoulder`` (the clavicle, above ``LeftArm``) both land right; an upper arm whose name says
clavicle/collar, or a clavicle named arm, is refused as ambiguous. ``explicit`` (from ``--joint-map``
TOML or ``FILE.joints.toml`` beside the file: ``load_joint_map``, ``beside``) pins any roles by name. Every missing or ambiguous role is listed in one
``MotionFileError``. Units: ``unit`` (m, cm, in, mm), ``height`` in metres, else detected from the
standing height (the head joint's height above the lower sole, along hips → head, in the 90th
percentile of frames, ÷ ``HEAD_SHARE``; 1.0–2.5 m in one of the units); ``describe()`` says what was used.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from sensors.untrusted import UntrustedInput, load_toml, shorten
from sensors.untrusted.limits import CONFIG_TOML  # a joint map is a small config
from sim.motion.bvh import BvhMotion
from sim.motion.mocap import MotionFileError

__all__ = ["ROLES", "UNITS", "JointMap", "beside", "load_joint_map", "map_joints", "words"]

_SIDED = ("clavicle", "upper_arm", "forearm", "hand", "thigh", "shin", "foot", "toe")
ROLES: tuple[str, ...] = ("hips", "chest", "neck", "head") + tuple(
    f"{s}_{r}" for s in ("left", "right") for r in _SIDED)
UNITS: dict[str, float] = {"m": 1.0, "cm": 0.01, "in": 0.0254, "mm": 0.001}  # metres per file unit
_PREFIXES = {"mixamorig", "cc", "base", "bip01", "bip", "def", "rl"}
_SKIP = re.compile(r"twist|roll|share|nub|end$")
_RAW_SIDE = re.compile(r"^([lr])(femur|tibia|foot|toes|humerus|radius|wrist|hand|clavicle|hipjoint|thigh|shin|"
                       r"shldr|uparm|lowarm|forearm|collar|upleg|leg|arm)$")
HEAD_SHARE = 0.87  # the head joint (skull base) stands at ~87 % of a person's height (anthropometric tables)
_CLAVICLE_WORDS = ("clavicle", "collar")
_ARM_WORDS = ("arm", "upperarm", "humerus", "uparm")


def words(name: str) -> tuple[str, str]:
    """(side, part) of a joint name: side "left", "right" or ""; part the rest in lower case without
    separators or rig prefixes. ``mixamorig:LeftUpLeg`` → ("left", "upleg"); ``CC_Base_L_Thigh`` →
    ("left", "thigh"); ``LHipJoint`` → ("left", "hipjoint"); ``rfemur`` → ("right", "femur")."""
    tokens: list[str] = []
    for chunk in re.split(r"[_\s.\-:]+", name.split(":")[-1]):
        tokens += re.findall(r"[A-Z]+(?=[A-Z][a-z])|[A-Z]?[a-z]+|[A-Z]+|\d+", chunk)
    low = [t.lower() for t in tokens]
    side = ""
    for i, t in enumerate(low):
        if t in ("left", "l", "right", "r"):
            side = "left" if t[0] == "l" else "right"
            del low[i]
            break
    while low and low[0] in _PREFIXES:
        low.pop(0)
    part = "".join(low)
    raw = _RAW_SIDE.match(part) if not side else None
    if raw:
        side, part = ("left" if raw.group(1) == "l" else "right"), raw.group(2)
    return side, part


@dataclass(frozen=True)
class JointMap:
    """What ``map_joints`` found: role → joint index, the rig it recognised, metres per unit, height."""

    roles: dict[str, int]
    rig: str
    unit: str  # "m", "cm", "in", "mm", or "scaled" for --height
    scale: float  # metres per file unit
    height_m: float  # the standing height of the rest pose, in metres
    how: str  # "detected", "--unit", "--height"

    def describe(self) -> str:
        return f"rig {self.rig}, unit {self.unit} ({self.how}), standing height {self.height_m:.2f} m"


def load_joint_map(path: Path) -> dict[str, str]:
    """A ``--joint-map`` TOML file: a ``[joints]`` table of role = "BVH joint name" (roles: ``ROLES``)."""
    try:
        data = load_toml(path, CONFIG_TOML, "joint map")
    except UntrustedInput as e:
        raise MotionFileError(str(e)) from None
    unknown = [k for k in data if k != "joints"]
    table = data.get("joints")
    if unknown or not isinstance(table, dict):
        raise MotionFileError(f"{path}: expected one [joints] table of role = \"joint name\"")
    bad = [k for k in table if k not in ROLES]
    if bad:
        raise MotionFileError(f"{path}: joints.{shorten(bad[0])}: not a role; expected one of {', '.join(ROLES)}")
    not_text = [k for k, v in table.items() if not isinstance(v, str)]
    if not_text:
        raise MotionFileError(f"{path}: joints.{not_text[0]}: expected a joint name in quotes")
    return {str(k): str(v) for k, v in table.items()}


def beside(bvh: Path) -> dict[str, str] | None:
    """The joint map of ``FILE.joints.toml`` beside ``FILE.bvh`` when there is one (used wherever a BVH is
    read without a ``--joint-map`` flag: clips, ragdoll skeletons), else None."""
    path = bvh.with_suffix(".joints.toml")
    return load_joint_map(path) if path.is_file() else None


def map_joints(motion: BvhMotion, explicit: dict[str, str] | None = None, *, unit: str | None = None,
               height: float | None = None, source: str = "bvh") -> JointMap:
    """Map ``motion``'s joints to ``ROLES`` (see the module docstring); MotionFileError lists every role
    that is missing or ambiguous at once, naming ``source``."""
    names = motion.names
    problems: list[str] = []
    roles: dict[str, int] = {}
    for role, joint in (explicit or {}).items():
        if joint in names:
            roles[role] = names.index(joint)
        else:
            problems.append(f"{role}: the joint map names {shorten(joint)}, which the file does not have")
    ws = [words(n) for n in names]
    rest = _rest(motion)
    size = float(np.ptp(rest, axis=0).max()) or 1.0
    joints = [b for b in range(len(names)) if not motion.is_end(b)]

    def up(b: int) -> int:
        """The next joint above ``b`` that is a bone of its own (not a twist, not where ``b`` is)."""
        p = motion.parents[b]
        while p >= 0 and motion.parents[p] >= 0 and (
                _SKIP.search(ws[p][1]) or np.linalg.norm(rest[b] - rest[p]) < 0.01 * size
                or _stem(ws[p]) == _stem(ws[motion.parents[p]])):  # a bone split in parts: take its first
            p = motion.parents[p]
        return p

    def by_name(side: str, options: tuple[str, ...], role: str) -> int | None:
        for option in options:
            hits = [b for b in joints if ws[b] == (side, option)]
            if len(hits) > 1:
                problems.append(f"{role}: ambiguous ({', '.join(names[b] for b in hits)})")
                return hits[0]
            if hits:
                return hits[0]
        return None

    for side in ("left", "right"):
        arm = [f"{side}_{r}" for r in ("hand", "forearm", "upper_arm")]
        leg = [f"{side}_{r}" for r in ("foot", "shin", "thigh")]
        for chain, tip_names in ((arm, ("wrist", "hand")), (leg, ("ankle", "foot"))):
            if chain[0] not in roles:
                found = by_name(side, tip_names, chain[0])
                if found is None:
                    problems.append(f"{chain[0]}: no joint named {side} {' or '.join(tip_names[:2])}")
                    continue
                roles[chain[0]] = found
            for below, role in zip(chain, chain[1:], strict=False):
                if role not in roles and below in roles and up(roles[below]) >= 0:
                    roles[role] = up(roles[below])
        if f"{side}_clavicle" not in roles and f"{side}_upper_arm" in roles:
            c = up(roles[f"{side}_upper_arm"])
            if c >= 0 and ws[c][0] == side:
                roles[f"{side}_clavicle"] = c
        if f"{side}_toe" not in roles and f"{side}_foot" in roles:
            f = roles[f"{side}_foot"]
            kids = [k for k in motion.children(f) if not _SKIP.search(ws[k][1]) or motion.is_end(k)]
            toes = [k for k in kids if ws[k][1].startswith("toe")] or kids
            if toes:
                roles[f"{side}_toe"] = toes[0]
            else:
                problems.append(f"{side}_toe: {names[f]} has no joint or end site below it")
        _check_arm(side, roles, names, ws, problems)
    if "head" not in roles:
        head = by_name("", ("head",), "head")
        if head is None:
            problems.append("head: no joint named head")
        else:
            roles["head"] = head
    _meeting(motion, roles, "hips", ("left_thigh", "right_thigh"), problems)
    _meeting(motion, roles, "chest", ("left_upper_arm", "right_upper_arm"), problems)
    if "neck" not in roles and "head" in roles and "chest" in roles:
        path = _path_down(motion, roles["chest"], roles["head"])
        if path is None:
            problems.append(f"neck: the head {names[roles['head']]} does not hang below the chest {names[roles['chest']]}")
        else:
            roles["neck"] = path[1] if len(path) > 1 else roles["head"]
    said = {p.split(":")[0] for p in problems}
    missing = [r for r in ROLES if r not in roles and r not in said and not r.endswith("clavicle")
               and not said & set(_found_from(r))]  # a role found from one already reported is not repeated
    problems += [f"{r}: not found" for r in missing]
    if problems:
        have = ", ".join(n for n in names if not n.endswith("_end"))
        raise MotionFileError(f"{source}: cannot map the joints ({'; '.join(problems)}); the file has {shorten(have, 600)}"
                              "; name them in a joint map: --joint-map MAP.toml, or FILE.joints.toml beside the BVH "
                              "(configs/joint_maps/README.md)")
    scale, unit_name, how, h = _units(motion, rest, roles, unit, height, source)
    return JointMap(roles, _rig(names), unit_name, scale, h, how)


def _found_from(role: str) -> tuple[str, ...]:
    """The roles ``role`` is found from (by walking the hierarchy)."""
    side, _, part = role.partition("_")
    if part in ("forearm", "upper_arm"):
        return (f"{side}_hand",)
    if part in ("shin", "thigh", "toe"):
        return (f"{side}_foot",)
    return {"hips": ("left_foot", "right_foot"), "chest": ("left_hand", "right_hand"),
            "neck": ("head", "left_hand", "right_hand")}.get(role, ())


def _stem(w: tuple[str, str]) -> tuple[str, str]:
    return w[0], w[1].rstrip("0123456789")


def _check_arm(side: str, roles: dict[str, int], names: tuple[str, ...], ws: list[tuple[str, str]],
               problems: list[str]) -> None:
    """An upper arm named clavicle/collar, or a clavicle named arm, is ambiguous: say so, never guess."""
    ua, cl = roles.get(f"{side}_upper_arm"), roles.get(f"{side}_clavicle")
    if ua is not None and any(w in ws[ua][1] for w in _CLAVICLE_WORDS):
        problems.append(f"{side}_upper_arm: {names[ua]} is named as a clavicle but is where the upper arm is")
    if cl is not None and ws[cl][1] in _ARM_WORDS:
        problems.append(f"{side}_clavicle: {names[cl]} is named as an upper arm but hangs above one")


def _meeting(motion: BvhMotion, roles: dict[str, int], role: str, pair: tuple[str, str], problems: list[str]) -> None:
    """``role`` := the lowest joint both ``pair`` joints hang from (where the legs or arms meet)."""
    if role in roles or not all(p in roles for p in pair):
        return
    chain_a = _ancestors(motion, roles[pair[0]])
    common = next((b for b in _ancestors(motion, roles[pair[1]]) if b in chain_a), None)
    if common is None:
        problems.append(f"{role}: {pair[0]} and {pair[1]} share no joint")
    else:
        roles[role] = common


def _ancestors(motion: BvhMotion, b: int) -> list[int]:
    out = []
    while b >= 0:
        b = motion.parents[b]
        if b >= 0:
            out.append(b)
    return out


def _path_down(motion: BvhMotion, top: int, b: int) -> list[int] | None:
    path = [b]
    while path[-1] != top:
        p = motion.parents[path[-1]]
        if p < 0:
            return None
        path.append(p)
    return path[::-1]


def _rest(motion: BvhMotion) -> np.ndarray:
    """Joint positions (B, 3) of the rest pose: the offsets alone, in file units."""
    rest = np.zeros((len(motion.names), 3))
    for b, p in enumerate(motion.parents):
        if p >= 0:
            rest[b] = rest[p] + motion.offsets[b]
    return rest


def _units(motion: BvhMotion, rest: np.ndarray, roles: dict[str, int], unit: str | None, height: float | None,
           source: str) -> tuple[float, str, str, float]:
    """(metres per unit, unit name, how it was chosen, standing height in metres)."""
    p = motion.positions
    up = p[:, roles["head"]] - p[:, roles["hips"]]
    up /= np.maximum(np.linalg.norm(up, axis=-1, keepdims=True), 1e-12)
    soles = [roles[f"{s}_{q}"] for s in ("left", "right") for q in ("foot", "toe")]
    tall = np.sum(p[:, roles["head"]] * up, axis=-1) - np.min(np.einsum("fjk,fk->fj", p[:, soles], up), axis=-1)
    raw = float(np.percentile(tall, 90)) / HEAD_SHARE  # the frames where the person stands tallest
    if raw <= 0:
        raise MotionFileError(f"{source}: the rest pose has no height (all joints at one place)")
    if height is not None:
        return height / raw, "scaled", "--height", height
    if unit is not None:
        if unit not in UNITS:
            raise MotionFileError(f"--unit: expected one of {', '.join(UNITS)}, got {shorten(unit)}")
        return UNITS[unit], unit, "--unit", raw * UNITS[unit]
    for name, k in UNITS.items():
        if 1.0 <= raw * k <= 2.5:
            return k, name, "detected", raw * k
    raise MotionFileError(f"{source}: cannot tell the unit (the rest pose stands {raw:.4g} file units tall, "
                          "1.0-2.5 m in none of m, cm, in, mm); give --unit or --height M")


def _rig(names: tuple[str, ...]) -> str:
    low = " ".join(names).lower()
    for mark, rig in (("mixamorig", "Mixamo"), ("cc_base_", "iClone"), ("leftcollar", "CMU ASF-style"),
                      ("leftupleg", "MotionBuilder/cgspeed"), ("right_hip", "DeepMimic"), ("lhumerus", "CMU ASF")):
        if mark in low:
            return rig
    return "unrecognised names (mapped by structure)"
