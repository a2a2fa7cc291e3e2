"""The control state machine (Mitake et al. 2009, Figure 3), for every character at once, pure of pybullet.

    WALK ──load ≥ stagger──▶ STAGGER ──load < recover for recover_hold_s──▶ WALK
      │                         │
      └──────load ≥ fall────────┴──▶ FALL ──tilt ≥ ground_tilt──▶ BRAKE ──still for still_hold_s──▶ LIE
                                                                    ▲                                │
                                                                    └──────── moved again ───────────┤
    WALK ◀──upright and balanced── STAND_UP ◀──────────── lie_duration_s ───────────────────────────┘
                                      │ knocked over (tilt far above its reference) or too slow
                                      └──▶ FALL

"load" is ``Crowd.balance_load``: whether the *bounded* controller can still bring the body back
(capture-point criterion, ``sim.mitake.balance``), not a fixed angle. Lying face up or face down is decided
when the body comes to rest (the body's face axis up or down).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from sim.mitake.ai import on_stood_up
from sim.mitake.body import set_friction
from sim.mitake.crowd import BRAKE, FALL, LIE, STAGGER, STAND_UP, WALK, Crowd

Array = NDArray[np.float64]
BoolArray = NDArray[np.bool_]

FALL_TIMEOUT_S = 3.0  # a fall that never reaches the ground (leaning on someone) brakes anyway
STAND_UP_ABORT_RAD = math.radians(30.0)  # tilt this far above the stand-up reference: knocked over
STAND_UP_GRACE_S = 0.3
STAND_UP_SLACK_S = 3.0  # stand-up may take this much longer than getup_duration_s before giving up


def smoothstep(u: Array) -> Array:
    u = np.clip(u, 0.0, 1.0)
    out: Array = u * u * (3.0 - 2.0 * u)
    return out


def stand_up_reference(start_tilt: Array, elapsed: Array, duration: Array) -> Array:
    """The tilt the stand-up PD aims at ``elapsed`` seconds in: start_tilt → 0, smoothly."""
    out: Array = start_tilt * (1.0 - smoothstep(elapsed / duration))
    return out


@dataclass(frozen=True, slots=True)
class Readings:
    """What the state machine looks at, once per control tick (one entry per character)."""

    load: Array  # balance load, 0 upright and still, ≥ 1 beyond the bounded controller
    tilt: Array  # radians between the body axis and vertical
    speed: Array  # m/s of the centre of mass
    spin: Array  # rad/s
    face_up: BoolArray  # the body's face axis points up
    stand_up_error: Array  # radians of tilt above the stand-up reference (used in STAND_UP only)


def quiet(crowd: Crowd, load: Array) -> bool:
    """True when no machine can change this tick: everyone walking, nobody near staggering."""
    return bool((crowd.state == WALK).all() and (load < crowd.cols.stagger_ratio).all())


def readings(crowd: Crowd, t: float, load: Array | None = None) -> Readings:
    f, c = crowd.frames, crowd.cols
    reference = stand_up_reference(crowd.stand_up_start, t - crowd.entered, c.getup_duration_s)
    return Readings(
        load=crowd.balance_load() if load is None else load,
        tilt=f.tilt,
        speed=np.sqrt(np.sum(crowd.vel * crowd.vel, axis=1)),
        spin=np.sqrt(np.sum(crowd.ang * crowd.ang, axis=1)),
        face_up=f.face_up,
        stand_up_error=f.tilt - reference,
    )


def _held(crowd: Crowd, rows: BoolArray, condition: BoolArray, t: float, hold: Array) -> BoolArray:
    """For ``rows``: time ``condition`` (restarting when it breaks); True once it held for ``hold``."""
    since = crowd.since
    start = np.where(np.isnan(since), t, since)
    crowd.since = np.where(rows, np.where(condition, start, math.nan), since)
    out: BoolArray = rows & condition & (t - crowd.since >= hold - 1e-9)
    return out


def advance(crowd: Crowd, r: Readings, t: float) -> list[tuple[int, int, int]]:
    """Advance every character's machine one tick; returns (row, before, after) for each change."""
    c = crowd.cols
    s = crowd.state
    in_state = t - crowd.entered
    nxt = s.copy()
    upright = s <= STAGGER
    falls = upright & (r.load >= c.fall_ratio)
    nxt[falls] = FALL
    staggers = (s == WALK) & ~falls & (r.load >= c.stagger_ratio)
    nxt[staggers] = STAGGER
    staggering = (s == STAGGER) & ~falls
    nxt[_held(crowd, staggering, r.load < c.recover_ratio, t, c.recover_hold_s)] = WALK
    nxt[(s == FALL) & ((r.tilt >= c.ground_tilt) | (in_state >= FALL_TIMEOUT_S))] = BRAKE
    braking = s == BRAKE
    still = (r.speed < c.still_speed) & (r.spin < c.still_rate)
    nxt[_held(crowd, braking, still, t, c.still_hold_s)] = LIE
    lying = s == LIE
    moved = (r.speed > 3.0 * c.still_speed) | (r.spin > 3.0 * c.still_rate)
    nxt[lying & moved] = BRAKE
    nxt[lying & ~moved & (in_state >= c.lie_duration_s)] = STAND_UP
    rising = s == STAND_UP
    done = rising & (r.tilt < c.upright_tilt) & (r.load < c.stagger_ratio)
    nxt[done] = WALK
    knocked = (in_state > STAND_UP_GRACE_S) & (r.stand_up_error > STAND_UP_ABORT_RAD)
    nxt[rising & ~done & (knocked | (in_state > c.getup_duration_s + STAND_UP_SLACK_S))] = FALL
    changed = np.flatnonzero(nxt != s)
    if changed.size == 0:
        return []
    before = s[changed].tolist()
    after = nxt[changed]
    crowd.state = nxt
    crowd.entered[changed] = t
    crowd.since[changed] = math.nan
    to_lie = changed[after == LIE]
    crowd.face_up[to_lie] = r.face_up[to_lie].astype(np.int64)
    crowd.face_up[changed[(after != LIE) & (after != STAND_UP)]] = -1
    return list(zip(changed.tolist(), before, after.tolist(), strict=True))


def enter_state(client: int, crowd: Crowd, row: int, before: int, after: int, t: float,
                floor_friction: float) -> None:
    """What entering ``after`` does to character ``row``: frictionless feet while upright (the controller
    owns the horizontal force), the stand-up start pose, the time of the fall, a new heading goal."""
    mu = 0.0 if after <= STAGGER else floor_friction
    if crowd.friction_now[row] != mu:
        set_friction(client, crowd.bodies[row], mu)
        crowd.friction_now[row] = mu
    if after == STAND_UP:
        crowd.stand_up_start[row] = crowd.frames.tilt[row]
    elif after == FALL and math.isnan(crowd.fell_at[row]):
        crowd.fell_at[row] = t
    elif after == WALK:
        crowd.heading_goal[row] = crowd.frames.heading[row]
        if before == STAND_UP:
            on_stood_up(crowd, row, t)
        crowd.fell_at[row] = math.nan
