"""One kind of quadruped (frozen, validated, TOML-shaped: configs/characters/quadruped.toml)."""

from __future__ import annotations

import math
from dataclasses import dataclass, fields


@dataclass(frozen=True)
class QuadrupedSpec:
    """A quadruped walking on the cube terrain (He, Tsai, Ko, Lu).

    Body: ``urdf`` (relative to pybullet_data, or absolute; laikago's joint names) at ``scale``
    (1.5: legs 0.75 m, so one 0.3 m cube is a step it can climb). Gait: the symmetrical gait, one leg
    swinging at a time for a quarter of ``cycle_s``; ``walk_speed`` on the flat (``climb_speed`` while
    climbing); feet lift ``step_height`` above the higher end of a step and land at least
    ``edge_margin`` from a cube's edge, within ``foot_search`` of where the gait would put them. The
    chassis stands ``stand_fraction`` of the straight-leg height above the feet.
    Path (eq. 2): ``near_cost``, ``climb_cost``, ``climb_threshold`` (see ``sim.quadruped.planner``).
    Pushes: a shove changes the body's velocity by impulse / mass; up to ``knock_speed`` m/s the body is
    offset (at most ``max_offset`` m) and springs back at ``recover_frequency`` rad/s while the gait
    steps under it; beyond, it falls (pybullet takes it), lies ``lie_s`` and gets up in ``getup_s``.
    ``waypoints`` (x0, y0, x1, y1, … stage metres) are walked in a loop when no person is near.
    """

    name: str = "quadruped"
    urdf: str = "laikago/laikago_toes_zup_lores.urdf"
    scale: float = 1.5
    walk_speed: float = 0.3
    climb_speed: float = 0.18
    cycle_s: float = 1.0
    step_height: float = 0.08
    edge_margin: float = 0.07
    foot_search: float = 0.16
    stand_fraction: float = 0.8
    turn_rate_deg: float = 45.0
    goal_tolerance: float = 0.3
    near_cost: float = 0.5
    climb_cost: float = 3.0
    climb_threshold: float = 3.0
    knock_speed: float = 0.9
    max_offset: float = 0.15
    recover_frequency: float = 3.0
    lie_s: float = 1.5
    getup_s: float = 2.0
    follow_people: bool = True  # walk to the nearest person when one is on the terrain
    waypoints: tuple[float, ...] = ()

    def __post_init__(self) -> None:
        if not isinstance(self.name, str) or not self.name.strip():
            raise ValueError(f"name: expected a non-empty string, got {self.name!r}")
        if not isinstance(self.urdf, str) or not self.urdf.endswith(".urdf"):
            raise ValueError(f"urdf: expected a .urdf path (relative to pybullet_data or absolute), got {self.urdf!r}")
        for f in fields(self):
            value = getattr(self, f.name)
            if f.type == "float" and (isinstance(value, bool) or not isinstance(value, int | float)
                                      or not math.isfinite(value)):
                raise ValueError(f"{f.name}: expected a finite number, got {value!r}")
        for name in ("scale", "walk_speed", "climb_speed", "cycle_s", "step_height", "edge_margin",
                     "foot_search", "stand_fraction", "turn_rate_deg", "goal_tolerance", "climb_cost",
                     "knock_speed", "max_offset", "recover_frequency", "lie_s", "getup_s"):
            if getattr(self, name) <= 0:
                raise ValueError(f"{name}: expected a number > 0, got {getattr(self, name)!r}")
        if not 0.3 <= self.stand_fraction <= 0.95:
            raise ValueError(f"stand_fraction: expected 0.3..0.95 of the straight-leg height, got {self.stand_fraction}")
        if self.near_cost < 0 or self.climb_threshold < 0:
            raise ValueError(f"near_cost: expected >= 0 (and climb_threshold >= 0), got {self.near_cost}, "
                             f"{self.climb_threshold}")
        if len(self.waypoints) % 2 or not all(isinstance(v, int | float) and math.isfinite(v)
                                              for v in self.waypoints):
            raise ValueError(f"waypoints: expected finite x, y pairs, got {self.waypoints!r}")
