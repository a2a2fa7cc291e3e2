"""The quadruped in the World: snapshot contract, cubes never under characters, the Mitake characters
colliding with the cubes, shoves it recovers from and knock-downs it gets up from."""

from __future__ import annotations

import math
from collections.abc import Iterator

import numpy as np
import pytest

from sim.config import CharacterSpec, WorldConfig
from sim.quadruped.config import QuadrupedSpec
from sim.quadruped.herd import Quadrupeds
from sim.snapshot import CharacterState, WorldSnapshot
from sim.terrain import Placement, TerrainConfig
from sim.world import World

TERRAIN = TerrainConfig(cell=0.3, nx=20, ny=8, origin=(-3.0, -1.2))


@pytest.fixture
def world() -> Iterator[World]:
    w = World(WorldConfig(), np.random.default_rng(0))
    yield w
    w.close()


def _quad(snap: WorldSnapshot):  # type: ignore[no-untyped-def]
    return next(c for c in snap.characters if c.kind == "quadruped")


def _herd(world: World) -> Quadrupeds:
    herd = world.population("quadruped")
    assert isinstance(herd, Quadrupeds)
    return herd


def _run(world: World, seconds: float) -> list[WorldSnapshot]:
    return [world.step(None, 1 / 30) for _ in range(int(round(seconds * 30)))]


def test_snapshot_contract_and_walk_to_goal(world: World) -> None:
    world.add_terrain(TERRAIN)
    herd = _herd(world)
    world.add_character(CharacterSpec(), (2.0, 0.6), 0.0, intent="idle")
    name = world.add_character(QuadrupedSpec(), (-2.4, 0.0), 0.0, goal=(-0.6, 0.0))
    snaps = _run(world, 9.0)
    q = _quad(snaps[-1])
    assert q.name == name and q.kind == "quadruped" and len(snaps[-1].characters) == 2
    names = [link.name for link in q.links]
    assert names[0] == "chassis" and {"toeFR", "toeRR", "toeFL", "toeRL", "FR_lower_leg"} <= set(names)
    assert all(math.isfinite(v) for link in q.links for v in (*link.position, *link.orientation))
    assert q.state is CharacterState.WALK and q.intent == "goal"
    assert math.dist(q.position[:2], (-0.6, 0.0)) < 0.45 and q.behaviour == "stand"
    assert q.d_front > 1.2
    m = herd.members[name]
    assert m.penetration_max * 1000 <= 5.0 and m.slip.p95() * 1000 <= 10.0


def test_no_cube_under_any_character(world: World) -> None:
    grid = world.add_terrain(TERRAIN)
    world.add_character(CharacterSpec(), (1.35, 0.15), 0.0, intent="idle")
    world.add_character(QuadrupedSpec(), (-1.65, 0.15), 0.0)
    _run(world, 0.2)
    assert grid.place(*grid.cell_of(1.35, 0.15)) is Placement.UNDER_CHARACTER  # type: ignore[misc]
    assert grid.place(*grid.cell_of(-1.65, 0.15)) is Placement.UNDER_CHARACTER  # type: ignore[misc]
    assert grid.place(*grid.cell_of(0.0, -0.9)) is Placement.PLACED  # type: ignore[misc]


def test_mitake_characters_collide_with_the_cubes(world: World) -> None:
    grid = world.add_terrain(TERRAIN)
    for iy in range(TERRAIN.ny):
        grid.set_height(10, iy, 2)  # a wall across the stage at x in [0, 0.3)
    world.add_character(CharacterSpec(), (-1.5, 0.0), 0.0, intent="follow", waypoints=[(2.0, 0.0), (2.5, 0.0)])
    xs = [c.position[0] for snap in _run(world, 8.0) for c in snap.characters]
    assert max(xs) < 0.0  # never through the wall
    assert max(xs) > -0.6  # it did walk up to it


def test_a_shove_offsets_it_and_it_steps_back(world: World) -> None:
    world.add_terrain(TERRAIN)
    herd = _herd(world)
    name = world.add_character(QuadrupedSpec(), (0.0, 0.0), 0.0)
    _run(world, 0.5)
    x0 = _quad(world.snapshot()).position
    herd.shove(name, (0.0, 0.6, 0.0), world.t)
    snaps = _run(world, 3.0)
    offsets = [math.dist(_quad(s).position[:2], x0[:2]) for s in snaps]
    assert max(offsets) > 0.04  # it moved
    assert CharacterState.STAGGER in {_quad(s).state for s in snaps}
    assert offsets[-1] < 0.02 and _quad(snaps[-1]).state is CharacterState.WALK  # and came back, upright
    m = herd.members[name]
    assert m.body.unreached == 0


def test_a_strong_shove_knocks_it_over_and_it_gets_up(world: World) -> None:
    world.add_terrain(TERRAIN)
    herd = _herd(world)
    spec = QuadrupedSpec()
    name = world.add_character(spec, (0.0, 0.0), 0.0)
    _run(world, 0.3)
    herd.shove(name, (0.0, 2.5, 0.0), world.t)
    snaps = _run(world, spec.lie_s + spec.getup_s + 3.0)
    states = [_quad(s).state for s in snaps]
    assert CharacterState.FALL in states or CharacterState.LIE in states
    assert CharacterState.STAND_UP in states
    assert states[-1] is CharacterState.WALK
    q = _quad(snaps[-1])
    assert abs(q.tilt[0]) < 0.1 and abs(q.tilt[1]) < 0.1  # upright again
