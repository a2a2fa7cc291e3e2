"""Footstep prediction (He, Tsai, Ko, Lu): which motion model the next steps need, and where a foot lands.

The motion models are the paper's: walk, climb (up and down), turn left / right, turn back. The
prediction reads the path ahead (cells of the grid, their heights) against the body's heading:
- a change of column height within reach ahead → climb up / climb down;
- the path leading behind (beyond ``TURN_BACK_DEG`` off the heading) → turn back;
- leading off to a side by more than ``TURN_DEG`` → turn left / right;
- otherwise walk.
A foothold is the nearest spot to where the gait would put the foot that is flat for ``margin`` all
around (never on a cube's edge) and on the level of the ground under its hip when it can be.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Sequence
from enum import StrEnum

import numpy as np
from numpy.typing import NDArray

from sim.terrain import Cell, TerrainGrid

Array = NDArray[np.float64]

TURN_DEG = 30.0
TURN_BACK_DEG = 135.0


class MotionModel(StrEnum):
    WALK = "walk"
    CLIMB_UP = "climb_up"
    CLIMB_DOWN = "climb_down"
    TURN_LEFT = "turn_left"
    TURN_RIGHT = "turn_right"
    TURN_BACK = "turn_back"
    STAND = "stand"  # at the goal (or waiting for one): feet planted


def wrap(angle: float) -> float:
    return math.remainder(angle, math.tau)


def turn_model(error: float) -> MotionModel | None:
    """The turning model for a heading error (target − heading, radians), or None below the threshold."""
    deg = abs(math.degrees(error))
    if deg >= TURN_BACK_DEG:
        return MotionModel.TURN_BACK
    if deg > TURN_DEG:
        return MotionModel.TURN_LEFT if error > 0 else MotionModel.TURN_RIGHT
    return None


def predict_models(grid: TerrainGrid, cells: Sequence[Cell], heading: float) -> list[MotionModel]:
    """The motion models a path needs, in order, consecutive repeats merged (the paper's footstep
    prediction over a whole path): one per cell-to-cell move, from the body's ``heading``."""
    out: list[MotionModel] = []
    h = heading
    for a, b in zip(cells, cells[1:], strict=False):
        direction = math.atan2(b[1] - a[1], b[0] - a[0])
        model = turn_model(wrap(direction - h))
        if model is not None:
            _append(out, model)
        h = direction
        dh = grid.height(*b) - grid.height(*a)
        _append(out, MotionModel.CLIMB_UP if dh > 0 else MotionModel.CLIMB_DOWN if dh < 0 else MotionModel.WALK)
    return out


def _append(out: list[MotionModel], model: MotionModel) -> None:
    if not out or out[-1] != model:
        out.append(model)


def climb_ahead(grid: TerrainGrid, points: Array, start: float, stop: float, cum: Array,
                centre: float | None = None) -> MotionModel | None:
    """CLIMB_UP / CLIMB_DOWN when the ground along the path polyline ``points`` (with cumulative lengths
    ``cum``) changes height between arc lengths ``start`` and ``stop`` (the edge nearest ``centre``
    when there are several: over a one-cube ridge the body climbs up, then down); None when level."""
    if len(points) < 2 or stop <= start:
        return None
    s = np.linspace(start, stop, max(12, int((stop - start) / 0.02)))
    xs = np.interp(s, cum, points[:, 0])
    ys = np.interp(s, cum, points[:, 1])
    z = np.array([grid.ground_z(float(x), float(y)) for x, y in zip(xs, ys, strict=True)])
    steps = np.flatnonzero(np.abs(np.diff(z)) > 1e-9)
    if not steps.size:
        return None
    ref = 0.5 * (start + stop) if centre is None else centre
    k = int(steps[np.argmin(np.abs(s[steps] - ref))])
    return MotionModel.CLIMB_UP if z[k + 1] > z[k] else MotionModel.CLIMB_DOWN


@functools.lru_cache(maxsize=8)
def _offsets(search: float, step: float = 0.015) -> Array:
    k = int(math.ceil(search / step))
    g = np.arange(-k, k + 1) * step
    xy = np.stack(np.meshgrid(g, g, indexing="ij"), axis=-1).reshape(-1, 2)
    xy = xy[np.hypot(xy[:, 0], xy[:, 1]) <= search + 1e-9]
    out: Array = xy[np.argsort(np.hypot(xy[:, 0], xy[:, 1]), kind="stable")]
    return out


def choose_foothold(grid: TerrainGrid, nominal: Array, level_z: float, margin: float, search: float,
                    level_weight: float = 0.3, levels: Sequence[int] | None = None,
                    stay: Array | None = None) -> tuple[Array, bool]:
    """Where a foot lands: (x, y, surface z), and whether a flat spot was found.

    Candidates within ``search`` of ``nominal`` (x, y) (then within twice that) whose ground is level
    for ``margin`` all round (every column under the square of half side ``margin`` around it of one
    height); cost = distance from nominal + ``level_weight`` per cube of difference from ``level_z``
    (the ground under the hip), so a foot does not climb onto a wall beside the path; ``levels`` (cube
    counts), when given, are the only column heights a foot may land on (those the path itself crosses
    there). Off the grid counts as floor. ``stay`` is where the foot is now (x, y, surface z): a spot is
    only taken if the straight step from there, widened by ``margin``, passes over no column higher than
    both its ends (no foot swung over a wall's corner) when there is such a spot. None found: ``stay`` (it steps in place), else the nominal spot; False.
    """
    for radius in (search, 2.0 * search):
        spot = _best_spot(grid, nominal, level_z, margin, radius, level_weight, levels, stay)
        if spot is not None:
            return spot, True
    if stay is not None:
        return np.asarray(stay, dtype=np.float64).copy(), False
    return np.array([nominal[0], nominal[1], grid.ground_z(float(nominal[0]), float(nominal[1]))]), False


def _cells_z(grid: TerrainGrid, xy: Array) -> Array:
    """Column top (m) under each stage point of ``xy`` (..., 2); off the grid: 0."""
    c = grid.config
    ix = np.floor((xy[..., 0] - c.origin[0]) / c.cell).astype(np.int64)
    iy = np.floor((xy[..., 1] - c.origin[1]) / c.cell).astype(np.int64)
    inside = (ix >= 0) & (iy >= 0) & (ix < c.nx) & (iy < c.ny)
    out: Array = np.where(inside, grid.heights[np.clip(ix, 0, c.nx - 1), np.clip(iy, 0, c.ny - 1)], 0
                          ).astype(np.float64) * c.cell
    return out


def _best_spot(grid: TerrainGrid, nominal: Array, level_z: float, margin: float, search: float,
               level_weight: float, levels: Sequence[int] | None, stay: Array | None) -> Array | None:
    offsets = _offsets(search)
    pts = nominal[None, :2] + offsets
    c = grid.config
    # the centre and the corners of the square of half side ``margin``: columns are wider than it, so
    # any column reaching into the square holds one of its corners
    probes = np.stack([pts, pts + (margin, margin), pts + (margin, -margin), pts + (-margin, margin),
                       pts - (margin, margin)])
    z = _cells_z(grid, probes)
    cost = np.hypot(offsets[:, 0], offsets[:, 1]) + level_weight * np.abs(z[0] - level_z) / c.cell
    cost[~np.all(np.abs(z - z[0]) < 1e-9, axis=0)] = math.inf
    if levels is not None:
        cost[~np.isin(np.rint(z[0] / c.cell).astype(np.int64), np.asarray(levels, dtype=np.int64))] = math.inf
    if stay is not None:
        t = np.linspace(0.0, 1.0, 12)[:, None, None]
        line = stay[None, None, :2] + t * (pts[None, :, :] - stay[None, None, :2])
        corners = np.array([(margin, margin), (margin, -margin), (-margin, margin), (-margin, -margin)])
        # the foot's square (half side ``margin``) swept along the step: no column above both ends under it
        along = _cells_z(grid, line[None] + corners[:, None, None, :]).max(axis=(0, 1))
        clear = np.where(along > np.maximum(z[0], stay[2]) + 1e-9, math.inf, cost)
        if np.isfinite(clear).any():  # (else a step over the corner, swung high, beats none at all)
            cost = clear
    if not np.isfinite(cost).any():
        return None
    best = int(np.argmin(cost))
    return np.array([pts[best, 0], pts[best, 1], z[0, best]])
