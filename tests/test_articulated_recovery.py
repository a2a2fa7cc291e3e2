"""Recovering at finer physics steps (``sim.articulated.recovery``, issue 9's "joint limits are never exceeded"):
with ``recovery_substeps`` 8 the joints stay inside their limits through a push taken
by stepping and through a fall and a get-up, where at the world's step the same pushes carry a hip past."""

from __future__ import annotations

import math

import numpy as np
import pybullet as p
import pytest

from sim.articulated import balance as bal
from sim.articulated.character import ArticulatedCharacter
from sim.articulated.recovery import Recovery, advance
from sim.articulated.skeleton import ArticulatedSkeleton
from sim.articulated.spec import ArticulatedSpec
from sim.config import WorldConfig
from sim.snapshot import CharacterState
from sim.world import World

DT = 1.0 / 240.0
RECOVERING = ArticulatedSpec(recovery_substeps=8)
# Measured at both settings on these two runs (a 300 N push to its left at 2.0 s, 0.2 s, then walking on; a
# 700 N push forward at 1.0 s, then the fall, lying, the get-up and walking on): at the world's step 5.1° and
# 5.4° past a limit at worst; recovering at 8 substeps 0.0° and 0.8°.
BOUND_DEG = 1.5  # margin over the 0.8° (the physics differs a little between builds)


def _run(client: int, skeleton: ArticulatedSkeleton, spec: ArticulatedSpec, push_at: float, forward: float,
         left: float, seconds: float) -> tuple[float, ArticulatedCharacter, list[CharacterState], list[int]]:
    """(worst excess in degrees over every physics step, the character, the states it went through, substeps
    taken at every step)."""
    ch = ArticulatedCharacter(client, skeleton, spec, None, (0.0, 0.0), 0.0)
    worst, states, fine = 0.0, [ch.state], []
    for _ in range(round(seconds / DT)):
        if abs(ch.t - push_at) < DT / 2:
            h = bal.heading_of(ch.root()[1])
            ch.push("root", (forward * math.cos(h) - left * math.sin(h), forward * math.sin(h) + left * math.cos(h),
                             0.0), 0.2)
        fine.append(advance(client, [ch], DT))
        worst = max(worst, math.degrees(ch.limit_excess()))
        if states[-1] != ch.state:
            states.append(ch.state)
    return worst, ch, states, fine


def test_recovering_at_finer_steps_keeps_the_joints_inside_their_limits(client: int,
                                                                        skeleton: ArticulatedSkeleton) -> None:
    side_off, *_ = _run(client, skeleton, ArticulatedSpec(), 2.0, 0.0, 300.0, 5.0)
    side_on, ch, states, fine = _run(client, skeleton, RECOVERING, 2.0, 0.0, 300.0, 10.0)
    assert ch.falls == 0 and CharacterState.STAGGER in states  # taken by stepping, and it walks on
    pushed_at = round(2.0 / DT)
    settled = pushed_at + fine[pushed_at:].index(1)
    assert set(fine[:pushed_at - 1]) == {1} and set(fine[pushed_at:settled]) == {8}  # finer from the push on
    # settled recovery_settle_s after the push ended (measured: 6.2 s) and walked on at the world's step
    assert settled * DT < 8.0 and set(fine[settled:]) == {1}
    fall_off, *_ = _run(client, skeleton, ArticulatedSpec(), 1.0, 700.0, 0.0, 12.0)
    fall_on, ch, states, _ = _run(client, skeleton, RECOVERING, 1.0, 700.0, 0.0, 12.0)
    order = [CharacterState.FALL, CharacterState.LIE, CharacterState.STAND_UP, CharacterState.WALK]
    seen = iter(states)
    assert all(s in seen for s in order), states  # it fell, lay, got up and walked again
    assert ch.getups == 1
    assert max(side_on, fall_on) <= BOUND_DEG, (side_on, fall_on)
    assert max(side_off, fall_off) > 2.0 * BOUND_DEG, (side_off, fall_off)  # the soft limits it is there for


def test_a_twin_walks_on_while_the_world_steps_finely_for_the_pushed_one(client: int,
                                                                          skeleton: ArticulatedSkeleton) -> None:
    """Stepped finely for the other's sake, a walker balances with the recovery's gains too (with its walking
    gains at the finer step it fell, at each of 4 walking phases tried: measured)."""
    pushed = ArticulatedCharacter(client, skeleton, RECOVERING, None, (0.0, 0.0), 0.0)
    twin = ArticulatedCharacter(client, skeleton, RECOVERING, None, (0.0, 3.0), 0.0)
    p.setCollisionFilterPair(pushed.body, twin.body, -1, -1, 0, physicsClientId=client)
    fine = []
    for _ in range(round(8.0 / DT)):
        if abs(pushed.t - 2.0) < DT / 2:
            h = bal.heading_of(pushed.root()[1])
            pushed.push("root", (-300.0 * math.sin(h), 300.0 * math.cos(h), 0.0), 0.2)
        fine.append(advance(client, [pushed, twin], DT) > 1 and twin.stepped_finely)
        assert not twin.recovery.active  # nobody touched it: it only follows the world's step
    assert 3.0 < sum(fine) * DT < 6.0  # the pushed one recovered, settled, and the world's step came back
    assert pushed.falls == 0 and twin.falls == 0 and twin.state == CharacterState.WALK


def test_recovery_settles_after_walking_steadily() -> None:
    r = Recovery(ArticulatedSpec(recovery_substeps=4, recovery_settle_s=1.0))
    assert not r.active and r.wanted_substeps == 1
    r.begin()
    assert r.active and r.wanted_substeps == 4
    walk, fall = CharacterState.WALK, CharacterState.FALL
    for _ in range(9):
        r.update(walk, False, False, 0.1)
    r.update(walk, True, False, 0.1)  # pushed again: the steady time starts over
    for _ in range(9):
        r.update(CharacterState.STAGGER, False, False, 0.1)  # staggering upright counts as steady
    r.update(walk, False, True, 0.1)  # walking off from a stand does not
    r.update(fall, False, False, 0.1)  # nor falling
    for _ in range(9):
        r.update(walk, False, False, 0.1)
    assert r.active
    r.update(walk, False, False, 0.1)
    assert not r.active and r.wanted_substeps == 1
    off = Recovery(ArticulatedSpec())  # recovery_substeps 1: never
    off.begin()
    assert not off.active and off.wanted_substeps == 1


def test_advance_steps_finer_and_gives_the_world_its_step_back(client: int, skeleton: ArticulatedSkeleton) -> None:
    ch = ArticulatedCharacter(client, skeleton, ArticulatedSpec(recovery_substeps=4), None, (0.0, 0.0), 0.0)
    assert advance(client, [ch], DT) == 1
    ch.push("root", (50.0, 0.0, 0.0), 0.2)
    t0 = ch.t
    assert [advance(client, [ch], DT) for _ in range(24)] == [4] * 24
    assert ch.t - t0 == pytest.approx(24 * DT)  # four quarter steps make each step
    assert p.getPhysicsEngineParameters(physicsClientId=client)["fixedTimeStep"] == pytest.approx(DT)


def test_the_world_steps_finer_while_an_articulated_character_recovers() -> None:
    with World(WorldConfig(x_min=-6.0, x_max=6.0, y_min=-3.0, y_max=3.0), np.random.default_rng(1)) as world:
        name = world.add_character(ArticulatedSpec(recovery_substeps=4), (-3.0, 0.0), 0.0)
        for _ in range(15):
            world.step(None, 1.0 / 30.0)
        assert world.articulated.substeps() == 1
        world.strike(name, (0.0, 200.0, 0.0), 0.2, (0.0, 0.0, 0.0))
        for _ in range(15):
            world.step(None, 1.0 / 30.0)
        ch = world.articulated.characters[name]
        assert world.articulated.substeps() == 4 and ch.falls == 0
        assert ch.t == pytest.approx(world.t)  # its control saw every quarter step: the same time as the world
        assert p.getPhysicsEngineParameters(physicsClientId=ch.client)["fixedTimeStep"] == pytest.approx(DT)


def test_recovery_fields_are_checked() -> None:
    for bad in (0, 33, 2.5, True):
        with pytest.raises(ValueError, match="^recovery_substeps"):
            ArticulatedSpec(recovery_substeps=bad)  # type: ignore[arg-type]
    for field in ("fall_load", "recovery_settle_s", "recovery_cv_sagittal", "recovery_cv_coronal",
                  "recovery_assist_torque_max_nm", "recovery_fall_load", "recovery_neck_gain"):
        with pytest.raises(ValueError, match=f"^{field}"):
            ArticulatedSpec(**{field: -1.0})  # type: ignore[arg-type]
