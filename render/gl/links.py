"""Characters drawn from their own links (``CharacterSnapshot.links``) in the renderer's capsule pipeline.

Two kinds of drawing, chosen per character by its link names:

- an articulated body whose skeleton is known (``sim.articulated.skeleton.ArticulatedSkeleton``: the
  DeepMimic humanoid, or one registered with ``register_link_skeleton``, e.g. a body built from a BVH)
  is drawn with one impostor capsule per link exactly where the sim's collision shape of that link is,
  from the link's frame (a sphere is a capsule of zero length; a box the capsule along its longest side,
  as thick as its middle side); materials by body part: shirt, trousers, skin, shoes;
- anything else with links (quadrupeds, unknown skeletons) goes to ``render.gl.link_figures``
  (capsules between link origins by kind, or a stick figure).

Shirt colours are by the character's place in the snapshot, as for keyframe figures.
"""

from __future__ import annotations

import functools
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from render.gl.link_figures import Part, figure_part
from render.gl.scene import character_colours, figure_colours
from render.gl.style import Colours
from render.keyframes.skeletons import SHIRT, SHOES, SKIN, TROUSERS
from sim.articulated.bvh_body import body_part
from sim.articulated.skeleton import ArticulatedSkeleton
from sim.motion import quaternion as quat
from sim.snapshot import CharacterSnapshot

__all__ = ["LinkFigure", "articulated_part", "link_capsules", "link_figure", "link_figure_for", "merge_parts",
           "register_link_skeleton"]

_MATERIAL = {"hip": TROUSERS, "upper_leg": TROUSERS, "lower_leg": TROUSERS, "foot": SHOES, "toe": SHOES,
             "head": SKIN, "neck": SKIN, "hand": SKIN, "lower_arm": SKIN}


@dataclass(frozen=True, eq=False)
class LinkFigure:
    """Capsules on a skeleton's links: the link whose frame each is in, its two ends in that frame (metres),
    its radius and its material. The first L capsules are the L links' own shapes."""

    names: tuple[str, ...]
    link: np.ndarray  # (C,) link index
    a: np.ndarray  # (C, 3)
    b: np.ndarray  # (C, 3)
    radii: np.ndarray  # (C,)
    material: np.ndarray  # (C,) SHIRT, TROUSERS, SKIN or SHOES


def link_figure(skeleton: ArticulatedSkeleton) -> LinkFigure:
    """The capsules of a skeleton's collision shapes, in each link's frame, and a bridge from a link's shape
    to each child joint that lies outside it (the DeepMimic chest is a ball: its shoulders would float)."""
    a, b, r, m = [], [], [], []
    for link in skeleton.links:
        centre = np.array(link.shape_offset, dtype=float)
        turn = np.array(link.shape_rotation, dtype=float)
        if link.shape == "sphere":
            half, radius = np.zeros(3), link.size[0]
        elif link.shape == "capsule":
            half, radius = quat.rotate(turn, np.array([0.0, 0.0, link.size[1] / 2.0])), link.size[0]
        else:  # box: along its longest half extent, as thick as its middle one
            ext = np.array(link.size[:3], dtype=float)
            k = int(np.argmax(ext))
            radius = float(np.sort(ext)[1])
            axis = np.zeros(3)
            axis[k] = max(ext[k] - radius, 0.0)
            half = quat.rotate(turn, axis)
        a.append(centre - half)
        b.append(centre + half)
        r.append(radius)
        m.append(_MATERIAL.get(body_part(link.name, link.parent < 0), SHIRT))
    owner = list(range(len(skeleton.links)))
    for c, child in enumerate(skeleton.links):
        i = child.parent
        if i < 0:
            continue
        joint = np.array(child.joint_offset, dtype=float)
        seg = b[i] - a[i]
        t = float(np.clip(np.dot(joint - a[i], seg) / max(float(np.dot(seg, seg)), 1e-12), 0.0, 1.0))
        near = a[i] + t * seg
        if np.linalg.norm(joint - near) > 1.05 * r[i]:
            owner.append(i)
            a.append(near)
            b.append(joint)
            r.append(min(r[i], r[c]))
            m.append(m[i])
    return LinkFigure(skeleton.names, np.array(owner), np.array(a), np.array(b), np.array(r, dtype=float),
                      np.array(m, dtype=int))


_REGISTERED: dict[tuple[str, ...], LinkFigure] = {}


def register_link_skeleton(skeleton: ArticulatedSkeleton) -> LinkFigure:
    """Draw characters whose links are named as this skeleton's with its shapes; returns the figure."""
    figure = link_figure(skeleton)
    _REGISTERED[figure.names] = figure
    return figure


@functools.cache
def _default_figures() -> dict[tuple[str, ...], LinkFigure]:
    from sim.articulated.skeleton import deepmimic_humanoid

    figure = link_figure(deepmimic_humanoid())
    return {figure.names: figure}


def link_figure_for(names: tuple[str, ...]) -> LinkFigure | None:
    """The skeleton figure for links with these names (registered ones first, then the DeepMimic humanoid)."""
    return _REGISTERED.get(names) or _default_figures().get(names)


def link_capsules(chars: Sequence[CharacterSnapshot]) -> tuple[np.ndarray, np.ndarray, np.ndarray, list[LinkFigure]]:
    """Capsule ends a, b (N, C, 3) and radii (N, C) in stage metres for characters of known skeletons,
    and their figures; C is the most capsules (smaller figures repeat their first capsule)."""
    figures = []
    for c in chars:
        f = link_figure_for(tuple(link.name for link in c.links))
        if f is None:
            raise KeyError(f"render: no skeleton figure for the links of {c.name!r}")
        figures.append(f)
    width = max((len(f.radii) for f in figures), default=0)
    n = len(chars)
    a, b, r = np.zeros((n, width, 3)), np.zeros((n, width, 3)), np.zeros((n, width))
    for i, (c, f) in enumerate(zip(chars, figures, strict=True)):
        pos = np.array([link.position for link in c.links], dtype=float)[f.link]
        orn = np.array([link.orientation for link in c.links], dtype=float)[f.link]
        count = len(f.radii)
        a[i, :count] = pos + quat.rotate(orn, f.a)
        b[i, :count] = pos + quat.rotate(orn, f.b)
        r[i, :count] = f.radii
        a[i, count:], b[i, count:], r[i, count:] = a[i, :1], b[i, :1], r[i, :1]
    return a, b, r, figures


def _skeleton_part(chars: Sequence[CharacterSnapshot], sel: np.ndarray, colours: Colours,
                   flash_newtons: float) -> Part:
    a, b, r, figures = link_capsules(chars)
    width = a.shape[1]
    out = np.zeros((len(chars), width, 5))
    shirts = character_colours(int(sel.max()) + 1)
    for i, (c, f) in enumerate(zip(chars, figures, strict=True)):
        material = np.concatenate([f.material, np.repeat(f.material[:1], width - len(f.material))])
        out[i] = figure_colours([c], material, colours, flash_newtons)[0]
        out[i, material == SHIRT, :3] = shirts[sel[i]]
    return sel, a, b, r, out


def articulated_part(chars: Sequence[CharacterSnapshot], sel: np.ndarray, colours: Colours,
                     flash_newtons: float) -> Part:
    """(sel, a, b, r, colours) for the characters ``chars`` (all with links; ``sel`` their places in the
    snapshot): known skeletons capsule per link, the rest through ``render.gl.link_figures``."""
    sel = np.asarray(sel, dtype=int)
    known = np.array([link_figure_for(tuple(lk.name for lk in c.links)) is not None for c in chars], dtype=bool)
    parts = []
    if known.any():
        parts.append(_skeleton_part([c for c, k in zip(chars, known, strict=True) if k], sel[known], colours,
                                    flash_newtons))
    if not known.all():
        parts.append(figure_part([c for c, k in zip(chars, known, strict=True) if not k], sel[~known], colours,
                                 flash_newtons))
    if len(parts) == 1:
        return parts[0]
    per = max(part[1].shape[1] for part in parts)
    widened = [tuple(_widen(x, per) for x in part[1:]) for part in parts]
    return (np.concatenate([part[0] for part in parts]),
            *(np.concatenate([w[k] for w in widened]) for k in range(4)))  # type: ignore[return-value]


def _widen(x: np.ndarray, per: int) -> np.ndarray:
    """(k, C, …) → (k, per, …) repeating each figure's first capsule (drawn twice in place: nothing shows)."""
    return np.concatenate([x, np.repeat(x[:, :1], per - x.shape[1], axis=1)], axis=1)


def merge_parts(parts: Sequence[Part], n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The parts' capsules back in snapshot order: a, b (n, C, 3), r (n, C), colours (n, C, 5), C the most
    capsules of any figure."""
    per = max(part[1].shape[1] for part in parts)
    a, b = np.zeros((n, per, 3)), np.zeros((n, per, 3))
    r, colours = np.zeros((n, per)), np.zeros((n, per, 5))
    for sel, pa, pb, pr, pc in parts:
        a[sel], b[sel], r[sel], colours[sel] = (_widen(x, per) for x in (pa, pb, pr, pc))
    return a, b, r, colours
