"""TerrainGrid: the paper's placing rules, stage geometry, change events, and the pybullet twin."""

from __future__ import annotations

import numpy as np
import pybullet as p
import pytest

from sim.config import WorldConfig
from sim.physics import open_client
from sim.terrain import CellChange, Placement, TerrainBody, TerrainConfig, TerrainGrid


def test_config_rejects_bad_fields_naming_them() -> None:
    with pytest.raises(ValueError, match="^cell:"):
        TerrainConfig(cell=0.0)
    with pytest.raises(ValueError, match="^nx:"):
        TerrainConfig(nx=0)
    with pytest.raises(ValueError, match="^origin:"):
        TerrainConfig(origin=(1.0,))


def test_stacking_limits_and_refusals() -> None:
    grid = TerrainGrid(TerrainConfig(nx=4, ny=3, max_height=2))
    assert grid.place(1, 1) is Placement.PLACED
    assert grid.place(1, 1) is Placement.PLACED
    assert grid.place(1, 1) is Placement.TOO_HIGH
    assert grid.height(1, 1) == 2
    assert grid.place(4, 0) is Placement.OUTSIDE
    assert grid.remove(0, 0) is Placement.EMPTY
    assert grid.remove(1, 1) is Placement.REMOVED
    assert grid.height(1, 1) == 1
    assert grid.set_height(2, 2, 2) is Placement.SET
    assert grid.set_height(2, 2, 2) is Placement.UNCHANGED
    assert grid.set_height(2, 2, 3) is Placement.TOO_HIGH
    with pytest.raises(ValueError):
        grid.heights[0, 0] = 1  # read-only view


def test_never_on_the_character() -> None:
    grid = TerrainGrid(TerrainConfig(nx=10, ny=10, origin=(0.0, 0.0), cell=0.5))
    grid.place(3, 3)
    cells = grid.cells_within(1.75, 1.75, 0.2)  # centre of (3, 3), radius reaching no further cell
    assert cells == {(3, 3)}
    grid.reserve("dog", cells)
    assert grid.place(3, 3) is Placement.UNDER_CHARACTER
    assert grid.remove(3, 3) is Placement.UNDER_CHARACTER
    assert grid.set_height(3, 3, 0) is Placement.UNDER_CHARACTER
    assert grid.height(3, 3) == 1
    grid.reserve("dog", grid.cells_within(0.25, 0.25, 0.1))  # it moved on
    assert grid.place(3, 3) is Placement.PLACED
    grid.release("dog")
    assert grid.place(0, 0) is Placement.PLACED


def test_stage_geometry_round_trips() -> None:
    cfg = TerrainConfig(cell=0.3, nx=8, ny=5, origin=(-1.2, -0.6))
    grid = TerrainGrid(cfg)
    for ix in range(cfg.nx):
        for iy in range(cfg.ny):
            x, y = grid.centre(ix, iy)
            assert grid.cell_of(x, y) == (ix, iy)
    assert grid.cell_of(-1.21, 0.0) is None
    grid.place(2, 1)
    grid.place(2, 1)
    x, y = grid.centre(2, 1)
    assert grid.ground_z(x, y) == pytest.approx(0.6)
    assert grid.ground_z(x + 0.16, y) == 0.0  # next cell
    assert grid.ground_z_max(x + 0.16, y, 0.05) == pytest.approx(0.6)


def test_listeners_see_every_accepted_change_in_order() -> None:
    grid = TerrainGrid(TerrainConfig(nx=3, ny=3))
    seen: list[CellChange] = []
    grid.subscribe(seen.append)
    grid.place(0, 0)
    grid.place(5, 5)  # refused: no event
    grid.set_height(1, 2, 3)
    grid.remove(0, 0)
    assert [(c.ix, c.iy, c.before, c.after, c.version) for c in seen] == [
        (0, 0, 0, 1, 1), (1, 2, 0, 3, 2), (0, 0, 1, 0, 3)]
    assert grid.version == 3


def _top_hit(client: int, body: TerrainBody, x: float, y: float) -> float:
    """Top of the pybullet box standing under (x, y) (0 when none); rays ignore the floor's collision group."""
    for box in body.boxes.values():
        lo, hi = p.getAABB(box, physicsClientId=client)
        if lo[0] < x < hi[0] and lo[1] < y < hi[1]:
            return float(hi[2])
    return 0.0


def test_pybullet_body_follows_the_grid() -> None:
    client, _floor = open_client(WorldConfig())
    try:
        grid = TerrainGrid(TerrainConfig(cell=0.3, nx=6, ny=6, origin=(0.0, 0.0)))
        grid.set_height(1, 1, 2)
        body = TerrainBody(client, grid)  # built from a grid that already has cubes
        x, y = grid.centre(1, 1)
        assert _top_hit(client, body, x, y) == pytest.approx(0.6, abs=1e-4)
        grid.place(4, 2)
        x2, y2 = grid.centre(4, 2)
        assert _top_hit(client, body, x2, y2) == pytest.approx(0.3, abs=1e-4)
        grid.remove(1, 1)
        assert _top_hit(client, body, x, y) == pytest.approx(0.3, abs=1e-4)
        grid.remove(1, 1)
        assert _top_hit(client, body, x, y) == pytest.approx(0.0, abs=1e-4)  # the floor
        assert set(body.boxes) == {(4, 2)}
        # a ball dropped on the cube rests on its top face
        ball = p.createMultiBody(1.0, p.createCollisionShape(p.GEOM_SPHERE, radius=0.05, physicsClientId=client),
                                 -1, (x2, y2, 0.6), physicsClientId=client)
        from sim.physics import GROUP_CHARACTER, MASK_CHARACTER
        p.setCollisionFilterGroupMask(ball, -1, GROUP_CHARACTER, MASK_CHARACTER, physicsClientId=client)
        for _ in range(240):
            p.stepSimulation(physicsClientId=client)
        z = p.getBasePositionAndOrientation(ball, physicsClientId=client)[0][2]
        assert z == pytest.approx(0.35, abs=0.01)
    finally:
        p.disconnect(physicsClientId=client)


def test_heights_array_matches_columns() -> None:
    grid = TerrainGrid(TerrainConfig(nx=5, ny=4))
    rng = np.random.default_rng(3)
    for ix, iy in rng.integers(0, 4, size=(20, 2)):
        grid.place(int(ix), int(iy))
    assert int(grid.heights.sum()) == sum(grid.height(i, j) for i in range(5) for j in range(4))
