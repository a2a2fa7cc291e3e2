"""The quadruped on the paper's scenes (He, Tsai, Ko, Lu, Figs. 11–13): pybullet DIRECT, the laikago body,
the procedural legs; motion models, replanning, unreachable goals, feet on the cubes, determinism."""

from __future__ import annotations

from collections.abc import Iterator

import numpy as np
import pytest

from jostle.bench.quadruped_trial import Trial
from sim.quadruped.footsteps import MotionModel as M
from sim.quadruped.footsteps import predict_models
from sim.quadruped.gait import Locomotion
from sim.quadruped.planner import PlanStatus
from sim.terrain import TerrainConfig

CFG = TerrainConfig(cell=0.3, nx=20, ny=10, origin=(0.0, 0.0), max_height=3)


@pytest.fixture
def trial() -> Iterator[Trial]:
    t = Trial(CFG)
    yield t
    t.close()


def _feet_ok(result) -> None:  # type: ignore[no-untyped-def]
    assert result.penetration_mm_max <= 5.0
    assert np.percentile(result.slip_mm, 95) <= 10.0
    assert max(result.slip_mm) <= 10.0


def test_obstacle_free_walk(trial: Trial) -> None:
    result = trial.walk(trial.grid.centre(2, 5), 0.0, trial.grid.centre(14, 5), 40.0)
    assert result.reached and result.models == [M.WALK, M.STAND]
    _feet_ok(result)
    assert trial.body.unreached == 0  # every IK target was reachable


def test_climb_up_and_down_one_cube(trial: Trial) -> None:
    for iy in range(CFG.ny):  # a ridge one cube high across the whole grid: it must climb
        trial.grid.set_height(9, iy, 1)
    start, goal = trial.grid.centre(3, 5), trial.grid.centre(16, 5)
    plan = trial.field.plan((3, 5), (16, 5))
    assert predict_models(trial.grid, plan.cells, 0.0) == [M.WALK, M.CLIMB_UP, M.CLIMB_DOWN, M.WALK]
    result = trial.walk(start, 0.0, goal, 60.0)
    assert result.reached
    assert result.models == [M.WALK, M.CLIMB_UP, M.CLIMB_DOWN, M.WALK, M.STAND]
    _feet_ok(result)
    tops = [z for z in np.array(result.toes).reshape(-1, 4, 3)[:, :, 2].ravel()]
    assert max(tops) > CFG.cell  # feet were on the cube (and lifted above it)


def test_two_cubes_high_goes_around_or_reports(trial: Trial) -> None:
    for iy in range(CFG.ny - 2):  # a wall two cubes high with a gap at the top end: around, never over
        trial.grid.set_height(9, iy, 2)
    result = trial.walk(trial.grid.centre(3, 3), 0.0, trial.grid.centre(15, 3), 80.0)
    assert result.reached
    assert M.CLIMB_UP not in result.models
    assert all(cell[1] >= CFG.ny - 2 for cell in result.paths[0] if cell[0] == 9)
    _feet_ok(result)


def test_turn_left_then_walk(trial: Trial) -> None:
    result = trial.walk(trial.grid.centre(6, 1), 0.0, trial.grid.centre(6, 8), 40.0)
    assert result.reached
    assert result.models[:2] == [M.TURN_LEFT, M.WALK]
    _feet_ok(result)


def test_turn_back(trial: Trial) -> None:
    result = trial.walk(trial.grid.centre(12, 5), 0.0, trial.grid.centre(3, 5), 50.0)
    assert result.reached
    assert result.models == [M.TURN_BACK, M.WALK, M.STAND]
    _feet_ok(result)


def test_cube_placed_on_the_path_mid_walk_changes_the_path(trial: Trial) -> None:
    placed: list[tuple[int, int]] = []

    def drop_wall(t: float, loco: Locomotion) -> None:
        if t >= 3.0 and not placed:  # people build a 2-high wall across the path ahead of it
            for iy in range(0, CFG.ny - 3):
                trial.grid.set_height(11, iy, 2)
                placed.append((11, iy))

    result = trial.walk(trial.grid.centre(3, 4), 0.0, trial.grid.centre(16, 4), 80.0, during=drop_wall)
    assert placed and result.reached
    assert len(result.paths) >= 2 and result.paths[0] != result.paths[-1]
    assert (11, 4) in result.paths[0]
    assert all(cell[1] >= CFG.ny - 3 for cell in result.paths[-1] if cell[0] == 11)  # through the gap
    _feet_ok(result)


def test_cube_off_the_path_keeps_it(trial: Trial) -> None:
    def drop_far(t: float, loco: Locomotion) -> None:
        if abs(t - 2.0) < 1e-6 or (2.0 <= t < 2.0 + 1 / 30 - 1e-9):
            trial.grid.place(18, 9)

    result = trial.walk(trial.grid.centre(3, 2), 0.0, trial.grid.centre(12, 2), 40.0, during=drop_far)
    assert result.reached and trial.grid.height(18, 9) == 1
    assert result.replans == 1  # the paper: a change that does not touch the path keeps the motion


def test_unreachable_goal_is_reported_not_walked_into(trial: Trial) -> None:
    goal_cell = (15, 5)
    for dx in (-1, 0, 1):  # the goal walled in by columns two cubes high
        for dy in (-1, 0, 1):
            if (dx, dy) != (0, 0):
                trial.grid.set_height(goal_cell[0] + dx, goal_cell[1] + dy, 2)
    start = trial.grid.centre(3, 5)
    result = trial.walk(start, 0.0, trial.grid.centre(*goal_cell), 10.0)
    assert not result.reached
    assert result.status is PlanStatus.UNREACHABLE
    assert result.seconds < 1.0  # it stopped at once
    assert result.models == [M.STAND]
    toes = np.array(result.toes[-1]).reshape(4, 3)
    assert np.all(np.abs(toes[:, 0] - start[0]) < 0.6)  # still where it started


def test_same_inputs_same_trace() -> None:
    traces = []
    for _ in range(2):
        trial = Trial(CFG)
        try:
            for iy in range(4, 7):
                trial.grid.set_height(8, iy, 1)
            result = trial.walk(trial.grid.centre(2, 2), 0.3, trial.grid.centre(15, 7), 12.0)
            traces.append((result.toes, result.models, result.paths))
        finally:
            trial.close()
    assert traces[0] == traces[1]
