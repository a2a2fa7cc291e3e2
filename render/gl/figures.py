"""The characters as capsules: each snapshot character posed by its keyframe set at its point of Q
(or, articulated, from its own link transforms), placed in its rigid body's frame and scaled to its
height, with per-capsule colours — the instances the renderer draws. Numpy only, no GL.

Where the figures' feet meet the floor is set by ``com_fraction``: the height of the sim body's
centre of mass above its base over its height, so a keyframe pose (centred on the skeleton's own
centre of mass) is lifted by the difference.
"""

from __future__ import annotations

import warnings
from collections.abc import Mapping

import numpy as np

from render.gl.effects import BehaviourFade
from render.gl.links import articulated_part, merge_parts
from render.gl.scene import (
    CAPSULE_FLOATS,
    body_rotations,
    figure_colours,
    orientation_mismatch,
    posed_capsules,
)
from render.gl.style import Colours
from render.keyframes import KeyframeSet
from render.keyframes.skeleton_pose import com_fraction as set_com_fraction
from render.keyframes.skeletons import figure_for
from sim.snapshot import CharacterSnapshot

__all__ = ["Figures", "Sets"]

Sets = Mapping[str, KeyframeSet] | KeyframeSet


class Figures:
    """Poses snapshots' characters into capsules, remembering what a fade between behaviours needs.

    ``com_fraction``: one for all, or by character name or kind (key ``"*"`` for the rest), each in
    (0, 1), or None: each snapshot's ``com_height`` over its height; ``flash_newtons``: the contact force at which a pushed character glows fully.
    """

    def __init__(self, com_fraction: float | Mapping[str, float] | None, colours: Colours,
                 flash_newtons: float) -> None:
        fractions = com_fraction.values() if isinstance(com_fraction, Mapping) else [
            0.5 if com_fraction is None else com_fraction]
        if not all(0.0 < f < 1.0 for f in fractions):
            raise ValueError(f"com_fraction: expected fractions in (0, 1), got {com_fraction!r}")
        self.com_fraction = com_fraction
        self.colours = colours
        self.flash_newtons = flash_newtons
        self.fade = BehaviourFade()
        self._warned: set[str] = set()

    def capsules(
        self, t: float, chars: tuple[CharacterSnapshot, ...], keyframes: Sets
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Capsule ends a, b (N, C, 3), radii (N, C) and instances (N·C, CAPSULE_FLOATS), in snapshot order."""
        n = len(chars)
        if n == 0:
            return np.zeros((0, 0, 3)), np.zeros((0, 0, 3)), np.zeros((0, 0)), np.zeros((0, CAPSULE_FLOATS))
        rots = body_rotations(np.array([c.orientation for c in chars], dtype=float))
        if "frame" not in self._warned and (problem := orientation_mismatch(chars, rots)):
            self._warned.add("frame")
            warnings.warn(problem, stacklevel=2)
        positions = np.array([c.position for c in chars], dtype=float)
        heights = np.array([c.height for c in chars], dtype=float)
        behaviours = self.fade.behaviours(t, chars)
        groups: dict[int, tuple[KeyframeSet, list[int]]] = {}
        linked = [i for i, c in enumerate(chars) if c.links]  # articulated: drawn from their own links
        for i, c in enumerate(chars):
            if not c.links:
                kset = self._set_for(c, keyframes)
                groups.setdefault(id(kset), (kset, []))[1].append(i)
        parts = [articulated_part([chars[i] for i in linked], np.array(linked), self.colours,
                                  self.flash_newtons)] if linked else []
        for kset, idx in groups.values():
            figure = figure_for(kset.skeleton)
            sel = np.array(idx)
            group = [chars[i] for i in idx]
            poses = kset.evaluate(kset.snapshot_array(group), [behaviours[i] for i in idx])
            scale = heights[sel] / kset.height
            body = np.array([self._com_fraction(c) for c in group])
            lift = (set_com_fraction(figure) - body) * kset.height
            a, b, r = posed_capsules(figure, poses, positions[sel], rots[sel], scale, lift)
            colours = figure_colours(group, figure.material, self.colours, self.flash_newtons)
            parts.append((sel, a, b, r, colours))
        a, b, r, colours = merge_parts(parts, n)  # several sets: back into snapshot order
        instances = np.concatenate([a, b, r[..., None], colours], axis=2).reshape(-1, CAPSULE_FLOATS)
        return a, b, r, instances

    def _com_fraction(self, c: CharacterSnapshot) -> float:
        f = self.com_fraction
        if not isinstance(f, Mapping):  # None: from the snapshot
            return float(f) if f is not None else 0.5 if c.com_height is None else c.com_height / c.height
        return float(f.get(c.name, f.get(getattr(c, "kind", ""), f.get("*", 0.5))))

    @staticmethod
    def _set_for(c: CharacterSnapshot, keyframes: Sets) -> KeyframeSet:
        """The character's set: one for all, or by its name, else by its kind (spec name), else ``"*"``."""
        if isinstance(keyframes, KeyframeSet):
            return keyframes
        found = keyframes.get(c.name) or keyframes.get(getattr(c, "kind", "")) or keyframes.get("*")
        if found is None:
            raise KeyError(
                f"render: no keyframe set for character {c.name!r} (sets for: {', '.join(sorted(keyframes))})"
            )
        return found
