"""render.gl.terrain: the cubes are drawn where the grid says (real headless pixels, EGL/llvmpipe)."""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest

from render.gl.link_figures import link_capsules
from render.gl.renderer import Renderer
from render.gl.style import Camera
from render.gl.terrain import COLUMN_FLOATS, TerrainView, column_instances
from render.keyframes import KeyframeSet
from sim.snapshot import CharacterSnapshot, CharacterState, LinkPose, WorldSnapshot

SHIPPED = Path(__file__).resolve().parent.parent / "configs" / "keyframes" / "humanoid" / "keyframes.toml"
W, H = 320, 180
CELL, ORIGIN = 0.3, (-3.0, -1.2)
COLUMNS = {(3, 2): 1, (10, 4): 3, (16, 5): 2}
EMPTY = WorldSnapshot(t=0.0, steps=0, characters=())


def heights(columns: dict[tuple[int, int], int]) -> np.ndarray:
    h = np.zeros((20, 8), dtype=np.int16)
    for (ix, iy), n in columns.items():
        h[ix, iy] = n
    return h


def project(points: np.ndarray) -> np.ndarray:
    """(row, col) pixels of stage points (N, 3) through the default camera (only its documented matrix)."""
    clip = np.c_[points, np.ones(len(points))] @ Camera().view_projection(W, H).T
    ndc = clip[:, :2] / clip[:, 3:4]
    return np.stack([(ndc[:, 1] + 1) / 2 * H, (ndc[:, 0] + 1) / 2 * W], axis=1)


def column_box(ix: int, iy: int, cubes: int, margin: int) -> tuple[int, int, int, int]:
    x0, y0 = ORIGIN[0] + ix * CELL, ORIGIN[1] + iy * CELL
    corners = np.array([(x, y, z) for x in (x0, x0 + CELL) for y in (y0, y0 + CELL) for z in (0.0, cubes * CELL)])
    rc = project(corners)
    return (int(rc[:, 0].min()) - margin, int(math.ceil(rc[:, 0].max())) + margin,
            int(rc[:, 1].min()) - margin, int(math.ceil(rc[:, 1].max())) + margin)


@pytest.fixture(scope="module")
def kset() -> KeyframeSet:
    return KeyframeSet.load(SHIPPED)


@pytest.fixture(scope="module")
def renderer() -> Iterator[Renderer]:
    r = Renderer(W, H, samples=0)
    yield r
    r.close()


def changed(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.abs(a.astype(int) - b.astype(int)).max(axis=2) > 8


def test_cubes_are_drawn_where_the_grid_says(renderer: Renderer, kset: KeyframeSet) -> None:
    bare = renderer.draw(EMPTY, None, kset).copy()
    built = renderer.draw(EMPTY, None, kset, terrain=TerrainView(heights(COLUMNS), CELL, ORIGIN)).copy()
    diff = changed(bare, built)
    allowed = np.zeros_like(diff)
    for (ix, iy), n in COLUMNS.items():
        r0, r1, c0, c1 = column_box(ix, iy, n, 0)
        inside = diff[max(r0, 0):r1, max(c0, 0):c1]
        assert inside.mean() > 0.6, f"column {(ix, iy)} barely drawn: {inside.mean():.2f} of its box changed"
        r0, r1, c0, c1 = column_box(ix, iy, n, 2)
        allowed[max(r0, 0):r1, max(c0, 0):c1] = True
        # the middle of the column's front face is cardboard: warm (red over blue, BGR order)
        x, y = ORIGIN[0] + (ix + 0.5) * CELL, ORIGIN[1] + iy * CELL
        row, col = project(np.array([(x, y, 0.5 * n * CELL)]))[0].round().astype(int)
        b, _, r = built[row, col].astype(int)
        assert r > b + 40, f"column {(ix, iy)}: front face pixel {built[row, col]} is not cardboard"
    assert not (diff & ~allowed).any(), "pixels changed away from every column"


def test_a_stack_stands_as_tall_as_its_cubes(renderer: Renderer, kset: KeyframeSet) -> None:
    bare = renderer.draw(EMPTY, None, kset).copy()
    for cubes in (1, 2, 3):
        frame = renderer.draw(EMPTY, None, kset, terrain=TerrainView(heights({(10, 4): cubes}), CELL, ORIGIN))
        diff = changed(bare, frame)
        rows = np.flatnonzero(diff.any(axis=1))
        expected_top = column_box(10, 4, cubes, 0)[0]
        assert abs(int(rows.min()) - expected_top) <= 2, (cubes, int(rows.min()), expected_top)


def test_taking_a_cube_away_redraws_the_floor(renderer: Renderer, kset: KeyframeSet) -> None:
    bare = renderer.draw(EMPTY, None, kset).copy()
    renderer.draw(EMPTY, None, kset, terrain=TerrainView(heights(COLUMNS), CELL, ORIGIN))
    fewer = dict(COLUMNS)
    del fewer[(10, 4)]
    frame = renderer.draw(EMPTY, None, kset, terrain=TerrainView(heights(fewer), CELL, ORIGIN))
    r0, r1, c0, c1 = column_box(10, 4, 3, 0)
    assert not changed(bare, frame)[r0:r1, c0:c1].any()


def test_column_instances() -> None:
    rows = column_instances(TerrainView(heights(COLUMNS), CELL, ORIGIN))
    assert rows.shape == (3, COLUMN_FLOATS)
    np.testing.assert_allclose(rows[:, :4], [[-2.1, -0.6, 0.3, 1], [0.0, 0.0, 0.3, 3], [1.8, 0.3, 0.3, 2]], atol=1e-6)
    assert column_instances(TerrainView(np.zeros((4, 4)), CELL, ORIGIN)).shape == (0, COLUMN_FLOATS)


# ------------------------------------------------------------------ a character drawn from its links


def laikago_links(x: float, y: float) -> tuple[LinkPose, ...]:
    """The link frames of pybullet's laikago standing at (x, y) (DIRECT mode; its own joint names)."""
    import pybullet as p
    import pybullet_data

    client = p.connect(p.DIRECT)
    try:
        p.setAdditionalSearchPath(pybullet_data.getDataPath(), physicsClientId=client)
        body = p.loadURDF("laikago/laikago_toes_zup.urdf", [x, y, 0.48], physicsClientId=client)
        out = []
        for j in range(p.getNumJoints(body, physicsClientId=client)):
            name = p.getJointInfo(body, j, physicsClientId=client)[12].decode()
            state = p.getLinkState(body, j, physicsClientId=client)
            out.append(LinkPose(name, tuple(state[4]), tuple(state[5])))
        return tuple(out)
    finally:
        p.disconnect(physicsClientId=client)


def quadruped(x: float, y: float, links: tuple[LinkPose, ...]) -> CharacterSnapshot:
    return CharacterSnapshot(name="dog", position=(x, y, 0.45), orientation=(0.0, 0.0, 0.0, 1.0),
                             velocity=(0.0, 0.0, 0.0), angular_velocity=(0.0, 0.0, 0.0), heading=0.0, tilt=(0.0, 0.0),
                             d_front=0.0, d_side=0.0, state=CharacterState.WALK, behaviour="walk", intent="wander",
                             face_up=None, contact_force_n=0.0, height=0.5, kind="quadruped", links=links)


def test_a_quadruped_is_drawn_where_its_links_are(renderer: Renderer, kset: KeyframeSet) -> None:
    links = laikago_links(1.0, 0.0)
    caps = link_capsules(quadruped(1.0, 0.0, links))
    assert len(caps) == 2 + 4 * 4  # body, head, and per leg hip, thigh, shin, foot: every link name known
    bare = renderer.draw(EMPTY, None, kset).copy()
    frame = renderer.draw(WorldSnapshot(t=0.0, steps=0, characters=(quadruped(1.0, 0.0, links),)), None, kset)
    diff = changed(bare, frame)
    pts = np.array([lp.position for lp in links])
    lo, hi = pts.min(axis=0) - 0.12, pts.max(axis=0) + 0.12
    corners = np.array([(x, y, z) for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (0.0, hi[2])])
    rc = project(corners)
    r0, r1, c0, c1 = int(rc[:, 0].min()), int(rc[:, 0].max()) + 1, int(rc[:, 1].min()), int(rc[:, 1].max()) + 1
    inside = diff[r0:r1, c0:c1]
    assert inside.sum() > 40, "the quadruped is not drawn"
    assert inside.sum() >= 0.97 * diff.sum(), "pixels changed away from the quadruped (shadows aside)"
    # its feet: each toe's pixel neighbourhood changed (the foot capsules)
    for toe in ("toeFR", "toeFL", "toeRR", "toeRL"):
        row, col = project(np.array([next(lp.position for lp in links if lp.name == toe)]))[0].round().astype(int)
        assert diff[row - 2:row + 3, col - 2:col + 3].any(), toe


def test_unknown_linked_kinds_are_a_stick_figure() -> None:
    links = tuple(LinkPose(f"l{i}", (0.1 * i, 0.0, 0.5), (0.0, 0.0, 0.0, 1.0)) for i in range(4))
    c = dataclasses.replace(quadruped(0.0, 0.0, links), kind="lizard")
    caps = link_capsules(c)
    assert len(caps) == 4
    np.testing.assert_allclose([caps[2][0], caps[2][1]], [(0.1, 0.0, 0.5), (0.2, 0.0, 0.5)])


def test_a_hold_under_way_shows_a_growing_cube_on_its_column(renderer: Renderer, kset: KeyframeSet) -> None:
    h = heights({(10, 4): 1})
    base = renderer.draw(EMPTY, None, kset, terrain=TerrainView(h, CELL, ORIGIN)).copy()
    half = renderer.draw(EMPTY, None, kset, terrain=TerrainView(h, CELL, ORIGIN, ((10, 4, 0.5),))).copy()
    full = renderer.draw(EMPTY, None, kset, terrain=TerrainView(h, CELL, ORIGIN, ((10, 4, 1.0),))).copy()
    rows_half = np.flatnonzero(changed(base, half).any(axis=1))
    rows_full = np.flatnonzero(changed(base, full).any(axis=1))
    # the ghost sits on the one-cube column: from its top up to 1.5 (half) or 2 (full) cubes
    for rows, top in ((rows_half, 1.5), (rows_full, 2.0)):
        x, y = ORIGIN[0] + 10.5 * CELL, ORIGIN[1] + 4 * CELL
        expected = project(np.array([(x, y + CELL, top * CELL)]))[0, 0]  # the top's far edge, highest on screen
        assert abs(int(rows.min()) - expected) <= 3, (top, int(rows.min()), expected)
    assert rows_full.min() < rows_half.min()


def test_the_faces_seen_are_the_outer_ones(kset: KeyframeSet) -> None:
    """From above, a column shows its lit top and front (not its dark bottom and back from inside)."""
    camera = Camera(eye=(0.0, -4.0, 4.0), target=(0.0, 0.0, 0.0))
    with Renderer(W, H, samples=0, camera=camera) as r:
        frame = r.draw(EMPTY, None, kset, terrain=TerrainView(heights({(10, 4): 2}), CELL, ORIGIN))
        vp = camera.view_projection(W, H)

    def pixel(p: tuple[float, float, float]) -> np.ndarray:
        clip = np.array([*p, 1.0]) @ vp.T
        col, row = ((clip[:2] / clip[3]) + 1) / 2 * np.array([W, H])
        return frame[int(row), int(col)].astype(float)

    x, y = ORIGIN[0] + 10.5 * CELL, ORIGIN[1] + 4.5 * CELL
    top, front = pixel((x, y, 2 * CELL)), pixel((x, y - 0.5 * CELL, 0.5 * CELL))  # not on a seam
    assert top.sum() > front.sum() > 0.5 * top.sum(), (top, front)  # lit top (0.95), front (0.80); inside: 0.38/0.49
    assert front[2] > 125, front  # a lit cardboard face: red ≈ 151 (the back face from inside: ≈ 93)
