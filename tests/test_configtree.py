"""The generic TOML → dataclass builder: strict, and every error names file, key and expectation."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Literal

import pytest

from jostle.configtree import ConfigError, build


@dataclass(frozen=True)
class Inner:
    gain: float = 1.0


@dataclass(frozen=True)
class Sample:
    name: str
    fps: float = 30.0
    count: int = 1
    on: bool = True
    path: Path = Path("x.txt")
    size: tuple[int, int] = (320, 240)
    weights: tuple[float, ...] = ()
    mode: Literal["fast", "slow"] = "fast"
    inner: Inner = field(default_factory=Inner)

    def __post_init__(self) -> None:
        if self.fps <= 0:
            raise ValueError(f"fps: expected a number > 0, got {self.fps}")


def make(table: dict[str, object]) -> Sample:
    return build(Sample, table, source="configs/test.toml", key="things.a", base_dir=Path("/base"))


def test_builds_with_conversions() -> None:
    s = make({"name": "a", "fps": 15, "path": "rec/x.mcap", "size": [640, 480], "weights": [1, 2.5],
              "mode": "slow", "inner": {"gain": 2}})
    assert s.fps == 15.0 and isinstance(s.fps, float)
    assert s.path == Path("/base/rec/x.mcap")
    assert s.size == (640, 480) and s.weights == (1.0, 2.5)
    assert s.mode == "slow" and s.inner == Inner(2.0)


@pytest.mark.parametrize(
    "table, expected",
    [
        ({"name": "a", "colour": 1}, "configs/test.toml: things.a.colour: unknown key; expected one of:"),
        ({}, "configs/test.toml: things.a.name: missing; expected a string"),
        ({"name": 42}, "configs/test.toml: things.a.name: expected a string, got 42 (int)"),
        ({"name": "a", "count": 1.5}, "things.a.count: expected a whole number, got 1.5"),
        ({"name": "a", "count": True}, "things.a.count: expected a whole number, got True"),
        ({"name": "a", "on": "yes"}, "things.a.on: expected true or false, got 'yes'"),
        ({"name": "a", "fps": -3}, "configs/test.toml: things.a.fps: expected a number > 0, got -3.0"),
        ({"name": "a", "mode": "medium"}, "things.a.mode: expected one of 'fast', 'slow', got 'medium'"),
        ({"name": "a", "size": [1, 2, 3]}, "things.a.size: expected"),
        ({"name": "a", "inner": {"gian": 2}}, "things.a.inner.gian: unknown key"),
        ({"name": "a", "path": 7}, "things.a.path: expected a path (string), got 7 (int)"),
    ],
)
def test_errors_name_file_key_and_expectation(table: dict[str, object], expected: str) -> None:
    with pytest.raises(ConfigError) as err:
        make(table)
    message = str(err.value)
    assert expected in message
    assert "\n" not in message
