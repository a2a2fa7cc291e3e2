"""Reading and writing keyframe sets: a manifest (``keyframes.toml``) and pose files (TOML).

The manifest names the skeleton (``render.keyframes.skeletons``), the standing height (metres), the
default behaviour, the pose files (relative to it), the interpolation settings, any added dimensions
of Q and every animation with the coordinates of its keys; a pose file holds one table per pose in
the rigid body's frame with the skeleton's axes (x forward, y up, z right), metres (``pose_text``).
The format, with an example of each, is in ``configs/keyframes/humanoid/README.md``.

Every error is one line naming the file, the animation and key (or pose) and what was expected.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from render.keyframes.interp import STANDARD_AXES, Curve, Family, Space
from render.keyframes.pose_text import number, parse_pose
from render.keyframes.skeletons import SKELETONS
from sensors.untrusted import MissingInput, UntrustedInput, load_toml
from sensors.untrusted.limits import KEYFRAME_SET, POSE_FILE
from sim.motion.mocap import JOINTS, Skeleton

FORMAT = 1
_TOP_KEYS = {
    "format", "skeleton", "height", "default_behaviour", "poses", "interpolation", "dimensions", "animation"
}
_DIM_KEYS = {"scale", "min", "max", "periodic"}
_ANIM_KEYS = {"name", "behaviour", "family", "axis", "at", "keys"}


class KeyframeError(ValueError):
    """A keyframe set that cannot be used; the message is one line naming file, animation and key."""


@dataclass(frozen=True, eq=False)
class SetData:
    """Everything a keyframe set file holds, checked."""

    skeleton: Skeleton
    height: float
    default_behaviour: str
    cycle_weight: float
    sharpness: float
    space: Space
    families: dict[str, Family]
    key_names: tuple[str, ...]
    key_offsets: np.ndarray  # (K, 3)
    key_rotations: np.ndarray  # (K, 1 + J, 4): root, then JOINTS order


def _read_toml(path: Path, what: str) -> dict[str, Any]:
    """A manifest or pose file read within its limits (``sensors.untrusted``); KeyframeError if not."""
    limits = KEYFRAME_SET if what == "keyframe manifest" else POSE_FILE
    try:
        return load_toml(path, limits, what)
    except MissingInput:
        raise KeyframeError(f"{path}: no such {what}") from None
    except UntrustedInput as e:
        raise KeyframeError(str(e)) from None


def read_set(manifest: str | Path) -> SetData:
    """Read and check a keyframe set; raises KeyframeError with one line naming file, animation, key."""
    path = Path(manifest)
    doc = _read_toml(path, "keyframe manifest")

    def fail(msg: str) -> KeyframeError:
        return KeyframeError(f"{path}: {msg}")

    unknown = set(doc) - _TOP_KEYS
    if unknown:
        raise fail(f"{sorted(unknown)[0]}: unknown key; expected {', '.join(sorted(_TOP_KEYS))}")
    if doc.get("format") != FORMAT:
        raise fail(f"format: expected {FORMAT}, got {doc.get('format')!r}")
    skel_name = doc.get("skeleton")
    if skel_name not in SKELETONS:
        raise fail(f"skeleton: expected one of {', '.join(SKELETONS)}, got {skel_name!r}")
    height = number(doc.get("height"))
    if height is None or height <= 0:
        raise fail(f"height: expected metres > 0, got {doc.get('height')!r}")
    interp = doc.get("interpolation", {})
    if not isinstance(interp, dict) or set(interp) - {"cycle_weight", "sharpness"}:
        raise fail("interpolation: expected a table with only cycle_weight and sharpness")
    cycle_weight = number(interp.get("cycle_weight", 0.5))
    if cycle_weight is None or cycle_weight <= 0:
        raise fail(f"interpolation.cycle_weight: expected a number > 0, got {interp.get('cycle_weight')!r}")
    sharpness = number(interp.get("sharpness", 2.0))
    if sharpness is None or sharpness < 1:
        raise fail(f"interpolation.sharpness: expected a number >= 1, got {interp.get('sharpness')!r}")

    space = _dimensions(doc.get("dimensions", {}), Space.standard(cycle_weight), fail)

    # ---- pose files: raw tables by name, parsed when a key first uses them
    files = doc.get("poses")
    if not isinstance(files, list) or not files or not all(isinstance(f, str) for f in files):
        raise fail("poses: expected a list of pose file paths (relative to this file)")
    raw: dict[str, tuple[Path, Any]] = {}
    for rel in files:
        ppath = path.parent / rel
        for name, table in _read_toml(ppath, "pose file").items():
            if name in raw:
                raise KeyframeError(f"{ppath}: pose '{name}': defined twice (also in {raw[name][0]})")
            raw[name] = (ppath, table)
    names: list[str] = []
    offsets: list[np.ndarray] = []
    rotations: list[np.ndarray] = []
    index: dict[str, int] = {}

    def use_pose(name: str, where: str) -> int:
        if name not in index:
            ppath, table = raw[name]
            try:
                off, rot = parse_pose(table)
            except ValueError as e:
                raise KeyframeError(f"{ppath}: pose '{name}'{where}: {e}") from None
            index[name] = len(names)
            names.append(name)
            offsets.append(off)
            rotations.append(rot)
        return index[name]

    # ---- animations
    anims = doc.get("animation")
    if not isinstance(anims, list) or not anims:
        raise fail("animation: expected at least one [[animation]] table")
    curves: list[Curve] = []
    for i, a in enumerate(anims):
        curves.append(_read_animation(a, i, fail, raw, use_pose, space))
    seen: set[str] = set()
    for c in curves:
        if c.name in seen:
            raise fail(f"animation '{c.name}': name used twice")
        seen.add(c.name)
    for name in raw:  # poses no key uses are still checked
        use_pose(name, "")
    families = _families(curves, fail, space)
    behaviours = {f.behaviour for f in families.values()}
    default = doc.get("default_behaviour")
    if default not in behaviours:
        raise fail(f"default_behaviour: expected one of {', '.join(sorted(behaviours))}, got {default!r}")
    return SetData(
        skeleton=SKELETONS[skel_name],
        height=height,
        default_behaviour=default,
        cycle_weight=cycle_weight,
        sharpness=sharpness,
        space=space,
        families=families,
        key_names=tuple(names),
        key_offsets=np.array(offsets).reshape(-1, 3),
        key_rotations=np.array(rotations).reshape(-1, 1 + len(JOINTS), 4),
    )


def _dimensions(table: Any, space: Space, fail: Any) -> Space:
    if not isinstance(table, dict):
        raise fail("dimensions: expected tables like [dimensions.speed]")
    for name, d in table.items():
        where = f"dimensions.{name}"
        if name in STANDARD_AXES:
            raise fail(f"{where}: {name} is always a dimension; add only new ones")
        if not isinstance(d, dict) or set(d) - _DIM_KEYS:
            raise fail(f"{where}: expected a table with only {', '.join(sorted(_DIM_KEYS))}")
        periodic = d.get("periodic", False)
        if not isinstance(periodic, bool):
            raise fail(f"{where}.periodic: expected true or false, got {periodic!r}")
        scale = number(d.get("scale", 1.0))
        if scale is None or scale <= 0:
            raise fail(f"{where}.scale: expected a number > 0, got {d.get('scale')!r}")
        lo, hi = (0.0, 1.0) if periodic else (number(d.get("min", -math.inf)), number(d.get("max", math.inf)))
        if "min" in d and lo is None or "max" in d and hi is None:
            raise fail(f"{where}: min and max: expected finite numbers")
        lo = -math.inf if lo is None else lo
        hi = math.inf if hi is None else hi
        if not lo < hi:
            raise fail(f"{where}: expected min < max, got {lo} and {hi}")
        space = space.with_axis(name, periodic=periodic, scale=scale, lo=lo, hi=hi)
    return space


def _read_animation(
    a: Any, i: int, fail: Any, raw: dict[str, Any], use_pose: Any, space: Space
) -> Curve:
    if not isinstance(a, dict):
        raise fail(f"animation {i}: expected a table")
    name = a.get("name")
    if not isinstance(name, str) or not name:
        raise fail(f"animation {i}: name: expected a non-empty string")
    where = f"animation '{name}'"
    unknown = set(a) - _ANIM_KEYS
    if unknown:
        raise fail(f"{where}: {sorted(unknown)[0]}: unknown key; expected {', '.join(sorted(_ANIM_KEYS))}")
    behaviour = a.get("behaviour")
    if not isinstance(behaviour, str) or not behaviour:
        raise fail(f"{where}: behaviour: expected a non-empty string")
    family = a.get("family", name)
    if not isinstance(family, str) or not family:
        raise fail(f"{where}: family: expected a non-empty string")
    axes = space.axes
    axis_name = a.get("axis")
    if axis_name not in axes:
        raise fail(f"{where}: axis: expected one of {', '.join(axes)}, got {axis_name!r}")
    axis = axes.index(axis_name)
    at = a.get("at")
    others = [c for c in STANDARD_AXES if c != axis_name]
    extra = [c for c in axes[len(STANDARD_AXES) :] if c != axis_name]
    if not isinstance(at, dict) or not set(others) <= set(at) or set(at) - set(others) - set(extra):
        got = sorted(at) if isinstance(at, dict) else at
        more = f" (and optionally {', '.join(extra)})" if extra else ""
        raise fail(
            f'{where}: at: expected exactly {", ".join(others)}{more} (each a number or "any"), got {got!r}'
        )
    base: list[float | None] = [None] * len(axes)
    for c in others + [e for e in extra if e in at]:
        v = at[c]
        if v == "any":
            continue
        f = number(v)
        if f is None:
            raise fail(f'{where}: at.{c}: expected a finite number or "any", got {v!r}')
        k = axes.index(c)
        base[k] = f - math.floor(f) if space.periodic[k] else f
    keys = a.get("keys")
    if not isinstance(keys, list) or not keys:
        raise fail(f"{where}: keys: expected a list of {{ at = …, pose = … }} tables")
    coords: list[float] = []
    slots: list[int | str] = []
    for k, key in enumerate(keys):
        kw = f"{where} key {k}"
        if not isinstance(key, dict) or "at" not in key or len(set(key) & {"pose", "family"}) != 1:
            raise fail(
                f'{kw}: expected {{ at = number, pose = "name" }} or {{ at = number, family = "name" }}'
            )
        if set(key) - {"at", "pose", "family"}:
            raise fail(f"{kw}: {sorted(set(key) - {'at', 'pose', 'family'})[0]}: unknown key")
        x = number(key["at"])
        if x is None:
            raise fail(f"{kw}: at: expected a finite number, got {key['at']!r}")
        if space.periodic[axis] and not 0.0 <= x < 1.0:
            raise fail(f"{kw}: at: {axis_name} is periodic; expected 0 <= at < 1, got {x}")
        kw = f"{kw} at {axis_name}={x:g}"
        if x in coords:
            raise fail(f"{kw}: duplicate coordinate (key {coords.index(x)} is there too)")
        if "pose" in key:
            pose = key["pose"]
            if not isinstance(pose, str) or pose not in raw:
                raise fail(f"{kw}: pose: no pose named {pose!r} in the pose files")
            slots.append(use_pose(pose, f" ({kw})"))
        else:
            ref = key["family"]
            if not isinstance(ref, str):
                raise fail(f"{kw}: family: expected a family name")
            slots.append(ref)
        coords.append(x)
    order = np.argsort(coords, kind="stable")
    return Curve(
        name=name,
        behaviour=behaviour,
        family=family,
        axis=axis,
        base=tuple(base),
        coords=np.array(coords, dtype=float)[order],
        keys=tuple(slots[j] for j in order),
    )


def _families(curves: list[Curve], fail: Any, space: Space) -> dict[str, Family]:
    groups: dict[str, list[Curve]] = {}
    for c in curves:
        groups.setdefault(c.family, []).append(c)
    out: dict[str, Family] = {}
    for name, members in groups.items():
        first = members[0]
        for m in members[1:]:
            if m.behaviour != first.behaviour or m.axis != first.axis:
                raise fail(
                    f"animation '{m.name}': family '{name}': its members must share behaviour and axis "
                    f"(as '{first.name}': {first.behaviour}, {space.axes[first.axis]})"
                )
        loft: int | None = None
        if len(members) > 1:
            differ = {c for m in members for c in range(space.dims) if m.base[c] != first.base[c]}
            if len(differ) != 1 or any(m.base[next(iter(differ))] is None for m in members):
                raise fail(
                    f"family '{name}': its animations must differ in exactly one coordinate, a number in all"
                )
            loft = next(iter(differ))
            values = [m.base[loft] for m in members]
            if len(set(values)) != len(values):
                raise fail(f"family '{name}': two animations at the same {space.axes[loft]}")
            members = sorted(members, key=lambda m: m.base[loft])  # type: ignore[arg-type, return-value]
        refs = frozenset(k for m in members for k in m.keys if isinstance(k, str))
        out[name] = Family(name, first.behaviour, tuple(members), loft, refs)
    for fam in out.values():
        for ref in sorted(fam.refs):
            if ref not in out:
                raise fail(
                    f"family '{fam.name}': a key refers to family '{ref}', which the set does not have"
                )
            if out[ref].refs:
                raise fail(f"family '{fam.name}': refers to family '{ref}', which itself refers to others")
    return out
