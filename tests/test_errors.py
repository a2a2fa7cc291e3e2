"""The user's errors are matched by type (one line, exit 2); anything else is an internal error."""

from __future__ import annotations

import errno

import pytest

from interaction.depth.calibration import DepthCalibrationError
from interaction.webcam.calibration import CalibrationError
from jostle.configtree import ConfigError
from jostle.errors import UsageError, user_facing
from jostle.terrain_layout import LayoutError
from render.gl.context import RendererUnavailable
from render.gl.video import VideoError
from render.keyframes.set_file import KeyframeError
from sensors.base import SensorError, SensorUnavailable
from sensors.untrusted import UntrustedInput
from sim.motion.mocap import MotionFileError


@pytest.mark.parametrize("kind", [UsageError, ConfigError, SensorError, SensorUnavailable, MotionFileError,
                                  KeyframeError, RendererUnavailable, CalibrationError, VideoError,
                                  DepthCalibrationError, LayoutError])
def test_a_user_error_is_its_message(kind: type[Exception]) -> None:
    assert user_facing(kind("what to fix")) == "what to fix"


def test_refused_input_and_a_symlink_loop_are_user_errors() -> None:
    assert user_facing(UntrustedInput("x.toml", "is a FIFO, expected a regular file")) == \
        "x.toml: is a FIFO, expected a regular file"
    loop = OSError(errno.ELOOP, "Too many levels of symbolic links", "loop.toml")
    assert user_facing(loop) == "loop.toml: too many levels of symbolic links (a symlink loop?)"
    assert user_facing(OSError(errno.EIO, "I/O error", "x")) is None  # the machine's fault, not the user's


def test_a_missing_file_is_named() -> None:
    assert user_facing(FileNotFoundError(2, "No such file", "x.toml")) == "x.toml: no such file"


@pytest.mark.parametrize("error", [ValueError("bug"), RuntimeError("bug"), KeyError("k")])
def test_anything_else_is_internal(error: Exception) -> None:
    assert user_facing(error) is None


def test_a_class_merely_named_like_a_user_error_is_not_one() -> None:
    lookalike = type("KeyframeError", (Exception,), {})
    assert user_facing(lookalike("x")) is None
