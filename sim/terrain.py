"""The terrain people build (He, Tsai, Ko, Lu §A): unit cubes on a floor grid, and its pybullet twin.

Geometry (stage frame: metres, z up, x to the audience's right, y into the screen): ``nx`` × ``ny`` square
cells of side ``cell``; cell (ix, iy) spans x ∈ [ox + ix·cell, ox + (ix+1)·cell), y ∈ [oy + iy·cell,
oy + (iy+1)·cell), (ox, oy) = ``origin``. A column holds ``heights[ix, iy]`` cubes (each ``cell`` high),
so its top is at z = heights·cell.

The paper's placing rules hold by construction and by check:
- aligned: cubes snap to cells, so two side-by-side cubes share one full face;
- stacked: a cube goes on top of its column (no floating cube, a full face below it);
- never on the character: cells reserved by a character (``reserve``) refuse placing and removing.
Refusals are ordinary (people place cubes anywhere): ``place``/``remove``/``set_height`` return a
``Placement`` saying what happened; nothing raises for a refused cube.

Every accepted change bumps ``version`` and is passed to each listener (``subscribe``) as a ``CellChange``.
``TerrainBody`` is such a listener: one static pybullet box per occupied column, rebuilt column by column.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from enum import StrEnum

import numpy as np
import pybullet as p
from numpy.typing import NDArray

from sim.physics import GROUP_FLOOR, MASK_FLOOR

Cell = tuple[int, int]


@dataclass(frozen=True)
class TerrainConfig:
    """The cube grid: ``cell`` metres per cube side, ``nx`` × ``ny`` cells from ``origin`` (stage x, y of the
    corner of cell (0, 0)), at most ``max_height`` cubes per column, ``friction`` of the cube faces."""

    cell: float = 0.3
    nx: int = 20
    ny: int = 8
    origin: tuple[float, ...] = (-3.0, -1.2)
    max_height: int = 3
    friction: float = 0.8

    def __post_init__(self) -> None:
        if isinstance(self.cell, bool) or not isinstance(self.cell, int | float) or not (
                math.isfinite(self.cell) and 0.01 <= self.cell <= 5.0):
            raise ValueError(f"cell: expected a cube size in metres between 0.01 and 5, got {self.cell!r}")
        for name in ("nx", "ny", "max_height"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int) or not 1 <= value <= 1024:
                raise ValueError(f"{name}: expected an integer between 1 and 1024, got {value!r}")
        if len(self.origin) != 2 or not all(
                isinstance(v, int | float) and not isinstance(v, bool) and math.isfinite(v) for v in self.origin):
            raise ValueError(f"origin: expected [x, y] in stage metres, got {self.origin!r}")
        if isinstance(self.friction, bool) or not isinstance(self.friction, int | float) or not (
                math.isfinite(self.friction) and self.friction >= 0):
            raise ValueError(f"friction: expected a number >= 0, got {self.friction!r}")


class Placement(StrEnum):
    """What became of a request to change a column."""

    PLACED = "placed"  # a cube was added
    REMOVED = "removed"  # a cube was taken away
    SET = "set"  # set_height changed the column
    UNCHANGED = "unchanged"  # set_height to the height it already had
    OUTSIDE = "outside"  # the cell is not on the grid
    UNDER_CHARACTER = "under_character"  # a character stands on (or reserved) that cell
    TOO_HIGH = "too_high"  # the column already has max_height cubes (or the height asked is above it)
    EMPTY = "empty"  # remove on a column without cubes

    @property
    def changed(self) -> bool:
        return self in (Placement.PLACED, Placement.REMOVED, Placement.SET)


@dataclass(frozen=True, slots=True)
class CellChange:
    """One accepted change of one column: its height (in cubes) before and after, and the grid version."""

    ix: int
    iy: int
    before: int
    after: int
    version: int


Listener = Callable[[CellChange], None]


class TerrainGrid:
    """Columns of unit cubes on the floor grid (see the module notes); the one source of truth."""

    def __init__(self, config: TerrainConfig) -> None:
        self.config = config
        self._h = np.zeros((config.nx, config.ny), dtype=np.int16)
        self._reserved: dict[str, frozenset[Cell]] = {}
        self._blocked_cache: set[Cell] | None = set()  # union of the reserved cells (None: to rebuild)
        self._listeners: list[Listener] = []
        self._version = 0

    # ------------------------------------------------------------------ reading
    @property
    def version(self) -> int:
        """Bumped by every accepted change (planners compare it to know when to replan)."""
        return self._version

    @property
    def heights(self) -> NDArray[np.int16]:
        """Cubes per column, shape (nx, ny) (a read-only view: change it through place/remove/set_height)."""
        view = self._h.view()
        view.flags.writeable = False
        return view

    @property
    def shape(self) -> tuple[int, int]:
        return self.config.nx, self.config.ny

    def inside(self, ix: int, iy: int) -> bool:
        return 0 <= ix < self.config.nx and 0 <= iy < self.config.ny

    def height(self, ix: int, iy: int) -> int:
        """Cubes in column (ix, iy); 0 off the grid (the floor goes on)."""
        return int(self._h[ix, iy]) if self.inside(ix, iy) else 0

    def top_z(self, ix: int, iy: int) -> float:
        """Stage z of the column's top face (0 on bare floor or off the grid)."""
        return self.height(ix, iy) * self.config.cell

    def cell_of(self, x: float, y: float) -> Cell | None:
        """The cell under stage point (x, y), or None off the grid."""
        c = self.config
        ix = math.floor((x - c.origin[0]) / c.cell)
        iy = math.floor((y - c.origin[1]) / c.cell)
        return (ix, iy) if self.inside(ix, iy) else None

    def cell_index(self, x: float, y: float) -> Cell:
        """The (possibly off-grid) cell indices of stage point (x, y)."""
        c = self.config
        return math.floor((x - c.origin[0]) / c.cell), math.floor((y - c.origin[1]) / c.cell)

    def centre(self, ix: int, iy: int) -> tuple[float, float]:
        """Stage (x, y) of the centre of cell (ix, iy)."""
        c = self.config
        return c.origin[0] + (ix + 0.5) * c.cell, c.origin[1] + (iy + 0.5) * c.cell

    def ground_z(self, x: float, y: float) -> float:
        """Stage z of the surface under stage point (x, y): the top of its column, 0 on the floor."""
        ix, iy = self.cell_index(x, y)
        return self.top_z(ix, iy)

    def ground_z_max(self, x: float, y: float, radius: float) -> float:
        """Highest surface within the square of half side ``radius`` around (x, y) (for clearance checks)."""
        c = self.config
        i0, j0 = self.cell_index(x - radius, y - radius)
        i1, j1 = self.cell_index(x + radius, y + radius)
        i0, j0, i1, j1 = max(i0, 0), max(j0, 0), min(i1, c.nx - 1), min(j1, c.ny - 1)
        if i0 > i1 or j0 > j1:
            return 0.0
        return float(self._h[i0:i1 + 1, j0:j1 + 1].max()) * c.cell

    def cells_within(self, x: float, y: float, radius: float) -> frozenset[Cell]:
        """Grid cells whose square comes within ``radius`` of stage point (x, y) (a character's footprint)."""
        c = self.config
        i0, j0 = self.cell_index(x - radius, y - radius)
        i1, j1 = self.cell_index(x + radius, y + radius)
        out: set[Cell] = set()
        for ix in range(max(i0, 0), min(i1, c.nx - 1) + 1):
            for iy in range(max(j0, 0), min(j1, c.ny - 1) + 1):
                x0, y0 = c.origin[0] + ix * c.cell, c.origin[1] + iy * c.cell
                dx = max(x0 - x, 0.0, x - (x0 + c.cell))
                dy = max(y0 - y, 0.0, y - (y0 + c.cell))
                if dx * dx + dy * dy <= radius * radius:
                    out.add((ix, iy))
        return frozenset(out)

    @property
    def _blocked(self) -> set[Cell]:
        if self._blocked_cache is None:
            self._blocked_cache = set().union(*self._reserved.values())
        return self._blocked_cache

    def reserved(self, ix: int, iy: int) -> bool:
        """True when a character stands on (has reserved) cell (ix, iy)."""
        return (ix, iy) in self._blocked

    # ------------------------------------------------------------------ characters
    def reserve(self, owner: str, cells: Iterable[Cell]) -> None:
        """The cells character ``owner`` stands on now (replaces its previous ones); no cube goes there."""
        cells = frozenset((int(i), int(j)) for i, j in cells)
        if self._reserved.get(owner) != cells:
            self._reserved[owner] = cells
            self._blocked_cache = None

    def release(self, owner: str) -> None:
        """Forget the cells of ``owner`` (it left the terrain)."""
        if self._reserved.pop(owner, None) is not None:
            self._blocked_cache = None

    # ------------------------------------------------------------------ changing
    def subscribe(self, listener: Listener) -> None:
        """Call ``listener`` with every accepted ``CellChange`` from now on (in the order they happen)."""
        self._listeners.append(listener)

    def place(self, ix: int, iy: int) -> Placement:
        """Stack one cube on column (ix, iy)."""
        refused = self._refusal(ix, iy)
        if refused is not None:
            return refused
        if self._h[ix, iy] >= self.config.max_height:
            return Placement.TOO_HIGH
        self._apply(ix, iy, int(self._h[ix, iy]) + 1)
        return Placement.PLACED

    def remove(self, ix: int, iy: int) -> Placement:
        """Take the top cube off column (ix, iy)."""
        refused = self._refusal(ix, iy)
        if refused is not None:
            return refused
        if self._h[ix, iy] == 0:
            return Placement.EMPTY
        self._apply(ix, iy, int(self._h[ix, iy]) - 1)
        return Placement.REMOVED

    def set_height(self, ix: int, iy: int, cubes: int) -> Placement:
        """Make column (ix, iy) ``cubes`` high (a layout, a box the depth camera sees)."""
        refused = self._refusal(ix, iy)
        if refused is not None:
            return refused
        if isinstance(cubes, bool) or not isinstance(cubes, int | np.integer) or not 0 <= cubes <= self.config.max_height:
            return Placement.TOO_HIGH
        if int(self._h[ix, iy]) == int(cubes):
            return Placement.UNCHANGED
        self._apply(ix, iy, int(cubes))
        return Placement.SET

    def _refusal(self, ix: int, iy: int) -> Placement | None:
        if not self.inside(ix, iy):
            return Placement.OUTSIDE
        if (ix, iy) in self._blocked:
            return Placement.UNDER_CHARACTER
        return None

    def _apply(self, ix: int, iy: int, after: int) -> None:
        before = int(self._h[ix, iy])
        self._h[ix, iy] = after
        self._version += 1
        change = CellChange(ix, iy, before, after, self._version)
        for listener in self._listeners:
            listener(change)


class TerrainBody:
    """The grid in pybullet: one static box per occupied column (its full height), in the floor's collision
    group, so every character collides with the cubes as with the floor. Kept in step by listening to the
    grid: a changed column's box is removed and, if cubes remain, made again (one shape per height, shared).
    """

    def __init__(self, client: int, grid: TerrainGrid) -> None:
        self._client = client
        self._grid = grid
        self._shapes: dict[int, int] = {}
        self._boxes: dict[Cell, int] = {}
        nx, ny = grid.shape
        for ix in range(nx):
            for iy in range(ny):
                if grid.height(ix, iy):
                    self._build(ix, iy, grid.height(ix, iy))
        grid.subscribe(self._on_change)

    @property
    def boxes(self) -> dict[Cell, int]:
        """pybullet body id of each occupied column (a copy)."""
        return dict(self._boxes)

    def _on_change(self, change: CellChange) -> None:
        old = self._boxes.pop((change.ix, change.iy), None)
        if old is not None:
            p.removeBody(old, physicsClientId=self._client)
        if change.after:
            self._build(change.ix, change.iy, change.after)

    def _build(self, ix: int, iy: int, cubes: int) -> None:
        cell = self._grid.config.cell
        if cubes not in self._shapes:
            self._shapes[cubes] = p.createCollisionShape(
                p.GEOM_BOX, halfExtents=(cell / 2, cell / 2, cubes * cell / 2), physicsClientId=self._client)
        x, y = self._grid.centre(ix, iy)
        body: int = p.createMultiBody(0.0, self._shapes[cubes], -1, (x, y, cubes * cell / 2),
                                      physicsClientId=self._client)
        p.changeDynamics(body, -1, lateralFriction=self._grid.config.friction, restitution=0.0,
                         physicsClientId=self._client)
        p.setCollisionFilterGroupMask(body, -1, GROUP_FLOOR, MASK_FLOOR, physicsClientId=self._client)
        self._boxes[(ix, iy)] = body
