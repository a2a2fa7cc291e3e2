"""Who is on the stage: each person's size, mass, clips and path, decided from the config and its seed.

A person is a :class:`Person`: its :class:`PersonPlan` (id, body scale, clips, lane, heading,
pace, when it enters) and its path (a ``SegmentPath`` giving its pose at any time). ``route =
"round"`` gives the single performer of the demo (``Choreography``); ``"crossing"`` gives 1..4
people walking straight across the stage on their own lanes (:class:`Route`), half from each side.
Each starts just out of the webcam's view soon after the empty start (``empty_s`` plus up to
0.4 s), walks in, plays its action clips a little before the middle, and walks out on the other
side; people from opposite sides pass each other near the middle about 3.5 s after the empty
start (walkers of different paces from one side may overtake each other).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from jostle.performer.choreography import Choreography, SegmentPath, scaled_clip
from jostle.performer.config import PerformerConfig, load_clip
from sim.motion.mocap import MotionClip

MASS_AT_SCALE_1_KG = 70.0
"""Body mass of the scale-1 humanoid (1.6 m); a person of scale s weighs this × s² (constant BMI)."""

OFF_VIEW_M = 0.4  # people start this far beyond the edge of the webcam's view
LANE_SPACING_M = 0.6  # between neighbouring lanes (y); the lanes are centred on y = 0
WALK_PAST_M = 1.0  # how far past the far edge of the view each person walks before leaving


@dataclass(frozen=True)
class PersonPlan:
    """One person's part. ``rate`` is the walking pace relative to the clip's own (at this size)."""

    id: int
    clips: tuple[str, ...]
    size: float
    start_xy: tuple[float, float]
    heading_deg: float
    rate: float
    enter_s: float
    action_after_m: float

    @property
    def mass_kg(self) -> float:
        return MASS_AT_SCALE_1_KG * self.size**2

    @property
    def speed(self) -> float:
        """Walking speed along the path, m/s."""
        walk = load_clip(self.clips[0], True)
        return float(np.linalg.norm(walk.cycle_offset)) / walk.duration * self.size * self.rate


class Route(SegmentPath):
    """Walk straight from ``start`` along ``heading`` from time ``enter_s``; after ``action_after_m``
    play the action clips, then walk back onto the lane and on until ``length_m`` from the start."""

    def __init__(
        self,
        walk: MotionClip,
        actions: tuple[MotionClip, ...],
        *,
        start: tuple[float, float],
        heading: float,
        enter_s: float,
        action_after_m: float,
        length_m: float,
        rate: float,
        scale: float,
    ) -> None:
        super().__init__(walk, start_s=enter_s, state=(start[0], start[1], heading), turn_radius=0.3 * scale,
                         rate=rate, scale=scale)
        if not actions:
            self._add_walk(length_m, 0.0)
            return
        self._add_walk(action_after_m, 0.0)
        for clip in actions:
            self._action(clip)
        end = (start[0] + length_m * math.cos(heading), start[1] + length_m * math.sin(heading))
        self._go_to(*end)


@dataclass(frozen=True, eq=False)
class Person:
    plan: PersonPlan
    path: SegmentPath

    @property
    def id(self) -> int:
        return self.plan.id


def _sizes(config: PerformerConfig, rng: np.random.Generator) -> list[float]:
    """Given sizes, 1.0 for the round's single performer, else distinct sizes from 0.8..1.1."""
    if config.sizes:
        return [float(s) for s in config.sizes]
    if config.route == "round":
        return [1.0]
    n = config.people
    bins = rng.permutation(n)
    return [round(0.8 + 0.3 * (int(b) + float(rng.uniform(0.15, 0.85))) / n, 3) for b in bins]


def _clips(config: PerformerConfig, i: int) -> tuple[str, ...]:
    if config.person_clips:
        return tuple(config.person_clips[i].split("+"))
    actions = config.clips[1:]
    if actions:
        k = i % len(actions)
        actions = actions[k:] + actions[:k]
    return (config.clips[0], *actions)


def entry_x(config: PerformerConfig, lane_y: float) -> float:
    """How far left or right of the middle a person on lane y is out of the webcam's view."""
    half_fov = math.radians(config.camera_hfov_deg) / 2
    return (config.camera_distance_m + lane_y) * math.tan(half_fov) + OFF_VIEW_M


def plan_cast(config: PerformerConfig) -> tuple[PersonPlan, ...]:
    """Everyone's plan, deterministic from the config's seed, people, sizes and clips (not from its
    duration: a longer recording of the same seed begins with the same people doing the same)."""
    rng = np.random.default_rng([config.seed, 31])
    sizes = _sizes(config, rng)
    if config.route == "round":
        return (PersonPlan(0, config.clips, sizes[0], (0.0, 0.0), 0.0, 1.0, config.empty_s, 0.0),)
    n = config.people
    lanes = (np.arange(n) - (n - 1) / 2) * LANE_SPACING_M
    lanes = rng.permutation(lanes + rng.uniform(-0.04, 0.04, n))
    plans = []
    for i in range(n):
        direction = 1.0 if i % 2 == 0 else -1.0
        lane = round(float(lanes[i]), 4)
        start_x = -direction * entry_x(config, lane)
        rate = round(float(rng.uniform(1.0, 1.35)), 4)
        enter = round(config.empty_s + float(rng.uniform(0.0, 0.4)), 4)
        action_after = round(abs(start_x) * float(rng.uniform(0.6, 0.9)), 4)
        heading = 0.0 if direction > 0 else 180.0
        plans.append(PersonPlan(i, _clips(config, i), sizes[i], (round(start_x, 4), lane), heading, rate, enter,
                                action_after))
    return tuple(plans)


def build_cast(config: PerformerConfig) -> tuple[Person, ...]:
    """The people of the performance, each with a path to sample poses from."""
    cast = []
    for plan in plan_cast(config):
        walk = scaled_clip(load_clip(plan.clips[0], True), plan.size)
        actions = tuple(scaled_clip(load_clip(c), plan.size) for c in plan.clips[1:])
        path: SegmentPath
        if config.route == "round":
            hw = config.stage_half_width_m
            view_half = config.camera_distance_m * math.tan(math.radians(config.camera_hfov_deg) / 2)
            path = Choreography(walk, actions, entry_x=-(view_half + 0.7), turn_x=0.6 * hw, action_x=-0.35 * hw,
                                turn_radius=config.turn_radius_m * plan.size, empty_s=config.empty_s,
                                scale=plan.size)
        else:
            heading = math.radians(plan.heading_deg)
            across = 2 * abs(plan.start_xy[0]) + WALK_PAST_M
            path = Route(walk, actions, start=plan.start_xy, heading=heading, enter_s=plan.enter_s,
                         action_after_m=plan.action_after_m, length_m=across, rate=plan.rate, scale=plan.size)
        cast.append(Person(plan, path))
    return tuple(cast)
