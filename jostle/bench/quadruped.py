"""``jostle bench quadruped``: the quadruped on generated cube terrains (issue 10's checks).

Walks: ``--terrains`` seeded terrains of ``--walk-size``² cells (0.3 m cubes; blocks one or two cubes
high, some walls), each with a start and a goal on the floor far apart (every fourth goal walled in);
mid-walk a cube is dropped on the path ahead (a replan). A goal A* cannot reach on the terrain as built is counted apart (``unreachable``)
and must be reported, not walked to: ``goals_reached`` is the fraction of the REACHABLE ones reached
within a time limit, ``unreachable_reported`` the fraction of the others that ended standing with the
planner's UNREACHABLE.
Feet, read on pybullet's toe links every update: ``foot_penetration_mm_max`` (deepest any toe sphere
went into a cube or the floor), ``foot_slip_mm_p95`` (stance toes' distance from where they landed).
Replanning on ``--replan-size``² (64 by default): random blocks, a plan, then cubes placed one by one on
the path a few cells ahead of a walker, each followed by the replan the locomotion does
(``planner.replan``: a local repair around the change — a bounded A* that rejoins the path — else A* in
full): ``replan_ms_p50`` / ``replan_ms_p99`` time the cost-field update plus that replan (CPU time of the
thread: the machine is shared; ``replan_wall_ms_p99`` is the wall-clock figure);
``full_astar_ms_p50`` / ``_p99`` time A* in full from the same spot for comparison. ``fps``: locomotion updates (gait, legs, IK, posing the pybullet body) per wall second
for one character.
"""

from __future__ import annotations

import argparse
import time
from typing import Any

import numpy as np

TARGETS = {"foot_penetration_mm_max": 5.0, "foot_slip_mm_p95": 10.0, "replan_ms_p99": 5.0}


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--terrains", type=int, default=6, help="generated terrains to walk (default 6)")
    parser.add_argument("--walk-size", type=int, default=24, help="cells per side of a walk terrain (default 24)")
    parser.add_argument("--replan-size", type=int, default=64, help="cells per side for replanning (default 64)")
    parser.add_argument("--replans", type=int, default=300, help="cube placements to replan after (default 300)")
    parser.add_argument("--seed", type=int, default=0)


def run(args: argparse.Namespace) -> dict[str, Any]:
    if args.terrains < 1 or args.walk_size < 12 or args.replan_size < 24 or args.replans < 1:
        raise SystemExit("jostle bench quadruped: expected --terrains >= 1, --walk-size >= 12, "
                         "--replan-size >= 24, --replans >= 1")
    return measure(args.terrains, args.walk_size, args.replan_size, args.replans, args.seed)


def generate(heights: np.ndarray, rng: np.random.Generator, blocks: int, walls: int) -> None:
    """Blocks (1–4 cells a side, one or two cubes high) and walls (a line of two-high columns)."""
    nx, ny = heights.shape
    for _ in range(blocks):
        x, y = rng.integers(0, nx), rng.integers(0, ny)
        w, d = rng.integers(1, 5, size=2)
        heights[x:x + w, y:y + d] = 1 if rng.random() < 0.7 else 2
    for _ in range(walls):
        if rng.random() < 0.5:
            x, y0 = rng.integers(2, nx - 2), rng.integers(0, ny)
            heights[x, y0:y0 + rng.integers(3, ny // 2)] = 2
        else:
            y, x0 = rng.integers(2, ny - 2), rng.integers(0, nx)
            heights[x0:x0 + rng.integers(3, nx // 2), y] = 2


def measure(terrains: int, walk_size: int, replan_size: int, replans: int, seed: int) -> dict[str, Any]:
    from jostle.bench.quadruped_trial import Trial
    from sim.quadruped.planner import PlanStatus
    from sim.terrain import TerrainConfig

    rng = np.random.default_rng(seed)
    cfg = TerrainConfig(cell=0.3, nx=walk_size, ny=walk_size, origin=(0.0, 0.0), max_height=3)
    reached = reachable = unreachable = reported = 0
    pen: list[float] = []
    slip: list[float] = []
    update_s: list[float] = []
    walk_replans = 0
    trial = Trial(cfg)
    skeleton, client = trial.skeleton, trial.client
    try:
        for k in range(terrains):
            if k:
                trial = Trial(cfg, skeleton=skeleton, client=client)
            heights = np.zeros((walk_size, walk_size), dtype=np.int64)
            generate(heights, rng, blocks=walk_size // 2, walls=2)
            start, goal = _ends(heights, rng)
            heights[max(start[0] - 2, 0):start[0] + 3, max(start[1] - 2, 0):start[1] + 3] = 0  # room to stand
            if k % 4 == 3:  # every fourth goal walled in by columns two cubes high: unreachable, to be reported
                gx, gy = goal
                heights[max(gx - 1, 0):gx + 2, max(gy - 1, 0):gy + 2] = 2
                heights[goal] = 0
            for (ix, iy), h in np.ndenumerate(heights):
                if h:
                    trial.grid.set_height(ix, iy, int(h))
            ok = trial.field.plan(start, goal).ok
            dropped: list[bool] = []

            def drop(t: float, loco: Any, dropped: list[bool] = dropped, trial: Any = trial) -> None:
                if t < 4.0 or dropped or loco.route is None or not loco.route.plan.ok:
                    return
                cells = loco.route.plan.cells
                i = loco._path_cell_index() + 4  # a few cells ahead of it
                if i < len(cells) - 1:
                    dropped.append(trial.grid.place(*cells[i]).changed)

            path_m = 0.3 * (abs(goal[0] - start[0]) + abs(goal[1] - start[1]))
            result = trial.walk(trial.grid.centre(*start), float(rng.uniform(-np.pi, np.pi)),
                                trial.grid.centre(*goal), 40.0 + 6.0 * path_m, during=drop)
            if ok:
                reachable += 1
                reached += result.reached
            else:
                unreachable += 1
                reported += result.status is PlanStatus.UNREACHABLE and not result.reached
            pen.append(result.penetration_mm_max)
            slip.extend(result.slip_mm)
            update_s.extend(result.update_s)
            walk_replans += result.replans
            _clear(trial)
    finally:
        trial.close()
        import pybullet as p

        if p.isConnected(physicsClientId=client):
            p.disconnect(physicsClientId=client)
    replan, replan_wall, full = _replan_times(replan_size, replans, rng)
    figures: dict[str, Any] = {
        "terrains": terrains,
        "walk_size": walk_size,
        "reachable": reachable,
        "goals_reached": reached / reachable if reachable else None,
        "unreachable": unreachable,
        "unreachable_reported": reported / unreachable if unreachable else None,
        "foot_penetration_mm_max": round(max(pen), 4),
        "foot_slip_mm_p95": round(float(np.percentile(slip, 95)), 4) if slip else None,
        "foot_slip_mm_max": round(max(slip), 4) if slip else None,
        "walk_replans": walk_replans,
        "replan_size": replan_size,
        "replan_ms_p50": round(float(np.percentile(replan, 50)), 3),
        "replan_ms_p99": round(float(np.percentile(replan, 99)), 3),
        "replan_ms_max": round(float(np.max(replan)), 3),
        "replan_wall_ms_p99": round(float(np.percentile(replan_wall, 99)), 3),
        "full_astar_ms_p50": round(float(np.percentile(full, 50)), 3),
        "full_astar_ms_p99": round(float(np.percentile(full, 99)), 3),
        "fps": round(1.0 / float(np.mean(update_s)), 1),
        "targets": TARGETS,
    }
    return figures


def _ends(heights: np.ndarray, rng: np.random.Generator) -> tuple[tuple[int, int], tuple[int, int]]:
    """A start near one side and a goal on the floor near the other."""
    n = heights.shape[0]
    while True:
        start = (int(rng.integers(2, 5)), int(rng.integers(2, n - 2)))
        goal = (int(rng.integers(n - 5, n - 2)), int(rng.integers(2, n - 2)))
        if heights[goal] == 0:
            return start, goal


def _clear(trial: Any) -> None:
    """Take every cube off (the pybullet twin follows), so the client can serve the next terrain."""
    nx, ny = trial.grid.shape
    for ix in range(nx):
        for iy in range(ny):
            trial.grid.set_height(ix, iy, 0)


def _replan_times(size: int, count: int, rng: np.random.Generator) -> tuple[list[float], list[float], list[float]]:
    """Milliseconds after each cube placed on the path a few cells ahead of a walker on a ``size``² grid:
    CPU time of what the locomotion does (cost-field update + local repair, else A* in full), the same
    in wall time, and CPU time of A* in full alone. CPU time (``time.thread_time``) because this machine
    is shared: wall time also counts the moments another process had the core."""
    from sim.quadruped.planner import CostField, Route, replan
    from sim.terrain import TerrainConfig, TerrainGrid

    out: list[float] = []
    wall: list[float] = []
    full: list[float] = []
    for _ in range(50 * count):  # (bounded: a terrain gives up to 12 placements, some none)
        if len(out) >= count:
            break
        grid = TerrainGrid(TerrainConfig(nx=size, ny=size, origin=(0.0, 0.0)))
        heights = np.zeros((size, size), dtype=np.int64)
        generate(heights, rng, blocks=size * size // 40, walls=size // 16)
        for (ix, iy), h in np.ndenumerate(heights):
            if h:
                grid.set_height(ix, iy, int(h))
        field = CostField(grid)
        start, goal = _ends(heights, rng)
        route = Route(grid, field.plan(start, goal))
        here = 0
        for _ in range(12):
            cells = route.plan.cells
            if not route.plan.ok or len(cells) - here < 8:
                break
            here += int(rng.integers(0, 4))  # the walker moved on
            cell = cells[here + int(rng.integers(2, 6))]
            w0, t0 = time.perf_counter(), time.thread_time()
            grid.place(*cell)  # the cost field updates itself (listener)
            plan = replan(field, route, cells[here], goal, here) if route.touched(here) else route.plan
            t1, w1 = time.thread_time(), time.perf_counter()
            field.plan(cells[here], goal)
            full.append((time.thread_time() - t1) * 1000.0)
            out.append((t1 - t0) * 1000.0)
            wall.append((w1 - w0) * 1000.0)
            route, here = Route(grid, plan), 0
    return out[:count], wall[:count], full[:count]
