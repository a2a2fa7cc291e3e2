"""What the command leaves on the terminal: log records as one line each, and a closed pipe ended quietly.

Without ``--debug`` a log record that carries an exception (an observer's crash) is printed as its
one line only; the traceback is printed with ``--debug`` (and kept in the journal under systemd).

A reader that stops early (``jostle info x.mcap | head -5``) closes the pipe: the next write raises
BrokenPipeError. :func:`end_on_closed_pipe` then points stdout and stderr at /dev/null (so the
interpreter's last flush cannot fail again) and gives the exit status :data:`CLOSED_PIPE`.
"""

from __future__ import annotations

import logging
import os
import sys

# 128 + SIGPIPE (13), what a shell reports for `cat`, `yes` or `grep` stopped by a closed pipe: a script
# under `set -o pipefail` sees the same as with those tools, and the output was not all delivered, so not 0.
CLOSED_PIPE = 141


class OneLineFormatter(logging.Formatter):
    """The record's message without its traceback (``--debug`` shows tracebacks), its level in lower
    case (``jostle: warning: …``, like the command's own error and warning lines)."""

    def formatMessage(self, record: logging.LogRecord) -> str:  # noqa: N802 (logging's name)
        return str(self._fmt) % dict(vars(record), levelname=record.levelname.lower())

    def formatException(self, ei: object) -> str:  # noqa: N802 (logging's name)
        return ""

    def formatStack(self, stack_info: str) -> str:  # noqa: N802 (logging's name)
        return ""

    def format(self, record: logging.LogRecord) -> str:
        saved = record.exc_text
        record.exc_text = ""  # logging caches the traceback's text on the record: not printed here
        try:
            return super().format(record).rstrip("\n")
        finally:
            record.exc_text = saved


def one_line_records(fmt: str, logger: logging.Logger | None = None) -> None:
    """Give the stderr handlers of ``logger`` (the root logger) the one-line format ``fmt``."""
    target = logger or logging.getLogger()
    for handler in target.handlers:
        if isinstance(handler, logging.StreamHandler) and getattr(handler, "stream", None) is sys.stderr:
            handler.setFormatter(OneLineFormatter(fmt))


def end_on_closed_pipe() -> int:
    """After a BrokenPipeError on stdout or stderr: both pointed at /dev/null; the exit status."""
    devnull = os.open(os.devnull, os.O_WRONLY)
    for stream in (sys.stdout, sys.stderr):
        try:
            os.dup2(devnull, stream.fileno())
        except (OSError, ValueError):  # no file descriptor (a test's captured stream)
            pass
    os.close(devnull)
    return CLOSED_PIPE


def flush_output() -> None:
    """Flush stdout and stderr now, so a closed pipe is found inside ``main`` and not at exit."""
    for stream in (sys.stdout, sys.stderr):
        stream.flush()
