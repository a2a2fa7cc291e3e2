"""Walking off after a get-up: the character that stood up walks on without falling again (issue 9)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from sim.articulated import balance as bal
from sim.articulated.character import ArticulatedCharacter
from sim.articulated.recovery import advance
from sim.articulated.skeleton import deepmimic_humanoid
from sim.articulated.spec import ArticulatedSpec
from sim.snapshot import CharacterState

DT = 1.0 / 240.0
DOWN = (CharacterState.FALL, CharacterState.LIE, CharacterState.STAND_UP)


def _until(client: int, ch: ArticulatedCharacter, seconds: float, done: list[CharacterState],
           worst: list[float] | None = None) -> bool:
    """Step until ``ch`` is in one of ``done`` (True) or ``seconds`` pass (False); the most any joint went past
    a limit (degrees) is kept in ``worst[0]``."""
    for _ in range(int(round(seconds / DT))):
        advance(client, [ch], DT)
        if worst is not None:
            worst[0] = max(worst[0], math.degrees(ch.limit_excess()))
        if ch.state in done:
            return True
    return False


# heading +x: pushed forward / to its left it falls face down, pushed back it falls face up (600 N back it
# recovers by stepping: measured)
@pytest.mark.parametrize(("force", "face_up"), [((600.0, 0.0, 0.0), False), ((0.0, 600.0, 0.0), False),
                                                ((-700.0, 0.0, 0.0), True)])
def test_walks_on_after_getting_up(client: int, force: tuple[float, float, float], face_up: bool) -> None:
    ch = ArticulatedCharacter(client, deepmimic_humanoid(), ArticulatedSpec(), None, (0.0, 0.0), 0.0)
    worst = [0.0]
    assert not _until(client, ch, 2.0, list(DOWN))
    ch.push("root", force, 0.2)
    assert _until(client, ch, 3.0, [CharacterState.FALL], worst)
    assert _until(client, ch, 10.0, [CharacterState.WALK], worst) and ch.getups == 1
    assert ch.getup_face_up is face_up
    start = ch.root()[0].copy()
    fell_again = _until(client, ch, 6.0, list(DOWN), worst)
    assert not fell_again, f"fell again {ch.t:.2f} s into the run"
    print(f"at most {worst[0]:.2f} deg past a limit")
    # the fall, the get-up and the walk on: measured 0.71 / 2.11 / 0.13° past a limit at most (sideways: a hip,
    # toppling, in the last 1/100 s before the fall); pybullet's limits are soft, see test_articulated_recovery
    assert worst[0] <= 2.5
    assert float(np.linalg.norm((ch.root()[0] - start)[:2])) > 2.0  # walked on, not stood still
    # the walk-in help stays within its bound: the walking torque limit times walk_in_assist
    s = ch.spec
    assert ch.external_assist_peak_nm <= max(s.getup_assist_torque_max_nm,
                                             s.assist_torque_max_nm * s.walk_in_assist) + 1e-6
    # … and the get-up's force: lift and (face up) the root held over the feet, each within its own limit
    assert ch.external_assist_peak_n <= float(np.hypot(s.getup_assist_force_max_n, s.getup_place_force_n)) + 1e-6


def test_face_up_get_up_ends_standing_over_its_feet(client: int) -> None:
    """The face-up get-up clip ends upright at 0.84 m with the feet under the pelvis; tracked without the root
    held over the feet the body pivoted forward over them and ended at 0.74 m leaning ~20° forward."""
    ch = ArticulatedCharacter(client, deepmimic_humanoid(), ArticulatedSpec(), None, (0.0, 0.0), 0.0)
    assert not _until(client, ch, 2.0, list(DOWN))
    ch.push("root", (-700.0, 0.0, 0.0), 0.2)
    assert _until(client, ch, 13.0, [CharacterState.WALK]) and ch.getup_face_up
    root, orn = ch.root()
    assert root[2] > 0.8 and np.degrees(bal.tilt_of(orn)) < 12.0


def test_walk_in_fields_are_checked() -> None:
    with pytest.raises(ValueError, match="^walk_in_blend_s"):
        ArticulatedSpec(walk_in_blend_s=-0.1)
    with pytest.raises(ValueError, match="^getup_grace_s"):
        ArticulatedSpec(getup_grace_s=0.0)
    with pytest.raises(ValueError, match="^getup_place_force_n"):
        ArticulatedSpec(getup_place_force_n=-1.0)
    with pytest.raises(ValueError, match="^getup_place_tilt_deg"):
        ArticulatedSpec(getup_place_tilt_deg=0.0)
    with pytest.raises(ValueError, match="^ankle_gain_coronal"):
        ArticulatedSpec(ankle_gain_coronal=-1.0)
