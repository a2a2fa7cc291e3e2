"""The composition root's terrain: ``[terrain]`` → the sim's cube grid, kept in step with what people do.

Three inputs change the grid (sim.terrain.TerrainGrid, whose rules refuse a cube on a
character's cells or above ``max_height``):

- the layout (``[terrain] layout`` or ``rows``), built once at the start;
- hands held still over a cell (``interaction.terrain_cells``: one PlacementRequest → one cube placed);
- real boxes the depth camera sees: each CellReport lists the boxes settled so far; when a box
  appears, grows or goes, its column gains or loses that many cubes (a column's height = the box's
  cubes + the cubes placed on it by hand or layout). A change the grid refuses (a character stands
  there) is tried again with every report until it is taken.

Counts of what happened go to :attr:`TerrainWiring.counts` (for the run summary and the tests).
"""

from __future__ import annotations

import dataclasses
import logging
import math
from collections import Counter
from dataclasses import dataclass, field

import numpy as np

from interaction.depth_calibration import DepthCalibration
from interaction.terrain_cells import CellReport, PlacementRequest, TerrainObserver
from interaction.types import BodyObservation
from jostle.config import JostleConfig
from jostle.terrain_layout import TerrainSection
from render.terrain import TerrainView
from sensors.base import Frame
from sim.terrain import Placement, TerrainConfig, TerrainGrid
from sim.world import World

log = logging.getLogger("jostle")

__all__ = ["TerrainWiring", "attach_terrain", "grid_config"]


def grid_config(section: TerrainSection) -> TerrainConfig:
    """The sim grid's config from ``[terrain]`` (same geometry as the interaction side's FloorGrid)."""
    g = section.floor_grid
    return TerrainConfig(cell=g.cell, nx=g.nx, ny=g.ny, origin=g.origin, max_height=section.max_height)


@dataclass
class TerrainWiring:
    """Applies the layout, the held hands and the depth camera's boxes to ``grid``."""

    section: TerrainSection
    grid: TerrainGrid
    observer: TerrainObserver
    boxes_applied: dict[tuple[int, int], int] = field(default_factory=dict)  # cubes each real box stands for
    counts: Counter[str] = field(default_factory=Counter)
    placements: list[PlacementRequest] = field(default_factory=list)  # the last update's, for display
    report: CellReport | None = None  # the last depth frame's boxes

    @classmethod
    def build(cls, section: TerrainSection, grid: TerrainGrid, calibration: DepthCalibration | None = None
              ) -> TerrainWiring:
        """The wiring for ``grid`` (whose geometry must be the section's), the layout already built."""
        g = section.floor_grid
        c = grid.config
        if (c.cell, c.nx, c.ny, tuple(c.origin)) != (g.cell, g.nx, g.ny, g.origin):
            raise ValueError(f"terrain: the world's grid ({c.nx}×{c.ny} cells of {c.cell} m from {c.origin}) "
                             f"is not the [terrain] grid ({g.nx}×{g.ny} of {g.cell} m from {g.origin})")
        wiring = cls(section, grid, TerrainObserver(g, section.observe, calibration))
        wiring.apply_layout()
        return wiring

    def apply_layout(self) -> None:
        layout = self.section.initial_layout()
        for ix, iy, cubes in layout.columns:
            result = self.grid.set_height(ix, iy, cubes)
            self.counts[f"layout_{result.value}"] += 1
            if not result.changed and result is not Placement.UNCHANGED:
                log.warning("terrain: %s: cell (%d, %d): %d cubes refused (%s)", layout.source, ix, iy, cubes,
                            result.value)

    # ------------------------------------------------------------ per frame

    def observe_depth(self, frame: Frame, bodies: BodyObservation) -> BodyObservation:
        """A depth frame (and the people the depth observer found in it) → boxes → the grid. Returns
        ``bodies`` without the "people" who are a stack of boxes as tall as a person (so they push no one)."""
        self.report = self.observer.observe_depth(frame, bodies)
        self.apply_boxes(self.report)
        boxes = self.observer.box_people
        if not boxes:
            return bodies
        self.counts["box_taken_for_person"] += 1
        kept = tuple(c for c in bodies.contactors if c.person not in boxes)
        return dataclasses.replace(bodies, contactors=kept, people=max(0, bodies.people - len(boxes)))

    def apply_boxes(self, report: CellReport) -> None:
        want = {(ix, iy): cubes for ix, iy, cubes in report.cells}
        for cell in sorted(set(want) | set(self.boxes_applied)):
            have, new = self.boxes_applied.get(cell, 0), want.get(cell, 0)
            if have == new:
                continue
            target = int(np.clip(self.grid.height(*cell) - have + new, 0, self.section.max_height))
            result = self.grid.set_height(cell[0], cell[1], target)
            if result.changed or result is Placement.UNCHANGED:
                self.counts["box_added" if new > have else "box_removed"] += 1
                if new:
                    self.boxes_applied[cell] = new
                else:
                    self.boxes_applied.pop(cell, None)
            else:
                self.counts[f"box_{result.value}"] += 1  # tried again with the next report

    def observe_hands(self, observation: BodyObservation) -> tuple[PlacementRequest, ...]:
        """The people's hands (fused observation) → cubes placed where a hand was held still."""
        if not self.section.hands:
            return ()
        requests = self.observer.observe_hands(observation)
        for req in requests:
            result = self.grid.place(req.ix, req.iy)
            self.counts[f"hand_{result.value}"] += 1
            log.info("terrain: person %d asked for a cube on (%d, %d): %s", req.person, req.ix, req.iy, result.value)
        self.placements = list(requests)
        return requests

    # ------------------------------------------------------------ drawing

    def view(self) -> TerrainView:
        """What the renderer draws: a copy of the heights, and the hands' holds under way."""
        g = self.observer.grid
        pending = self.observer.holding() if self.section.hands else ()
        return TerrainView(np.array(self.grid.heights, copy=True), g.cell, (g.origin[0], g.origin[1]), pending)


def attach_terrain(config: JostleConfig, world: World) -> TerrainWiring | None:
    """The run's terrain (None without ``[terrain]``): the world's cube grid (with its pybullet twin, so
    every character collides with the cubes), the layout built around the characters already standing
    (their cells refuse cubes), then the ``[[quadrupeds]]`` stood on it; boxes from the depth
    observer named by ``boxes`` (through its calibration)."""
    section = config.terrain
    if section is None:
        return None
    grid = world.add_terrain(grid_config(section))
    calibration = None
    for ob in config.observers:
        if ob.name == section.boxes and ob.calibration is not None:
            calibration = DepthCalibration.load(ob.calibration)
    wiring = TerrainWiring.build(section, grid, calibration)
    for group in config.quadrupeds:
        q = group.table
        path = np.asarray(q.waypoints, dtype=float).reshape(-1, 2)
        world.add_character(group.spec, (q.position[0], q.position[1]), math.radians(q.heading_deg),
                            waypoints=[(float(x), float(y)) for x, y in path] if len(path) else None)
    return wiring

