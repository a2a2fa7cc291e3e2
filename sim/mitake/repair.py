"""What the world repairs, found for all characters at once: runaway speeds, lost and stuck characters.

``World`` acts on the rows these return (slows them, or stands them up again on a free spot) and counts
every repair in ``WorldCounters``.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from sim.config import WorldConfig
from sim.frames import yaw_quaternion
from sim.mitake.ai import Stage
from sim.mitake.body import reset_body, set_friction, write_velocities
from sim.mitake.crowd import WALK, Crowd

IntArray = NDArray[np.int64]


def too_fast(crowd: Crowd, cfg: WorldConfig) -> IntArray:
    """Rows faster than ``max_character_speed`` or spinning faster than ``max_character_spin``; their
    velocities in ``crowd`` are scaled down to the limits (the caller writes them to the bodies)."""
    if not len(crowd):
        return np.zeros(0, dtype=np.int64)
    speed = np.sqrt(np.einsum("ij,ij->i", crowd.vel, crowd.vel))
    spin = np.sqrt(np.einsum("ij,ij->i", crowd.ang, crowd.ang))
    fast = (speed > cfg.max_character_speed) | (spin > cfg.max_character_spin)
    if not fast.any():
        return np.zeros(0, dtype=np.int64)
    rows = np.flatnonzero(fast)
    with np.errstate(invalid="ignore", divide="ignore"):
        crowd.vel[rows] *= np.minimum(1.0, cfg.max_character_speed / speed[rows])[:, None]
        crowd.ang[rows] *= np.minimum(1.0, cfg.max_character_spin / spin[rows])[:, None]
    return rows


def lost_characters(crowd: Crowd, cfg: WorldConfig, t: float) -> list[tuple[int, bool]]:
    """(row, lost) of every character to stand up again: non-finite or off the stage (lost: put it
    anywhere free), or fallen for longer than ``stuck_timeout_s`` (stand it up where it is)."""
    if not len(crowd):
        return []
    m = cfg.stage_escape_margin
    x, y, z = crowd.pos[:, 0], crowd.pos[:, 1], crowd.pos[:, 2]
    if np.isfinite(crowd.pos.sum() + crowd.quat.sum() + crowd.vel.sum() + crowd.ang.sum()) \
            and x.min() >= cfg.x_min - m and x.max() <= cfg.x_max + m and y.min() >= cfg.y_min - m \
            and y.max() <= cfg.y_max + m and z.min() >= -1.0 and z.max() <= 20.0 \
            and not (t - crowd.not_upright_since > cfg.stuck_timeout_s).any():
        return []  # the common case: nothing to repair
    finite = np.isfinite(crowd.pos).all(axis=1) & np.isfinite(crowd.quat).all(axis=1) \
        & np.isfinite(crowd.vel).all(axis=1) & np.isfinite(crowd.ang).all(axis=1)
    with np.errstate(invalid="ignore"):
        off = (x < cfg.x_min - m) | (x > cfg.x_max + m) | (y < cfg.y_min - m) | (y > cfg.y_max + m) \
            | (z < -1.0) | (z > 20.0)
        stuck = t - crowd.not_upright_since > cfg.stuck_timeout_s
    lost = ~finite | off
    return [(row, bool(lost[row])) for row in np.flatnonzero(lost | stuck).tolist()]


def free_spot(crowd: Crowd, row: int, stage: Stage, rng: np.random.Generator,
              near: tuple[float, float] | None) -> tuple[float, float]:
    """A spot on the walkable stage clear of the other characters: ``near`` if it is free, else drawn."""
    margin = float(crowd.cols.stage_margin[row])
    cx, cy = 0.5 * (stage.x_min + stage.x_max), 0.5 * (stage.y_min + stage.y_max)
    lo_x, hi_x = min(stage.x_min + margin, cx), max(stage.x_max - margin, cx)
    lo_y, hi_y = min(stage.y_min + margin, cy), max(stage.y_max - margin, cy)
    others = np.delete(crowd.pos[:, :2], row, axis=0)
    others = others[np.isfinite(others).all(axis=1)]
    clear = 2.0 * float(crowd.cols.half_width[row]) + 0.1

    def free(px: float, py: float) -> bool:
        return bool(np.all(np.hypot(others[:, 0] - px, others[:, 1] - py) > clear))

    if near is not None and math.isfinite(near[0]) and math.isfinite(near[1]):
        px, py = min(max(near[0], lo_x), hi_x), min(max(near[1], lo_y), hi_y)
        if free(px, py):
            return px, py
    for _ in range(32):
        px, py = float(rng.uniform(lo_x, hi_x)), float(rng.uniform(lo_y, hi_y))
        if free(px, py):
            return px, py
    return 0.5 * (lo_x + hi_x), 0.5 * (lo_y + hi_y)


def slow_down(client: int, crowd: Crowd, cfg: WorldConfig) -> int:
    """Scale every too-fast body down to the limits (``too_fast``) and write it; returns how many."""
    rows = too_fast(crowd, cfg)
    if rows.size:
        finite = rows[np.isfinite(crowd.vel[rows]).all(axis=1) & np.isfinite(crowd.ang[rows]).all(axis=1)]
        if finite.size:  # (non-finite ones are put back upright by the lost-character repair)
            write_velocities(client, [crowd.bodies[i] for i in finite.tolist()], crowd.vel[finite],
                             crowd.ang[finite])
    return int(rows.size)


def stand_again(client: int, crowd: Crowd, row: int, spot: tuple[float, float], t: float, gravity: float) -> int:
    """Put character ``row`` upright and still at ``spot`` (walking, frictionless feet, its heading kept
    when finite); returns the state it was in before."""
    before = int(crowd.state[row])
    heading = float(crowd.frames.heading[row]) if np.isfinite(crowd.quat[row]).all() else 0.0
    pos = (spot[0], spot[1], float(crowd.cols.com_height[row]) + 0.002)
    orn = yaw_quaternion(heading)
    reset_body(client, crowd.bodies[row], pos, orn)
    set_friction(client, crowd.bodies[row], 0.0)
    crowd.friction_now[row] = 0.0
    crowd.state[row], crowd.entered[row], crowd.since[row], crowd.face_up[row] = WALK, t, math.nan, -1
    crowd.not_upright_since[row] = crowd.fell_at[row] = math.nan
    crowd.heading_goal[row] = heading
    crowd.place(row, pos, orn, crowd.specs[row].mass, gravity)
    return before
