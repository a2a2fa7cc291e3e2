"""The ``jostle`` command line: one module per command, one table of them in :mod:`jostle.cli.main`."""

from jostle.cli.main import main

__all__ = ["main"]
