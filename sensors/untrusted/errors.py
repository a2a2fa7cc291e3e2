"""The one error for input from outside that breaks a rule, and how values are shown in its message."""

from __future__ import annotations

import errno
import os
from typing import Any

SHOWN_CHARS = 40  # an echoed string or bytes value is cut to this many characters in a message
MESSAGE_CHARS = 400  # a whole message is cut to this many characters (it is one line for a person)


class UntrustedInput(ValueError):
    """Input from outside (a file, a flag, a message, a value in one) that breaks a rule or a limit.

    A user error: ``str(e)`` is one line, ``SOURCE: PROBLEM``, with any echoed value shortened.
    ``source`` names the file or the setting (``configs/demo.toml``, ``--duration``); ``problem`` says
    what is wrong. Both are kept as attributes, unshortened only in ``problem``'s own words.
    """

    def __init__(self, source: str | os.PathLike[str], problem: str) -> None:
        self.source = os.fspath(source)
        self.problem = problem
        self.message = one_line(f"{_source(self.source)}: {problem}")
        super().__init__(self.message)

    def __str__(self) -> str:
        return self.message

    def __reduce__(self) -> tuple[Any, ...]:  # picklable across processes despite the two arguments
        return (type(self), (self.source, self.problem))


class MissingInput(UntrustedInput, FileNotFoundError):
    """A named input file that does not exist; also a ``FileNotFoundError`` (``filename`` set)."""

    def __init__(self, source: str | os.PathLike[str], problem: str = "no such file") -> None:
        super().__init__(source, problem)
        self.errno = errno.ENOENT
        self.strerror = problem
        self.filename = self.source


def shorten(value: object, chars: int = SHOWN_CHARS) -> str:
    """``value`` as one short line for a message: a repr cut to ``chars`` characters with '…' and the
    full length, e.g. ``'aaaa…' (10485760 characters)``; never builds the whole repr of a big value."""
    if isinstance(value, str | bytes | bytearray):
        unit = "characters" if isinstance(value, str) else "bytes"
        if len(value) <= chars:
            return repr(value)
        head = repr(value[:chars])
        return f"{head[:-1]}…{head[-1]} ({len(value)} {unit})"
    if isinstance(value, bool) or value is None:
        return repr(value)
    if isinstance(value, int):
        if value.bit_length() > 128:  # str() of a huge int is slow (and refused past 4300 digits)
            return f"{'a negative' if value < 0 else 'an'} integer of {value.bit_length()} bits"
        return repr(value)
    if isinstance(value, float):
        return repr(value)
    if isinstance(value, list | tuple | dict | set | frozenset):
        return f"a {type(value).__name__} of {len(value)} items"
    text = object.__repr__(value) if type(value).__repr__ is object.__repr__ else _safe_repr(value)
    return one_line(text, chars + 20)


def one_line(text: str, chars: int = MESSAGE_CHARS) -> str:
    """``text`` with every non-printable character (newlines, controls, separators) escaped and cut
    to ``chars`` characters, so it prints as exactly one line."""
    if len(text) > chars:
        text = text[:chars] + "…"
    if text.isprintable():
        return text
    return "".join(c if c.isprintable() else repr(c)[1:-1] for c in text)


def _safe_repr(value: object) -> str:
    try:
        text = repr(value)
    except Exception as e:  # a hostile object's repr is not worth a traceback
        return f"<{type(value).__name__} ({type(e).__name__} in repr)>"
    return text


def _source(source: str) -> str:
    """A file name or setting as shown: itself when printable and short, else shortened."""
    if source and len(source) <= 200 and source.isprintable():
        return source
    return shorten(source, 120)
