"""People's input made safe for pybullet: NaN, inf and absurd values are dropped or clamped, and counted.

Nothing from an observation reaches pybullet without passing through ``clean_observation``.
"""

from __future__ import annotations

import math
import numbers
from dataclasses import dataclass

from interaction.types import BodyObservation, Contactor, Impulse, TerrainReport, Vec3, finite
from sim.config import WorldConfig

_FAR_M = 100.0  # positions farther than this from the stage origin are nonsense


@dataclass(frozen=True, slots=True)
class CleanedObservation:
    contactors: tuple[Contactor, ...]
    impulses: tuple[Impulse, ...]
    terrain: TerrainReport | None  # its cells whole numbers (a box's cubes ≥ 0)
    rejected: int  # items dropped (position, force or cell unusable)
    clamped: int  # values replaced or limited


def _finite(v: Vec3) -> bool:
    return len(v) == 3 and finite(*v)


def _limit(v: Vec3, bound: float) -> tuple[Vec3, bool]:
    n = math.sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2])
    if n <= bound:
        return (float(v[0]), float(v[1]), float(v[2])), False
    s = bound / n
    return (v[0] * s, v[1] * s, v[2] * s), True


def clean_observation(obs: BodyObservation, config: WorldConfig) -> CleanedObservation:
    rejected = 0
    clamped = 0
    contactors: list[Contactor] = []
    for c in obs.contactors:
        if not _finite(c.position) or max(abs(v) for v in c.position) > _FAR_M \
                or not isinstance(c.radius, int | float) or not math.isfinite(c.radius) or c.radius <= 0.0:
            rejected += 1
            continue
        velocity: Vec3 = (0.0, 0.0, 0.0)
        if _finite(c.velocity):
            velocity, cut = _limit(c.velocity, config.max_contactor_speed)
            clamped += cut
        else:
            clamped += 1
        radius = float(c.radius)
        if radius > config.max_contactor_radius:
            radius, clamped = config.max_contactor_radius, clamped + 1
        half_depth = c.half_depth
        if not isinstance(half_depth, int | float) or not math.isfinite(half_depth) or half_depth < 0.0:
            half_depth, clamped = 0.0, clamped + 1
        elif half_depth > config.max_contactor_radius * 4.0:
            half_depth, clamped = config.max_contactor_radius * 4.0, clamped + 1
        pos = (float(c.position[0]), float(c.position[1]), float(c.position[2]))
        contactors.append(Contactor(int(c.person), str(c.part), pos, velocity, radius, float(half_depth)))
    impulses: list[Impulse] = []
    for i in obs.impulses:
        push = clean_push(i.force, i.duration, config)
        if push is None or not _finite(i.position) or max(abs(v) for v in i.position) > _FAR_M:
            rejected += 1
            continue
        force, duration, cuts = push
        clamped += cuts
        pos = (float(i.position[0]), float(i.position[1]), float(i.position[2]))
        impulses.append(Impulse(pos, force, duration, str(i.source)))
    terrain, dropped = _clean_terrain(obs.terrain)
    return CleanedObservation(tuple(contactors), tuple(impulses), terrain, rejected + dropped, clamped)


def _whole(*values: object) -> bool:
    return all(isinstance(v, numbers.Integral) and not isinstance(v, bool) for v in values)


def _clean_terrain(report: TerrainReport | None) -> tuple[TerrainReport | None, int]:
    """The report with only whole-number cells (a box of ≥ 0 cubes), and how many items were dropped."""
    if report is None:
        return None, 0
    placements = tuple((int(c[0]), int(c[1])) for c in report.placements if len(c) == 2 and _whole(*c))
    boxes = None if report.boxes is None else \
        tuple((int(b[0]), int(b[1]), int(b[2])) for b in report.boxes if len(b) == 3 and _whole(*b) and b[2] >= 0)
    dropped = len(report.placements) - len(placements) + (0 if boxes is None else len(report.boxes or ()) - len(boxes))
    return TerrainReport(placements, boxes), dropped


def clean_push(force: Vec3, duration: float, config: WorldConfig) -> tuple[Vec3, float, int] | None:
    """A force held for ``duration`` made safe: None when unusable (non-finite, duration ≤ 0), else the
    force and duration within ``max_impulse_force_n`` / ``max_impulse_duration_s`` / ``max_impulse_ns``
    and how many of those limits cut it."""
    if not _finite(force) or not isinstance(duration, int | float) or not math.isfinite(duration) \
            or duration <= 0.0:
        return None
    safe, cut = _limit(force, config.max_impulse_force_n)
    clamped = int(cut)
    duration = float(duration)
    if duration > config.max_impulse_duration_s:
        duration, clamped = config.max_impulse_duration_s, clamped + 1
    safe, cut = _limit(safe, config.max_impulse_ns / duration)
    return safe, duration, clamped + int(cut)


def contactors_at(contactors: tuple[Contactor, ...], age: float, hold_s: float) -> tuple[Contactor, ...]:
    """The last observation's contactors ``age`` s after it, each moved on at its own velocity; none once
    they are older than ``hold_s`` (the person is no longer known to be there)."""
    if not contactors or age > hold_s + 1e-9:
        return ()
    if age <= 0.0:
        return contactors
    return tuple(
        Contactor(c.person, c.part, (c.position[0] + c.velocity[0] * age, c.position[1] + c.velocity[1] * age,
                                 c.position[2] + c.velocity[2] * age), c.velocity, c.radius, c.half_depth)
        for c in contactors
    )
