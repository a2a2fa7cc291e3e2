"""The people's changes to the world's cube grid (``sim.terrain.TerrainGrid``), applied by ``World.step``.

Three inputs change the grid, whose rules refuse a cube on a character's cells or above ``max_height``:

- the layout, built once when the terrain is laid (``layout``: (ix, iy, cubes) per column);
- hands held still over a cell (``TerrainReport.placements``: one cube placed per request);
- real boxes the depth camera sees (``TerrainReport.boxes``, every box settled so far): when a box
  appears, grows or goes, its column gains or loses that many cubes (a column's height = the box's
  cubes + the cubes placed on it by hand or layout). A change the grid refuses (a character stands
  there) is tried again with every report until it is taken.

``counts`` says what happened (``layout_<result>``, ``hand_<result>``, ``box_added``/``box_removed``,
``box_<refusal>``; results are ``sim.terrain.Placement`` values).
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Iterable

import numpy as np

from interaction.types import TerrainReport
from sim.terrain import Placement, TerrainGrid

__all__ = ["TerrainEdits"]


class TerrainEdits:
    def __init__(self, grid: TerrainGrid) -> None:
        self.grid = grid
        self.boxes_applied: dict[tuple[int, int], int] = {}  # cubes each real box stands for
        self.counts: Counter[str] = Counter()

    def layout(self, columns: Iterable[tuple[int, int, int]]) -> list[tuple[int, int, int, Placement]]:
        """Set each column (ix, iy, cubes); returns the refused ones with why."""
        refused: list[tuple[int, int, int, Placement]] = []
        for ix, iy, cubes in columns:
            result = self.grid.set_height(ix, iy, cubes)
            self.counts[f"layout_{result.value}"] += 1
            if not result.changed and result is not Placement.UNCHANGED:
                refused.append((ix, iy, cubes, result))
        return refused

    def apply(self, report: TerrainReport) -> None:
        """The boxes (when reported), then the placements, in order."""
        if report.boxes is not None:
            self.apply_boxes(report.boxes)
        for ix, iy in report.placements:
            result = self.grid.place(int(ix), int(iy))
            self.counts[f"hand_{result.value}"] += 1

    def apply_boxes(self, cells: Iterable[tuple[int, int, int]]) -> None:
        want = {(int(ix), int(iy)): int(cubes) for ix, iy, cubes in cells}
        max_height = self.grid.config.max_height
        for cell in sorted(set(want) | set(self.boxes_applied)):
            have, new = self.boxes_applied.get(cell, 0), want.get(cell, 0)
            if have == new:
                continue
            target = int(np.clip(self.grid.height(*cell) - have + new, 0, max_height))
            result = self.grid.set_height(cell[0], cell[1], target)
            if result.changed or result is Placement.UNCHANGED:
                self.counts["box_added" if new > have else "box_removed"] += 1
                if new:
                    self.boxes_applied[cell] = new
                else:
                    self.boxes_applied.pop(cell, None)
            else:
                self.counts[f"box_{result.value}"] += 1  # tried again with the next report
