"""The contact law between people and characters: a penalty spring-damper with each person's force budget.

Contactor bodies take no part in pybullet's contact solver (collision group and mask 0); once per tick
``prepare`` finds the character links near each contactor (``getOverlappingObjects``), and before every
physics substep ``apply`` reads their closest points (``getClosestPoints``, one per pair).
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
from typing import Any

import pybullet as p

from interaction.types import Contactor, Vec3

__all__ = ["PersonContact", "PairForce"]

PairForce = dict[tuple[str, int], float]  # (character, person) → |F| summed over that pair's points, N
_STABLE = 0.5  # damping at most this fraction of m/dt (explicit Euler on the link)
_MARGIN_M = 0.1  # how far a character may move in one control tick (3 m/s at 30 Hz), for the per-tick search


class PersonContact:
    """Computes, bounds and applies the people's contact forces before each physics substep."""

    def __init__(self, client: int, stiffness: float, damping: float, friction: float, budget_n: float) -> None:
        self._client = client
        self._k = stiffness
        self._c = damping
        self._mu = friction
        self._budget = budget_n
        self._masses: dict[tuple[int, int], float] = {}
        self._near: dict[int, list[tuple[int, int, str]]] = {}  # contactor body → links near it this tick

    def _mass(self, body: int, link: int) -> float:
        key = (body, link)
        m = self._masses.get(key)
        if m is None:
            m = self._masses[key] = float(p.getDynamicsInfo(body, link, physicsClientId=self._client)[0])
        return m

    def _point_velocity(self, body: int, link: int, at: Vec3) -> Vec3:
        cid = self._client
        if link < 0:
            v, w = p.getBaseVelocity(body, physicsClientId=cid)
            com = p.getBasePositionAndOrientation(body, physicsClientId=cid)[0]
        else:
            state = p.getLinkState(body, link, computeLinkVelocity=1, physicsClientId=cid)
            com, v, w = state[0], state[6], state[7]
        rx, ry, rz = at[0] - com[0], at[1] - com[1], at[2] - com[2]
        return (v[0] + w[1] * rz - w[2] * ry, v[1] + w[2] * rx - w[0] * rz, v[2] + w[0] * ry - w[1] * rx)

    def _pair_force(self, c: Contactor, body: int, link: int, cp: tuple[Any, ...], dt: float,
                    ahead: float) -> Vec3 | None:
        """The force (N, world frame) on the character at the closest point ``cp``; None: no push."""
        nx, ny, nz = -cp[7][0], -cp[7][1], -cp[7][2]  # on the character, away from the contactor
        vx, vy, vz = c.velocity
        depth = -cp[8] + ahead * (vx * nx + vy * ny + vz * nz)
        if depth <= 0.0:
            return None
        u = self._point_velocity(body, link, cp[6])
        sx, sy, sz = vx - u[0], vy - u[1], vz - u[2]  # the contactor's slip over the character's surface
        c_eff = min(self._c, _STABLE * self._mass(body, link) / dt)
        approach = sx * nx + sy * ny + sz * nz
        f_n = self._k * depth + c_eff * approach
        if f_n <= 0.0:
            return None
        tx, ty, tz = sx - approach * nx, sy - approach * ny, sz - approach * nz
        speed = math.sqrt(tx * tx + ty * ty + tz * tz)
        drag = min(self._mu * f_n, c_eff * speed) / speed if speed > 1e-9 else 0.0
        return (f_n * nx + drag * tx, f_n * ny + drag * ty, f_n * nz + drag * tz)

    def prepare(self, contactors: Mapping[int, Contactor], characters: Mapping[int, str], horizon: float) -> None:
        """Once per control tick, after the contactors are placed: the character links each contactor may
        touch within ``horizon`` s (its box grown by its own travel and ``_MARGIN_M`` for the character's)."""
        cid = self._client
        near: dict[int, list[tuple[int, int, str]]] = {}
        for cbody, c in contactors.items():
            reach = horizon * math.sqrt(sum(v * v for v in c.velocity)) + _MARGIN_M
            lo, hi = p.getAABB(cbody, physicsClientId=cid)
            found = p.getOverlappingObjects([v - reach for v in lo], [v + reach for v in hi], physicsClientId=cid)
            links = [(body, link, characters[body]) for body, link in found or () if body in characters]
            if links:
                near[cbody] = links
        self._near = near

    def apply(self, contactors: Mapping[int, Contactor], dt: float, ahead: float = 0.0) -> PairForce:
        """Push the characters for the coming substep of ``dt`` s; returns the force of each pair (N).

        The contactors' bodies stand where they were placed; ``ahead`` s later each has moved on along its
        velocity (to first order along the contact normal), and that is where it pushes from. Only the
        links ``prepare`` found near are looked at.
        """
        cid = self._client
        found: list[tuple[int, int, str, int, Vec3, Vec3]] = []
        totals: dict[int, float] = {}
        for cbody, links in self._near.items():
            c = contactors[cbody]
            reach = ahead * math.sqrt(sum(v * v for v in c.velocity))
            for body, link, name in links:
                for cp in p.getClosestPoints(cbody, body, reach, linkIndexB=link, physicsClientId=cid):
                    f = self._pair_force(c, body, link, cp, dt, ahead)
                    if f is not None:
                        found.append((body, link, name, c.person, cp[6], f))
                        totals[c.person] = totals.get(c.person, 0.0) + math.sqrt(f[0] ** 2 + f[1] ** 2 + f[2] ** 2)
        pairs: PairForce = {}
        for body, link, name, person, at, f in found:
            k = min(1.0, self._budget / totals[person])
            f = (f[0] * k, f[1] * k, f[2] * k)
            p.applyExternalForce(body, link, f, at, p.WORLD_FRAME, physicsClientId=cid)
            key = (name, person)
            pairs[key] = pairs.get(key, 0.0) + math.sqrt(f[0] ** 2 + f[1] ** 2 + f[2] ** 2)
        return pairs
