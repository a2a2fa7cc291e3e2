"""The quadrupeds of a world as a ``sim.population.Population``, walking on the world's cube terrain.

``Quadrupeds`` holds each quadruped's locomotion and body and the planner's cost fields over the world's
``TerrainGrid`` (``sim.terrain``: the world owns it and its pybullet twin). Once per control tick, before
the physics substeps (``before_tick``): each quadruped reserves its cells, picks its goal (the nearest
person on the terrain when ``follow_people``, else its waypoints in a loop, else the goal it was given),
is shoved by the people touching it, updates its procedural locomotion and is put in its pose.
``snapshots`` reports them on the World's contract (``CharacterSnapshot``, ``kind`` = the spec's name,
``links`` = every link's pose). Pads and strikes do not act on them; people push them by touch.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pybullet as p
from numpy.typing import NDArray

from interaction.types import Contactor, Impulse
from sim.population import Footprint, Tick
from sim.quadruped.body import BodyMode, QuadrupedBody
from sim.quadruped.config import QuadrupedSpec
from sim.quadruped.gait import Locomotion, Pose
from sim.quadruped.metrics import SlipMeter, penetration
from sim.quadruped.planner import CostField, PlanCosts
from sim.quadruped.skeleton import load_laikago
from sim.snapshot import CharacterSnapshot, CharacterState, ContactEvent, LinkPose
from sim.terrain import TerrainGrid

__all__ = ["Member", "Quadrupeds"]

Array = NDArray[np.float64]

_PUSH_TRANSFER = 0.35  # share of a touching person's approach speed handed to the body per tick


@dataclass
class Member:
    spec: QuadrupedSpec
    loco: Locomotion
    body: QuadrupedBody
    waypoints: Array
    goal: tuple[float, float] | None = None
    next_waypoint: int = 0
    d_front: float = 0.0
    d_side: float = 0.0
    pose: Pose | None = None
    slip: SlipMeter = field(default_factory=SlipMeter)
    penetration_max: float = 0.0
    intent: str = "idle"


class Quadrupeds:
    def __init__(self, client: int, grid: TerrainGrid) -> None:
        self.client = client
        self.grid = grid
        self._fields: dict[PlanCosts, CostField] = {}
        self.members: dict[str, Member] = {}

    def __contains__(self, name: object) -> bool:
        return name in self.members

    def __len__(self) -> int:
        return len(self.members)

    @property
    def bodies(self) -> Mapping[int, str]:
        return {}  # people's contact forces on them are not reported (they push them by touch)

    def add(self, name: str, spec: Any, position: tuple[float, float], heading: float, t: float,
            **options: Any) -> None:
        """Options: ``goal`` (stage x, y) or ``waypoints`` (stage x, y; replaces the spec's loop)."""
        assert isinstance(spec, QuadrupedSpec)
        goal, waypoints = options.get("goal"), options.get("waypoints")
        costs = PlanCosts(spec.near_cost, spec.climb_cost, spec.climb_threshold)
        if costs not in self._fields:
            self._fields[costs] = CostField(self.grid, costs)
        skeleton = load_laikago(self.client, spec.scale, spec.urdf)
        loco = Locomotion(spec, skeleton, self.grid, self._fields[costs], position, heading, t)
        path = np.asarray(spec.waypoints if waypoints is None else waypoints, dtype=np.float64).reshape(-1, 2)
        member = Member(spec, loco, QuadrupedBody(self.client, skeleton), path, goal)
        self.members[name] = member
        member.pose = loco.update(t, 0.0)
        member.body.apply(member.pose)

    def footprints(self) -> Iterable[Footprint]:
        return ()  # each reserves its own cells as it walks

    def start_step(self) -> None:
        pass

    def reach(self, position: tuple[float, float, float]) -> float | None:
        return None

    def impulse(self, impulse: Impulse, t: float) -> None:
        raise ValueError("quadrupeds take no pad impulses")

    def strike(self, name: str, force: tuple[float, float, float], duration: float,
               at: tuple[float, float, float], t: float) -> None:
        raise ValueError(f"{name}: a quadruped is shoved (Quadrupeds.shove), not struck")

    def substeps(self) -> tuple[int, bool]:
        return 1, False

    def before_substep(self, dt: float, recovering: bool) -> None:
        pass

    def after_substep(self, t: float, dt: float, forces: Mapping[tuple[str, int], float]) -> None:
        pass

    def after_tick(self, tick: Tick) -> None:
        pass

    def notice(self, tick: Tick, ended: Sequence[ContactEvent]) -> None:
        pass

    def push_threshold(self, name: str) -> float:
        return math.inf

    def counts(self) -> Mapping[str, int]:
        return {}

    def set_goal(self, name: str, goal: tuple[float, float] | None) -> None:
        self.members[name].goal = goal

    def shove(self, name: str, dv: tuple[float, float, float], t: float) -> None:
        """Change quadruped ``name``'s velocity by ``dv`` (m/s): offset and recover, or knocked over."""
        m = self.members[name]
        if m.body.mode is not BodyMode.KINEMATIC:
            return
        if math.hypot(dv[0], dv[1]) > m.spec.knock_speed:
            m.body.knock(dv, t)
            m.slip.reset()
        else:
            m.loco.shove((dv[0], dv[1]))

    # ------------------------------------------------------------------ one control tick
    def before_tick(self, tick: Tick) -> None:
        """Before the physics substeps: walk, get up, or lie (the other characters' cells are reserved)."""
        t, dt, touches = tick.t, tick.dt, tick.contactors
        people = _people(touches)
        for name, m in self.members.items():
            if m.body.mode is BodyMode.KINEMATIC:
                self._walk(name, m, t, dt, touches, people)
            elif m.body.mode is BodyMode.FALLEN:
                lying = t - m.body.mode_since
                if lying >= m.spec.lie_s and (m.body.settled() or lying >= m.spec.lie_s + 5.0):
                    pos, orn = m.body.base()
                    heading = math.atan2(*_forward_xy(orn)[::-1])
                    m.loco.xy, m.loco.heading = pos[:2].copy(), heading
                    m.loco.offset[:] = 0.0
                    m.loco.offset_vel[:] = 0.0
                    m.loco.plant_all()
                    m.body.start_getup(m.loco.update(t, 0.0), t)
            elif m.body.getup(t, m.spec.getup_s):
                m.loco.set_goal(None, t)
                m.slip.reset()

    def _walk(self, name: str, m: Member, t: float, dt: float, touches: Sequence[Contactor],
              people: dict[int, Array]) -> None:
        loco, spec = m.loco, m.spec
        self.grid.reserve(name, self.grid.cells_within(float(loco.xy[0]), float(loco.xy[1]),
                                                       0.45 * spec.scale * 0.66))
        goal, m.intent = self._goal(m, people)
        loco.set_goal(goal, t)
        if loco.status is not None and not loco.route.plan.ok:  # type: ignore[union-attr]
            m.intent = "unreachable"
        for c in touches:  # people touching it push it
            d = np.array([loco.xy[0] + loco.offset[0] - c.position[0], loco.xy[1] + loco.offset[1] - c.position[1]])
            dist = float(np.hypot(*d))
            if dist < 0.35 * spec.scale + c.radius and dist > 1e-6:
                n = d / dist
                closing = float(np.dot(c.velocity[:2], n) - np.dot(loco.offset_vel, n))
                if closing > 0:
                    dv = _PUSH_TRANSFER * closing * n
                    self.shove(name, (float(dv[0]), float(dv[1]), 0.0), t)
        if m.body.mode is not BodyMode.KINEMATIC:
            return
        before = loco.xy.copy()
        m.pose = loco.update(t, dt)
        m.body.apply(m.pose)
        step = loco.xy - before
        cos_h, sin_h = math.cos(loco.heading), math.sin(loco.heading)
        m.d_front += float(step[0] * cos_h + step[1] * sin_h)
        m.d_side += float(step[0] * sin_h - step[1] * cos_h)
        toes = m.body.toes()
        m.slip.add(toes, m.pose.stance)
        r = m.body.skeleton.toe_radius
        m.penetration_max = max(m.penetration_max, *(penetration(self.grid, toes[k], r) for k in range(4)))

    def _goal(self, m: Member, people: dict[int, Array]) -> tuple[tuple[float, float] | None, str]:
        loco = m.loco
        if m.spec.follow_people and people:
            on_grid = [xy for xy in people.values() if self.grid.cell_of(float(xy[0]), float(xy[1])) is not None]
            if on_grid:
                near = min(on_grid, key=lambda xy: float(np.hypot(*(xy - loco.xy))))
                return (float(near[0]), float(near[1])), "approach"
        if len(m.waypoints):
            wp = m.waypoints[m.next_waypoint % len(m.waypoints)]
            if math.dist(loco.xy, wp) <= m.spec.goal_tolerance:
                m.next_waypoint += 1
                wp = m.waypoints[m.next_waypoint % len(m.waypoints)]
            return (float(wp[0]), float(wp[1])), "follow"
        return m.goal, "idle" if m.goal is None else "goal"

    # ------------------------------------------------------------------ reporting
    def snapshots(self) -> tuple[CharacterSnapshot, ...]:
        out = []
        for name, m in self.members.items():
            pos, orn = m.body.base()
            lin, ang = p.getBaseVelocity(m.body.body, physicsClientId=self.client)
            mode = m.body.mode
            fwd = _forward_xy(orn)
            pitch = math.asin(max(-1.0, min(1.0, _forward(orn)[2])))
            roll = math.asin(max(-1.0, min(1.0, _left(orn)[2])))
            if mode is BodyMode.KINEMATIC:
                state = CharacterState.STAGGER if float(np.hypot(*m.loco.offset)) > 0.03 else CharacterState.WALK
            elif mode is BodyMode.FALLEN:
                state = CharacterState.LIE if m.body.settled() else CharacterState.FALL
            else:
                state = CharacterState.STAND_UP
            behaviour = m.loco.model.value if mode is BodyMode.KINEMATIC else state.value
            out.append(CharacterSnapshot(
                name=name, position=(pos[0], pos[1], pos[2]), orientation=orn, velocity=lin, angular_velocity=ang,
                heading=math.atan2(fwd[1], fwd[0]), tilt=(-pitch, -roll), d_front=m.d_front, d_side=m.d_side,
                state=state, behaviour=behaviour, intent=m.intent, face_up=None, contact_force_n=0.0,
                height=float(pos[2]) + 0.1 * m.spec.scale, kind=m.spec.name,
                balance_load=min(float(np.hypot(*m.loco.offset)) / m.spec.max_offset, 1.0)
                if mode is BodyMode.KINEMATIC else 10.0,
                links=self._links(m)))
        return tuple(out)

    def _links(self, m: Member) -> tuple[LinkPose, ...]:
        body, c = m.body.body, self.client
        pos, orn = p.getBasePositionAndOrientation(body, physicsClientId=c)
        out = [LinkPose("chassis", pos, orn)]
        states = p.getLinkStates(body, list(range(len(m.body.skeleton.link_names))), computeForwardKinematics=True,
                                 physicsClientId=c)
        for name, s in zip(m.body.skeleton.link_names, states, strict=True):
            out.append(LinkPose(name, s[4], s[5]))
        return tuple(out)

    def foot_penetration_max(self) -> float:
        return max((m.penetration_max for m in self.members.values()), default=0.0)


def _people(touches: Sequence[Contactor]) -> dict[int, Array]:
    acc: dict[int, list[tuple[float, float]]] = {}
    for c in touches:
        acc.setdefault(c.person, []).append((c.position[0], c.position[1]))
    return {k: np.mean(np.array(v), axis=0) for k, v in acc.items()}


def _forward(orn: Sequence[float]) -> Array:
    return np.array(p.getMatrixFromQuaternion(orn)).reshape(3, 3)[:, 0]


def _left(orn: Sequence[float]) -> Array:
    return np.array(p.getMatrixFromQuaternion(orn)).reshape(3, 3)[:, 1]


def _forward_xy(orn: Sequence[float]) -> Array:
    out: Array = _forward(orn)[:2]
    return out

