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
(made when the folder has none).
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from render.keyframes.pose_text import format_pose
from render.keyframes.set_file import FORMAT, KeyframeError
from render.keyframes.skeleton_pose import X, in_body_frame, standing_height, tilt_rotation, yaw_rotation
from render.keyframes.skeletons import FIGURES, Figure
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


def load_clip(path: Path, figure: Figure) -> MotionClip:
    """A DeepMimic JSON clip (``.txt``/``.json``) or a BVH file (``.bvh``), on ``figure``'s skeleton."""
    if path.suffix.lower() == ".bvh":
        from render.keyframes.bvh import bvh_to_clip, read_bvh

        return bvh_to_clip(read_bvh(path), figure, path.stem)
    return MotionClip.load(path)


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
    return f'"{v}"' if isinstance(v, str) else repr(float(v))


def animation_text(p: Placement, keys: list[tuple[float, str, str]]) -> str:
    """An [[animation]] table; keys are (coordinate, pose name or "", referenced family or "")."""
    lines = ["", "[[animation]]", f'name = "{p.name}"', f'behaviour = "{p.behaviour}"']
    if p.family:
        lines.append(f'family = "{p.family}"')
    lines.append(f'axis = "{p.axis}"')
    lines.append("at = { " + ", ".join(f"{k} = {_value(v)}" for k, v in p.at.items()) + " }")
    lines.append("keys = [")
    for x, pose, fam in sorted(keys):
        lines.append(f"  {{ at = {x!r}, " + (f'family = "{fam}"' if fam else f'pose = "{pose}"') + " },")
    lines.append("]")
    return "\n".join(lines) + "\n"


def add_animation(set_dir: Path, placement: Placement, keys: list[tuple[float, str, str]],
                  poses: dict[str, Posed], source: str, skeleton: str = "humanoid", *, check: bool = True) -> Path:
    """Write the poses to ``poses/<name>.toml`` and append the animation to the set's manifest (made if
    missing); returns the manifest. With ``check`` the set is loaded afterwards; on failure the manifest
    is left as it was."""
    set_dir.mkdir(parents=True, exist_ok=True)
    (set_dir / "poses").mkdir(exist_ok=True)
    manifest = set_dir / "keyframes.toml"
    rel = f"poses/{placement.name}.toml"
    before = manifest.read_text(encoding="utf-8") if manifest.exists() else None
    known = _pose_names(set_dir, before) if before is not None else set()
    text = f"# Imported from {source} by `jostle keyframes import`.\n\n" + "\n".join(
        format_pose(name, off, rots) for name, (off, rots) in poses.items() if name not in known
    )
    if before is None:
        if skeleton not in FIGURES:
            raise KeyframeError(f"skeleton: expected one of {', '.join(FIGURES)}, got {skeleton!r}")
        head = (f'format = {FORMAT}\nskeleton = "{skeleton}"\nheight = {standing_height(FIGURES[skeleton]):.4f}\n'
                f'default_behaviour = "{placement.behaviour}"\nposes = ["{rel}"]\n')
        after = "# Made by `jostle keyframes import`; see configs/keyframes/humanoid/README.md for the format.\n" + head
    else:
        listed = re.search(r"^poses\s*=\s*\[(.*?)\]", before, flags=re.M | re.S)
        if listed is None:
            raise KeyframeError(f"{manifest}: poses: expected a list of pose files to add {rel} to")
        if f'"{rel}"' in listed.group(1):
            raise KeyframeError(f"{manifest}: already has {rel}; pick another --name")
        inner = listed.group(1).rstrip().rstrip(",")
        after = before[: listed.start(1)] + (inner + ", " if inner.strip() else "") + f'"{rel}"' + before[listed.end(1):]
    pose_file = set_dir / rel
    pose_file.write_text(text, encoding="utf-8")
    manifest.write_text(after.rstrip("\n") + "\n" + animation_text(placement, keys), encoding="utf-8")
    if not check:
        return manifest
    try:
        from render.keyframes.keyframe_set import KeyframeSet

        KeyframeSet.load(manifest)
    except KeyframeError:
        if before is None:
            manifest.unlink()
        else:
            manifest.write_text(before, encoding="utf-8")
        pose_file.unlink()
        raise
    return manifest


def _pose_names(set_dir: Path, manifest_text: str) -> set[str]:
    """Names of the poses the set's pose files already define (a key naming one reuses it)."""
    import tomllib

    try:
        files = tomllib.loads(manifest_text).get("poses", [])
    except tomllib.TOMLDecodeError:
        return set()
    names: set[str] = set()
    for rel in files if isinstance(files, list) else []:
        try:
            names |= set(tomllib.loads((set_dir / str(rel)).read_text(encoding="utf-8")))
        except (OSError, tomllib.TOMLDecodeError):
            continue
    return names


def import_clip(source: Path, set_dir: Path, placement: Placement, *, keys: int | None = None,
                frames: list[int] | None = None, coords: list[float] | None = None,
                span: tuple[float, float] | None = None) -> Path:
    """Import a DeepMimic or BVH clip as one animation of the set in ``set_dir``; returns the manifest."""
    manifest = set_dir / "keyframes.toml"
    skeleton = "humanoid"
    if manifest.exists():
        m = re.search(r'^skeleton\s*=\s*"([^"]+)"', manifest.read_text(encoding="utf-8"), flags=re.M)
        skeleton = m.group(1) if m else skeleton
    figure = FIGURES.get(skeleton, FIGURES["humanoid"])
    clip = load_clip(source, figure)  # DeepMimic joints drive any of our skeletons: same joints and axes
    times = key_times(clip, keys, frames)
    periodic = placement.axis in ("dx", "dz")
    xs = key_coords(placement.axis, periodic, len(times), coords, span)
    posed = clip_poses(clip, times, placement, xs, figure)
    names = [f"{placement.name}_{k:02d}" for k in range(len(posed))]
    entries = [(float(x), n, "") for x, n in zip(xs, names, strict=True)]
    return add_animation(set_dir, placement, entries, dict(zip(names, posed, strict=True)), source.name, skeleton)
