"""Procedural locomotion of one quadruped (He, Tsai, Ko, Lu): path → footsteps → legs → body pose.

Pure numpy (no pybullet): ``Locomotion.update(t, dt)`` returns the ``Pose`` to put the body in — the
chassis (position, orientation) and the four toe centres — and ``sim.quadruped.body`` writes it to
pybullet through leg IK. Per update:
1. replan (A*, ``sim.quadruped.planner``) when the goal moved to another cell or the terrain changed on
   or beside the path ahead (the paper: a change off the path keeps the motion);
2. the body moves along the path polyline at the model's speed, its heading turning toward the path at
   ``turn_rate_deg``; a path leading behind makes it turn on the spot (turn back);
3. the symmetrical gait: every quarter cycle one leg (right fore, right rear, left fore, left rear; a
   turn starts with the fore leg on its side) swings on a 5-point Bezier curve clear of the cubes
   (``legs``) to a foothold predicted for the middle of its next stance (``footsteps``); stance feet
   never move;
4. the chassis stands over its feet: its height and pitch follow the surfaces under the front and rear
   feet (the keyframes adjusted to the terrain's heights), its roll half the side-to-side difference,
   plus the motion model's keyframes (``motion_models``, DTW-joined);
5. a shove offsets the body (spring-damper, bounded) and the gait steps under it again.
"""

from __future__ import annotations

import math
import time
from collections import deque
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from sim.quadruped.config import QuadrupedSpec
from sim.quadruped.footsteps import MotionModel, choose_foothold, climb_ahead, turn_model, wrap
from sim.quadruped.legs import swing_control_points, swing_position
from sim.quadruped.motion_models import BodyStyle
from sim.quadruped.planner import CostField, Plan, PlanStatus, Route, replan
from sim.quadruped.skeleton import LEGS, Skeleton
from sim.terrain import Cell, TerrainGrid

Array = NDArray[np.float64]

_LOOKAHEAD = 0.35  # m along the path: where the heading aims
_TRANSLATE_BELOW = math.radians(60.0)  # heading error above which it turns on the spot
_SWING_SHARE = 0.85  # of a quarter cycle: the rest has all four feet down
_TRACE_LENGTH = 1024  # entries of each kind the trace keeps


@dataclass(frozen=True, slots=True)
class Pose:
    """Where the body goes this update (stage frame)."""

    position: Array  # chassis origin
    orientation: tuple[float, float, float, float]  # x, y, z, w
    toes: Array  # (4, 3) toe-sphere centres, in LEGS order
    stance: tuple[bool, bool, bool, bool]
    velocity: Array  # chassis linear velocity (for the kinematic body's contacts)


@dataclass
class _Swing:
    leg: int
    control: Array
    t0: float
    duration: float
    start_surface: float
    end_surface: float


def _recent() -> deque[Any]:
    return deque(maxlen=_TRACE_LENGTH)


@dataclass
class Trace:
    """What the locomotion did lately (tests and the bench read it; bounded, for a kiosk running all day)."""

    models: deque[tuple[float, MotionModel]] = field(default_factory=_recent)
    plans: deque[tuple[float, Plan]] = field(default_factory=_recent)
    replan_ms: deque[float] = field(default_factory=_recent)
    footholds: deque[tuple[float, int, tuple[float, float, float], bool]] = field(default_factory=_recent)

    def model_sequence(self) -> list[MotionModel]:
        out: list[MotionModel] = []
        for _, m in self.models:
            if not out or out[-1] != m:
                out.append(m)
        return out


def yaw_pitch_roll_quaternion(yaw: float, pitch: float, roll: float) -> tuple[float, float, float, float]:
    """R = Rz(yaw)·Ry(−pitch)·Rx(roll): ``pitch`` > 0 lifts the nose (x forward, y left, z up)."""
    cy, sy = math.cos(yaw / 2), math.sin(yaw / 2)
    cp, sp = math.cos(-pitch / 2), math.sin(-pitch / 2)
    cr, sr = math.cos(roll / 2), math.sin(roll / 2)
    return (sr * cp * cy - cr * sp * sy, cr * sp * cy + sr * cp * sy, cr * cp * sy - sr * sp * cy,
            cr * cp * cy + sr * sp * sy)


class Locomotion:
    def __init__(self, spec: QuadrupedSpec, skeleton: Skeleton, grid: TerrainGrid, field_: CostField,
                 xy: tuple[float, float], heading: float, t: float = 0.0) -> None:
        self.spec, self.grid, self.field = spec, grid, field_
        if not skeleton.toe_radius < spec.edge_margin < grid.config.cell / 2:
            raise ValueError(f"edge_margin: expected between the toe radius {skeleton.toe_radius:.3f} m and half a "
                             f"cube {grid.config.cell / 2:.3f} m (feet land clear of edges), got {spec.edge_margin}")
        self.hips = np.array([skeleton.hip(leg)[:2] for leg in LEGS])  # chassis x, y
        legs = skeleton.legs
        self.feet_nominal = np.array([[legs[leg].abduction_at[0], legs[leg].abduction_at[1] + legs[leg].side_offset]
                                      for leg in LEGS])
        self.toe_radius = skeleton.toe_radius
        self.body_height = spec.stand_fraction * skeleton.stand_height  # chassis origin over toe centres
        front, rear = float(self.hips[0, 0]), float(self.hips[1, 0])
        self.hip_span = front - rear
        self.rear_share = -rear / self.hip_span  # chassis origin between rear (0) and front (1) hips
        self.hip_width = float(self.hips[2, 1] - self.hips[0, 1])
        self.xy = np.array(xy, dtype=np.float64)
        self.heading = float(heading)
        self.offset = np.zeros(2)
        self.offset_vel = np.zeros(2)
        self.goal: tuple[float, float] | None = None
        self.goal_cell: Cell | None = None
        self.route: Route | None = None
        self.points = self.xy[None, :].copy()
        self.cum = np.zeros(1)
        self.s = 0.0
        self.model = MotionModel.STAND
        self.style = BodyStyle(spec.cycle_s, spec.scale)
        self.trace = Trace()
        self.feet = np.zeros((4, 3))
        self.surface = np.zeros(4)
        self._swing: _Swing | None = None
        self._next_leg = 0
        self._last_leg = -1
        self._slot_t = t
        self._speed = 0.0
        self._prev_pos: Array | None = None
        self.plant_all()

    # ------------------------------------------------------------------ goals and paths
    @property
    def status(self) -> PlanStatus | None:
        """The last plan's status (None before any goal)."""
        return self.route.plan.status if self.route is not None else None

    def set_goal(self, goal: tuple[float, float] | None, t: float) -> None:
        """Walk to stage ``goal`` (None: stop where it is). Replans when it lies in another cell."""
        self.goal = goal
        cell = None if goal is None else self.grid.cell_index(*goal)
        if cell != self.goal_cell:
            self.goal_cell = cell
            self._replan(t)

    def reached(self) -> bool:
        return self.goal is not None and math.dist(self.xy, self.goal) <= self.spec.goal_tolerance

    def _replan(self, t: float, repair: bool = False) -> None:
        if self.goal is None or self.goal_cell is None:
            self.route = None
            self._set_path(self.xy[None, :])
            return
        start = self.grid.cell_index(float(self.xy[0]), float(self.xy[1]))
        t0 = time.perf_counter()
        if repair:  # the terrain changed on the path: go around the change if that is enough
            plan = replan(self.field, self.route, start, self.goal_cell, self._path_cell_index())
        else:
            plan = self.field.plan(start, self.goal_cell)
        self.trace.replan_ms.append((time.perf_counter() - t0) * 1000.0)
        self.trace.plans.append((t, plan))
        self.route = Route(self.grid, plan)
        if not plan.ok:  # unreachable (reported through status): stay, never walk into it
            self._set_path(self.xy[None, :])
            return
        centres = [self.grid.centre(*c) for c in plan.cells[1:]]
        if plan.cells[-1] == self.goal_cell and centres:
            centres[-1] = self.goal
        self._set_path(np.array([self.xy, *centres]))

    def _set_path(self, points: Array) -> None:
        self.points = np.asarray(points, dtype=np.float64).reshape(-1, 2)
        seg = np.hypot(*np.diff(self.points, axis=0).T) if len(self.points) > 1 else np.zeros(0)
        self.cum = np.concatenate([[0.0], np.cumsum(seg)])
        self.s = 0.0

    def _at(self, s: float) -> Array:
        return np.array([np.interp(s, self.cum, self.points[:, 0]), np.interp(s, self.cum, self.points[:, 1])])

    def _path_cell_index(self) -> int:
        if self.route is None or not self.route.plan.cells:
            return 0
        return int(np.searchsorted(self.cum, self.s, side="right"))

    # ------------------------------------------------------------------ feet
    def plant_all(self) -> None:
        """Put every foot down where the gait would stand it now (a fresh start or after getting up)."""
        self._swing = None
        for k in range(4):
            spot, _ = choose_foothold(self.grid, self._nominal_foot(k, self.xy + self.offset, self.heading),
                                      self._level(k, self.xy, self.heading), self.spec.edge_margin,
                                      self.spec.foot_search)
            self.feet[k] = (spot[0], spot[1], spot[2] + self.toe_radius)
            self.surface[k] = spot[2]

    def _nominal_foot(self, k: int, xy: Array, heading: float) -> Array:
        c, s = math.cos(heading), math.sin(heading)
        fx, fy = self.feet_nominal[k]
        out: Array = xy + np.array([c * fx - s * fy, s * fx + c * fy])
        return out

    def _level(self, k: int, xy: Array, heading: float) -> float:
        c, s = math.cos(heading), math.sin(heading)
        hx, hy = self.hips[k]
        return self.grid.ground_z(float(xy[0] + c * hx - s * hy), float(xy[1] + s * hx + c * hy))

    def _path_levels(self, s: float, xy: Array) -> list[int]:
        """Column heights (cubes) the path crosses within a body length of arc length ``s``, and the one
        under ``xy``: the levels a foot may land on (never onto a wall beside the path)."""
        span = self.hip_span + 0.3 * self.spec.scale
        c = self.grid.config
        levels = {int(round(self.grid.ground_z(float(xy[0]), float(xy[1])) / c.cell))}
        if len(self.points) > 1:
            for a in np.linspace(max(s - span, 0.0), min(s + span, float(self.cum[-1])), 16):
                x, y = self._at(float(a))
                levels.add(int(round(self.grid.ground_z(float(x), float(y)) / c.cell)))
        return sorted(levels)

    def _needs_steps(self, xy: Array) -> bool:
        for k in range(4):
            if np.hypot(*(self.feet[k, :2] - self._nominal_foot(k, xy, self.heading))) > 0.06 * self.spec.scale:
                return True
        return False

    # ------------------------------------------------------------------ pushes
    def shove(self, dv: tuple[float, float]) -> None:
        """A push that changed the body's horizontal velocity by ``dv`` (m/s); the caller decides falls."""
        self.offset_vel += np.asarray(dv, dtype=np.float64)

    # ------------------------------------------------------------------ one update
    def update(self, t: float, dt: float) -> Pose:
        spec = self.spec
        if self.route is not None and self.route.touched(self._path_cell_index()):
            self._replan(t, repair=True)
        remaining = float(self.cum[-1] - self.s)
        moving = self.goal is not None and self.route is not None and self.route.plan.ok and not (
            remaining < 1e-6 or self.reached())
        target = self.heading
        if moving:
            aim = self._at(min(self.s + _LOOKAHEAD, float(self.cum[-1])))
            if np.hypot(*(aim - self.xy)) > 1e-6:
                target = math.atan2(aim[1] - self.xy[1], aim[0] - self.xy[0])
        err = wrap(target - self.heading)
        rate = math.radians(spec.turn_rate_deg)
        self.heading = wrap(self.heading + max(-rate * dt, min(rate * dt, err)))
        model = self._model(moving, err)
        speed = 0.0
        if moving and abs(err) < _TRANSLATE_BELOW:
            base = spec.climb_speed if model in (MotionModel.CLIMB_UP, MotionModel.CLIMB_DOWN) else spec.walk_speed
            speed = base * math.cos(err)
            self.s = min(self.s + speed * dt, float(self.cum[-1]))
            self.xy = self._at(self.s)
        self._speed = speed
        # push offset: critically damped spring back, bounded
        w = spec.recover_frequency
        acc = -2.0 * w * self.offset_vel - w * w * self.offset
        self.offset_vel += acc * dt
        self.offset += self.offset_vel * dt
        norm = float(np.hypot(*self.offset))
        if norm > spec.max_offset:
            self.offset *= spec.max_offset / norm
            self.offset_vel *= 0.0
        body_xy = self.xy + self.offset
        turning = abs(err) > math.radians(2.0)
        self._gait(t, moving or turning or self._needs_steps(body_xy) or norm > 0.02, model, err)
        if model != self.model or not self.trace.models:
            self.trace.models.append((t, model))
            self.model = model
        self.style.switch(model, t)
        return self._pose(t, dt, body_xy)

    def _model(self, moving: bool, err: float) -> MotionModel:
        if not moving:
            return MotionModel.STAND if self._swing is None else self.model
        turn = turn_model(err)
        if self.model is MotionModel.TURN_BACK and turn is not None:
            return MotionModel.TURN_BACK  # a turn back lasts until it faces the path (no left/right on the way)
        if turn is MotionModel.TURN_BACK:
            return turn
        rear = -self.hip_span * self.rear_share
        front = self.hip_span * (1.0 - self.rear_share)
        climb = climb_ahead(self.grid, self.points, self.s + rear - 0.1, self.s + front + 0.5 * self.spec.walk_speed
                            * self.spec.cycle_s, self.cum, centre=self.s)
        if climb is not None:
            return climb
        return turn or MotionModel.WALK

    def _gait(self, t: float, active: bool, model: MotionModel, err: float) -> None:
        spec = self.spec
        slot = spec.cycle_s / 4.0
        if self._swing is not None:
            sw = self._swing
            if t >= sw.t0 + sw.duration - 1e-9:
                self.feet[sw.leg] = sw.control[4]
                self.surface[sw.leg] = sw.end_surface
                self._swing = None
        if self._swing is not None or t < self._slot_t - 1e-9:
            return
        if not active:
            self._slot_t = t
            return
        if model != self.model and model in (MotionModel.TURN_LEFT, MotionModel.TURN_RIGHT, MotionModel.TURN_BACK):
            side_fore = LEGS.index("FL") if err > 0 else LEGS.index("FR")  # the turning side's fore leg first
            if side_fore != self._last_leg:
                self._next_leg = side_fore
        k = self._next_leg
        self._next_leg = (k + 1) % 4
        self._last_leg = k
        duration = _SWING_SHARE * slot
        self._slot_t = t + slot
        # foothold for the middle of the coming stance, on the body pose predicted for then
        ahead = duration + 0.5 * (spec.cycle_s - duration)
        s_pred = min(self.s + self._speed * ahead, float(self.cum[-1]))
        xy_pred = self._at(s_pred) if len(self.points) > 1 else self.xy.copy()
        aim = self._at(min(s_pred + _LOOKAHEAD, float(self.cum[-1])))
        heading_pred = self.heading
        if np.hypot(*(aim - xy_pred)) > 1e-6 and self.goal is not None and not self.reached():
            e = wrap(math.atan2(aim[1] - xy_pred[1], aim[0] - xy_pred[0]) - self.heading)
            limit = math.radians(spec.turn_rate_deg) * ahead
            heading_pred = self.heading + max(-limit, min(limit, e))
        spot, flat = choose_foothold(self.grid, self._nominal_foot(k, xy_pred, heading_pred),
                                     self._level(k, xy_pred, heading_pred), spec.edge_margin, spec.foot_search,
                                     levels=self._path_levels(s_pred, xy_pred),
                                     stay=np.array([*self.feet[k, :2], self.surface[k]]))
        end = np.array([spot[0], spot[1], spot[2] + self.toe_radius])
        self.trace.footholds.append((t, k, (float(end[0]), float(end[1]), float(end[2])), flat))
        control = swing_control_points(self.grid, self.feet[k].copy(), end, spec.step_height * spec.scale,
                                       self.toe_radius)
        self._swing = _Swing(k, control, t, duration, float(self.surface[k]), float(spot[2]))

    def _pose(self, t: float, dt: float, body_xy: Array) -> Pose:
        toes = self.feet.copy()
        support = self.surface.copy()
        stance = [True, True, True, True]
        if self._swing is not None:
            sw = self._swing
            u = min(max((t - sw.t0) / sw.duration, 0.0), 1.0)
            toes[sw.leg] = swing_position(sw.control, u)
            e = u * u * (3.0 - 2.0 * u)
            support[sw.leg] = (1.0 - e) * sw.start_surface + e * sw.end_surface
            stance[sw.leg] = False
        front = 0.5 * (support[0] + support[2])
        rear = 0.5 * (support[1] + support[3])
        right = 0.5 * (support[0] + support[1])
        left = 0.5 * (support[2] + support[3])
        dz, dpitch, droll = self.style.value(t)
        base = self.toe_radius + self.body_height + dz
        pitch = math.asin(max(-0.9, min(0.9, (front - rear) / self.hip_span))) + dpitch
        roll = math.asin(max(-0.5, min(0.5, 0.5 * (left - right) / self.hip_width))) + droll
        z = rear + self.rear_share * (front - rear) + base
        position = np.array([body_xy[0], body_xy[1], z])
        velocity = np.zeros(3) if self._prev_pos is None or dt <= 0 else (position - self._prev_pos) / dt
        self._prev_pos = position
        orientation = yaw_pitch_roll_quaternion(self.heading, pitch, roll)
        return Pose(position, orientation, toes, (stance[0], stance[1], stance[2], stance[3]), velocity)
