"""One quadruped walking a cube terrain to a goal, on its own pybullet client (tests and the bench).

No Mitake characters, no people: the locomotion, its pybullet body and the terrain's twin, updated at
``control_dt`` the way ``Quadrupeds.before_tick`` does, with the readings of the issue taken on pybullet's own
toe links every update (penetration into the cubes, slip of stance feet) and the cost of an update.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
import pybullet as p

from sim.config import WorldConfig
from sim.physics import open_client
from sim.quadruped.body import QuadrupedBody
from sim.quadruped.config import QuadrupedSpec
from sim.quadruped.footsteps import MotionModel
from sim.quadruped.gait import Locomotion
from sim.quadruped.metrics import SlipMeter, penetration
from sim.quadruped.planner import CostField, PlanCosts, PlanStatus
from sim.quadruped.skeleton import Skeleton, load_laikago
from sim.terrain import TerrainBody, TerrainConfig, TerrainGrid


@dataclass
class TrialResult:
    reached: bool
    status: PlanStatus | None  # of the last plan
    seconds: float  # simulated
    models: list[MotionModel]
    penetration_mm_max: float
    slip_mm: list[float]
    update_s: list[float] = field(default_factory=list)  # wall seconds per locomotion update + posing
    replans: int = 0
    paths: list[tuple[tuple[int, int], ...]] = field(default_factory=list)
    toes: list[tuple[float, ...]] = field(default_factory=list)  # every update's toe centres (flattened)


class Trial:
    """A grid of ``config`` on a fresh DIRECT client, with one quadruped loaded (``spec``)."""

    def __init__(self, config: TerrainConfig, spec: QuadrupedSpec | None = None,
                 skeleton: Skeleton | None = None, client: int | None = None) -> None:
        self.own_client = client is None
        self.client = open_client(WorldConfig())[0] if client is None else client
        self.spec = spec = spec if spec is not None else QuadrupedSpec()
        self.grid = TerrainGrid(config)
        self.terrain_body = TerrainBody(self.client, self.grid)
        self.field = CostField(self.grid, PlanCosts(spec.near_cost, spec.climb_cost, spec.climb_threshold))
        self.skeleton = skeleton if skeleton is not None else load_laikago(self.client, spec.scale, spec.urdf)
        self.body = QuadrupedBody(self.client, self.skeleton)

    def walk(self, start: tuple[float, float], heading: float, goal: tuple[float, float], seconds: float,
             control_dt: float = 1.0 / 30.0,
             during: Callable[[float, Locomotion], None] | None = None) -> TrialResult:
        """Walk from ``start`` to ``goal`` for at most ``seconds``; ``during(t, loco)`` runs before each
        update (to place cubes mid-walk). Stops once the goal is reached and all feet are down."""
        loco = Locomotion(self.spec, self.skeleton, self.grid, self.field, start, heading)
        loco.set_goal(goal, 0.0)
        slip = SlipMeter()
        pen = 0.0
        result = TrialResult(False, loco.status, 0.0, [], 0.0, [])
        r = self.skeleton.toe_radius
        t = 0.0
        for _ in range(int(math.ceil(seconds / control_dt))):
            if during is not None:
                during(t, loco)
            w0 = time.perf_counter()
            pose = loco.update(t, control_dt)
            self.body.apply(pose)
            result.update_s.append(time.perf_counter() - w0)
            toes = self.body.toes()
            result.toes.append(tuple(np.round(toes.ravel(), 9).tolist()))
            slip.add(toes, pose.stance)
            pen = max(pen, *(penetration(self.grid, toes[k], r) for k in range(4)))
            t += control_dt
            if loco.reached() and all(pose.stance) and loco.model is MotionModel.STAND:
                result.reached = True
                break
            if loco.route is not None and not loco.route.plan.ok and loco.model is MotionModel.STAND:
                break  # unreachable: reported, standing where it is
        result.seconds = t
        result.status = loco.status
        result.models = loco.trace.model_sequence()
        result.penetration_mm_max = pen * 1000.0
        result.slip_mm = [s * 1000.0 for s in slip.samples]
        result.replans = len(loco.trace.plans)
        result.paths = [plan.cells for _, plan in loco.trace.plans]
        return result

    def close(self) -> None:
        if self.own_client:
            p.disconnect(physicsClientId=self.client)
