"""Which exceptions are the user's to fix (printed as one line) and which are bugs (tracebacks)."""

from __future__ import annotations


def user_facing(e: BaseException) -> str | None:
    """The one-line message for an error the user can fix, or None for an internal error."""
    from jostle.configtree import ConfigError
    from sensors.base import SensorError
    from sim.motion.mocap import MotionFileError

    if isinstance(e, ConfigError | SensorError | MotionFileError):
        return str(e)
    from jostle.cli.main import UsageError

    if isinstance(e, UsageError):
        return str(e)
    if isinstance(e, FileNotFoundError):
        return f"{e.filename}: no such file" if e.filename else str(e)
    if isinstance(e, PermissionError):
        return f"{e.filename}: permission denied" if e.filename else str(e)
    if isinstance(e, IsADirectoryError):
        return f"{e.filename}: is a folder, expected a file"
    name = type(e).__name__
    if name in ("KeyframeError", "KeyframeFileError", "RendererUnavailable", "CalibrationError", "VideoError"):
        return str(e)
    return None
