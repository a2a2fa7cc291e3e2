"""The composition root's terrain: ``[terrain]`` → the world's cube grid and what people do to it.

The world owns the grid (``World.add_terrain``, with the layout of ``[terrain] layout`` or ``rows``) and
changes it only through ``World.step``'s observations (``sim.terrain_edits``). Here the observations get
their ``TerrainReport``: the boxes the depth observer named by ``boxes`` sees (``observe_depth``, which
also hands on no "person" that is a stack of boxes) and the cubes asked for by hands held still over a
cell (``observe_hands``, ``with_hands``). ``view`` is what the renderer draws.
"""

from __future__ import annotations

import dataclasses
import logging
import math
from collections import Counter
from dataclasses import dataclass, field

import numpy as np

from interaction.depth.calibration import DepthCalibration
from interaction.depth.terrain_cells import CellReport, PlacementRequest, TerrainObserver
from interaction.types import BodyObservation, TerrainReport
from jostle.config import JostleConfig
from jostle.terrain_layout import TerrainSection
from render.gl.terrain import TerrainView
from sensors.base import Frame
from sim.terrain import TerrainConfig, TerrainGrid
from sim.world import World

log = logging.getLogger("jostle")

__all__ = ["TerrainWiring", "attach_terrain", "grid_config"]


def grid_config(section: TerrainSection) -> TerrainConfig:
    """The sim grid's config from ``[terrain]`` (same geometry as the interaction side's FloorGrid)."""
    g = section.floor_grid
    return TerrainConfig(cell=g.cell, nx=g.nx, ny=g.ny, origin=g.origin, max_height=section.max_height)


@dataclass
class TerrainWiring:
    """Turns depth frames and held hands into the observations' ``TerrainReport``s for ``grid``."""

    section: TerrainSection
    grid: TerrainGrid  # the world's (read here; the world changes it)
    observer: TerrainObserver
    counts: Counter[str] = field(default_factory=Counter)
    placements: list[PlacementRequest] = field(default_factory=list)  # the last update's, for display
    report: CellReport | None = None  # the last depth frame's boxes

    @classmethod
    def build(cls, section: TerrainSection, grid: TerrainGrid, calibration: DepthCalibration | None = None
              ) -> TerrainWiring:
        """The wiring for ``grid`` (whose geometry must be the section's)."""
        g = section.floor_grid
        c = grid.config
        if (c.cell, c.nx, c.ny, tuple(c.origin)) != (g.cell, g.nx, g.ny, g.origin):
            raise ValueError(f"terrain: the world's grid ({c.nx}×{c.ny} cells of {c.cell} m from {c.origin}) "
                             f"is not the [terrain] grid ({g.nx}×{g.ny} of {g.cell} m from {g.origin})")
        return cls(section, grid, TerrainObserver(g, section.observe, calibration))

    # ------------------------------------------------------------ per frame

    def observe_depth(self, frame: Frame, bodies: BodyObservation) -> BodyObservation:
        """A depth frame (and the people the depth observer found in it) → ``bodies`` with the boxes seen
        (``terrain.boxes``) and without the "people" who are a stack of boxes as tall as a person."""
        self.report = self.observer.observe_depth(frame, bodies)
        bodies = dataclasses.replace(bodies, terrain=TerrainReport(boxes=self.report.cells))
        boxes = self.observer.box_people
        if not boxes:
            return bodies
        self.counts["box_taken_for_person"] += 1
        kept = tuple(c for c in bodies.contactors if c.person not in boxes)
        return dataclasses.replace(bodies, contactors=kept, people=max(0, bodies.people - len(boxes)))

    def observe_hands(self, observation: BodyObservation) -> tuple[PlacementRequest, ...]:
        """The people's hands (fused observation) → the cubes asked for where a hand was held still."""
        if not self.section.hands:
            return ()
        requests = self.observer.observe_hands(observation)
        for req in requests:
            log.info("terrain: person %d asked for a cube on (%d, %d)", req.person, req.ix, req.iy)
        self.placements = list(requests)
        return requests

    def with_hands(self, observation: BodyObservation) -> BodyObservation:
        """``observation`` with the cubes its hands ask for added to its ``terrain`` report."""
        asked = TerrainReport(placements=tuple((r.ix, r.iy) for r in self.observe_hands(observation)))
        if not asked.placements:
            return observation
        return dataclasses.replace(observation, terrain=TerrainReport.merge([observation.terrain, asked]))

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
    layout = section.initial_layout()
    grid = world.add_terrain(grid_config(section), layout.columns)
    refused = sum(n for key, n in world.terrain_counts.items()
                  if key.startswith("layout_") and key not in ("layout_set", "layout_unchanged"))
    if refused:
        log.warning("terrain: %s: %d columns refused (a character stands there, or off the grid)", layout.source,
                    refused)
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
