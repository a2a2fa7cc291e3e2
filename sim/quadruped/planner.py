"""Path planning over the cube grid (He, Tsai, Ko, Lu §B): A*, eq. (1) p(n) = g(n) + h(n), with the
paper's weights, eq. (2) c'(n) = c(n) + w.

Costs (all per unit of cell-to-cell distance; 1 straight, √2 diagonal):
- every cell costs 1, plus ``near_cost`` per 4-neighbour column of another height: placing a cube changes
  the cost of its cell and of its neighbours (eq. 2), so paths keep off edges when they can;
- a move onto a column of another height is a climb: ``climb_cost``·|Δh| more, and it is allowed only
  straight (no diagonal over an edge) and only when that cost is at most ``climb_threshold`` (with the
  defaults: one cube up or down); above it the character goes around;
- a diagonal move needs all four cells level (no corner cutting), and a cell walled on two opposite sides
  (a one-cell slot between higher columns) is too narrow for the body.
The heuristic is the octile distance (admissible: no move costs less than its length), ties broken by
insertion order, so the same grid gives the same path.

An unreachable or impossible goal is a ``Plan`` with a ``reason``, never a path into a wall.
``Route`` remembers the heights along and beside a path, and says when a change touches it (replan).
"""

from __future__ import annotations

import functools
import heapq
import math
from dataclasses import dataclass
from enum import StrEnum

import numpy as np
from numpy.typing import NDArray

from sim.terrain import Cell, CellChange, TerrainGrid

_SQRT2 = math.sqrt(2.0)
# 8 moves: (dx, dy, length); the first four are straight
_MOVES = ((1, 0, 1.0), (-1, 0, 1.0), (0, 1, 1.0), (0, -1, 1.0),
          (1, 1, _SQRT2), (1, -1, _SQRT2), (-1, 1, _SQRT2), (-1, -1, _SQRT2))
_MOVE_INDEX = {(dx, dy): k for k, (dx, dy, _) in enumerate(_MOVES)}


@dataclass(frozen=True, slots=True)
class PlanCosts:
    """The weights of eq. (2) and the climb rule."""

    near_cost: float = 0.5
    climb_cost: float = 3.0
    climb_threshold: float = 3.0


class PlanStatus(StrEnum):
    FOUND = "found"
    AT_GOAL = "at_goal"  # start and goal are the same cell
    START_OUTSIDE = "start_outside"
    GOAL_OUTSIDE = "goal_outside"
    UNREACHABLE = "unreachable"  # no allowed sequence of moves leads there (walls, too-high climbs)
    GAVE_UP = "gave_up"  # a bounded local repair expanded its budget (the caller then plans in full)


@dataclass(frozen=True, slots=True)
class Plan:
    """A* result: ``cells`` from start to goal inclusive (empty unless FOUND/AT_GOAL), its total ``cost``,
    and how many cells A* ``expanded`` (its work)."""

    status: PlanStatus
    cells: tuple[Cell, ...] = ()
    cost: float = math.inf
    expanded: int = 0

    @property
    def ok(self) -> bool:
        return self.status in (PlanStatus.FOUND, PlanStatus.AT_GOAL)

    @property
    def reason(self) -> str:
        """One line for a person: why there is no path (empty when there is one)."""
        return {
            PlanStatus.START_OUTSIDE: "the character is off the terrain grid",
            PlanStatus.GOAL_OUTSIDE: "the goal is off the terrain grid",
            PlanStatus.UNREACHABLE: "no path: the goal is walled in or behind climbs over the threshold",
        }.get(self.status, "")


def cell_costs(heights: NDArray[np.integer], costs: PlanCosts) -> NDArray[np.float64]:
    """c'(n) of eq. (2) per cell: 1 + near_cost × (4-neighbours of another height); inf for one-cell slots."""
    h = heights.astype(np.int32)
    padded = np.pad(h, 1, mode="edge")
    centre = padded[1:-1, 1:-1]
    left, right = padded[:-2, 1:-1], padded[2:, 1:-1]
    down, up = padded[1:-1, :-2], padded[1:-1, 2:]
    differ = ((left != centre).astype(np.int32) + (right != centre) + (down != centre) + (up != centre))
    c = 1.0 + costs.near_cost * differ
    slot = ((left > centre) & (right > centre)) | ((down > centre) & (up > centre))
    c[slot] = math.inf
    return c


def move_costs(heights: NDArray[np.integer], costs: PlanCosts) -> tuple[list[list[float]], list[int], int]:
    """Cost of each of the 8 moves out of every cell (inf where not allowed), on the grid padded with a
    one-cell border nobody may enter; flat row-major indices. Returns (costs per move, index offset per
    move, padded row length). Vectorised, so A*'s inner loop is only list reads and heap operations."""
    nx, ny = heights.shape
    h = np.full((nx + 4, ny + 4), np.iinfo(np.int32).max // 2, dtype=np.int64)
    h[2:-2, 2:-2] = heights
    c = np.full((nx + 4, ny + 4), math.inf)
    c[2:-2, 2:-2] = cell_costs(heights, costs)
    max_climb = math.floor(costs.climb_threshold / costs.climb_cost + 1e-9) if costs.climb_cost > 0 else 10**9
    core = (slice(1, -1), slice(1, -1))  # the padded grid A* works on: (nx + 2) x (ny + 2)
    hc = h[core]
    out: list[list[float]] = []
    offsets: list[int] = []
    row = ny + 2
    for dx, dy, length in _MOVES:
        dest = (slice(1 + dx, nx + 3 + dx), slice(1 + dy, ny + 3 + dy))
        hd, cd = h[dest], c[dest]
        dh = np.abs(hd - hc)
        if dx and dy:
            side_a = h[(slice(1 + dx, nx + 3 + dx), slice(1, -1))]
            side_b = h[(slice(1, -1), slice(1 + dy, ny + 3 + dy))]
            ok = (dh == 0) & (side_a == hc) & (side_b == hc)
            cost = np.where(ok, length * cd, math.inf)
        else:
            ok = dh <= max_climb
            cost = np.where(ok, cd + costs.climb_cost * dh, math.inf)
        out.append(cost.ravel().tolist())
        offsets.append(dx * row + dy)
    return out, offsets, row


class CostField:
    """``move_costs`` of a grid, kept in step with it: a changed column recomputes only the moves out of
    the cells within two of it (their costs read heights at most two cells further), so a replan after a
    cube is placed pays for A* alone."""

    def __init__(self, grid: TerrainGrid, costs: PlanCosts = PlanCosts()) -> None:
        self.grid = grid
        self.costs = costs
        self.moves, self.offsets, self.row = move_costs(grid.heights, costs)
        grid.subscribe(self._on_change)

    def _on_change(self, change: CellChange) -> None:
        nx, ny = self.grid.shape
        x0, x1 = max(change.ix - 4, 0), min(change.ix + 5, nx)
        y0, y1 = max(change.iy - 4, 0), min(change.iy + 5, ny)
        block, _, brow = move_costs(self.grid.heights[x0:x1, y0:y1], self.costs)
        row = self.row
        for ix in range(max(change.ix - 2, 0), min(change.ix + 3, nx)):
            for iy in range(max(change.iy - 2, 0), min(change.iy + 3, ny)):
                full = (ix + 1) * row + iy + 1
                local = (ix - x0 + 1) * brow + iy - y0 + 1
                for k in range(8):
                    self.moves[k][full] = block[k][local]

    def plan(self, start: Cell, goal: Cell, pocket_budget: int = 600, budget: int | None = None) -> Plan:
        """A* on the grid as it is now (see ``plan``); ``budget``: give up after expanding that many cells."""
        return _search(self.moves, self.offsets, self.row, self.grid.shape, start, goal, pocket_budget, budget)

    def move_cost(self, a: Cell, b: Cell) -> float:
        """Cost of the single move from cell ``a`` to the neighbouring cell ``b`` (inf: not allowed)."""
        k = _MOVE_INDEX.get((b[0] - a[0], b[1] - a[1]))
        if k is None:
            return math.inf
        return self.moves[k][(a[0] + 1) * self.row + a[1] + 1]

    def repair(self, cells: tuple[Cell, ...], here: int, last_touched: int, budget: int = 300) -> Plan | None:
        """A path that leaves ``cells`` from its ``here``-th cell, goes around the change that touched it
        up to its ``last_touched``-th cell, and rejoins it a few cells later (a bounded A*), its tail
        unchanged; None when the tail is no longer walkable or the detour is not found within ``budget``."""
        rejoin = min(last_touched + 3, len(cells) - 1)
        tail = cells[rejoin:]
        tail_cost = 0.0
        for a, b in zip(tail, tail[1:], strict=False):
            tail_cost += self.move_cost(a, b)
        if tail_cost == math.inf:
            return None
        local = self.plan(cells[here], cells[rejoin], pocket_budget=0, budget=budget)
        if local.status is PlanStatus.AT_GOAL:
            return Plan(PlanStatus.FOUND, tail, tail_cost, 0) if len(tail) > 1 else None
        if local.status is not PlanStatus.FOUND:
            return None
        return Plan(PlanStatus.FOUND, local.cells + tail[1:], local.cost + tail_cost, local.expanded)


def replan(field: CostField, route: Route | None, here: Cell, goal: Cell, ahead_from: int = 0) -> Plan:
    """The plan after the terrain changed: a local repair of ``route`` around what changed on it when
    that works (``CostField.repair``), else A* from ``here`` to ``goal`` in full."""
    if route is not None and route.plan.ok and route.plan.cells[-1] == goal:
        touched = route.touched_cells(ahead_from)
        cells = route.plan.cells
        if touched and here in cells[max(ahead_from - 1, 0):ahead_from + 1]:
            start = cells.index(here, max(ahead_from - 1, 0))
            repaired = field.repair(cells, start, max(touched))
            if repaired is not None:
                return repaired
    return field.plan(here, goal)


def plan(heights: NDArray[np.integer], start: Cell, goal: Cell, costs: PlanCosts = PlanCosts(),
         pocket_budget: int = 600) -> Plan:
    """A* from ``start`` to ``goal`` over the columns ``heights`` (nx, ny).

    A goal walled into a pocket is found out first by a flood from the goal of at most ``pocket_budget``
    cells (cheap), so the usual unreachable case does not cost a search of the whole grid.
    """
    moves, offsets, row = move_costs(heights, costs)
    return _search(moves, offsets, row, heights.shape, start, goal, pocket_budget)


def _search(moves: list[list[float]], offsets: list[int], row: int, shape: tuple[int, ...], start: Cell,
            goal: Cell, pocket_budget: int, budget: int | None = None) -> Plan:
    nx, ny = shape
    if not (0 <= start[0] < nx and 0 <= start[1] < ny):
        return Plan(PlanStatus.START_OUTSIDE)
    if not (0 <= goal[0] < nx and 0 <= goal[1] < ny):
        return Plan(PlanStatus.GOAL_OUTSIDE)
    if start == goal:
        return Plan(PlanStatus.AT_GOAL, (start,), 0.0, 0)
    s = (start[0] + 1) * row + start[1] + 1
    g_idx = (goal[0] + 1) * row + goal[1] + 1
    inf = math.inf
    # leaving the cell it stands on is allowed whenever coming back would be (it may stand in a slot a
    # cube just made, whose cost forbids entering it)
    out_of_start = []
    for k, (dx, dy, length) in enumerate(_MOVES):
        step = moves[k][s]
        if step == inf and 0 <= start[0] + dx < nx and 0 <= start[1] + dy < ny:
            back = moves[_MOVES.index((-dx, -dy, length))][s + offsets[k]]
            step = back if back < inf else inf
        out_of_start.append(step)
    if pocket_budget and _walled_in(moves, offsets, g_idx, s, pocket_budget):
        return Plan(PlanStatus.UNREACHABLE)
    gx, gy = goal[0] + 1, goal[1] + 1
    size = row * (nx + 2)
    heur = _octile(row, nx + 2, gx, gy)
    g_cost = [inf] * size
    g_cost[s] = 0.0
    came: dict[int, int] = {}
    closed = bytearray(size)
    closed[s] = 1
    heap: list[tuple[float, float, int]] = []  # (f, h, cell): among equal f, the one nearer the goal first
    push, pop = heapq.heappush, heapq.heappop
    for step, off in zip(out_of_start, offsets, strict=True):
        if step < inf:
            nxt = s + off
            g_cost[nxt] = step
            came[nxt] = s
            push(heap, (step + heur[nxt], heur[nxt], nxt))
    expanded = 1
    pairs = list(zip(moves, offsets, strict=True))
    while heap:
        cur = pop(heap)[2]
        if closed[cur]:
            continue
        if cur == g_idx:
            cells = tuple((c // row - 1, c % row - 1) for c in _walk_back(came, cur))
            return Plan(PlanStatus.FOUND, cells, g_cost[cur], expanded)
        closed[cur] = 1
        expanded += 1
        if budget is not None and expanded > budget:
            return Plan(PlanStatus.GAVE_UP, expanded=expanded)
        base = g_cost[cur]
        for move, off in pairs:
            step = move[cur]
            if step == inf:
                continue
            nxt = cur + off
            cost = base + step
            if cost < g_cost[nxt] and not closed[nxt]:
                g_cost[nxt] = cost
                came[nxt] = cur
                push(heap, (cost + heur[nxt], heur[nxt], nxt))
    return Plan(PlanStatus.UNREACHABLE, expanded=expanded)


@functools.lru_cache(maxsize=16)
def _octile(row: int, rows: int, gx: int, gy: int) -> list[float]:
    """The octile distance of every cell of the padded grid to (gx, gy) (the same goal is planned to
    again and again while a character walks to it)."""
    idx = np.arange(row * rows)
    ax, ay = np.abs(idx // row - gx), np.abs(idx % row - gy)
    out: list[float] = (np.maximum(ax, ay) + (_SQRT2 - 1.0) * np.minimum(ax, ay)).tolist()
    return out


def _walled_in(moves: list[list[float]], offsets: list[int], goal: int, start: int, budget: int) -> bool:
    """True when the cells that can reach ``goal`` are fewer than ``budget`` and ``start`` is not one of
    them (moves are symmetric, so the flood runs from the goal along the moves out of each cell)."""
    seen = {goal}
    todo = [goal]
    inf = math.inf
    while todo:
        cur = todo.pop()
        for move, off in zip(moves, offsets, strict=True):
            if move[cur] == inf:
                continue
            nxt = cur + off
            if nxt == start:
                return False
            if nxt not in seen:
                seen.add(nxt)
                if len(seen) > budget:
                    return False
                todo.append(nxt)
    return True


def _walk_back(came: dict[int, int], cur: int) -> list[int]:
    out = [cur]
    while cur in came:
        cur = came[cur]
        out.append(cur)
    out.reverse()
    return out


class Route:
    """A plan being walked: the heights it was planned on, around every cell still ahead, so a change
    that does not touch it keeps the plan (the paper: the motion model does not change) and one that
    does asks for a replan."""

    def __init__(self, grid: TerrainGrid, result: Plan) -> None:
        self.plan = result
        self._grid = grid
        self._version = grid.version
        nx, ny = grid.shape
        cells = np.array(result.cells, dtype=np.int64).reshape(-1, 2)
        around = cells[:, None, :] + np.array([(dx, dy) for dx in (-1, 0, 1) for dy in (-1, 0, 1)])[None]
        # off-grid neighbours read as a clipped cell whose change is harmless to over-report
        self._ix = np.clip(around[..., 0], 0, nx - 1)
        self._iy = np.clip(around[..., 1], 0, ny - 1)
        self._heights = grid.heights[self._ix, self._iy].copy()

    def touched(self, ahead_from: int = 0) -> bool:
        """Has the terrain changed on or beside the path from its ``ahead_from``-th cell on (since the
        plan was made)?"""
        if self._grid.version == self._version:
            return False
        touched = bool(self.touched_cells(ahead_from))
        if not touched:  # changes elsewhere: do not look again until the next change
            self._version = self._grid.version
        return touched

    def touched_cells(self, ahead_from: int = 0) -> list[int]:
        """Indices of the path cells (from ``ahead_from`` − 1 on) with a changed column on or beside them."""
        first = max(0, ahead_from - 1)
        now = self._grid.heights[self._ix[first:], self._iy[first:]]
        changed = np.any(now != self._heights[first:], axis=1)
        return (np.flatnonzero(changed) + first).tolist()
