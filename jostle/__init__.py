"""jostle: the composition root. Config loading, the main loop and the ``jostle`` command.

The only package that imports all four others (sensors, interaction, sim, render).
"""

__version__ = "0.1.0"
