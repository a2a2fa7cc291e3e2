"""What interaction/ produces: people's bodies as contactors and impulses, in stage metres.

Stage frame (shared by sim/ and render/): right-handed, metres, **z up**; x to the audience's
right; y away from the audience (into the screen). The floor is z = 0.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    import numpy as np

    from interaction.webcam.calibration import Calibration

Vec3 = tuple[float, float, float]
Cell = tuple[int, int]  # (ix, iy) of the terrain's floor grid


def finite(*values: object) -> bool:
    """True when every value is a real number (int or float, not bool-like text) and finite: the one test
    of numbers in observations (``jostle.observer_guard`` drops on it, ``sim.inputs`` rejects or clamps)."""
    return all(isinstance(v, int | float) and math.isfinite(v) for v in values)


@dataclass(frozen=True, slots=True)
class Contactor:
    """A kinematic sphere (``half_depth == 0``) or a capsule along the stage's y axis
    (``half_depth > 0``, its segment running from ``y - half_depth`` to ``y + half_depth``)
    that stands for part of a person's body.

    A webcam knows nothing of depth, so its contactors are capsules sweeping the stage band;
    a depth camera gives spheres.
    """

    person: int
    part: str  # "outline", "head", "hand", "foot", ... (free text, for display and traces)
    position: Vec3
    velocity: Vec3
    radius: float
    half_depth: float = 0.0

    @property
    def finite(self) -> bool:
        return finite(*self.position, *self.velocity, self.radius, self.half_depth)


@dataclass(frozen=True, slots=True)
class Impulse:
    """A hit measured directly (a force pad): a force applied for ``duration`` seconds at ``position``."""

    position: Vec3
    force: Vec3
    duration: float
    source: str

    @property
    def finite(self) -> bool:
        return finite(*self.position, *self.force, self.duration)


@dataclass(frozen=True, slots=True, eq=False)
class Silhouette:
    """The people a camera sees, as a mask: (h, w) uint8 in camera pixels, 255 = a person, read-only;
    ``calibration`` maps its pixels onto the stage plane (for drawing it where the people stand)."""

    mask: np.ndarray
    calibration: Calibration

    def __eq__(self, other: object) -> bool:  # the same pixels and the same calibration
        return isinstance(other, Silhouette) and self.calibration == other.calibration \
            and self.mask.shape == other.mask.shape and bool((self.mask == other.mask).all())

    __hash__ = None  # type: ignore[assignment]


@dataclass(frozen=True, slots=True)
class TerrainReport:
    """What people did to the cube terrain, in cells of its floor grid.

    ``placements``: one cube more asked for on each cell (a hand held still over it), in order.
    ``boxes``: every real box the depth camera sees now, (ix, iy, height in cubes) per cell; None when
    this observation holds no depth report (the boxes are then as last reported).
    """

    placements: tuple[Cell, ...] = ()
    boxes: tuple[tuple[int, int, int], ...] | None = None

    @staticmethod
    def merge(parts: list[TerrainReport | None]) -> TerrainReport | None:
        """All placements in order; the last boxes reported. None when every part is None."""
        reports = [r for r in parts if r is not None]
        if not reports:
            return None
        boxes = [r.boxes for r in reports if r.boxes is not None]
        return TerrainReport(tuple(c for r in reports for c in r.placements), boxes[-1] if boxes else None)


@dataclass(frozen=True, slots=True)
class BodyObservation:
    """Everything seen of the people at loop time ``t``; ``silhouette`` and ``terrain`` only from the
    observers that see them (a webcam's silhouette; the boxes and held hands of the cube terrain)."""

    t: float
    contactors: tuple[Contactor, ...] = ()
    impulses: tuple[Impulse, ...] = ()
    people: int = 0
    silhouette: Silhouette | None = None
    terrain: TerrainReport | None = None

    @staticmethod
    def merge(t: float, parts: list[BodyObservation]) -> BodyObservation:
        """One observation from several observers' (all contactors and impulses, people summed, the first
        silhouette, the terrain reports merged)."""
        return BodyObservation(
            t=t,
            contactors=tuple(c for o in parts for c in o.contactors),
            impulses=tuple(i for o in parts for i in o.impulses),
            people=sum(o.people for o in parts),
            silhouette=next((o.silhouette for o in parts if o.silhouette is not None), None),
            terrain=TerrainReport.merge([o.terrain for o in parts]),
        )
