"""Values no body or line should carry: a character's body out of any drawable size is refused by
name, and a logged warning or error reads like the command's own lines (``jostle: warning: …``)."""

from __future__ import annotations

import logging

import pytest

from jostle.cli.terminal import OneLineFormatter
from sim.config import CharacterSpec


@pytest.mark.parametrize(("key", "value"), [("height", 1e308), ("height", 0.01), ("mass", 1e9), ("inertia", 1e30),
                                            ("half_width", 50.0)])
def test_a_body_out_of_any_drawable_size_is_refused_by_name(key: str, value: float) -> None:
    with pytest.raises(ValueError, match=rf"^{key}: expected .* \(a character's body\), got"):
        CharacterSpec(**{key: value})


def test_the_shipped_body_is_within_the_ranges() -> None:
    CharacterSpec()  # the defaults (1.5 m, 40 kg, 10 kg·m²)


def test_log_lines_read_like_the_commands_own() -> None:
    formatter = OneLineFormatter("jostle: %(levelname)s: %(message)s")
    for level, word in ((logging.WARNING, "warning"), (logging.ERROR, "error"), (logging.INFO, "info")):
        record = logging.LogRecord("jostle.pads", level, __file__, 1, "pads %r: a bad line", ("p",), None)
        assert formatter.format(record) == f"jostle: {word}: pads 'p': a bad line"
        assert record.levelname == logging.getLevelName(level)  # the record itself is left as it was
