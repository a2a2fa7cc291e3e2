"""Values put into systemd unit files, by systemd's own rules (systemd.syntax(7), systemd.service(5)
"Command lines", systemd.exec(5), systemd-escape(1)); anything that cannot be said exactly is refused.

Every value is refused if it holds a newline or any other control or invisible format character
(Unicode categories Cc, Cf, Cs, Co, Zl, Zp): a newline would start a new setting in the unit. In
every setting systemd expands ``%`` specifiers, so a literal ``%`` is written ``%%``.
"""

from __future__ import annotations

import os
import re
import unicodedata

from sensors.untrusted.errors import UntrustedInput, shorten
from sensors.untrusted.limits import UNIT_VALUE_MAX_CHARS

_REFUSED_CATEGORIES = frozenset({"Cc", "Cf", "Cs", "Co", "Zl", "Zp"})
_PLAIN_ARGUMENT = re.compile(r"[A-Za-z0-9_@+=:,./-]+")
_ENV_NAME = re.compile(r"[A-Za-z_][A-Za-z0-9_]*")
_USER_NAME = re.compile(r"[A-Za-z_][A-Za-z0-9_-]{0,30}")  # systemd's strict user name rule
_UNIT_NAME_KEPT = re.compile(r"[A-Za-z0-9:_.]")


def systemd_exec_argument(value: str | os.PathLike[str], what: str) -> str:
    """One argument of ``ExecStart=`` (after the program): as is if only letters, digits and
    ``_@+=:,./-``; else in double quotes with ``\\`` and ``"`` backslash-escaped, ``$`` written ``$$``
    (no variable expansion) and ``%`` written ``%%``. An empty value is ``""``."""
    text = _checked(value, what)
    if _PLAIN_ARGUMENT.fullmatch(text):
        return text
    escaped = text.replace("\\", "\\\\").replace('"', '\\"').replace("$", "$$").replace("%", "%%")
    return f'"{escaped}"'


def systemd_exec_path(path: str | os.PathLike[str], what: str) -> str:
    """The program of ``ExecStart=``: an absolute path, quoted like an argument. Refused if it holds
    ``$``: systemd takes the program path literally (``$$`` is not undone there in systemd 252)."""
    text = _checked(path, what)
    if not text.startswith("/"):
        raise UntrustedInput(what, f"{shorten(text, 80)}: the program of ExecStart= must be an absolute path")
    if "$" in text:
        raise UntrustedInput(what, f"{shorten(text, 80)}: a '$' in the program's path cannot be written in ExecStart=")
    return systemd_exec_argument(text, what)


def systemd_path(path: str | os.PathLike[str], what: str) -> str:
    """An absolute path for ``WorkingDirectory=`` (and other single-path settings), which systemd takes
    verbatim — no quotes, no escapes — after stripping trailing spaces and joining a line that ends
    in ``\\``; so a path ending in a space or ``\\`` gets a final ``/``, ``%`` becomes ``%%``, and a
    path that is relative, holds a ``..`` part or is longer than PATH_MAX is refused."""
    text = _checked(path, what)
    if not text.startswith("/"):
        raise UntrustedInput(what, f"{shorten(text, 80)}: expected an absolute path")
    parts = text.split("/")
    if ".." in parts:
        raise UntrustedInput(what, f"{shorten(text, 80)}: a path with '..' is refused by systemd (not normalized)")
    if any(len(p.encode()) > 255 for p in parts):
        raise UntrustedInput(what, f"{shorten(text, 80)}: a part of the path is longer than 255 bytes")
    if text.endswith((" ", "\\")):
        text += "/"  # systemd drops the trailing slash; the space or backslash is kept
    return text.replace("%", "%%")


def systemd_environment(name: str, value: str, what: str) -> str:
    """One ``Environment=`` assignment, ``"NAME=value"``: NAME letters, digits and ``_`` (not first a
    digit); the value double-quoted with ``\\`` and ``"`` escaped and ``%`` as ``%%`` (``$`` is
    literal in Environment=, so it is left alone)."""
    if not _ENV_NAME.fullmatch(name):
        raise UntrustedInput(what, f"{shorten(name, 80)} is not an environment variable name")
    text = _checked(value, what)
    escaped = text.replace("\\", "\\\\").replace('"', '\\"').replace("%", "%%")
    return f'"{name}={escaped}"'


def systemd_user(name: str, what: str) -> str:
    """A ``User=`` value: a user name by systemd's strict rule (a letter or ``_``, then letters, digits,
    ``_`` or ``-``, 1–31 characters) or a numeric UID from 0 to 4294967294."""
    text = _checked(name, what)
    if text.isascii() and text.isdigit() and int(text) < 2**32 - 1:
        return text
    if not _USER_NAME.fullmatch(text):
        raise UntrustedInput(what, f"{shorten(text, 80)} is not a user name systemd accepts "
                                   "(a letter or '_', then letters, digits, '_' or '-', at most 31)")
    return text


def systemd_text(value: str, what: str) -> str:
    """Free text for a setting such as ``Description=``: ``%`` as ``%%``; spaces at either end are
    dropped (systemd would drop them); a trailing ``\\`` (a line continuation) is refused."""
    text = _checked(value, what).strip(" ")
    if text.endswith("\\"):
        raise UntrustedInput(what, f"{shorten(text, 80)}: a value may not end in a backslash (it joins the next line)")
    return text.replace("%", "%%")


def systemd_escape(text: str) -> str:
    """``text`` as a unit-name part, as ``systemd-escape TEXT`` writes it: ``/`` becomes ``-``;
    letters, digits, ``:``, ``_`` and ``.`` (not first) stay; every other byte of its UTF-8 is ``\\xNN``."""
    out = []
    for i, ch in enumerate(text):
        if ch == "/":
            out.append("-")
        elif _UNIT_NAME_KEPT.fullmatch(ch) and not (i == 0 and ch == "."):
            out.append(ch)
        else:
            out.extend(f"\\x{b:02x}" for b in ch.encode("utf-8", "surrogateescape"))
    return "".join(out)


def _checked(value: str | os.PathLike[str], what: str) -> str:
    """``value`` as text, refused if too long or holding a newline, control or format character."""
    text = os.fspath(value)
    if not isinstance(text, str):
        raise UntrustedInput(what, "expected text, got bytes")
    if len(text) > UNIT_VALUE_MAX_CHARS:
        raise UntrustedInput(what, f"{len(text)} characters, more than the {UNIT_VALUE_MAX_CHARS} a unit value may have")
    for i, ch in enumerate(text):
        if unicodedata.category(ch) in _REFUSED_CATEGORIES:
            raise UntrustedInput(what, f"holds {_named(ch)} at character {i + 1}; refused in a systemd unit")
    return text


def _named(ch: str) -> str:
    if ch == "\n":
        return "a newline"
    name = unicodedata.name(ch, "")
    return f"U+{ord(ch):04X}" + (f" ({name.lower()})" if name else " (a control character)")
