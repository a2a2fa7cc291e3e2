"""Readings of how well the feet keep to the terrain: penetration into the cubes, slip of stance feet."""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from sim.terrain import TerrainGrid

Array = NDArray[np.float64]


def penetration(grid: TerrainGrid, centre: Array, radius: float) -> float:
    """How deep (m) a sphere at ``centre`` reaches into the floor or any cube column (0 when clear)."""
    x, y, z = (float(v) for v in centre)
    worst = max(0.0, radius - z)
    c = grid.config
    i0, j0 = grid.cell_index(x - radius, y - radius)
    i1, j1 = grid.cell_index(x + radius, y + radius)
    for ix in range(max(i0, 0), min(i1, c.nx - 1) + 1):
        for iy in range(max(j0, 0), min(j1, c.ny - 1) + 1):
            top = grid.top_z(ix, iy)
            if top <= 0.0:
                continue
            x0, y0 = c.origin[0] + ix * c.cell, c.origin[1] + iy * c.cell
            lo, hi = np.array([x0, y0, 0.0]), np.array([x0 + c.cell, y0 + c.cell, top])
            p = np.array([x, y, z])
            if np.all(p > lo) and np.all(p < hi):  # centre inside the column
                worst = max(worst, radius + float(np.min(np.minimum(p - lo, hi - p))))
                continue
            d = float(np.linalg.norm(p - np.clip(p, lo, hi)))
            worst = max(worst, radius - d)
    return worst


class SlipMeter:
    """Per leg: where its toe was when it touched down; every tick in stance, how far it has moved since."""

    def __init__(self) -> None:
        self._anchor: list[Array | None] = [None] * 4
        self.samples: list[float] = []

    def add(self, toes: Array, stance: tuple[bool, ...]) -> None:
        for k in range(4):
            if not stance[k]:
                self._anchor[k] = None
                continue
            anchor = self._anchor[k]
            if anchor is None:
                self._anchor[k] = toes[k].copy()
            else:
                self.samples.append(float(np.linalg.norm(toes[k] - anchor)))

    def reset(self) -> None:
        self._anchor = [None] * 4

    def p95(self) -> float:
        return float(np.percentile(self.samples, 95)) if self.samples else math.nan
