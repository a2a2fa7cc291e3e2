"""With the stagger strategies (the crossing step hurried, a stiffer stance hip; on by default, see
``ArticulatedSpec.stagger_hurry``), a 300 N sideways push on the pelvis while walking (issue 9's target:
DeepMimic's policy takes 300 N for 0.2 s) is taken by stepping and the character returns to the clip,
recovering at finer steps (the default) or at the world's step. At the world's step, without them the same
push at the first of the two walking phases tested makes it fall (at the second, it takes it either way);
recovering at finer steps it takes that push without them too (measured)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from sim.articulated import balance as bal
from sim.articulated.character import ArticulatedCharacter
from sim.articulated.recovery import advance
from sim.articulated.skeleton import ArticulatedSkeleton
from sim.articulated.spec import ArticulatedSpec
from sim.snapshot import CharacterState

DT = 1.0 / 240.0
DOWN = (CharacterState.FALL, CharacterState.LIE, CharacterState.STAND_UP)
CYCLE_S = 1.266616  # the walk clip's duration
AT_WORLD_STEP = {"recovery_substeps": 1}  # recovery off: the world's 1/240 s throughout
STIFF_FREE = ArticulatedSpec(stagger_hurry=0.0, stagger_stance_hip_gain=1.0, **AT_WORLD_STEP)  # strategies off


def _step(client: int, ch: ArticulatedCharacter) -> None:
    advance(client, [ch], DT)


@pytest.mark.parametrize("substeps", [8, 1])
@pytest.mark.parametrize(("walk_s", "to_left"), [(2.0, True), (2.0 + CYCLE_S / 2, False)])
def test_with_stagger_strategies_a_300_n_side_push_is_stepped_out_and_it_returns_to_the_clip(
        client: int, skeleton: ArticulatedSkeleton, walk_s: float, to_left: bool, substeps: int) -> None:
    spec = ArticulatedSpec(recovery_substeps=substeps)
    ch = ArticulatedCharacter(client, skeleton, spec, None, (0.0, 0.0), 0.0)
    before = []
    for i in range(round(walk_s / DT)):
        _step(client, ch)
        if i % 12 == 11 and (i + 1) * DT > walk_s - 1.0:
            before.append(ch.tracking_error_deg())
    start, _ = ch.com_state()
    h = bal.heading_of(ch.root()[1])
    sign = 1.0 if to_left else -1.0
    ch.push("root", (-sign * 300.0 * math.sin(h), sign * 300.0 * math.cos(h), 0.0), 0.2)  # 60 N·s sideways
    states, after, sideways = [], [], 0.0
    for i in range(round(5.0 / DT)):
        _step(client, ch)
        assert ch.state not in DOWN, f"fell {ch.t - walk_s:.2f} s after the push"
        if i % 12 == 11:
            states.append(ch.state)
            com, _ = ch.com_state()
            sideways = max(sideways, sign * (-(com - start)[0] * math.sin(h) + (com - start)[1] * math.cos(h)))
            if (i + 1) * DT > 4.0:
                after.append(ch.tracking_error_deg())
    assert CharacterState.STAGGER in states and ch.falls == 0
    assert sideways > 0.3  # the push moved it: it stepped out sideways, not stood its ground
    # back to the clip: walking again, tracking it as well as before the push
    assert states[-1] == CharacterState.WALK
    assert float(np.mean(after)) < float(np.mean(before)) + 2.0
    assert ch.limit_excess() < math.radians(10.0)


def test_without_stagger_strategies_the_same_push_fells_it(client: int, skeleton: ArticulatedSkeleton) -> None:
    ch = ArticulatedCharacter(client, skeleton, STIFF_FREE, None, (0.0, 0.0), 0.0)
    for _ in range(round(2.0 / DT)):
        _step(client, ch)
    h = bal.heading_of(ch.root()[1])
    ch.push("root", (-300.0 * math.sin(h), 300.0 * math.cos(h), 0.0), 0.2)  # to its left, as above
    for _ in range(round(5.0 / DT)):
        _step(client, ch)
    assert ch.falls >= 1


def test_stagger_fields_are_checked() -> None:
    with pytest.raises(ValueError, match="^stagger_hurry_max"):
        ArticulatedSpec(stagger_hurry_max=0.5)
    with pytest.raises(ValueError, match="^stagger_hurry"):
        ArticulatedSpec(stagger_hurry=-1.0)
    with pytest.raises(ValueError, match="^stagger_stance_hip_gain"):
        ArticulatedSpec(stagger_stance_hip_gain=-0.1)


def test_the_clip_hurries_only_while_the_body_heads_over_the_stance_foot() -> None:
    # standing on the left foot, heading left (side < 0): the right leg would cross, so the clip hurries
    assert bal.hurried_rate(-0.2, True, 2.0, 2.0) == pytest.approx(1.4)
    assert bal.hurried_rate(0.2, True, 2.0, 2.0) == 1.0  # heading right: the right leg steps out as recorded
    assert bal.hurried_rate(0.2, False, 2.0, 2.0) == pytest.approx(1.4)  # mirrored
    assert bal.hurried_rate(-3.0, True, 2.0, 1.5) == 1.5  # at most the limit
