"""The user's errors are matched by type (one line, exit 2); anything else is an internal error."""

from __future__ import annotations

import pytest

from interaction.webcam.calibration import CalibrationError
from jostle.configtree import ConfigError
from jostle.errors import UsageError, user_facing
from render.gl.context import RendererUnavailable
from render.gl.video import VideoError
from render.keyframes.set_file import KeyframeError
from sensors.base import SensorError, SensorUnavailable
from sim.motion.mocap import MotionFileError


@pytest.mark.parametrize("kind", [UsageError, ConfigError, SensorError, SensorUnavailable, MotionFileError,
                                  KeyframeError, RendererUnavailable, CalibrationError, VideoError])
def test_a_user_error_is_its_message(kind: type[Exception]) -> None:
    assert user_facing(kind("what to fix")) == "what to fix"


def test_a_missing_file_is_named() -> None:
    assert user_facing(FileNotFoundError(2, "No such file", "x.toml")) == "x.toml: no such file"


@pytest.mark.parametrize("error", [ValueError("bug"), RuntimeError("bug"), KeyError("k")])
def test_anything_else_is_internal(error: Exception) -> None:
    assert user_facing(error) is None


def test_a_class_merely_named_like_a_user_error_is_not_one() -> None:
    lookalike = type("KeyframeError", (Exception,), {})
    assert user_facing(lookalike("x")) is None
