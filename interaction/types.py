"""What interaction/ produces: people's bodies as contactors and impulses, in stage metres.

Stage frame (shared by sim/ and render/): right-handed, metres, **z up**; x to the audience's
right; y away from the audience (into the screen). The floor is z = 0.
"""

from __future__ import annotations

from dataclasses import dataclass

Vec3 = tuple[float, float, float]


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


@dataclass(frozen=True, slots=True)
class Impulse:
    """A hit measured directly (a force pad): a force applied for ``duration`` seconds at ``position``."""

    position: Vec3
    force: Vec3
    duration: float
    source: str


@dataclass(frozen=True, slots=True)
class BodyObservation:
    """Everything seen of the people at loop time ``t``."""

    t: float
    contactors: tuple[Contactor, ...] = ()
    impulses: tuple[Impulse, ...] = ()
    people: int = 0

    @staticmethod
    def merge(t: float, parts: list[BodyObservation]) -> BodyObservation:
        """One observation from several observers' (all contactors and impulses, people summed)."""
        return BodyObservation(
            t=t,
            contactors=tuple(c for o in parts for c in o.contactors),
            impulses=tuple(i for o in parts for i in o.impulses),
            people=sum(o.people for o in parts),
        )
