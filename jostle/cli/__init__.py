"""The ``jostle`` command line: one module per command, one table of them in :mod:`jostle.cli.commands`."""

from jostle.cli.commands import main

__all__ = ["main"]
