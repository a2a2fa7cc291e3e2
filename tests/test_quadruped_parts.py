"""The quadruped's parts on their own: A* and eq. (2), local repair, Bezier swing clear of the cubes,
closed-form leg IK against pybullet's forward kinematics, DTW joins, footholds off the edges."""

from __future__ import annotations

import math

import numpy as np
import pybullet as p
import pytest

from sim.quadruped.footsteps import MotionModel, choose_foothold
from sim.quadruped.legs import bezier, dtw_blend, dtw_path, swing_control_points, swing_position
from sim.quadruped.motion_models import BodyStyle
from sim.quadruped.planner import CostField, PlanCosts, PlanStatus, Route, cell_costs, plan, replan
from sim.quadruped.skeleton import LEGS, load_laikago
from sim.terrain import TerrainConfig, TerrainGrid


def _grid(nx: int = 12, ny: int = 8) -> TerrainGrid:
    return TerrainGrid(TerrainConfig(cell=0.3, nx=nx, ny=ny, origin=(0.0, 0.0)))


def test_eq2_a_cube_raises_its_cell_and_neighbours() -> None:
    h = np.zeros((5, 5), dtype=np.int16)
    before = cell_costs(h, PlanCosts(near_cost=0.5))
    h[2, 2] = 1
    after = cell_costs(h, PlanCosts(near_cost=0.5))
    changed = np.argwhere(after != before)
    assert {tuple(c) for c in changed} == {(2, 2), (1, 2), (3, 2), (2, 1), (2, 3)}
    assert after[2, 2] == pytest.approx(1.0 + 4 * 0.5) and after[1, 2] == pytest.approx(1.5)


def test_astar_is_optimal_on_open_ground_and_deterministic() -> None:
    h = np.zeros((10, 10), dtype=np.int16)
    r = plan(h, (0, 0), (9, 4))
    assert r.status is PlanStatus.FOUND
    assert r.cost == pytest.approx(5 + 4 * math.sqrt(2))  # octile distance
    assert plan(h, (0, 0), (9, 4)).cells == r.cells


def test_climb_only_under_the_threshold() -> None:
    h = np.zeros((10, 5), dtype=np.int16)
    h[5, :] = 1  # a ridge one cube high across the grid: climbed
    r = plan(h, (1, 2), (8, 2))
    assert r.ok and any(h[c] == 1 for c in r.cells)
    h[5, :] = 2  # two high: over the threshold, no way round
    r = plan(h, (1, 2), (8, 2))
    assert r.status is PlanStatus.UNREACHABLE and r.reason and not r.cells
    h[5, 0] = 0  # a gap: around
    r = plan(h, (1, 2), (8, 2))
    assert r.ok and (5, 0) in r.cells
    strict = plan(h, (1, 2), (8, 2), PlanCosts(climb_cost=3.0, climb_threshold=6.0))  # two cubes allowed
    assert strict.ok


def test_no_diagonal_over_an_edge_and_no_one_cell_slot() -> None:
    h = np.zeros((6, 6), dtype=np.int16)
    h[2, 3] = 1
    r = plan(h, (1, 1), (4, 4))
    for a, b in zip(r.cells, r.cells[1:], strict=False):
        if a[0] != b[0] and a[1] != b[1]:  # diagonal moves only between level cells with level corners
            assert h[a] == h[b] == h[a[0], b[1]] == h[b[0], a[1]]
    h = np.zeros((7, 5), dtype=np.int16)
    h[3, :] = 2
    h[3, 2] = 0  # a one-cell slot in a two-high wall: too narrow for the body
    h[2, 2] = h[4, 2] = 0
    assert plan(h, (0, 2), (6, 2)).status is PlanStatus.UNREACHABLE


def test_pocket_and_outside() -> None:
    h = np.zeros((20, 20), dtype=np.int16)
    h[14:17, 14:17] = 2
    h[15, 15] = 0
    r = plan(h, (0, 0), (15, 15))
    assert r.status is PlanStatus.UNREACHABLE and r.expanded == 0  # found out by the pocket flood
    assert plan(h, (0, 0), (25, 0)).status is PlanStatus.GOAL_OUTSIDE
    assert plan(h, (-1, 0), (5, 0)).status is PlanStatus.START_OUTSIDE


def test_cost_field_follows_the_grid_and_repair_matches_a_valid_path() -> None:
    grid = _grid(30, 20)
    rng = np.random.default_rng(5)
    field = CostField(grid)
    for _ in range(60):
        grid.set_height(int(rng.integers(0, 30)), int(rng.integers(0, 20)), int(rng.integers(0, 3)))
        fresh = plan(grid.heights, (0, 0), (29, 19))
        kept = field.plan((0, 0), (29, 19))
        assert (fresh.status, fresh.cells) == (kept.status, kept.cells)
    grid2 = _grid(30, 10)
    field2 = CostField(grid2)
    route = Route(grid2, field2.plan((0, 5), (29, 5)))
    assert not route.touched()
    grid2.place(15, 5)
    grid2.place(15, 5)  # two high, on the path
    assert route.touched() and route.touched_cells() == [14, 15, 16]
    new = replan(field2, route, (0, 5), (29, 5))
    assert new.ok and (15, 5) not in new.cells and new.cells[0] == (0, 5) and new.cells[-1] == (29, 5)
    for a, b in zip(new.cells, new.cells[1:], strict=False):
        assert field2.move_cost(a, b) < math.inf


def test_swing_clears_a_cube_and_lands_exactly() -> None:
    grid = _grid()
    grid.set_height(5, 3, 1)
    r = 0.045
    start = np.array([1.40, 1.05, r])  # floor, 0.1 m before the cube's face (x = 1.5)
    end = np.array([1.65, 1.05, 0.3 + r])  # on its top
    control = swing_control_points(grid, start, end, lift=0.05, radius=r)
    assert np.allclose(control[0], start) and np.allclose(control[4], end)
    pts = bezier(control, np.linspace(0, 1, 400))
    need = np.array([grid.ground_z_max(x, y, r) for x, y in pts[:, :2]]) + r
    assert np.all(pts[:, 2] >= need - 1e-9)
    assert np.allclose(swing_position(control, 0.0), start) and np.allclose(swing_position(control, 1.0), end)


def test_leg_ik_matches_pybullet_forward_kinematics() -> None:
    client = p.connect(p.DIRECT)
    try:
        sk = load_laikago(client, 1.5)
        p.resetBasePositionAndOrientation(sk.body, (0, 0, 0), (0, 0, 0, 1), physicsClientId=client)
        rng = np.random.default_rng(2)
        for leg in LEGS:
            g = sk.legs[leg]
            for _ in range(20):
                target = g.abduction_at + np.array([rng.uniform(-0.25, 0.25), math.copysign(0.06, g.side_offset)
                                                    + rng.uniform(-0.1, 0.1), -rng.uniform(0.4, 0.68)])
                q, ok = g.solve(target)
                assert ok
                for j, v in zip(g.joints, q, strict=True):
                    p.resetJointState(sk.body, j, v, physicsClientId=client)
                toe = p.getLinkState(sk.body, g.toe_link, computeForwardKinematics=True, physicsClientId=client)[4]
                assert np.linalg.norm(np.array(toe) - target) < 1e-5
            assert not g.solve(g.abduction_at + np.array([0.0, 0.0, -2.0]))[1]  # out of reach: said so
    finally:
        p.disconnect(physicsClientId=client)


def test_dtw_aligns_and_blends_without_a_seam() -> None:
    a = np.sin(np.linspace(0, np.pi, 20))[:, None]
    b = np.sin(np.linspace(0, np.pi, 30))[:, None]  # the same shape, slower
    path = dtw_path(a, b)
    assert path[0] == (0, 0) and path[-1] == (19, 29)
    assert all(i2 - i1 in (0, 1) and j2 - j1 in (0, 1) for (i1, j1), (i2, j2) in zip(path, path[1:], strict=False))
    err = max(abs(a[i, 0] - b[j, 0]) for i, j in path)
    assert err < 0.1  # aligned, not index to index
    out = dtw_blend(np.linspace(0, 1, 10)[:, None], np.linspace(2, 3, 10)[:, None], 40)
    assert out[0, 0] == pytest.approx(0.0) and out[-1, 0] == pytest.approx(3.0)
    assert np.max(np.abs(np.diff(out[:, 0]))) < 0.2  # no jump anywhere


def test_body_style_switch_is_continuous() -> None:
    style = BodyStyle(cycle_s=1.0, scale=1.5)
    style.switch(MotionModel.WALK, 0.0)
    values = []
    t = 0.0
    for k in range(120):
        if k == 40:
            style.switch(MotionModel.CLIMB_UP, t)
        if k == 60:
            style.switch(MotionModel.TURN_LEFT, t)  # a switch in the middle of a join
        values.append(style.value(t))
        t += 1 / 60
    steps = np.abs(np.diff(np.array(values), axis=0)).max(axis=0)
    assert np.all(steps < 0.01)


def test_foothold_keeps_off_edges_and_prefers_the_hip_level() -> None:
    grid = _grid()
    grid.set_height(5, 3, 2)  # a column two high
    nominal = np.array([1.52, 1.05])  # just onto it
    spot, flat = choose_foothold(grid, nominal, level_z=0.0, margin=0.07, search=0.16)
    assert flat and spot[2] == 0.0 and spot[0] <= 1.5 - 0.07 + 1e-9  # back on the floor, clear of the face
    spot, flat = choose_foothold(grid, nominal, level_z=0.6, margin=0.07, search=0.16)
    assert flat and spot[2] == pytest.approx(0.6) and 1.5 + 0.07 - 1e-9 <= spot[0] <= 1.8 - 0.07 + 1e-9
