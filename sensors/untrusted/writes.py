"""Writing where a path from outside points: only a regular file the run may replace, atomically."""

from __future__ import annotations

import os
import secrets
import stat
from pathlib import Path

from sensors.untrusted.errors import UntrustedInput
from sensors.untrusted.files import Pathish, kind_of, refuse_os_error


def write_owned(path: Pathish, data: bytes | str, mode: int = 0o644) -> Path:
    """Write ``data`` (str as UTF-8) to ``path``, atomically: a temporary file in the same folder,
    flushed to disk, then ``os.replace`` over ``path``. Returns ``path``.

    ``path`` must be a regular file or not exist yet (created with ``mode`` less the umask; an existing
    file keeps its mode). A FIFO, device (``/dev/full``), socket, folder or symbolic link there is
    refused by name and never replaced, even as root; so is a missing or non-folder parent.
    """
    target = Path(path)
    payload = data.encode("utf-8") if isinstance(data, str) else bytes(data)
    keep_mode = _existing_mode(target)
    folder = target.parent
    try:
        if not stat.S_ISDIR(os.stat(folder).st_mode):
            raise UntrustedInput(target, f"cannot write here: {folder} is not a folder")
    except OSError as e:
        raise UntrustedInput(target, f"cannot write here: the folder {folder}: {refuse_os_error(folder, e).problem}") from None
    temp = folder / f".{target.name[:64]}.{secrets.token_hex(6)}.part"
    try:  # O_EXCL: never an existing file; a new file gets ``mode`` less the umask
        fd = os.open(temp, os.O_WRONLY | os.O_CREAT | os.O_EXCL | os.O_CLOEXEC | os.O_NOFOLLOW, mode)
    except OSError as e:
        raise UntrustedInput(target, f"cannot write here: {refuse_os_error(folder, e).problem}") from None
    try:
        with os.fdopen(fd, "wb") as f:
            f.write(payload)
            f.flush()
            if keep_mode is not None:
                os.fchmod(f.fileno(), keep_mode)
            os.fsync(f.fileno())
        _existing_mode(target)  # again, just before replacing: a special file may have appeared
        os.replace(temp, target)
    except BaseException as e:
        try:
            os.unlink(temp)
        except OSError:
            pass
        if isinstance(e, OSError):  # a full disk, a read-only file system: one line, not a traceback
            raise UntrustedInput(target, f"cannot write: {e.strerror or type(e).__name__}") from None
        raise
    return target


def check_owned(path: Pathish) -> Path:
    """``path`` if a writer may create or replace it: nothing there, or a regular file (a symlink is
    not followed). For writers that stream (a recording) and cannot use ``write_owned``; anything
    else there is refused by name (``UntrustedInput``) and left as it is."""
    _existing_mode(Path(path))
    return Path(path)


def _existing_mode(target: Path) -> int | None:
    """The permission bits of the regular file at ``target``, None if nothing is there; anything
    else there (not followed if a symlink) is refused by name."""
    try:
        st = os.lstat(target)
    except FileNotFoundError:
        return None
    except (OSError, ValueError) as e:
        raise refuse_os_error(target, e) from None
    if not stat.S_ISREG(st.st_mode):
        raise UntrustedInput(target, f"is {kind_of(st.st_mode)}, expected a regular file to write (it is left as it is)")
    return stat.S_IMODE(st.st_mode)
