"""The terrain people build, as interaction/ sees it: boxes standing on the floor (depth camera) and
hands held still over a floor cell (any observer's contactors), on a grid of floor cells.

:class:`FloorGrid` is the geometry (stage metres): ``nx`` × ``ny`` square cells of ``cell`` metres (a
unit cube is ``cell`` tall too), cell (0, 0)'s corner at ``origin``; sim/ has its own grid of the same
geometry (the composition root builds both from one config); nothing here imports sim.

:class:`TerrainObserver` yields, beside the body observers and without changing their shapes:

- :meth:`~TerrainObserver.observe_depth`: a :class:`CellReport` per depth frame — every cell holding a
  box and its height in cubes. A cell holds a box when the points near its top (a high percentile of
  its raised points) cover most of it (a lid: :mod:`interaction.depth.terrain_points`) and no person's
  contactor is near; it is empty when floor points cover it; anything else is unknown. A cell changes
  only after the new answer has held for ``settle_s`` (``agreement``), so a passer-by leaves no box.
  :attr:`~TerrainObserver.box_people` names "people" that are stacks of boxes.
- :meth:`~TerrainObserver.observe_hands`: one :class:`PlacementRequest` per hold — a hand reached out
  ``min_reach_m`` from the head, over one cell, slower than ``hold_speed_mps`` for ``hold_s``;
  :meth:`~TerrainObserver.holding` says which holds are under way and how far.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from interaction.depth.calibration import DepthCalibration
from interaction.depth.terrain_points import StagePoints
from interaction.types import BodyObservation, Contactor
from sensors.base import DepthImage, Frame

__all__ = ["CellReport", "FloorGrid", "PlacementRequest", "TerrainObserver", "TerrainObserverConfig"]


def _number(name: str, value: object, lo: float, hi: float) -> float:
    if not isinstance(value, int | float) or isinstance(value, bool) or not lo <= value <= hi:
        raise ValueError(f"{name}: expected a number {lo:g}..{hi:g}, got {value!r}")
    return float(value)


def _whole(name: str, value: object, lo: int, hi: int) -> int:
    if not isinstance(value, int) or isinstance(value, bool) or not lo <= value <= hi:
        raise ValueError(f"{name}: expected a whole number {lo}..{hi}, got {value!r}")
    return value


@dataclass(frozen=True)
class FloorGrid:
    """Floor cells of ``cell`` metres, ``nx`` along stage x by ``ny`` along y, cell (0, 0)'s corner at
    stage (x, y) ``origin``."""

    cell: float = 0.3
    nx: int = 64
    ny: int = 64
    origin: tuple[float, ...] = (-9.6, -9.6)

    def __post_init__(self) -> None:
        _number("cell", self.cell, 0.02, 5.0)
        _whole("nx", self.nx, 1, 4096)
        _whole("ny", self.ny, 1, 4096)
        o = self.origin
        if not (isinstance(o, tuple) and len(o) == 2
                and all(isinstance(v, int | float) and not isinstance(v, bool) and math.isfinite(v) for v in o)):
            raise ValueError(f"origin: expected [x, y] in stage metres, got {o!r}")

    def cell_at(self, x: float, y: float) -> tuple[int, int] | None:
        """The cell under stage point (x, y), or None off the grid."""
        ix = math.floor((x - self.origin[0]) / self.cell)
        iy = math.floor((y - self.origin[1]) / self.cell)
        return (ix, iy) if 0 <= ix < self.nx and 0 <= iy < self.ny else None

    def centre(self, ix: int, iy: int) -> tuple[float, float]:
        """Stage (x, y) of a cell's middle."""
        return self.origin[0] + (ix + 0.5) * self.cell, self.origin[1] + (iy + 0.5) * self.cell

    def cells_of(self, xy: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Cell indices (N, 2) of stage points (N, ≥2) and whether each is on the grid (N,)."""
        ij = np.floor((np.asarray(xy, dtype=np.float64)[:, :2] - np.asarray(self.origin)) / self.cell).astype(np.int64)
        inside = (ij[:, 0] >= 0) & (ij[:, 0] < self.nx) & (ij[:, 1] >= 0) & (ij[:, 1] < self.ny)
        return ij, inside


@dataclass(frozen=True, slots=True)
class CellReport:
    """The boxes on the floor at time ``t``: (ix, iy, height in cubes) for every cell holding one,
    in (iy, ix) order. Cells not listed are empty floor (or were never seen holding a box)."""

    t: float
    cells: tuple[tuple[int, int, int], ...] = ()


@dataclass(frozen=True, slots=True)
class PlacementRequest:
    """A person asks for a cube on cell (ix, iy) (their hand held still over it) at time ``t``."""

    ix: int
    iy: int
    t: float
    person: int = -1


@dataclass(frozen=True)
class TerrainObserverConfig:
    """How boxes and held hands are told. Distances in stage metres, times in seconds."""

    work_width: int = 160  # depth pixels across the sampled image (the frame's width when smaller)
    rate_hz: float = 10.0  # depth frames looked at per second at most (boxes take a second to settle)
    floor_band_m: float = 0.04  # points within this of z = 0 are floor
    top_band_m: float = 0.08  # a flat top: its points lie within this below the cell's top
    cover_squares: int = 3  # a cell's sub-squares per side, for how much of it points cover
    min_cover: float = 0.55  # a box's top (the floor) covers at least this fraction of the sub-squares
    min_top_points: int = 6  # … with at least this many points
    min_lid: float = 0.42  # … and a lid over at least this fraction of its area (interaction.depth.terrain_points)
    max_cubes: int = 4  # taller than this many cubes: not a box (a person, furniture)
    person_clearance_m: float = 0.2  # cells this near a person's contactor are not judged …
    box_person_margin_m: float = 0.15  # … unless all their contactors are this near box cells (a tall stack)
    settle_s: float = 1.0  # a cell's new state must hold this long …
    agreement: float = 0.7  # … in at least this fraction of the frames (the rest: not told)
    hand_parts: tuple[str, ...] = ("hand",)
    hold_s: float = 1.0  # a hand held still this long over a cell places a cube
    hold_speed_mps: float = 0.1  # … moving slower than this
    min_reach_m: float = 0.3  # … reached out at least this far (horizontally) from the person's head
    hand_match_m: float = 0.25  # a hand moves less than this between observations
    hand_memory_s: float = 0.25  # a hand unseen this long is forgotten

    def __post_init__(self) -> None:
        _whole("work_width", self.work_width, 16, 4096)
        _number("rate_hz", self.rate_hz, 0.1, 1000.0)
        _number("floor_band_m", self.floor_band_m, 0.005, 0.5)
        _number("top_band_m", self.top_band_m, 0.01, 1.0)
        _whole("cover_squares", self.cover_squares, 1, 16)
        _number("min_cover", self.min_cover, 0.05, 1.0)
        _whole("min_top_points", self.min_top_points, 1, 100000)
        _number("min_lid", self.min_lid, 0.05, 1.0)
        _whole("max_cubes", self.max_cubes, 1, 100)
        _number("person_clearance_m", self.person_clearance_m, 0.0, 3.0)
        _number("box_person_margin_m", self.box_person_margin_m, 0.0, 1.0)
        _number("settle_s", self.settle_s, 0.0, 60.0)
        _number("agreement", self.agreement, 0.0, 1.0)
        if not (isinstance(self.hand_parts, tuple) and self.hand_parts and all(isinstance(p, str) for p in self.hand_parts)):
            raise ValueError(f"hand_parts: expected a list of contactor part names, got {self.hand_parts!r}")
        _number("hold_s", self.hold_s, 0.0, 60.0)
        _number("hold_speed_mps", self.hold_speed_mps, 0.0, 10.0)
        _number("min_reach_m", self.min_reach_m, 0.0, 3.0)
        _number("hand_match_m", self.hand_match_m, 0.01, 3.0)
        _number("hand_memory_s", self.hand_memory_s, 0.0, 10.0)


@dataclass(eq=False)
class _Hold:
    person: int
    position: np.ndarray  # where the hand was when the hold began
    last: np.ndarray  # where it was last seen
    cell: tuple[int, int] | None
    since: float
    seen: float
    placed: bool = False


@dataclass
class _Cells:
    """Per-cell state of the box finder (flat arrays over iy·nx + ix)."""

    settled: np.ndarray
    candidate: np.ndarray  # what the cell has looked like lately …
    since: np.ndarray  # … since when
    agree: np.ndarray  # frames since then that said so
    frames: np.ndarray  # frames since then
    holds: list[_Hold] = field(default_factory=list)


UNKNOWN = -1


class TerrainObserver:
    """Boxes from depth frames (:meth:`observe_depth`) and placements from held hands (:meth:`observe_hands`)."""

    def __init__(self, grid: FloorGrid, config: TerrainObserverConfig | None = None,
                 calibration: DepthCalibration | None = None) -> None:
        self.grid = grid
        self.config = config or TerrainObserverConfig()
        self.calibration = calibration
        n = grid.nx * grid.ny
        self._state = _Cells(np.zeros(n, np.int64), np.zeros(n, np.int64), np.full(n, -np.inf),
                             np.zeros(n, np.int64), np.zeros(n, np.int64))
        self._sampler: StagePoints | None = None
        self.last_seen: np.ndarray = np.full((grid.ny, grid.nx), UNKNOWN, np.int64)  # last frame's answer per cell
        self._hands_t = -math.inf
        self._depth_t = -math.inf  # when the last depth frame was looked at
        self.box_people: frozenset[int] = frozenset()  # last depth frame: "people" who are a stack of boxes

    # ------------------------------------------------------------ boxes (depth)

    def observe_depth(self, frame: Frame, bodies: BodyObservation | None = None) -> CellReport:
        """The settled boxes after one depth frame; ``bodies``: the people seen in it (their cells are
        left alone). Raises ValueError on a frame that is not a depth image or with no calibration."""
        p = frame.payload
        if not isinstance(p, DepthImage):
            raise ValueError(f"TerrainObserver: frame {frame.seq} from sensor {frame.sensor!r} carries a "
                             f"{frame.kind} payload; expected a depth image")
        if self.calibration is None:
            raise ValueError("TerrainObserver: boxes need a depth calibration (camera → stage)")
        if self._depth_t <= frame.t < self._depth_t + 1.0 / self.config.rate_hz - 1e-9:
            return self.report(frame.t)  # looked at one a moment ago (box_people stays that frame's)
        self._depth_t = frame.t
        if self._sampler is None or self._sampler.calibration is not self.calibration:
            self._sampler = StagePoints(self.calibration, self.config.work_width)
        points, areas = self._sampler.points(p)
        return self.observe_points(frame.t, points, bodies, areas)

    def observe_points(self, t: float, points: np.ndarray, bodies: BodyObservation | None = None,
                       areas: np.ndarray | None = None) -> CellReport:
        """As :meth:`observe_depth`, from stage points (N, 3) already measured; ``areas`` (N,): the floor
        area (m²) each point stands for on a level surface (without, only the sub-squares count)."""
        seen = self._judge(points, bodies, areas)
        self.last_seen = seen.reshape(self.grid.ny, self.grid.nx)
        s, cfg = self._state, self.config
        known = seen != UNKNOWN
        new = known & (seen != s.candidate)
        s.candidate[new] = seen[new]
        s.since[new] = t
        s.agree[new] = 0
        s.frames[new] = 0
        same = known & (seen == s.candidate)
        s.agree += same
        s.frames += 1
        # settled: said by most frames (an unknown frame does not reset the count, but does not agree)
        # for settle_s, and by this one
        ready = same & (t - s.since >= cfg.settle_s - 1e-9) & (s.agree >= cfg.agreement * s.frames)
        s.settled[ready] = s.candidate[ready]
        return self.report(t)

    def report(self, t: float) -> CellReport:
        """The boxes settled so far."""
        nx = self.grid.nx
        idx = np.flatnonzero(self._state.settled > 0)
        return CellReport(t, tuple((int(i % nx), int(i // nx), int(self._state.settled[i])) for i in idx))

    def _judge(self, points: np.ndarray, bodies: BodyObservation | None, areas: np.ndarray | None) -> np.ndarray:
        """Per cell (flat): cubes of the box on it (≥ 1), 0 for bare floor, UNKNOWN when it cannot be told."""
        g, cfg = self.grid, self.config
        n, k = g.nx * g.ny, cfg.cover_squares
        out = np.full(n, UNKNOWN, np.int64)
        pts = np.asarray(points, dtype=np.float64).reshape(-1, 3)
        ij, inside = g.cells_of(pts)
        pts, ij = pts[inside], ij[inside]
        area = None if areas is None else np.asarray(areas, dtype=np.float64)[inside]
        cell = ij[:, 1] * g.nx + ij[:, 0]
        frac = (pts[:, :2] - np.asarray(g.origin)) / g.cell - ij
        sq = np.minimum((frac * k).astype(np.int64), k - 1)  # frac ≥ 0: truncation is floor
        sub = cell * (k * k) + sq[:, 1] * k + sq[:, 0]
        z = pts[:, 2]

        def cover(sel: np.ndarray) -> np.ndarray:  # fraction of each cell's sub-squares holding a point of sel
            hit = np.bincount(sub[sel], minlength=n * k * k).reshape(n, k * k) > 0
            return np.asarray(hit.mean(axis=1))

        floor_cover = cover(np.abs(z) < cfg.floor_band_m)
        raised = z > 0.5 * g.cell
        top = np.full(n, -np.inf)
        if raised.any():
            rc, rz = cell[raised], z[raised]
            order = np.lexsort((rz, rc))
            rc, rz = rc[order], rz[order]
            starts = np.searchsorted(rc, np.arange(n))
            counts = np.bincount(rc, minlength=n)
            has = counts > 0
            pick = starts[has] + np.minimum((0.9 * counts[has]).astype(np.int64), counts[has] - 1)
            top[has] = rz[pick]
        on_top = raised & (z > top[cell] - cfg.top_band_m)
        top_cover = cover(on_top)
        top_count = np.bincount(cell[on_top], minlength=n)
        top_mean = np.bincount(cell[on_top], z[on_top], minlength=n) / np.maximum(top_count, 1)
        cubes = np.rint(top_mean / g.cell).astype(np.int64)
        # how much of the cell a lid covers: its points' level areas (a box straddling two cells counts in
        # the one it covers most), else the sub-squares they fall in
        lid = top_cover if area is None else np.bincount(cell[on_top], area[on_top], minlength=n) / g.cell**2
        box = (top_cover >= cfg.min_cover) & (lid >= cfg.min_lid) & (top_count >= cfg.min_top_points) & (cubes >= 1)
        tall = top > (cfg.max_cubes + 0.5) * g.cell
        out[(floor_cover >= cfg.min_cover) & ~box & (lid < 0.5 * cfg.min_lid)] = 0  # bare: no lid to speak of
        out[box & ~tall] = cubes[box & ~tall]
        out[tall] = UNKNOWN
        self.box_people = frozenset()
        if bodies is not None and bodies.contactors:
            box = (out > 0) | ((self._state.settled > 0) & (out != 0))  # a box now, or settled and not gone
            self.box_people = self._boxes_taken_for_people(bodies.contactors, box)
            people = tuple(c for c in bodies.contactors if c.person not in self.box_people)
            out[self._near_people(people)] = UNKNOWN
        return out

    def _boxes_taken_for_people(self, contactors: tuple[Contactor, ...], box: np.ndarray) -> frozenset[int]:
        """The people every contactor of whom is over a cell that looks like a box (within
        ``box_person_margin_m``): a stack of boxes as tall as a person (a person beside or on a box
        reaches out of its cells, or makes it too tall to be a box)."""
        g, m = self.grid, self.config.box_person_margin_m
        over: dict[int, bool] = {}
        for c in contactors:
            inside = False
            for dx in (-m, 0.0, m):
                for dy in (-m, 0.0, m):
                    cell = g.cell_at(c.position[0] + dx, c.position[1] + dy)
                    inside |= cell is not None and bool(box[cell[1] * g.nx + cell[0]])
            over[c.person] = over.get(c.person, True) and inside
        return frozenset(p for p, yes in over.items() if yes)

    def _near_people(self, contactors: tuple[Contactor, ...]) -> np.ndarray:
        """Flat mask of the cells within a person's contactor radius + clearance (horizontally)."""
        g = self.grid
        x0 = g.origin[0] + np.arange(g.nx) * g.cell
        y0 = g.origin[1] + np.arange(g.ny) * g.cell
        mask = np.zeros((g.ny, g.nx), dtype=bool)
        for c in contactors:
            x, y = c.position[0], c.position[1]
            dx = np.maximum(np.maximum(x0 - x, x - (x0 + g.cell)), 0.0)
            dy = np.maximum(np.maximum(y0 - y, y - (y0 + g.cell)), 0.0)
            dy = np.maximum(dy - c.half_depth, 0.0)
            reach = c.radius + self.config.person_clearance_m
            mask |= (dx[None, :] ** 2 + dy[:, None] ** 2) <= reach * reach
        return mask.reshape(-1)

    # ------------------------------------------------------------ hands

    def observe_hands(self, observation: BodyObservation) -> tuple[PlacementRequest, ...]:
        """The placements asked for by the hands in ``observation`` (at its time ``t``)."""
        cfg, t = self.config, observation.t
        heads: dict[int, Contactor] = {}
        for c in observation.contactors:
            if c.part == "head":
                heads.setdefault(c.person, c)
        holds = [h for h in self._state.holds if t - h.seen <= cfg.hand_memory_s + 1e-9]
        free = list(holds)
        out: list[PlacementRequest] = []
        for c in observation.contactors:
            if c.part not in cfg.hand_parts:
                continue
            pos = np.array(c.position, dtype=np.float64)
            head = heads.get(c.person)
            if head is not None and math.hypot(pos[0] - head.position[0], pos[1] - head.position[1]) < cfg.min_reach_m:
                continue  # a hand by the body is not held out over the floor
            mine = [h for h in free if h.person == c.person and float(np.linalg.norm(h.last - pos)) <= cfg.hand_match_m]
            hold = min(mine, key=lambda h: float(np.linalg.norm(h.last - pos)), default=None)
            cell = self.grid.cell_at(float(pos[0]), float(pos[1]))
            speed = math.sqrt(sum(v * v for v in c.velocity))
            if hold is None:
                hold = _Hold(c.person, pos, pos, cell, t, t)
                holds.append(hold)
            else:
                free.remove(hold)
            moved = cell != hold.cell or float(np.linalg.norm(pos[:2] - hold.position[:2])) > 0.5 * self.grid.cell
            still = speed < cfg.hold_speed_mps and not moved and cell is not None
            if moved:  # a new hold (and a new cube once it is long enough)
                hold.position, hold.cell, hold.since, hold.placed = pos, cell, t, False
            elif not still:
                hold.since = t  # a jerk starts the count again; it does not ask for a second cube
            hold.last, hold.seen = pos, t
            if still and not hold.placed and t - hold.since >= cfg.hold_s - 1e-9 and hold.cell is not None:
                hold.placed = True
                out.append(PlacementRequest(hold.cell[0], hold.cell[1], t, c.person))
        self._state.holds = holds
        self._hands_t = t
        return tuple(out)

    def holding(self, min_fraction: float = 0.2) -> tuple[tuple[int, int, float], ...]:
        """The holds under way at the last :meth:`observe_hands` (for feedback on screen): (ix, iy, how far
        from 0 to 1 toward placing) of the hands seen then, held at least ``min_fraction`` of ``hold_s``."""
        t, hold_s = self._hands_t, self.config.hold_s
        out = []
        for h in self._state.holds:
            if h.cell is None or h.placed or h.seen != t or hold_s <= 0:
                continue
            fraction = min(1.0, (t - h.since) / hold_s)
            if fraction >= min_fraction:
                out.append((h.cell[0], h.cell[1], fraction))
        return tuple(out)
