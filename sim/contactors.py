"""People in the physics: contactors as pybullet bodies for their shape, and contact episodes.

A contactor is a zero-mass pybullet multibody (sphere, or a capsule along stage y when
``half_depth > 0``) moved once per control tick with ``resetBasePositionAndOrientation``. It takes no
part in the contact solver (collision group and mask 0): ``sim.person_contact`` reads its closest points
to the characters and applies the contact law with the person's force budget. (Until issue K these were
kinematic solver bodies; their forces had no bound: ``docs/notes/contact-law.md``.)

Bodies are pooled by quantised shape (radius to 1 cm, half-depth to 5 cm) and reused frame to frame;
unused ones are parked far below the floor.

``ContactEpisodes`` turns per-substep forces into episodes per (person, character): an episode starts
at the first contact and ends after ``gap_s`` without one, yielding a ``ContactEvent`` with the
impulse ∫F dt, the peak force and whether the impulse reached the character's push threshold.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import pybullet as p

from interaction.types import Contactor
from sim.snapshot import ContactEvent

_RADIUS_STEP = 0.01
_DEPTH_STEP = 0.05
_PARK: tuple[float, float, float] = (0.0, 0.0, -50.0)
_CAPSULE_ALONG_Y = (-math.sqrt(0.5), 0.0, 0.0, math.sqrt(0.5))  # turns pybullet's capsule z axis onto y
_NO_TURN = (0.0, 0.0, 0.0, 1.0)

ShapeKey = tuple[int, int]


class ContactorPool:
    """Kinematic bodies standing for the people's contactors in one pybullet client."""

    def __init__(self, client: int) -> None:
        self._client = client
        self._shapes: dict[ShapeKey, int] = {}
        self._bodies: dict[ShapeKey, list[int]] = {}
        self._parked: set[int] = set()
        self.active: dict[int, Contactor] = {}  # body id -> the contactor it stands for

    def _shape(self, key: ShapeKey) -> int:
        shape = self._shapes.get(key)
        if shape is None:
            r_q, d_q = key
            if d_q == 0:
                shape = p.createCollisionShape(p.GEOM_SPHERE, radius=r_q * _RADIUS_STEP,
                                               physicsClientId=self._client)
            else:
                shape = p.createCollisionShape(p.GEOM_CAPSULE, radius=r_q * _RADIUS_STEP,
                                               height=2.0 * d_q * _DEPTH_STEP, physicsClientId=self._client)
            self._shapes[key] = shape
        return shape

    def _new_body(self, key: ShapeKey) -> int:
        body: int = p.createMultiBody(baseMass=0.0, baseCollisionShapeIndex=self._shape(key),
                                      basePosition=_PARK, useMaximalCoordinates=False,
                                      physicsClientId=self._client)
        p.setCollisionFilterGroupMask(body, -1, 0, 0, physicsClientId=self._client)  # outside the solver
        self._bodies.setdefault(key, []).append(body)
        return body

    @staticmethod
    def shape_key(c: Contactor) -> ShapeKey:
        return max(1, round(c.radius / _RADIUS_STEP)), max(0, round(c.half_depth / _DEPTH_STEP))

    def place(self, contactors: Sequence[Contactor]) -> None:
        """Move the pool's bodies onto ``contactors``; park the rest."""
        used: dict[ShapeKey, int] = {}
        active: dict[int, Contactor] = {}
        for c in contactors:
            key = self.shape_key(c)
            k = used.get(key, 0)
            pool = self._bodies.get(key, [])
            body = pool[k] if k < len(pool) else self._new_body(key)
            used[key] = k + 1
            turn = _CAPSULE_ALONG_Y if key[1] > 0 else _NO_TURN
            p.resetBasePositionAndOrientation(body, c.position, turn, physicsClientId=self._client)
            self._parked.discard(body)
            active[body] = c
        for key, pool in self._bodies.items():
            for body in pool[used.get(key, 0):]:
                if body not in self._parked:
                    p.resetBasePositionAndOrientation(body, _PARK, _NO_TURN, physicsClientId=self._client)
                    self._parked.add(body)
        self.active = active

    @property
    def size(self) -> int:
        return sum(len(v) for v in self._bodies.values())


@dataclass(slots=True)
class _Episode:
    t_start: float
    t_last: float
    impulse: float
    peak: float


class ContactEpisodes:
    """Contact episodes per (character, person), from per-physics-step forces."""

    def __init__(self, gap_s: float) -> None:
        self._gap = gap_s
        self._open: dict[tuple[str, int], _Episode] = {}

    def add(self, t: float, character: str, person: int, force_n: float, dt: float) -> None:
        """Force ``force_n`` acted over the physics step of length ``dt`` ending at ``t``."""
        if not force_n > 0.0:
            return
        key = (character, person)
        ep = self._open.get(key)
        if ep is None:
            self._open[key] = _Episode(t - dt, t, force_n * dt, force_n)
        else:
            ep.t_last = t
            ep.impulse += force_n * dt
            ep.peak = max(ep.peak, force_n)

    def impulse_so_far(self, character: str, person: int) -> float:
        ep = self._open.get((character, person))
        return ep.impulse if ep is not None else 0.0

    def close(self, t: float, threshold: Callable[[str], float], everything: bool = False) -> list[ContactEvent]:
        """End the episodes with no contact for ``gap_s`` up to ``t`` (or all of them)."""
        done: list[ContactEvent] = []
        for key in list(self._open):
            ep = self._open[key]
            if everything or t - ep.t_last >= self._gap - 1e-9:
                del self._open[key]
                character, person = key
                done.append(ContactEvent(t_start=ep.t_start, t_end=ep.t_last, character=character,
                                         person=person, impulse_ns=ep.impulse, peak_force_n=ep.peak,
                                         push=ep.impulse >= threshold(character)))
        return done

    def forget(self, character: str) -> None:
        for key in [k for k in self._open if k[0] == character]:
            del self._open[key]
