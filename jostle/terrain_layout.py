"""``[terrain]`` of the installation config and the cube layouts it names.

::

    [terrain]
    cell = 0.3                 # cube size, metres (cells are as wide as cubes are tall)
    size = [64, 64]            # cells along stage x and y
    origin = [-9.6, -9.6]      # stage (x, y) of cell (0, 0)'s corner; default: the grid centred on (0, 0)
    layout = "terrain/steps.toml"   # or inline: rows = ["..1..", ...] and at = [ix, iy]
    hands = true               # a hand held still over a cell places a cube there
    boxes = "oak"              # the depth observer whose frames show real boxes on the floor ("": none)
    [terrain.observe]          # interaction.depth.terrain_cells.TerrainObserverConfig (hold_s, settle_s, ...)

A layout (a file with the same ``rows`` and ``at`` keys, e.g. ``configs/terrain/steps.toml``) is a map of
heights seen from above with the audience at the bottom: one string per row of cells, one character per
cell (``.`` or ``0`` bare floor, ``1``–``9`` that many cubes) along +x; the LAST row is the one nearest
the audience (lowest y); ``at`` is the grid cell of the last row's first character. Errors are one line
naming the file, the row and column, and what was expected.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from interaction.depth.terrain_cells import FloorGrid, TerrainObserverConfig
from sensors.untrusted import MissingInput, UntrustedInput, load_toml
from sensors.untrusted.limits import TERRAIN_LAYOUT
from sim.quadruped.config import QuadrupedSpec

__all__ = ["LayoutError", "QuadrupedGroup", "QuadrupedTable", "TerrainLayout", "TerrainSection", "parse_rows",
           "read_layout"]


class LayoutError(ValueError):
    """A cube layout that cannot be used (one line: file, row, column, what was expected)."""


@dataclass(frozen=True, slots=True)
class TerrainLayout:
    """Columns of cubes to build: (ix, iy, cubes), cubes ≥ 1, in reading order."""

    columns: tuple[tuple[int, int, int], ...] = ()
    source: str = ""


def parse_rows(rows: Sequence[object], at: Sequence[object], source: str, size: tuple[int, int],
               max_height: int) -> TerrainLayout:
    """The columns of a map of rows (see the module notes); ``source`` names where it came from in errors
    (empty: the rows are inline, the message starts with the key)."""
    where = source
    source = f"{source}: " if source else ""
    if not isinstance(rows, list | tuple) or not rows:
        raise LayoutError(f"{source}rows: expected a list of strings (one per row of cells), got {rows!r}")
    if (not isinstance(at, list | tuple) or len(at) != 2
            or not all(isinstance(v, int | float) and not isinstance(v, bool) and float(v).is_integer() for v in at)):
        raise LayoutError(f"{source}at: expected [ix, iy], the whole-number cell of the last row's first "
                          f"character, got {at!r}")
    x0, y0 = (int(v) for v in at if isinstance(v, int | float))
    width = None
    out: list[tuple[int, int, int]] = []
    n = len(rows)
    for r, row in enumerate(rows, start=1):
        if not isinstance(row, str):
            raise LayoutError(f"{source}row {r}: expected a string of '.' and digits, got {row!r}")
        if width is None:
            width = len(row)
        elif len(row) != width:
            raise LayoutError(f"{source}row {r}: {len(row)} cells, but row 1 has {width} (every row "
                              "must be as long: pad with '.')")
        iy = y0 + (n - r)
        for c, ch in enumerate(row, start=1):
            cubes = 0 if ch == "." else int(ch) if ch.isdigit() and ch.isascii() else -1
            if cubes < 0 or cubes > max_height:
                raise LayoutError(f"{source}row {r}, column {c}: expected '.' or a digit 0..{max_height} "
                                  f"(cubes; max_height is {max_height}), got {ch!r}")
            ix = x0 + c - 1
            if cubes and not (0 <= ix < size[0] and 0 <= iy < size[1]):
                raise LayoutError(f"{source}row {r}, column {c}: cell ({ix}, {iy}) is off the "
                                  f"{size[0]}×{size[1]} grid (move 'at' or make [terrain] size bigger)")
            if cubes:
                out.append((ix, iy, cubes))
    return TerrainLayout(tuple(out), where or "rows")


def read_layout(path: Path, size: tuple[int, int], max_height: int) -> TerrainLayout:
    """A layout file (TOML with ``at`` and ``rows``)."""
    try:
        doc: Mapping[str, Any] = load_toml(path, TERRAIN_LAYOUT, "layout file")
    except MissingInput:
        raise LayoutError(f"{path}: no such layout file") from None
    except UntrustedInput as e:
        raise LayoutError(str(e)) from None
    unknown = [k for k in doc if k not in ("at", "rows")]
    if unknown:
        raise LayoutError(f"{path}: {unknown[0]}: unknown key; expected at, rows")
    return parse_rows(doc.get("rows", []), doc.get("at", [0, 0]), str(path), size, max_height)


@dataclass(frozen=True)
class TerrainSection:
    """``[terrain]``: the cube grid, its starting layout, and which inputs may change it."""

    cell: float = 0.3
    size: tuple[float, ...] = (64.0, 64.0)
    origin: tuple[float, ...] = ()  # empty: the grid centred on stage (0, 0)
    max_height: int = 3  # cubes per column at most
    layout: Path = Path()  # a layout file (empty: none)
    rows: tuple[str, ...] = ()  # or an inline map …
    at: tuple[float, ...] = (0.0, 0.0)  # … whose last row's first character is this cell
    hands: bool = True  # a hand held still over a cell places a cube
    boxes: str = ""  # name of the [observers.*] depth observer whose frames show boxes ("": none)
    observe: TerrainObserverConfig = field(default_factory=TerrainObserverConfig)

    def __post_init__(self) -> None:
        if isinstance(self.cell, bool) or not isinstance(self.cell, int | float) or not 0.02 <= self.cell <= 5.0:
            raise ValueError(f"cell: expected a cube size in metres 0.02..5, got {self.cell!r}")
        if len(self.size) != 2 or not all(float(v).is_integer() and 1 <= v <= 1024 for v in self.size):
            raise ValueError(f"size: expected [nx, ny], whole numbers of cells 1..1024, got {list(self.size)!r}")
        if self.origin and (len(self.origin) != 2 or not all(math.isfinite(v) for v in self.origin)):
            raise ValueError(f"origin: expected [x, y] in stage metres (or leave it out), got {list(self.origin)!r}")
        if isinstance(self.max_height, bool) or not 1 <= self.max_height <= 9:
            raise ValueError(f"max_height: expected a whole number of cubes 1..9, got {self.max_height!r}")
        if self.layout != Path() and self.rows:
            raise ValueError("layout: give a layout file or inline rows, not both")
        try:
            self.initial_layout()  # a bad layout is a config error, found before anything opens
        except LayoutError as e:
            message = str(e)
            if self.layout != Path():
                raise ValueError(f"layout: {message}") from None
            raise ValueError(message if message.startswith(("at:", "rows:")) else f"rows: {message}") from None

    @property
    def grid_size(self) -> tuple[int, int]:
        return int(self.size[0]), int(self.size[1])

    @property
    def floor_grid(self) -> FloorGrid:
        """The grid's geometry (interaction/'s view of it)."""
        nx, ny = self.grid_size
        origin = self.origin or (-0.5 * nx * self.cell, -0.5 * ny * self.cell)
        return FloorGrid(float(self.cell), nx, ny, (float(origin[0]), float(origin[1])))

    def initial_layout(self) -> TerrainLayout:
        """The cubes the run starts with (from ``layout`` or ``rows``; none when neither is given)."""
        if self.layout != Path():
            return read_layout(self.layout, self.grid_size, self.max_height)
        if self.rows:
            return parse_rows(list(self.rows), list(self.at), "", self.grid_size, self.max_height)
        return TerrainLayout()


@dataclass(frozen=True)
class QuadrupedTable:
    """``[[quadrupeds]]``: one quadruped walking on the terrain (needs ``[terrain]``)."""

    spec: Path = Path()  # its kind (sim.quadruped.config.QuadrupedSpec as TOML); empty: the defaults
    position: tuple[float, ...] = (0.0, 0.0)  # where it stands at the start, stage (x, y) metres
    heading_deg: float = 0.0  # which way it faces, from stage +x toward +y
    waypoints: tuple[float, ...] = ()  # x0, y0, x1, y1, … walked in a loop (empty: the spec's)

    def __post_init__(self) -> None:
        if self.spec != Path() and not self.spec.exists():
            raise ValueError(f"spec: no such quadruped file {self.spec}")
        if len(self.position) != 2 or not all(math.isfinite(v) for v in self.position):
            raise ValueError(f"position: expected [x, y] in stage metres, got {list(self.position)!r}")
        if not math.isfinite(self.heading_deg):
            raise ValueError(f"heading_deg: expected a finite number of degrees, got {self.heading_deg!r}")
        if len(self.waypoints) % 2 or not all(math.isfinite(v) for v in self.waypoints):
            raise ValueError(f"waypoints: expected x0, y0, x1, y1, … (pairs of stage metres), got {list(self.waypoints)!r}")


@dataclass(frozen=True)
class QuadrupedGroup:
    """A ``[[quadrupeds]]`` entry with its spec read."""

    spec: QuadrupedSpec
    table: QuadrupedTable
