"""Character AI: what each character wants — goal velocity, goal heading and intent — for all at once.

Intents: ``idle`` (stand, face the nearest person), ``wander`` (walk between random points of the
stage, pausing), ``approach`` (walk up to the nearest person and stop at ``approach_distance``),
``flee`` (away from the nearest person), ``follow`` (walk the loop of the spec's ``waypoints``).
A character that was pushed flees along the push for ``flee_duration_s``, then goes back to its own
intent; one that was knocked down takes ``after_fall_intent`` for ``after_fall_s`` once it stood up
(when the spec sets one). Every intent keeps ``personal_space`` from the other characters and stays on
the stage. All randomness comes from the ``numpy.random.Generator`` the world injects, drawn in row
order, so a seed gives one behaviour.

Behaviour B (the keyframe set's dimension): ``"stand_up"`` while standing up, ``"walk"`` otherwise
(the paper's "walking and falling down").
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from sim.mitake.crowd import APPROACH, FLEE, FOLLOW, IDLE, NO_INTENT, WANDER, Crowd
from sim.snapshot import CharacterState

INTENT_CODES = (IDLE, WANDER, APPROACH, FLEE, FOLLOW)

Array = NDArray[np.float64]

BEHAVIOUR_WALK = "walk"
BEHAVIOUR_STAND_UP = "stand_up"

ARRIVED_M = 0.2
_TURN_SPEED = 0.15  # below this goal speed the heading is not taken from the velocity
_EDGE_GAIN = 2.0  # 1/s, pull back onto the stage per metre outside the walkable area
_DENSE_UP_TO = 16  # up to this many characters the all-pairs separation is cheaper than the grid


@dataclass(frozen=True, slots=True)
class Stage:
    """The floor rectangle characters live on."""

    x_min: float
    x_max: float
    y_min: float
    y_max: float


def behaviour_for(state: CharacterState) -> str:
    """B for the keyframe set: standing up is its own behaviour; everything else walks (and falls)."""
    return BEHAVIOUR_STAND_UP if state is CharacterState.STAND_UP else BEHAVIOUR_WALK


def _pairs(xy: Array, reach: float) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    """All ordered pairs (i, j), i ≠ j, that may lie within ``reach``: same or neighbouring grid cell."""
    n = xy.shape[0]
    if n <= _DENSE_UP_TO:
        i, j = np.nonzero(~np.eye(n, dtype=bool))
        return i.astype(np.int64), j.astype(np.int64)
    cell = np.floor(xy / reach).astype(np.int64)
    cell -= cell.min(axis=0) - 1
    width = int(cell[:, 1].max()) + 2
    key = cell[:, 0] * width + cell[:, 1]
    order = np.argsort(key, kind="stable")
    sorted_key = key[order]
    offsets = np.array([dx * width + dy for dx in (-1, 0, 1) for dy in (-1, 0, 1)])
    wanted = (key[:, None] + offsets[None, :]).ravel()
    lo = np.searchsorted(sorted_key, wanted, side="left")
    counts = np.searchsorted(sorted_key, wanted, side="right") - lo
    owner = np.repeat(np.repeat(np.arange(n), offsets.size), counts)
    starts = np.repeat(lo - (np.cumsum(counts) - counts), counts)
    j = order[starts + np.arange(int(counts.sum()))]
    keep = owner != j
    return owner[keep], j[keep]


class Neighbours:
    """A Verlet list: the pairs within ``reach + skin``, rebuilt only when someone moved more than half
    the skin since the last build (so no pair within ``reach`` is ever missing)."""

    def __init__(self, skin: float = 0.6) -> None:
        self.skin = skin
        self._xy: Array | None = None
        self._reach = 0.0
        self._pairs: tuple[NDArray[np.int64], NDArray[np.int64]] = (np.zeros(0, np.int64), np.zeros(0, np.int64))
        self.builds = 0

    def pairs(self, xy: Array, reach: float) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
        old = self._xy
        if old is None or old.shape != xy.shape or reach != self._reach \
                or not float(np.max(np.abs(xy - old), initial=0.0)) < 0.5 * self.skin:
            self._pairs = _pairs(xy, reach + self.skin)
            self._xy, self._reach = xy.copy(), reach
            self.builds += 1
        return self._pairs


def separation_velocities(xy: Array, personal_space: Array, speed: Array,
                          neighbours: Neighbours | None = None) -> Array:
    """Per character, a velocity away from the others inside its personal space (all at once).

    ``xy`` is (N, 2); ``personal_space`` and ``speed`` are (N,). Each neighbour at distance d < s
    contributes (1 − d/s)·speed along the direction away from it. Neighbours are found on a grid of
    cells as wide as the largest personal space, so the cost grows with N, not N²; a ``Neighbours``
    list keeps them between calls.
    """
    n = xy.shape[0]
    if n < 2:
        return np.zeros((n, 2))
    reach = float(personal_space.max())
    i, j = neighbours.pairs(xy, reach) if neighbours is not None else _pairs(xy, reach)
    diff = xy[i] - xy[j]
    dist = np.sqrt(np.sum(diff * diff, axis=1))
    s = personal_space[i]
    weight = np.where(dist < s, (1.0 - dist / s) / np.maximum(dist, 1e-6), 0.0) * speed[i]
    return np.stack([np.bincount(i, weights=diff[:, 0] * weight, minlength=n),
                     np.bincount(i, weights=diff[:, 1] * weight, minlength=n)], axis=1)


def notice_push(crowd: Crowd, row: int, t: float, direction: tuple[float, float]) -> None:
    """Someone pushed character ``row`` along ``direction`` (stage xy): it flees that way for a while."""
    n = math.hypot(*direction)
    if n < 1e-9 or not math.isfinite(n):
        return
    crowd.flee_dir[row] = (direction[0] / n, direction[1] / n)
    crowd.flee_until[row] = t + crowd.cols.flee_duration_s[row]


def intents(crowd: Crowd, t: float) -> NDArray[np.int64]:
    """The intent each character follows now: fleeing a push, an after-fall intent, or its own."""
    own = np.where((crowd.override_intent != NO_INTENT) & (t < crowd.override_until),
                   crowd.override_intent, crowd.base_intent)
    out: NDArray[np.int64] = np.where(t < crowd.flee_until, FLEE, own)
    return out


def decide(crowd: Crowd, t: float, stage: Stage, separation: Array, person: Array,
           rng: np.random.Generator) -> None:
    """Set every character's goal velocity and heading for this tick.

    ``person`` is (N, 2): the closest person's stage xy for each character (NaN rows: nobody there).
    Branches run only when some character needs them (the common case is everyone wandering).
    """
    c = crowd.cols
    n = len(crowd)
    x, y = crowd.pos[:, 0], crowd.pos[:, 1]
    lo_x, hi_x, lo_y, hi_y = walkable(crowd, stage)
    intent = intents(crowd, t)
    crowd.intent = intent
    v = np.zeros((n, 2))
    face: Array | None = None
    kinds = set(np.flatnonzero(np.bincount(intent, minlength=len(INTENT_CODES))).tolist())
    if FLEE in kinds or IDLE in kinds or APPROACH in kinds:
        to_px, to_py = person[:, 0] - x, person[:, 1] - y
        d_p = np.hypot(to_px, to_py)
        seen = np.isfinite(d_p) & (d_p > 1e-6)
        d_safe = np.where(seen, d_p, 1.0)
        ux, uy = np.where(seen, to_px / d_safe, 0.0), np.where(seen, to_py / d_safe, 0.0)
        if FLEE in kinds:
            fleeing = intent == FLEE
            pushed = t < crowd.flee_until
            v[:, 0] = np.where(fleeing, np.where(pushed, crowd.flee_dir[:, 0], -ux) * c.flee_speed, 0.0)
            v[:, 1] = np.where(fleeing, np.where(pushed, crowd.flee_dir[:, 1], -uy) * c.flee_speed, 0.0)
        near = seen & ((intent == IDLE) | (intent == APPROACH))
        if near.any():
            face = np.where(near, np.arctan2(to_py, to_px), math.nan)
            approach = near & (intent == APPROACH)
            speed = c.walk_speed * np.clip((d_p - c.approach_distance) / 0.5, -1.0, 1.0)
            v[approach, 0] = (speed * ux)[approach]
            v[approach, 1] = (speed * uy)[approach]
    if WANDER in kinds:
        wander = intent == WANDER
        v[wander] = _wander(crowd, t, wander, rng, lo_x, hi_x, lo_y, hi_y)[wander]
    if FOLLOW in kinds:
        follow = (intent == FOLLOW) & (crowd.path_len > 0)
        if follow.any():
            v[follow] = _follow(crowd, follow)[follow]
    v += separation
    # at the edge of the walkable area nothing walks further out; outside it, the pull brings it back
    inside_x = np.minimum(np.maximum(x, lo_x), hi_x) - x
    inside_y = np.minimum(np.maximum(y, lo_y), hi_y) - y
    v[:, 0] = np.where(((x >= hi_x) & (v[:, 0] > 0.0)) | ((x <= lo_x) & (v[:, 0] < 0.0)), 0.0, v[:, 0])
    v[:, 1] = np.where(((y >= hi_y) & (v[:, 1] > 0.0)) | ((y <= lo_y) & (v[:, 1] < 0.0)), 0.0, v[:, 1])
    v[:, 0] += _EDGE_GAIN * inside_x
    v[:, 1] += _EDGE_GAIN * inside_y
    top = c.top_speed
    size = np.hypot(v[:, 0], v[:, 1])
    over = size > top
    if over.any():
        v *= np.where(over, top / np.maximum(size, 1e-12), 1.0)[:, None]
        size = np.minimum(size, top)
    moving = size > _TURN_SPEED
    heading = np.where(moving, np.arctan2(v[:, 1], v[:, 0]), crowd.heading_goal)
    if face is not None:
        heading = np.where(~moving & np.isfinite(face), face, heading)
    crowd.heading_goal = heading
    still = ~crowd.upright() | ~np.isfinite(size)  # on the ground: get up first; never a NaN goal
    if still.any():
        v[still] = 0.0
    crowd.goal_v = v


def walkable(crowd: Crowd, stage: Stage) -> tuple[Array, Array, Array, Array]:
    """Per character, the stage shrunk by its ``stage_margin`` (x_lo, x_hi, y_lo, y_hi); kept on the
    crowd's columns (they change only when characters are added)."""
    c = crowd.cols
    cached = c.walkable.get(stage)
    if cached is None:
        m = c.stage_margin
        cx, cy = 0.5 * (stage.x_min + stage.x_max), 0.5 * (stage.y_min + stage.y_max)
        cached = c.walkable[stage] = (np.minimum(stage.x_min + m, cx), np.maximum(stage.x_max - m, cx),
                                      np.minimum(stage.y_min + m, cy), np.maximum(stage.y_max - m, cy))
    return cached


def _wander(crowd: Crowd, t: float, rows: NDArray[np.bool_], rng: np.random.Generator, lo_x: Array,
            hi_x: Array, lo_y: Array, hi_y: Array) -> Array:
    c = crowd.cols
    x, y = crowd.pos[:, 0], crowd.pos[:, 1]
    active = rows & (t >= crowd.pause_until)
    need = np.flatnonzero(active & (np.isnan(crowd.waypoint[:, 0]) | (t > crowd.waypoint_deadline)))
    if need.size:
        u = rng.uniform(size=(need.size, 2))
        wx = lo_x[need] + u[:, 0] * (hi_x[need] - lo_x[need])
        wy = lo_y[need] + u[:, 1] * (hi_y[need] - lo_y[need])
        crowd.waypoint[need] = np.stack([wx, wy], axis=1)
        crowd.waypoint_deadline[need] = t + 3.0 * np.hypot(wx - x[need], wy - y[need]) / c.walk_speed[need] + 2.0
    dx, dy = crowd.waypoint[:, 0] - x, crowd.waypoint[:, 1] - y
    d = np.hypot(dx, dy)
    arrived = np.flatnonzero(active & (d < ARRIVED_M))
    if arrived.size:
        crowd.waypoint[arrived] = math.nan
        scale = c.wander_pause_s[arrived]
        pause = np.where(scale > 0.0, rng.exponential(np.maximum(scale, 1e-12)), 0.0)
        crowd.pause_until[arrived] = t + pause
    going = active & np.isfinite(d) & (d >= ARRIVED_M)
    d_safe = np.where(going, d, 1.0)
    speed = c.walk_speed * np.minimum(1.0, d_safe / 0.5) / d_safe
    return np.stack([np.where(going, speed * dx, 0.0), np.where(going, speed * dy, 0.0)], axis=1)


def _follow(crowd: Crowd, rows: NDArray[np.bool_]) -> Array:
    """Walk toward the current waypoint of the loop; the next one once within ``ARRIVED_M``."""
    idx = np.flatnonzero(rows)
    for _ in range(2):  # at most one advance per tick; the second pass recomputes the target
        target = crowd.path_xy[idx, crowd.path_index[idx]]
        d = np.hypot(target[:, 0] - crowd.pos[idx, 0], target[:, 1] - crowd.pos[idx, 1])
        reached = d < ARRIVED_M
        if not reached.any():
            break
        r = idx[reached]
        crowd.path_index[r] = (crowd.path_index[r] + 1) % crowd.path_len[r]
    out = np.zeros((len(crowd), 2))
    dx, dy = target[:, 0] - crowd.pos[idx, 0], target[:, 1] - crowd.pos[idx, 1]
    d = np.maximum(np.hypot(dx, dy), 1e-9)
    speed = crowd.cols.walk_speed[idx]
    out[idx] = np.stack([speed * dx / d, speed * dy / d], axis=1)
    return out


def on_stood_up(crowd: Crowd, row: int, t: float) -> None:
    """A character that was knocked down and stood up again takes its after-fall intent, if it has one."""
    if crowd.after_fall[row] != NO_INTENT:
        crowd.override_intent[row] = crowd.intent[row] = crowd.after_fall[row]
        crowd.override_until[row] = t + crowd.cols.after_fall_s[row]


def impose_intent(crowd: Crowd, intent: str | None, saved: NDArray[np.int64] | None) -> NDArray[np.int64] | None:
    """Make every character's own intent ``intent`` (attract mode), keeping their own ones in the returned
    array; ``intent=None`` gives them back ``saved`` and returns None."""
    from sim.config import INTENTS

    if intent is None:
        if saved is not None:
            crowd.base_intent[:len(saved)] = saved
        return None
    if intent not in INTENTS:
        raise ValueError(f"intent: expected one of {', '.join(INTENTS)} or None, got {intent!r}")
    if saved is None:
        saved = crowd.base_intent.copy()
    crowd.base_intent[:] = INTENTS.index(intent)
    return saved
