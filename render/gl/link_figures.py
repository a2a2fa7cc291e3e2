"""Drawing characters that carry their own links (``CharacterSnapshot.links``: quadrupeds, articulated
figures) as capsules between their link frames, in the renderer's one instanced capsule draw.

A :class:`LinkFigure` says which capsules a kind of character is made of. Each capsule end is a
weighted sum of link origins (weights summing to 1: a joint, the middle of two joints, or a point
beyond them, e.g. a head ahead of the shoulders), so a figure needs only the links' positions, never
their frames' axes (which depend on how each model file was written). Capsules whose links a
snapshot lacks are left out. A kind with no figure here (or none of whose capsules can be made) is
drawn as a stick figure: each link joined to the nearest link listed before it (models list parents
before children), so anything with links is drawn somehow.

Colours: ``body``/``head`` parts take the character's colour (the same golden-ratio hue as a keyframe
figure's shirt), ``limb`` a darker shade of it, ``foot`` the shoes colour. Glow while pushed, as the
keyframe figures.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from render.gl.scene import CAPSULE_FLOATS, character_colours
from render.gl.style import Colours, rgb
from sim.snapshot import CharacterSnapshot

__all__ = ["LINK_FIGURES", "LinkCapsule", "LinkFigure", "figure_part", "link_capsules", "link_instances"]

End = tuple[tuple[str, float], ...]  # (link name, weight), weights summing to 1


@dataclass(frozen=True)
class LinkCapsule:
    a: End
    b: End
    radius: float  # metres
    part: str = "limb"  # "body", "head", "limb" or "foot" (its colour)


@dataclass(frozen=True)
class LinkFigure:
    capsules: tuple[LinkCapsule, ...]
    stick_radius: float = 0.03  # the stick figure's capsules, for links the capsules do not name
    # two links and their distance in the model as the radii were chosen for: a body loaded at another
    # scale gets its capsules' radii scaled alike
    reference: tuple[str, str, float] | None = None


def _joint(name: str) -> End:
    return ((name, 1.0),)


def _quadruped(prefix_hip: str = "_hip_motor", upper: str = "_upper_leg", lower: str = "_lower_leg") -> LinkFigure:
    """Four legs (hip, thigh, shin) under a body from the front hips to the rear hips, and a head ahead
    of it (pybullet's laikago link names: FR_hip_motor, FR_upper_leg, FR_lower_leg, toeFR, …)."""
    front = (("FR" + prefix_hip, 0.5), ("FL" + prefix_hip, 0.5))
    rear = (("RR" + prefix_hip, 0.5), ("RL" + prefix_hip, 0.5))

    def along(k: float) -> End:  # front + k·(front − rear)
        return tuple((n, (1 + k) * w) for n, w in front) + tuple((n, -k * w) for n, w in rear)

    caps = [LinkCapsule(along(-0.05), tuple((n, w) for n, w in rear), 0.075, "body"),
            LinkCapsule(along(0.15), along(0.3), 0.055, "head")]
    for leg in ("FR", "FL", "RR", "RL"):
        caps += [LinkCapsule(_joint(leg + prefix_hip), _joint(leg + upper), 0.035, "body"),
                 LinkCapsule(_joint(leg + upper), _joint(leg + lower), 0.026, "limb"),
                 LinkCapsule(_joint(leg + lower), _joint("toe" + leg), 0.018, "limb"),
                 LinkCapsule(_joint("toe" + leg), _joint("toe" + leg), 0.022, "foot")]
    return LinkFigure(tuple(caps), reference=("FR" + prefix_hip, "RR" + prefix_hip, 0.437))


LINK_FIGURES: dict[str, LinkFigure] = {"quadruped": _quadruped()}


def _end(end: End, where: Mapping[str, np.ndarray]) -> np.ndarray | None:
    if not all(name in where for name, _ in end):
        return None
    return np.asarray(sum(w * where[name] for name, w in end), dtype=float)


def _stick(names: Sequence[str], pos: np.ndarray, radius: float) -> list[tuple[np.ndarray, np.ndarray, float, str]]:
    out = []
    for i in range(len(names)):
        if i == 0:
            out.append((pos[0], pos[0], 1.6 * radius, "body"))
            continue
        j = int(np.argmin(np.linalg.norm(pos[:i] - pos[i], axis=1)))
        out.append((pos[j], pos[i], radius, "limb"))
    return out


def link_capsules(c: CharacterSnapshot, figures: Mapping[str, LinkFigure] = LINK_FIGURES
                  ) -> list[tuple[np.ndarray, np.ndarray, float, str]]:
    """One character's capsules (a, b, radius, part) in stage metres, from its links."""
    names = [lp.name for lp in c.links]
    pos = np.array([lp.position for lp in c.links], dtype=float).reshape(-1, 3)
    where = dict(zip(names, pos, strict=True))
    figure = figures.get(c.kind) or figures.get(c.name)
    out: list[tuple[np.ndarray, np.ndarray, float, str]] = []
    if figure is not None:
        scale = 1.0
        if figure.reference is not None and figure.reference[0] in where and figure.reference[1] in where:
            ref = figure.reference
            scale = float(np.linalg.norm(where[ref[0]] - where[ref[1]])) / ref[2]
        for cap in figure.capsules:
            a, b = _end(cap.a, where), _end(cap.b, where)
            if a is not None and b is not None:
                out.append((a, b, cap.radius * scale, cap.part))
    if not out and len(pos):
        out = _stick(names, pos, figure.stick_radius if figure else 0.03)
    return out


def link_instances(chars: Sequence[CharacterSnapshot], index: Sequence[int], total: int, colours: Colours,
                   flash_newtons: float, figures: Mapping[str, LinkFigure] = LINK_FIGURES) -> np.ndarray:
    """Capsule instances (M, CAPSULE_FLOATS) of the characters ``chars`` (at positions ``index`` among the
    snapshot's ``total`` characters, which picks their colours)."""
    palette = character_colours(max(total, 1))
    shoes = rgb("shoes", colours.shoes)
    rows: list[list[float]] = []
    for c, i in zip(chars, index, strict=True):
        base = palette[i]
        glow = min(1.0, 0.35 + c.contact_force_n / flash_newtons) if c.contact_force_n > 0 else 0.0
        tint = {"body": base, "head": base, "limb": 0.6 * base, "foot": np.asarray(shoes)}
        for a, b, r, part in link_capsules(c, figures):
            rows.append([*a, *b, r, *tint.get(part, base), 1.0, glow])
    return np.array(rows, dtype=float).reshape(-1, CAPSULE_FLOATS)


Part = tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]  # sel, a, b, r, rgba+glow


def figure_part(chars: Sequence[CharacterSnapshot], sel: np.ndarray, colours: Colours, flash_newtons: float,
                figures: Mapping[str, LinkFigure] = LINK_FIGURES) -> Part:
    """The renderer's per-figure arrays for characters drawn from their links: ``sel`` (their places in
    the snapshot), capsule ends a, b (k, C, 3), radii (k, C) and colours (k, C, 5), C the most capsules
    any of them has (figures with fewer repeat their first capsule, which draws nothing new)."""
    sel = np.asarray(sel, dtype=int)
    total = int(sel.max()) + 1 if len(sel) else 1
    rows = [link_instances([c], [int(i)], total, colours, flash_newtons, figures) for c, i in zip(chars, sel, strict=True)]
    per = max((len(r) for r in rows), default=0)
    out = np.zeros((len(rows), max(per, 1), CAPSULE_FLOATS))
    for k, r in enumerate(rows):
        if len(r):
            out[k] = np.concatenate([r, np.repeat(r[:1], per - len(r), axis=0)])
    return sel, out[..., 0:3], out[..., 3:6], out[..., 6], out[..., 7:12]
