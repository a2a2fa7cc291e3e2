"""The contact law between people and characters: a penalty spring-damper with each person's force budget.

Contactor bodies take no part in pybullet's contact solver (collision group and mask 0); before every
physics substep ``PersonContact.apply`` finds, for each contactor, the character links whose boxes it
overlaps (``getOverlappingObjects``) and their closest points (``getClosestPoints``, one per pair).
Each touching pair pushes the link at its closest point with a normal force ``k·depth + c·approach``
(≥ 0; ``c`` capped at ``0.5·m_link/dt`` so the explicit step stays stable) and a tangential drag
``c·v_slip`` capped at ``μ·normal``, which carries the character along the hand's motion. Then each
person's forces are summed (|F| of every pair, N) and, beyond ``budget_n``, all scaled down together:
the budget is a hard bound every substep, however many contactors touch (``docs/notes/contact-law.md``).
Units: metres, seconds, newtons, kilograms.
"""

from __future__ import annotations

import math
from collections.abc import Mapping

import numpy as np
import pybullet as p

from interaction.types import Contactor

__all__ = ["PersonContact", "PairForce"]

PairForce = dict[tuple[str, int], float]  # (character, person) → |F| summed over that pair's points, N
_STABLE = 0.5  # damping at most this fraction of m/dt (explicit Euler on the link)


class PersonContact:
    """Computes, bounds and applies the people's contact forces before each physics substep."""

    def __init__(self, client: int, stiffness: float, damping: float, friction: float, budget_n: float) -> None:
        self._client = client
        self._k = stiffness
        self._c = damping
        self._mu = friction
        self._budget = budget_n
        self._masses: dict[tuple[int, int], float] = {}
        self.peak_person_n = 0.0  # largest total one person applied in a substep since made
        self.last_vectors: dict[tuple[str, int], tuple[float, float, float]] = {}  # summed force vectors

    def _mass(self, body: int, link: int) -> float:
        key = (body, link)
        m = self._masses.get(key)
        if m is None:
            m = self._masses[key] = float(p.getDynamicsInfo(body, link, physicsClientId=self._client)[0])
        return m

    def _point_velocity(self, body: int, link: int, at: np.ndarray) -> np.ndarray:
        cid = self._client
        if link < 0:
            v, w = p.getBaseVelocity(body, physicsClientId=cid)
            com = p.getBasePositionAndOrientation(body, physicsClientId=cid)[0]
        else:
            state = p.getLinkState(body, link, computeLinkVelocity=1, physicsClientId=cid)
            com, v, w = state[0], state[6], state[7]
        return np.asarray(v) + np.cross(np.asarray(w), at - np.asarray(com))

    def _pair_force(self, c: Contactor, body: int, link: int, cp: tuple[object, ...], dt: float,
                    ahead: float) -> np.ndarray:
        normal = -np.asarray(cp[7], dtype=float)  # on the character, away from the contactor
        velocity = np.asarray(c.velocity, dtype=float)
        depth = -float(cp[8]) + ahead * float(velocity @ normal)  # type: ignore[arg-type]
        if depth <= 0.0:
            return np.zeros(3)
        at = np.asarray(cp[6], dtype=float)
        slip = velocity - self._point_velocity(body, link, at)
        c_eff = min(self._c, _STABLE * self._mass(body, link) / dt) if self._c > 0 else 0.0
        approach = float(slip @ normal)
        f_n = max(0.0, self._k * depth + c_eff * approach)
        if f_n <= 0.0:
            return np.zeros(3)
        tangent = slip - approach * normal
        speed = float(np.linalg.norm(tangent))
        f_t = min(self._mu * f_n, c_eff * speed)
        drag = tangent * (f_t / speed) if speed > 1e-9 else np.zeros(3)
        return f_n * normal + drag

    def apply(self, contactors: Mapping[int, Contactor], characters: Mapping[int, str], dt: float,
              ahead: float = 0.0) -> PairForce:
        """Push the characters for the coming substep of ``dt`` s; returns the force of each pair (N).

        The contactors' bodies stand where they were placed; ``ahead`` s later each has moved on along its
        velocity (to first order along the contact normal), and that is where it pushes from.
        """
        cid = self._client
        found: list[tuple[int, int, str, int, tuple[float, float, float], np.ndarray]] = []
        totals: dict[int, float] = {}
        for cbody, c in contactors.items():
            reach = ahead * math.sqrt(sum(v * v for v in c.velocity))
            lo, hi = p.getAABB(cbody, physicsClientId=cid)
            lo, hi = [v - reach for v in lo], [v + reach for v in hi]
            for body, link in p.getOverlappingObjects(lo, hi, physicsClientId=cid) or ():
                name = characters.get(body)
                if name is None:
                    continue
                for cp in p.getClosestPoints(cbody, body, reach, linkIndexB=link, physicsClientId=cid):
                    f = self._pair_force(c, body, link, cp, dt, ahead)
                    size = float(np.linalg.norm(f))
                    if size > 0.0:
                        found.append((body, link, name, c.person, cp[6], f))
                        totals[c.person] = totals.get(c.person, 0.0) + size
        scale = {person: min(1.0, self._budget / total) for person, total in totals.items()}
        pairs: PairForce = {}
        vectors: dict[tuple[str, int], np.ndarray] = {}
        for body, link, name, person, at, f in found:
            f = f * scale[person]
            p.applyExternalForce(body, link, f.tolist(), at, p.WORLD_FRAME, physicsClientId=cid)
            key = (name, person)
            pairs[key] = pairs.get(key, 0.0) + float(np.linalg.norm(f))
            vectors[key] = vectors.get(key, np.zeros(3)) + f
        for person, total in totals.items():
            self.peak_person_n = max(self.peak_person_n, total * scale[person])
        self.last_vectors = {key: (float(v[0]), float(v[1]), float(v[2])) for key, v in vectors.items()}
        return pairs
