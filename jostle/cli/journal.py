"""Logging for the systemd journal: when stderr is connected to journald ($JOURNAL_STREAM names it),
each record becomes one line ``<P>level=… logger=… msg="…"`` (logfmt), where ``<P>`` is the syslog
priority journald reads from the line's start (``SyslogLevelPrefix=``, on by default): 2 critical,
3 error, 4 warning, 6 info, 7 debug. Tracebacks stay on the same line (``exc="…\\n…"``), so one
record is one journal entry. Read them with ``journalctl --user -u jostle-NAME -o json`` (PRIORITY
and MESSAGE fields) or ``-p warning`` for problems only.
"""

from __future__ import annotations

import logging
import os
import sys
from collections.abc import Mapping

PRIORITIES = ((logging.CRITICAL, 2), (logging.ERROR, 3), (logging.WARNING, 4), (logging.INFO, 6))


def priority(levelno: int) -> int:
    """The syslog priority of a logging level (debug and below: 7)."""
    for level, prio in PRIORITIES:
        if levelno >= level:
            return prio
    return 7


def under_journal(env: Mapping[str, str] | None = None, fd: int = 2) -> bool:
    """Whether ``fd`` (stderr) is the stream systemd connected to the journal: $JOURNAL_STREAM is
    "device:inode" of that stream (sd_journal_stream_fd(3)); a redirected stderr no longer matches."""
    value = (os.environ if env is None else env).get("JOURNAL_STREAM", "")
    dev, _, ino = value.partition(":")
    if not (dev.isdigit() and ino.isdigit()):
        return False
    try:
        st = os.fstat(fd)
    except OSError:
        return False
    return (st.st_dev, st.st_ino) == (int(dev), int(ino))


def prefix(levelno: int) -> str:
    """``"<P>"`` for a line printed to stderr at ``levelno`` under journald, else "" (so that
    ``journalctl -p warning`` shows the one-line errors the command line prints)."""
    return f"<{priority(levelno)}>" if under_journal() else ""


def _quote(value: str) -> str:
    if value and all(c.isalnum() or c in "._-/:@" for c in value):
        return value
    escaped = value.replace("\\", "\\\\").replace('"', '\\"').replace("\n", "\\n").replace("\r", "\\r")
    return f'"{escaped}"'


class JournalFormatter(logging.Formatter):
    """One record → one line ``<P>level=… logger=… msg=… [exc=…]`` (see the module docstring)."""

    def format(self, record: logging.LogRecord) -> str:
        fields = {"level": record.levelname.lower(), "logger": record.name, "msg": record.getMessage()}
        if record.exc_info:
            fields["exc"] = self.formatException(record.exc_info)
        body = " ".join(f"{k}={_quote(v)}" for k, v in fields.items())
        return f"<{priority(record.levelno)}>{body}"


def adopt_journal(logger: logging.Logger | None = None) -> bool:
    """Under journald, give the stderr handlers of ``logger`` (the root logger) the journal format;
    True when it did. Elsewhere nothing changes."""
    if not under_journal():
        return False
    target = logger or logging.getLogger()
    done = False
    for handler in target.handlers:
        if isinstance(handler, logging.StreamHandler) and getattr(handler, "stream", None) is sys.stderr:
            handler.setFormatter(JournalFormatter())
            done = True
    return done
