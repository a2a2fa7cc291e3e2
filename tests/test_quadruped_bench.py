"""``jostle bench quadruped`` end to end on a small setting, and the World's quadruped deterministic."""

from __future__ import annotations

import argparse

import numpy as np

from jostle.bench import quadruped as bench
from jostle.bench.table import BENCHES
from sim.config import CharacterSpec, WorldConfig
from sim.quadruped.config import QuadrupedSpec
from sim.terrain import TerrainConfig
from sim.world import World


def test_bench_reports_the_issue_keys() -> None:
    assert BENCHES["quadruped"][0] is bench
    parser = argparse.ArgumentParser()
    bench.add_arguments(parser)
    args = parser.parse_args(["--terrains", "4", "--walk-size", "14", "--replan-size", "24", "--replans", "20"])
    figures = bench.run(args)
    for key in ("terrains", "goals_reached", "unreachable", "foot_penetration_mm_max", "foot_slip_mm_p95",
                "replan_ms_p99", "fps"):
        assert key in figures
    assert figures["terrains"] == 4
    assert figures["unreachable"] >= 1 and figures["unreachable_reported"] == 1.0  # the walled-in goal
    assert figures["goals_reached"] == 1.0
    assert figures["foot_penetration_mm_max"] <= 5.0 and figures["foot_slip_mm_p95"] <= 10.0
    assert figures["fps"] > 0 and figures["replan_ms_p99"] > 0


def _trace(seed: int) -> list[tuple[float, ...]]:
    with World(WorldConfig(), np.random.default_rng(seed)) as world:
        grid = world.add_terrain(TerrainConfig(cell=0.3, nx=20, ny=8, origin=(-3.0, -1.2)))
        for iy in range(8):
            grid.set_height(12, iy, 1)
        world.add_character(CharacterSpec(), (2.0, 0.6), 0.0)
        world.add_character(QuadrupedSpec(waypoints=(2.0, -0.5, -2.0, -0.5)), (-2.4, -0.5), 0.0)
        out = []
        for _ in range(90):
            snap = world.step(None, 1 / 30)
            out.extend(tuple(link.position) for c in snap.characters for link in c.links)
            out.extend(c.position for c in snap.characters)
        return out


def test_world_with_a_quadruped_is_deterministic() -> None:
    assert _trace(3) == _trace(3)
