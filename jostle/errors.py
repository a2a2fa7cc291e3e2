"""Which exceptions are the user's to fix (printed as one line) and which are bugs (tracebacks).

A user error is one of :func:`user_error_types`, matched by type: a mistake on the command line
(:class:`UsageError`), in a config, recording, motion, keyframe or calibration file, a sensor that
cannot be opened, no renderer, no video encoder, any input refused by ``sensors.untrusted``.
Anything else is an internal error. Every message is cut to one line (``one_line``).
"""

from __future__ import annotations

import errno


class UsageError(Exception):
    """A mistake on the command line or in a file it names; printed as one line, exit status 2."""


class RunFailed(Exception):
    """A run that went to its end without doing its job (an observer produced nothing from the frames
    it was given); printed as one line, exit status 1 (the summary is still written)."""


def user_error_types() -> tuple[type[BaseException], ...]:
    """The exception types whose message is the whole story for the user (imported on demand)."""
    from interaction.depth.calibration import DepthCalibrationError
    from interaction.webcam.calibration import CalibrationError
    from jostle.configtree import ConfigError
    from jostle.terrain_layout import LayoutError
    from render.gl.context import RendererUnavailable
    from render.gl.video import VideoError
    from render.keyframes.set_file import KeyframeError
    from sensors.base import SensorError
    from sensors.untrusted import UntrustedInput
    from sim.motion.mocap import MotionFileError

    return (UsageError, ConfigError, SensorError, MotionFileError, KeyframeError, RendererUnavailable,
            CalibrationError, DepthCalibrationError, LayoutError, VideoError, UntrustedInput)


def user_facing(e: BaseException) -> str | None:
    """The one-line message for an error the user can fix, or None for an internal error."""
    from sensors.untrusted import one_line
    from sensors.untrusted.files import refuse_os_error

    if isinstance(e, user_error_types()):
        return one_line(str(e), MESSAGE_CHARS)
    if isinstance(e, OSError) and e.filename is not None and e.errno in _USER_ERRNOS:
        return one_line(str(refuse_os_error(e.filename, e)))
    if isinstance(e, FileNotFoundError | PermissionError | IsADirectoryError):
        return one_line(str(e), MESSAGE_CHARS)
    return None


MESSAGE_CHARS = 1000  # a user error's line is cut here (a list of known keys fits; a 10 MB value does not)

# OSErrors a user causes by naming a file: missing, not allowed, a folder, a symlink loop, a bad path
_USER_ERRNOS = frozenset({errno.ENOENT, errno.EACCES, errno.EPERM, errno.EISDIR, errno.ELOOP, errno.ENOTDIR,
                          errno.ENAMETOOLONG})

