"""Character AI: what each character wants — goal velocity, goal heading, behaviour B and intent.

Intents: ``idle`` (stand, face the nearest person), ``wander`` (walk between random points of the
stage, pausing), ``approach`` (walk up to the nearest person and stop at ``approach_distance``),
``flee`` (run away from whoever just pushed it, for ``flee_duration_s``, then back to its own intent).
Every intent keeps ``personal_space`` from the other characters (a separation velocity the world
computes for all characters at once) and stays on the stage. All randomness comes from the
``numpy.random.Generator`` the world injects.

Behaviour B (the keyframe set's dimension): ``"stand_up"`` while standing up, ``"walk"`` otherwise
(the paper's "walking and falling down").
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from sim.config import CharacterSpec
from sim.snapshot import CharacterState

INTENTS = ("idle", "wander", "approach", "flee")
BEHAVIOUR_WALK = "walk"
BEHAVIOUR_STAND_UP = "stand_up"

_ARRIVED_M = 0.2
_TURN_SPEED = 0.15  # below this goal speed the heading is not taken from the velocity
_EDGE_GAIN = 2.0  # 1/s, pull back onto the stage per metre outside the walkable area


@dataclass(frozen=True, slots=True)
class Stage:
    """The walkable rectangle (already shrunk by the character's stage margin)."""

    x_min: float
    x_max: float
    y_min: float
    y_max: float

    def shrunk(self, margin: float) -> Stage:
        cx, cy = 0.5 * (self.x_min + self.x_max), 0.5 * (self.y_min + self.y_max)
        hx = max(0.0, 0.5 * (self.x_max - self.x_min) - margin)
        hy = max(0.0, 0.5 * (self.y_max - self.y_min) - margin)
        return Stage(cx - hx, cx + hx, cy - hy, cy + hy)

    def pull_inside(self, x: float, y: float) -> tuple[float, float]:
        dx = (self.x_min - x) if x < self.x_min else (self.x_max - x) if x > self.x_max else 0.0
        dy = (self.y_min - y) if y < self.y_min else (self.y_max - y) if y > self.y_max else 0.0
        return _EDGE_GAIN * dx, _EDGE_GAIN * dy


def behaviour_for(state: CharacterState) -> str:
    """B for the keyframe set: standing up is its own behaviour; everything else walks (and falls)."""
    return BEHAVIOUR_STAND_UP if state is CharacterState.STAND_UP else BEHAVIOUR_WALK


@dataclass(frozen=True, slots=True)
class Goal:
    velocity: tuple[float, float]  # stage m/s
    heading: float  # radians from stage +x
    behaviour: str
    intent: str


class CharacterAI:
    def __init__(self, spec: CharacterSpec, intent: str, stage: Stage, rng: np.random.Generator,
                 heading: float) -> None:
        if intent not in INTENTS:
            raise ValueError(f"intent: expected one of {', '.join(INTENTS)}, got {intent!r}")
        self._spec = spec
        self._rng = rng
        self._stage = stage.shrunk(spec.stage_margin)
        self.base_intent = intent
        self.intent = intent
        self._heading = heading
        self._waypoint: tuple[float, float] | None = None
        self._waypoint_deadline = 0.0
        self._pause_until = 0.0
        self._flee_until = 0.0
        self._flee_direction = (0.0, 0.0)

    @property
    def waypoint(self) -> tuple[float, float] | None:
        """Where wandering is heading now (None when not wandering or pausing)."""
        return self._waypoint

    def notice_push(self, t: float, direction: tuple[float, float]) -> None:
        """Someone pushed it along ``direction`` (stage xy): flee that way for a while."""
        n = math.hypot(*direction)
        if n < 1e-9 or not math.isfinite(n):
            return
        self._flee_direction = (direction[0] / n, direction[1] / n)
        self._flee_until = t + self._spec.flee_duration_s
        self.intent = "flee"

    def _new_waypoint(self, t: float, x: float, y: float) -> None:
        st = self._stage
        wx = float(self._rng.uniform(st.x_min, st.x_max)) if st.x_max > st.x_min else st.x_min
        wy = float(self._rng.uniform(st.y_min, st.y_max)) if st.y_max > st.y_min else st.y_min
        self._waypoint = (wx, wy)
        self._waypoint_deadline = t + 3.0 * math.hypot(wx - x, wy - y) / self._spec.walk_speed + 2.0

    def _wander(self, t: float, x: float, y: float) -> tuple[float, float]:
        if t < self._pause_until:
            return 0.0, 0.0
        if self._waypoint is None or t > self._waypoint_deadline:
            self._new_waypoint(t, x, y)
        assert self._waypoint is not None
        dx, dy = self._waypoint[0] - x, self._waypoint[1] - y
        d = math.hypot(dx, dy)
        if d < _ARRIVED_M:
            self._waypoint = None
            self._pause_until = t + float(self._rng.exponential(self._spec.wander_pause_s)) \
                if self._spec.wander_pause_s > 0 else t
            return 0.0, 0.0
        speed = self._spec.walk_speed * min(1.0, d / 0.5)
        return speed * dx / d, speed * dy / d

    def decide(self, t: float, x: float, y: float, state: CharacterState,
               separation: tuple[float, float], nearest_person: tuple[float, float] | None) -> Goal:
        """The goal for this control tick. ``nearest_person`` is the closest contactor's stage xy."""
        spec = self._spec
        if self.intent == "flee" and t >= self._flee_until:
            self.intent = self.base_intent
        face: float | None = None
        vx = vy = 0.0
        if self.intent == "flee":
            if self._flee_until > 0.0:
                vx, vy = spec.flee_speed * self._flee_direction[0], spec.flee_speed * self._flee_direction[1]
            elif nearest_person is not None:  # asked to flee with no push yet: away from people
                dx, dy = x - nearest_person[0], y - nearest_person[1]
                d = math.hypot(dx, dy)
                if d > 1e-6:
                    vx, vy = spec.flee_speed * dx / d, spec.flee_speed * dy / d
        elif self.intent == "wander":
            vx, vy = self._wander(t, x, y)
        elif nearest_person is not None:  # idle or approach, someone there
            dx, dy = nearest_person[0] - x, nearest_person[1] - y
            d = math.hypot(dx, dy)
            if d > 1e-6:
                face = math.atan2(dy, dx)
                if self.intent == "approach":  # close in, or back off when crowded closer than asked
                    speed = spec.walk_speed * max(-1.0, min(1.0, (d - spec.approach_distance) / 0.5))
                    vx, vy = speed * dx / d, speed * dy / d
        ex, ey = self._stage.pull_inside(x, y)
        vx += separation[0] + ex
        vy += separation[1] + ey
        top = max(spec.walk_speed, spec.flee_speed)
        speed = math.hypot(vx, vy)
        if speed > top:
            vx, vy = vx * top / speed, vy * top / speed
            speed = top
        if speed > _TURN_SPEED:
            self._heading = math.atan2(vy, vx)
        elif face is not None:
            self._heading = face
        if state in (CharacterState.STAGGER, CharacterState.FALL, CharacterState.BRAKE, CharacterState.LIE,
                     CharacterState.STAND_UP):
            vx = vy = 0.0  # recovering: balance first
        return Goal(velocity=(vx, vy), heading=self._heading, behaviour=behaviour_for(state),
                    intent=self.intent)

    def reset_heading(self, heading: float) -> None:
        self._heading = heading


def separation_velocities(xy: np.ndarray, personal_space: np.ndarray, speed: np.ndarray) -> np.ndarray:
    """Per character, a velocity away from the others inside its personal space (all at once).

    ``xy`` is (N, 2); ``personal_space`` and ``speed`` are (N,). Each neighbour at distance d < s
    contributes (1 − d/s)·speed along the direction away from it.
    """
    n = xy.shape[0]
    if n < 2:
        return np.zeros((n, 2))
    diff = xy[:, None, :] - xy[None, :, :]
    dist = np.sqrt(np.sum(diff * diff, axis=2))
    np.fill_diagonal(dist, 1e6)  # never inside anyone's personal space
    s = personal_space[:, None]
    weight = np.where(dist < s, (1.0 - dist / s) / np.maximum(dist, 1e-6), 0.0) * speed[:, None]
    result: np.ndarray = np.sum(diff * weight[:, :, None], axis=1)
    return result
