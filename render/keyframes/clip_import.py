"""``jostle keyframes import``: turn what animators make into animations of a keyframe set.

- DeepMimic motion JSON (pybullet_data's clips) and BVH: one file is one animation; the caller says
  where it lies in Q (behaviour, axis, the other coordinates) and which frames become keys at which
  coordinates (``--keys N`` evenly spaced over the clip; along Dx/Dz at k/N, along Θ evenly over
  ``--range``; or ``--frames`` with ``--coords``);
- glTF 2.0: every animation that carries ``extras.jostle`` (written by ``jostle keyframes export``, or
  by hand in Blender's custom properties) — see ``render.keyframes.gltf_io``.

Each key is placed in its rigid body's frame: the body tilted by the key's Θ (when the animation runs
along Θ) and turned to the clip's heading, the skeleton's centre of mass at the body origin. The poses
go to ``poses/<animation>.toml`` in the set's folder and the animation is appended to its manifest
(made when the folder has none), as one transaction (``render.keyframes.set_staging``).
"""

from __future__ import annotations

import json
import math
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from render.keyframes.pose_text import format_pose
from render.keyframes.set_file import FORMAT, KeyframeError
from render.keyframes.set_staging import MANIFEST, StagedSet, checked_name, commit
from render.keyframes.skeleton_pose import X, in_body_frame, standing_height, tilt_rotation, yaw_rotation
from render.keyframes.skeletons import FIGURES, Figure
from sensors.untrusted import UntrustedInput, one_line, parse_toml, shorten
from sensors.untrusted.limits import KEYFRAME_SET
from sim.motion import quaternion as quat
from sim.motion.mocap import MotionClip

Posed = tuple[np.ndarray, np.ndarray]


@dataclass(frozen=True)
class Placement:
    """Where an imported animation lies in Q."""

    name: str
    behaviour: str
    axis: str  # theta_x | theta_z | dx | dz | an added dimension
    at: dict[str, float | str]  # the other coordinates: number or "any"
    family: str = ""


@dataclass(frozen=True)
class BvhOptions:
    """How to read a BVH file's joints and size: a ``--joint-map`` file's roles, ``--unit``, ``--height``."""

    joints: dict[str, str] | None = None
    unit: str | None = None
    height: float | None = None


def load_clip(path: Path, figure: Figure, bvh: BvhOptions | None = None) -> tuple[MotionClip, str]:
    """A DeepMimic JSON clip (``.txt``/``.json``) or a BVH file (``.bvh``), on ``figure``'s skeleton, and
    what was recognised (for a BVH: the rig, unit and standing height; "" for DeepMimic)."""
    if path.suffix.lower() == ".bvh":
        from render.keyframes.bvh import bvh_to_clip, read_bvh
        from sim.motion.joint_map import beside, map_joints

        o = bvh or BvhOptions()
        motion = read_bvh(path)
        joints = o.joints if o.joints is not None else beside(path)
        jm = map_joints(motion, joints, unit=o.unit, height=o.height, source=str(path))
        return bvh_to_clip(motion, figure, path.stem, jm), jm.describe()
    return MotionClip.load(path), ""


def key_times(clip: MotionClip, keys: int | None, frames: list[int] | None) -> list[float]:
    if frames is not None:
        bad = [f for f in frames if not 0 <= f < len(clip.times)]
        if bad:
            raise KeyframeError(f"frames: {bad[0]} is not a frame of the clip (it has {len(clip.times)})")
        return [float(clip.times[f]) for f in frames]
    n = keys or 8
    if clip.loop:
        return [clip.duration * k / n for k in range(n)]
    return [clip.duration * k / max(n - 1, 1) for k in range(n)]


def key_coords(axis: str, periodic: bool, count: int, coords: list[float] | None,
               span: tuple[float, float] | None) -> list[float]:
    if coords is not None:
        if len(coords) != count:
            raise KeyframeError(f"coords: expected {count} coordinates (one per key), got {len(coords)}")
        return coords
    if periodic:
        return [k / count for k in range(count)]
    if span is None:
        raise KeyframeError(f"range: an animation along {axis} needs --range LO HI (or --coords)")
    return list(np.linspace(span[0], span[1], count))


def clip_poses(clip: MotionClip, times: list[float], placement: Placement, coords: list[float],
               figure: Figure) -> list[Posed]:
    """Each sampled frame in the body frame at its coordinate (tilted along Θ), mean heading removed."""
    samples = [clip.sample(t) for t in times]
    fwd = np.array([quat.rotate(r, X) for _, r, _ in samples])
    heading = math.atan2(-float(fwd[:, 2].mean()), float(fwd[:, 0].mean()))
    out = []
    for (_, root_rot, joint_rots), x in zip(samples, coords, strict=True):
        tx = x if placement.axis == "theta_x" else _number(placement.at.get("theta_x"))
        tz = x if placement.axis == "theta_z" else _number(placement.at.get("theta_z"))
        body = quat.multiply(yaw_rotation(heading), tilt_rotation(tx, tz))
        off, rr = in_body_frame(body, root_rot, joint_rots, figure)
        out.append((off, np.concatenate([rr[None], joint_rots], axis=0)))
    return out


def _number(v: float | str | None) -> float:
    return float(v) if isinstance(v, int | float) else 0.0


# ------------------------------------------------------------------------------ writing into a set


def _value(v: float | str) -> str:
    return _string(v) if isinstance(v, str) else repr(float(v))


def _string(v: str) -> str:
    """``v`` as a TOML basic string (JSON's escapes are TOML's: quotes, backslashes, controls)."""
    return json.dumps(v)


def animation_text(p: Placement, keys: list[tuple[float, str, str]]) -> str:
    """An [[animation]] table; keys are (coordinate, pose name or "", referenced family or "")."""
    lines = ["", "[[animation]]", f"name = {_string(p.name)}", f"behaviour = {_string(p.behaviour)}"]
    if p.family:
        lines.append(f"family = {_string(p.family)}")
    lines.append(f"axis = {_string(p.axis)}")
    lines.append("at = { " + ", ".join(f"{_string(k)} = {_value(v)}" for k, v in p.at.items()) + " }")
    lines.append("keys = [")
    for x, pose, fam in sorted(keys):
        lines.append(f"  {{ at = {x!r}, " + (f"family = {_string(fam)}" if fam else f"pose = {_string(pose)}") + " },")
    lines.append("]")
    return "\n".join(lines) + "\n"


def add_animation(staged: StagedSet, placement: Placement, keys: list[tuple[float, str, str]],
                  poses: dict[str, Posed], source: str, skeleton: str = "humanoid") -> None:
    """Stage the poses as ``poses/<name>.toml`` and the animation appended to the set's manifest (made
    if missing). Nothing is written until ``staged.commit()``, which checks the whole set first."""
    checked_name(placement.name, "name")
    for name in poses:
        checked_name(name, f"animation '{placement.name}': pose")
    rel = f"poses/{placement.name}.toml"
    before = staged.text(MANIFEST)
    known = _pose_names(staged, before) if before is not None else set()
    text = f"# Imported from {one_line(source, 200)} by `jostle keyframes import`.\n\n" + "\n".join(
        format_pose(name, off, rots) for name, (off, rots) in poses.items() if name not in known
    )
    if before is None:
        if skeleton not in FIGURES:
            raise KeyframeError(f"skeleton: expected one of {', '.join(FIGURES)}, got {shorten(skeleton)}")
        head = (f'format = {FORMAT}\nskeleton = "{skeleton}"\nheight = {standing_height(FIGURES[skeleton]):.4f}\n'
                f'default_behaviour = {_string(placement.behaviour)}\nposes = ["{rel}"]\n')
        after = "# Made by `jostle keyframes import`; see configs/keyframes/humanoid/README.md for the format.\n" + head
    else:
        listed = re.search(r"^poses\s*=\s*\[(.*?)\]", before, flags=re.M | re.S)
        if listed is None:
            raise KeyframeError(f"{staged.manifest}: poses: expected a list of pose files to add {rel} to")
        if f'"{rel}"' in listed.group(1) or rel in staged.changed:
            raise KeyframeError(f"{staged.manifest}: already has {rel}; pick another --name")
        inner = listed.group(1).rstrip().rstrip(",")
        after = before[: listed.start(1)] + (inner + ", " if inner.strip() else "") + f'"{rel}"' + before[listed.end(1):]
    staged.write(rel, text)
    staged.write(MANIFEST, after.rstrip("\n") + "\n" + animation_text(placement, keys))


def _pose_names(staged: StagedSet, manifest_text: str) -> set[str]:
    """Names of the poses the set's pose files already define (a key naming one reuses it)."""
    try:
        files = parse_toml(manifest_text, staged.manifest, KEYFRAME_SET).get("poses", [])
    except UntrustedInput:
        return set()
    names: set[str] = set()
    for rel in files if isinstance(files, list) else []:
        names |= staged.pose_names(str(rel))
    return names


def import_clip(source: Path, set_dir: Path, placement: Placement, *, keys: int | None = None,
                frames: list[int] | None = None, coords: list[float] | None = None,
                span: tuple[float, float] | None = None, bvh: BvhOptions | None = None) -> tuple[Path, str]:
    """Import a DeepMimic or BVH clip as one animation of the set in ``set_dir``; returns the manifest and
    what was recognised in the file (``load_clip``)."""
    staged = StagedSet(set_dir)
    skeleton = "humanoid"
    manifest_text = staged.text(MANIFEST)
    if manifest_text is not None:
        m = re.search(r'^skeleton\s*=\s*"([^"]+)"', manifest_text, flags=re.M)
        skeleton = m.group(1) if m else skeleton
    figure = FIGURES.get(skeleton, FIGURES["humanoid"])
    clip, recognised = load_clip(source, figure, bvh)  # DeepMimic joints drive any of our skeletons: same joints and axes
    times = key_times(clip, keys, frames)
    periodic = placement.axis in ("dx", "dz")
    xs = key_coords(placement.axis, periodic, len(times), coords, span)
    posed = clip_poses(clip, times, placement, xs, figure)
    names = [f"{placement.name}_{k:02d}" for k in range(len(posed))]
    entries = [(float(x), n, "") for x, n in zip(xs, names, strict=True)]
    add_animation(staged, placement, entries, dict(zip(names, posed, strict=True)), source.name, skeleton)
    return commit(staged, source), recognised
