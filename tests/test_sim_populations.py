"""The world as populations (sim.population): all three kinds stepping together, the terrain changed only
through step inputs, and what the contracts now carry (silhouette, terrain reports, com_height)."""

from __future__ import annotations

import math
from collections.abc import Iterator

import numpy as np
import pytest

from interaction.fusion import SensorFusion
from interaction.types import BodyObservation, Impulse, Silhouette, TerrainReport
from interaction.webcam.calibration import Calibration
from sim.articulated.spec import ArticulatedSpec
from sim.config import CharacterSpec, WorldConfig
from sim.quadruped.config import QuadrupedSpec
from sim.terrain import TerrainConfig
from sim.world import World

TERRAIN = TerrainConfig(cell=0.3, nx=20, ny=8, origin=(-3.0, -1.2))
DT = 1 / 30


@pytest.fixture
def world() -> Iterator[World]:
    w = World(WorldConfig(x_min=-6.0, x_max=6.0, y_min=-3.0, y_max=3.0), np.random.default_rng(0))
    yield w
    w.close()


def test_all_three_kinds_step_in_one_world(world: World) -> None:
    world.add_terrain(TERRAIN)
    mitake = world.add_character(CharacterSpec(), (2.0, 0.6), 0.0, intent="idle")
    dog = world.add_character(QuadrupedSpec(), (-2.4, 0.0), 0.0, goal=(-1.2, 0.0))
    walker = world.add_character(ArticulatedSpec(), (0.0, -0.6), 0.0)
    assert len({mitake, dog, walker}) == 3
    for _ in range(30):
        snap = world.step(None, DT)
    kinds = [c.kind for c in snap.characters]
    assert [c.name for c in snap.characters] == [mitake, dog, walker]  # populations in a fixed order
    assert kinds[1] == "quadruped" and snap.characters[2].links and snap.characters[1].links
    assert all(math.isfinite(v) for c in snap.characters for v in (*c.position, *c.orientation))
    assert snap.t == pytest.approx(1.0)
    with pytest.raises(KeyError):
        world.strike("nobody", (1.0, 0.0, 0.0), 0.1, (0.0, 0.0, 0.0))


def test_a_quadruped_needs_the_terrain_first(world: World) -> None:
    with pytest.raises(ValueError, match="add_terrain"):
        world.add_character(QuadrupedSpec(), (0.0, 0.0), 0.0)


def test_the_terrain_changes_through_step_inputs(world: World) -> None:
    grid = world.add_terrain(TERRAIN, layout=((1, 1, 2),))
    name = world.add_character(CharacterSpec(), (1.35, 0.15), 0.0, intent="idle")
    assert name and grid.height(1, 1) == 2
    under = grid.cell_of(1.35, 0.15)
    assert under is not None
    report = TerrainReport(placements=((3, 3), under), boxes=((5, 5, 2),))
    world.step(BodyObservation(t=0.0, terrain=report), DT)
    assert grid.height(3, 3) == 1 and grid.height(5, 5) == 2 and grid.height(*under) == 0
    counts = world.terrain_counts
    assert counts["hand_placed"] == 1 and counts["hand_under_character"] == 1 and counts["box_added"] == 1
    world.step(BodyObservation(t=DT, terrain=TerrainReport(boxes=())), DT)  # the box lifted away
    assert grid.height(5, 5) == 0 and world.terrain_counts["box_removed"] == 1
    world.step(BodyObservation(t=2 * DT, terrain=TerrainReport(placements=((1.5, 2),))), DT)  # type: ignore[arg-type]
    assert world.counters.rejected_inputs == 1  # not a cell: dropped and counted


def test_an_impulse_acts_once_however_often_it_is_handed_over(world: World) -> None:
    spec = CharacterSpec()
    near = world.add_character(spec, (1.5, 0.0), 0.0, intent="idle")
    hit = Impulse(position=(1.4, 0.0, spec.com_height), force=(150.0, 0.0, 0.0), duration=0.1, source="pad0")
    events = []
    for k in range(20):
        events += world.step(BodyObservation(t=k * DT, impulses=(hit,)) if k < 2 else None, DT).contacts
    assert [e.character for e in events] == [near]
    events = []
    for k in range(20):  # the same hit again, once the first is over: a new hit
        events += world.step(BodyObservation(t=1.0, impulses=(hit,)) if k == 0 else None, DT).contacts
    assert len(events) == 1


def test_the_snapshot_carries_com_height_outside_its_repr(world: World) -> None:
    spec = CharacterSpec()
    world.add_character(spec, (0.0, 0.0), 0.0, intent="idle")
    c = world.step(None, DT).characters[0]
    assert c.com_height == spec.com_height and "com_height" not in repr(c)


def test_the_silhouette_and_terrain_reports_survive_merging() -> None:
    cal = Calibration(homography=(1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0), image_size=(4, 2))
    mask = np.zeros((2, 4), np.uint8)
    seen = BodyObservation(t=0.0, people=1, silhouette=Silhouette(mask, cal))
    boxes = BodyObservation(t=0.0, terrain=TerrainReport(boxes=((1, 2, 1),)))
    hands = BodyObservation(t=0.0, terrain=TerrainReport(placements=((3, 4),)))
    for merged in (BodyObservation.merge(0.1, [boxes, seen, hands]), SensorFusion().merge(0.1, [boxes, seen, hands])):
        assert merged.silhouette == Silhouette(mask.copy(), cal)
        assert merged.terrain == TerrainReport(placements=((3, 4),), boxes=((1, 2, 1),))
    assert BodyObservation.merge(0.1, [BodyObservation(t=0.0)]).terrain is None
