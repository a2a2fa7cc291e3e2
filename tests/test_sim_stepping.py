"""Control/physics step split and the sim config validation."""

from __future__ import annotations

import math

import pytest

from sim.config import CharacterSpec, WorldConfig
from sim.stepping import compute_n_substeps


@pytest.mark.parametrize(
    ("control_dt", "physics_dt", "n"),
    [(1 / 60, 1 / 240, 4), (1 / 240, 1 / 240, 1), (0.1, 0.001, 100), (1 / 30, 1 / 240, 8)],
)
def test_whole_ratios_give_the_substep_count(control_dt: float, physics_dt: float, n: int) -> None:
    assert compute_n_substeps(control_dt, physics_dt) == n


@pytest.mark.parametrize(
    ("control_dt", "physics_dt"),
    [(1 / 50, 1 / 240), (1 / 240, 1 / 60), (0.0, 1 / 240), (1 / 60, 0.0), (-1 / 60, 1 / 240),
     (math.nan, 1 / 240), (1 / 60, math.inf), (1 / 60 * (1 + 1e-6), 1 / 240)],
)
def test_non_whole_or_bad_ratios_raise(control_dt: float, physics_dt: float) -> None:
    with pytest.raises(ValueError) as err:
        compute_n_substeps(control_dt, physics_dt)
    assert str(err.value).split(":")[0] in ("control_dt", "physics_dt")


def test_ratio_within_relative_tolerance_is_accepted() -> None:
    assert compute_n_substeps(1 / 60 * (1 + 1e-12), 1 / 240) == 4


def test_world_config_defaults_and_errors_name_the_field() -> None:
    cfg = WorldConfig()
    assert cfg.n_substeps == 8  # physics 240 Hz, control 30 Hz
    with pytest.raises(ValueError, match=r"^control_dt: expected a whole multiple"):
        WorldConfig(control_dt=1 / 50)
    with pytest.raises(ValueError, match=r"^x_max: "):
        WorldConfig(x_min=1.0, x_max=-1.0)
    with pytest.raises(ValueError, match=r"^max_catchup_ticks: "):
        WorldConfig(max_catchup_ticks=0)
    with pytest.raises(ValueError, match=r"^gravity: "):
        WorldConfig(gravity=math.nan)


def test_character_spec_errors_name_the_field() -> None:
    spec = CharacterSpec()
    assert spec.height == 1.5 and spec.mass == 40.0 and spec.inertia == 10.0
    with pytest.raises(ValueError, match=r"^mass: expected a number > 0"):
        CharacterSpec(mass=-3.0)
    with pytest.raises(ValueError, match=r"^half_depth: "):
        CharacterSpec(half_depth=0.3, half_width=0.2)
    with pytest.raises(ValueError, match=r"^stagger_ratio: "):
        CharacterSpec(stagger_ratio=0.95, fall_ratio=0.9)
    with pytest.raises(ValueError, match=r"^com_height: "):
        CharacterSpec(com_height=2.0)
    with pytest.raises(ValueError, match=r"^name: "):
        CharacterSpec(name=" ")
