"""Which exceptions are the user's to fix (printed as one line) and which are bugs (tracebacks).

A user error is one of :func:`user_error_types`, matched by type: a mistake on the command line
(:class:`UsageError`), in a config, recording, motion, keyframe or calibration file, a sensor that
cannot be opened, no renderer, no video encoder. Anything else is an internal error.
"""

from __future__ import annotations


class UsageError(Exception):
    """A mistake on the command line or in a file it names; printed as one line, exit status 2."""


class RunFailed(Exception):
    """A run that went to its end without doing its job (an observer produced nothing from the frames
    it was given); printed as one line, exit status 1 (the summary is still written)."""


def user_error_types() -> tuple[type[BaseException], ...]:
    """The exception types whose message is the whole story for the user (imported on demand)."""
    from interaction.webcam.calibration import CalibrationError
    from jostle.configtree import ConfigError
    from render.gl.context import RendererUnavailable
    from render.gl.video import VideoError
    from render.keyframes.set_file import KeyframeError
    from sensors.base import SensorError
    from sim.motion.mocap import MotionFileError

    return (UsageError, ConfigError, SensorError, MotionFileError, KeyframeError, RendererUnavailable,
            CalibrationError, VideoError)


def user_facing(e: BaseException) -> str | None:
    """The one-line message for an error the user can fix, or None for an internal error."""
    if isinstance(e, user_error_types()):
        return str(e)
    if isinstance(e, FileNotFoundError):
        return f"{e.filename}: no such file" if e.filename else str(e)
    if isinstance(e, PermissionError):
        return f"{e.filename}: permission denied" if e.filename else str(e)
    if isinstance(e, IsADirectoryError):
        return f"{e.filename}: is a folder, expected a file"
    return None

