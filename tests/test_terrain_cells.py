"""interaction.depth.terrain_cells: boxes on the floor seen by a (virtual) depth camera, and hands held still.

The depth frames are ray-cast from a known scene (floor + axis-aligned boxes) with the virtual OAK's
camera and its stereo error model (jostle.performer), so the right answer is known by construction.
"""

from __future__ import annotations

import functools
import math

import numpy as np
import pytest

from interaction.depth.calibration import DepthCalibration
from interaction.depth.terrain_cells import (
    CellReport,
    FloorGrid,
    PlacementRequest,
    TerrainObserver,
    TerrainObserverConfig,
)
from interaction.depth.terrain_points import StagePoints
from interaction.types import BodyObservation, Contactor
from jostle.performer.camera import PinholeCamera
from jostle.performer.config import DepthCameraConfig
from jostle.performer.depth import stereo_depth
from sensors.base import DepthImage, Frame

OAK = DepthCameraConfig()
CAMERA = PinholeCamera(OAK.width, OAK.height, (0.0, -4.0, 2.4), OAK.pitch_deg, OAK.hfov_deg)
GRID = FloorGrid(cell=0.3, nx=16, ny=10, origin=(-2.4, -1.2))
Box = tuple[tuple[float, float, float], tuple[float, float, float]]


def cube_column(ix: int, iy: int, cubes: int, grid: FloorGrid = GRID) -> Box:
    x0, y0 = grid.origin[0] + ix * grid.cell, grid.origin[1] + iy * grid.cell
    return (x0, y0, 0.0), (x0 + grid.cell, y0 + grid.cell, cubes * grid.cell)


def calibration(camera: PinholeCamera = CAMERA) -> DepthCalibration:
    """The exact camera → stage transform of the virtual camera (floor z = 0)."""
    r = camera.rotation  # stage → camera
    up = r @ np.array([0.0, 0.0, 1.0])
    return DepthCalibration(tuple(r.T.reshape(-1).tolist()), tuple(camera.position),
                            (*up.tolist(), float(camera.position[2])), (camera.width, camera.height))


RAYS = CAMERA.pixel_rays()


@functools.cache
def clean_depth(boxes: tuple[Box, ...]) -> np.ndarray:
    """Metres along the optical axis to the floor or the nearest of ``boxes`` (ray-cast), per pixel."""
    d, c = RAYS, CAMERA.centre
    with np.errstate(divide="ignore", invalid="ignore"):
        t_hit = np.where(d[..., 2] < 0, -c[2] / d[..., 2], np.inf)
        for lo, hi in boxes:
            t1, t2 = (np.array(lo) - c) / d, (np.array(hi) - c) / d
            t_in, t_out = np.max(np.minimum(t1, t2), axis=-1), np.min(np.maximum(t1, t2), axis=-1)
            hit = (t_in <= t_out) & (t_in > 0) & (t_in < t_hit)
            t_hit = np.where(hit, t_in, t_hit)
    return np.asarray(t_hit * (d @ CAMERA.rotation[2]), dtype=np.float32)


def depth_frame(boxes: list[Box], t: float, seq: int, rng: np.random.Generator | None) -> Frame:
    """A depth frame of the floor and ``boxes``, with the OAK's stereo errors when ``rng``."""
    along = clean_depth(tuple(boxes))
    k = CAMERA.intrinsics
    if rng is None:
        mm = np.where(np.isfinite(along), np.rint(along * 1000), 0).astype(np.uint16)
    else:
        mm = stereo_depth(along, OAK, float(k[0, 0]), rng)
    return Frame("oak", t, seq, DepthImage(mm, float(k[0, 0]), float(k[1, 1]), float(k[0, 2]), float(k[1, 2])))


def run(observer: TerrainObserver, boxes: list[Box], t0: float, seconds: float, seed: int = 1,
        bodies: BodyObservation | None = None, fps: float = 15.0) -> list[CellReport]:
    rng = np.random.default_rng(seed)
    n = int(round(seconds * fps))
    return [observer.observe_depth(depth_frame(boxes, t0 + i / fps, i, rng), bodies) for i in range(n)]


LAYOUT = {(3, 4): 1, (8, 5): 2, (9, 5): 1, (12, 7): 3}


def test_boxes_give_their_cells_and_heights_once_settled() -> None:
    obs = TerrainObserver(GRID, TerrainObserverConfig(), calibration())
    boxes = [cube_column(ix, iy, h) for (ix, iy), h in LAYOUT.items()]
    reports = run(obs, boxes, 0.0, 1.5)
    assert reports[0].cells == ()  # nothing before it has stood still for settle_s
    assert reports[5].cells == ()
    final = {(ix, iy): h for ix, iy, h in reports[-1].cells}
    assert final == LAYOUT
    assert reports[-1].cells == tuple(sorted(reports[-1].cells, key=lambda c: (c[1], c[0])))


def test_a_clean_frame_gives_every_cell_seen() -> None:
    """Without the stereo errors every visible cell is judged: boxes exactly, the rest bare floor."""
    obs = TerrainObserver(GRID, TerrainObserverConfig(settle_s=0.0), calibration())
    boxes = [cube_column(ix, iy, h) for (ix, iy), h in LAYOUT.items()]
    report = obs.observe_depth(depth_frame(boxes, 0.0, 0, None))
    assert {(ix, iy): h for ix, iy, h in report.cells} == LAYOUT
    seen = obs.last_seen
    for (ix, iy), h in LAYOUT.items():
        assert seen[iy, ix] == h
    assert (seen == 0).sum() > 0.6 * GRID.nx * GRID.ny  # most of the floor is seen bare
    assert (seen > 0).sum() == len(LAYOUT)  # and no other cell holds a box (faces of boxes are not boxes)


def test_a_person_sized_column_and_a_moving_box_are_not_boxes() -> None:
    obs = TerrainObserver(GRID, TerrainObserverConfig(), calibration())
    rng = np.random.default_rng(3)
    person = ((0.0, 0.0, 0.0), (0.35, 0.25, 1.75))  # tall: a person the depth observer missed
    reports = []
    for i in range(30):  # 2 s at 15 fps; a low box slides 0.1 m per frame (1.5 m/s) across the floor
        x = -2.0 + 0.1 * i
        sliding = ((x, -0.6, 0.0), (x + 0.3, -0.3, 0.3))
        reports.append(obs.observe_depth(depth_frame([person, sliding], i / 15, i, rng)))
    assert all(r.cells == () for r in reports)


def test_a_box_taken_away_is_cleared_after_settling() -> None:
    obs = TerrainObserver(GRID, TerrainObserverConfig(), calibration())
    box = [cube_column(5, 4, 1)]
    assert run(obs, box, 0.0, 1.4)[-1].cells == ((5, 4, 1),)
    after = run(obs, [], 1.4, 1.4, seed=2)
    assert after[2].cells == ((5, 4, 1),)  # still there for a moment: it may be hidden, or a glitch
    assert after[-1].cells == ()


def test_cells_near_a_person_are_left_alone() -> None:
    """A box put down while a person stands beside it is reported once they step away."""
    obs = TerrainObserver(GRID, TerrainObserverConfig(), calibration())
    x, y = GRID.centre(6, 4)
    near = BodyObservation(0.0, (Contactor(0, "foot", (x + 0.2, y, 0.05), (0.0, 0.0, 0.0), 0.08),
                                 Contactor(0, "head", (x + 0.45, y, 1.6), (0.0, 0.0, 0.0), 0.12)), people=1)
    box = [cube_column(6, 4, 1)]
    assert run(obs, box, 0.0, 2.0, bodies=near)[-1].cells == ()
    later = run(obs, box, 2.0, 1.4, seed=5, bodies=BodyObservation(2.0))
    assert later[-1].cells == ((6, 4, 1),)


def test_frames_must_be_depth_and_calibrated() -> None:
    frame = depth_frame([], 0.0, 0, None)
    with pytest.raises(ValueError, match="depth calibration"):
        TerrainObserver(GRID).observe_depth(frame)


# ------------------------------------------------------------------ hands


def hand_run(path: list[tuple[float, float, float]], fps: float = 30.0, head: tuple[float, float, float] = (0.0, 0.0, 1.6),
             ) -> list[PlacementRequest]:
    """Feed a hand moving along ``path`` (one position per frame) with its finite-difference velocity."""
    obs = TerrainObserver(GRID)
    out: list[PlacementRequest] = []
    for i, p in enumerate(path):
        prev = path[max(i - 1, 0)]
        v = tuple((a - b) * fps for a, b in zip(p, prev, strict=True))
        contactors = (Contactor(3, "head", head, (0.0, 0.0, 0.0), 0.12),
                      Contactor(3, "hand", p, (v[0], v[1], v[2]), 0.07))
        out.extend(obs.observe_hands(BodyObservation(i / fps, contactors, people=1)))
    return out


def test_a_hand_held_still_for_a_second_places_exactly_one_cube() -> None:
    rng = np.random.default_rng(0)
    x, y = GRID.centre(10, 6)
    path = [(x + float(rng.normal(0, 0.001)), y + float(rng.normal(0, 0.001)), 1.0) for _ in range(75)]  # 2.5 s
    placed = hand_run(path)
    assert len(placed) == 1
    assert (placed[0].ix, placed[0].iy, placed[0].person) == (10, 6, 3)
    assert placed[0].t == pytest.approx(1.0, abs=0.05)


def test_a_moving_hand_places_nothing() -> None:
    x, y = GRID.centre(10, 6)
    slow_drift = [(x - 0.6 + 0.01 * i, y, 1.0) for i in range(90)]  # 0.3 m/s for 3 s
    assert hand_run(slow_drift) == []
    circling = [(x + 0.12 * math.cos(i / 5), y + 0.12 * math.sin(i / 5), 1.0) for i in range(90)]  # 0.72 m/s
    assert hand_run(circling) == []


def test_a_hand_by_the_body_places_nothing() -> None:
    path = [(0.1, 0.1, 1.0)] * 60  # within reach of the head's axis: a hand at rest by the side
    assert hand_run(path) == []


def test_holding_on_two_cells_in_turn_places_two_cubes() -> None:
    a, b = GRID.centre(10, 6), GRID.centre(12, 6)
    path = [(a[0], a[1], 1.0)] * 40 + [(a[0] + (b[0] - a[0]) * k / 10, a[1], 1.0) for k in range(1, 11)] + [(b[0], b[1], 1.0)] * 40
    placed = hand_run(path)
    assert [(p.ix, p.iy) for p in placed] == [(10, 6), (12, 6)]


def test_floor_grid_geometry_and_config_errors() -> None:
    assert GRID.cell_at(*GRID.centre(3, 7)) == (3, 7)
    assert GRID.cell_at(-2.5, 0.0) is None
    ij, inside = GRID.cells_of(np.array([[-2.4, -1.2, 0.0], [2.39, 1.79, 0.0], [2.4, 0.0, 0.0]]))
    assert ij[:2].tolist() == [[0, 0], [15, 9]] and inside.tolist() == [True, True, False]
    with pytest.raises(ValueError, match="^cell: "):
        FloorGrid(cell=-1.0)
    with pytest.raises(ValueError, match="^origin: "):
        FloorGrid(origin=(1.0,))
    with pytest.raises(ValueError, match="^hold_s: "):
        TerrainObserverConfig(hold_s=-1.0)


def test_a_hold_under_way_is_reported_until_it_places() -> None:
    obs = TerrainObserver(GRID)
    x, y = GRID.centre(10, 6)
    progress = []
    for i in range(40):
        people = (Contactor(3, "head", (0.0, 0.0, 1.6), (0.0, 0.0, 0.0), 0.12),
                  Contactor(3, "hand", (x, y, 1.0), (0.0, 0.0, 0.0), 0.07))
        obs.observe_hands(BodyObservation(i / 30, people, people=1))
        progress.append(obs.holding())
    assert progress[3] == ()  # too early to show
    assert progress[15] == ((10, 6, pytest.approx(0.5)),)
    assert progress[29] == ((10, 6, pytest.approx(29 / 30)),)
    assert progress[30] == () and progress[39] == ()  # placed: nothing under way


@pytest.mark.parametrize(("dx", "dy", "cell"), [(0.3, 0.0, (5, 4)), (-0.3, 0.0, (5, 4)), (0.7, 0.0, (6, 4)),
                                                (-0.7, 0.0, (4, 4)), (0.0, 0.3, (5, 4)), (0.0, 0.7, (5, 5)),
                                                (0.0, -0.3, (5, 4)), (0.0, -0.7, (5, 3)), (-0.8, -0.8, (4, 3))])
def test_a_box_off_the_grid_counts_once_in_the_cell_its_lid_covers_most(dx: float, dy: float,
                                                                         cell: tuple[int, int]) -> None:
    """Off along x or y either way: the cell holding most of the lid. Along y the box's side facing the
    camera stands in the other cell, its top rows as high as the lid: their points count for (almost) no
    floor area there (interaction.depth.terrain_points), so that cell does not look covered."""
    obs = TerrainObserver(GRID, TerrainObserverConfig(), calibration())
    (x0, y0, _), (x1, y1, z1) = cube_column(5, 4, 1)
    shift = np.array([dx, dy, 0.0]) * GRID.cell
    box = (tuple(np.array([x0, y0, 0.0]) + shift), tuple(np.array([x1, y1, z1]) + shift))
    assert run(obs, [box], 0.0, 1.4, seed=2)[-1].cells == ((*cell, 1),)


def test_points_stand_for_the_floor_area_their_pixels_see() -> None:
    """Summed over a bare cell, the floor areas of its points make the cell's area (±25 %: the sampling
    beats with the cells); over a box the lid's points make the lid and its side adds next to nothing."""
    sampler = StagePoints(calibration(), 160)
    frame = depth_frame([cube_column(5, 4, 1)], 0.0, 0, None)
    assert isinstance(frame.payload, DepthImage)
    pts, areas = sampler.points(frame.payload)
    ij, inside = GRID.cells_of(pts)
    cell = ij[inside, 1] * GRID.nx + ij[inside, 0]
    per_cell = np.bincount(cell, areas[inside], minlength=GRID.nx * GRID.ny).reshape(GRID.ny, GRID.nx) / 0.09
    bare = np.ones_like(per_cell, dtype=bool)
    bare[3:6, 4:7] = False  # the box's cell, and around it (its side, its shadow behind)
    bare[-1] = False  # the back row runs out of the picture
    ok = (per_cell[bare] > 0.6) & (per_cell[bare] < 1.4)
    assert 0.85 < float(np.median(per_cell[bare])) < 1.15 and ok.mean() > 0.85  # (a few: at the picture's edge)
    lid = (cell == 4 * GRID.nx + 5) & (pts[inside, 2] > 0.2)
    assert 0.75 < areas[inside][lid].sum() / 0.09 < 1.25
    (_, y0, _), _ = cube_column(5, 4, 1)
    side = (np.abs(pts[:, 1] - y0) < 0.01) & (pts[:, 2] > 0.02) & (pts[:, 2] < 0.28)  # the side facing the camera
    z = (pts[side] - CAMERA.centre) @ CAMERA.rotation[2]  # depth along the optical axis
    r_z = (pts[side, 2] - CAMERA.centre[2]) / z  # the ray's rise per metre of depth
    level = np.square(4 * z / CAMERA.focal_px) / np.abs(r_z)  # what they would stand for on a level surface
    assert side.sum() > 30
    assert areas[side].sum() < 0.2 * level.sum()
