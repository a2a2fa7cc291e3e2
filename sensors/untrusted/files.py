"""Reading files from outside: regular files only, bounded in size, named in every error."""

from __future__ import annotations

import errno
import os
import stat
from pathlib import Path
from typing import BinaryIO

from sensors.untrusted.errors import MissingInput, UntrustedInput, shorten

Pathish = str | os.PathLike[str]


def kind_of(mode: int) -> str:
    """What a file is, by its ``st_mode``: 'a regular file', 'a FIFO', 'a character device', …"""
    for test, name in ((stat.S_ISREG, "a regular file"), (stat.S_ISDIR, "a folder"), (stat.S_ISFIFO, "a FIFO"),
                       (stat.S_ISCHR, "a character device"), (stat.S_ISBLK, "a block device"),
                       (stat.S_ISSOCK, "a socket"), (stat.S_ISLNK, "a symbolic link")):
        if test(mode):
            return name
    return "a special file"


def refuse_os_error(path: Pathish, e: OSError | ValueError) -> UntrustedInput:
    """An ``OSError`` (or a NUL in the name) from opening ``path`` as the one-line user error."""
    if isinstance(e, ValueError):
        return UntrustedInput(path, "the file name holds a NUL character")
    if e.errno == errno.ENOENT:
        return MissingInput(path)
    reasons = {errno.ELOOP: "too many levels of symbolic links (a symlink loop?)",
               errno.ENOTDIR: "a part of the path is not a folder",
               errno.EACCES: "permission denied", errno.EPERM: "permission denied",
               errno.ENAMETOOLONG: "the file name is too long",
               errno.EISDIR: "is a folder, expected a regular file"}
    return UntrustedInput(path, reasons.get(e.errno or 0, e.strerror or type(e).__name__))


def open_regular(path: Pathish) -> BinaryIO:
    """``path`` opened for reading in binary, if it is a regular file (symlinks followed).

    Anything else is refused by name without blocking: a FIFO, device, socket or folder ("is a FIFO,
    expected a regular file"), a missing file (``MissingInput``, also a FileNotFoundError), a symlink
    loop. Checked with stat before opening (a device is never opened) and fstat after (no race).
    """
    try:
        before = os.stat(path)
        if not stat.S_ISREG(before.st_mode):
            raise UntrustedInput(path, f"is {kind_of(before.st_mode)}, expected a regular file")
        # O_NONBLOCK: if a FIFO is swapped in after the stat, opening it cannot hang
        fd = os.open(path, os.O_RDONLY | os.O_NONBLOCK | os.O_NOCTTY | os.O_CLOEXEC)
    except (OSError, ValueError) as e:
        if isinstance(e, UntrustedInput):
            raise
        raise refuse_os_error(path, e) from None
    try:
        after = os.fstat(fd)
        if not stat.S_ISREG(after.st_mode):
            raise UntrustedInput(path, f"is {kind_of(after.st_mode)}, expected a regular file")
        os.set_blocking(fd, True)
        return os.fdopen(fd, "rb")
    except BaseException:
        os.close(fd)
        raise


def read_bytes(path: Pathish, limit: int, what: str = "file") -> bytes:
    """The whole of regular file ``path``, refused (one line) if it holds more than ``limit`` bytes.

    ``what`` names the kind of file in the error ("config", "glTF buffer"). Never reads more than
    ``limit`` + 1 bytes, even from a file that grows or reports size 0 (/proc)."""
    with open_regular(path) as f:
        size = os.fstat(f.fileno()).st_size
        if size > limit:
            raise UntrustedInput(path, f"{what} of {size_text(size)} is larger than the {size_text(limit)} allowed")
        data = f.read(limit + 1)
    if len(data) > limit:
        raise UntrustedInput(path, f"{what} is larger than the {size_text(limit)} allowed")
    return data


def read_text(path: Pathish, limit: int, what: str = "file", encoding: str = "utf-8") -> str:
    """``read_bytes`` decoded; bytes that are not ``encoding`` are refused with their line number."""
    data = read_bytes(path, limit, what)
    return decode_text(data, path, what, encoding)


def decode_text(data: bytes, source: Pathish, what: str = "file", encoding: str = "utf-8") -> str:
    """``data`` decoded as ``encoding`` (a leading UTF-8 BOM dropped), or one line naming the line."""
    try:
        text = data.decode(encoding)
    except UnicodeDecodeError as e:
        line = data.count(b"\n", 0, e.start) + 1
        raise UntrustedInput(source, f"{what} is not {encoding} text (byte 0x{data[e.start]:02x} on line {line})") from None
    return text.removeprefix("\ufeff")


def resolve_within(folder: Pathish, reference: str, what: str = "file") -> Path:
    """``reference`` (a relative path from a file, e.g. a glTF buffer ``uri``) joined to ``folder``,
    refused if it is absolute, empty, holds a NUL, or leads outside ``folder`` (``..``, a symlink out)."""
    if not reference or "\0" in reference or os.path.isabs(reference):
        raise UntrustedInput(folder, f"{what} {_shown(reference)}: expected a relative path inside this folder")
    base = Path(folder).resolve()
    try:
        target = (base / reference).resolve()
    except (OSError, RuntimeError):  # RuntimeError: a symlink loop on older Pythons
        raise UntrustedInput(folder, f"{what} {_shown(reference)}: cannot be resolved (a symlink loop?)") from None
    if target != base and base not in target.parents:
        raise UntrustedInput(folder, f"{what} {_shown(reference)}: leads outside this folder")
    return target


def size_text(n: int) -> str:
    """A byte count for a message: '512 bytes', '1 MiB', '4194305 bytes (4 MiB)' (exact when not round)."""
    for unit, size in (("GiB", 1 << 30), ("MiB", 1 << 20), ("KiB", 1 << 10)):
        if n >= size:
            return f"{n // size} {unit}" if n % size == 0 else f"{n} bytes ({n / size:.3g} {unit})"
    return f"{n} bytes"


def _shown(value: str) -> str:
    return shorten(value, 80)
