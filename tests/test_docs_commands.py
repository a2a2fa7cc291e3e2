"""The commands shown in README.md and docs/ are real: every ``jostle …`` line in a fenced block parses
with the real command line (no renamed command or flag), every repository path it names exists, and
the ones that need no hardware and finish in seconds are run as written.

Not run here (and why): the live-sensor runs (``--window``/``--kiosk`` on a webcam: no camera or
display), lines with placeholders (``CONFIG.toml``, ``NAME``, ``walk.bvh``, ``session.mcap``: the
reader's own files), the benches and the demo (minutes each; the demo runs in test_demo_run.py,
each bench has its own test), ``synth shoe-model`` (~9 min) and ``service install`` (writes a unit).
"""

from __future__ import annotations

import re
import shlex
import subprocess
import sys
from pathlib import Path

import pytest

from jostle.cli.commands import _parser

ROOT = Path(__file__).resolve().parent.parent
DOCS = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md")), *sorted((ROOT / "configs").rglob("README.md"))]
_LINE = re.compile(r"^(?:\$ )?(?:\.venv/bin/)?(jostle(?:\s.*)?)$")
# Run as written: fast, no hardware, nothing written outside out/ (redirected to a tmp dir).
# The operator's own config, copied from a shipped one (docs/operators.md §1 says so): a placeholder.
PLACEHOLDERS = {"configs/arcade.toml"}
RUN = re.compile(r"^jostle (doctor|info configs/|terrain show |bench --help|keyframes check )")


def _commands() -> list[tuple[str, str]]:
    found = []
    for doc in DOCS:
        in_block = False
        for number, line in enumerate(doc.read_text(encoding="utf-8").splitlines(), 1):
            if line.strip().startswith("```"):
                in_block = not in_block
                continue
            m = _LINE.match(line.strip()) if in_block else None
            if m:
                command = m.group(1).split(" #")[0].strip()
                found.append((f"{doc.relative_to(ROOT)}:{number}", command))
    return found


COMMANDS = _commands()


def test_the_docs_show_commands() -> None:
    assert len(COMMANDS) >= 20 and any("README.md" in where for where, _ in COMMANDS)


@pytest.mark.parametrize(("where", "command"), COMMANDS, ids=[w for w, _ in COMMANDS])
def test_every_documented_command_parses_and_names_real_paths(where: str, command: str) -> None:
    args = shlex.split(command)[1:]
    try:
        _parser().parse_args(args)
    except SystemExit as e:
        if e.code == 0 and "--help" in args:
            return  # parsed, and printed its help
        raise AssertionError(f"{where}: `{command}` does not parse (exit {e.code})") from None
    for arg in args:
        if arg.startswith(("configs/", "tests/", "docs/")) and not arg.endswith(".mcap") or arg.startswith(
                "configs/recordings/"):
            if arg in PLACEHOLDERS or "--out" in args and args[args.index("--out") + 1] == arg:
                continue  # the reader's own file, or written by the command
            assert (ROOT / arg).exists(), f"{where}: `{command}` names {arg}, which is not in the repository"


RUNNABLE = [(w, c) for w, c in COMMANDS if RUN.match(c)]


def test_some_documented_commands_are_run() -> None:
    assert len(RUNNABLE) >= 3, RUNNABLE


@pytest.mark.parametrize(("where", "command"), RUNNABLE, ids=[w for w, _ in RUNNABLE])
def test_documented_commands_run_as_written(where: str, command: str, tmp_path: Path) -> None:
    args = [str(tmp_path / a[len("out/"):]) if a.startswith("out/") else a for a in shlex.split(command)[1:]]
    out = subprocess.run([sys.executable, "-m", "jostle.cli.commands", *args], cwd=ROOT, capture_output=True,
                         text=True, timeout=120)
    assert out.returncode == 0, f"{where}: `{command}` exited {out.returncode}: {out.stderr[-2000:]}"
    assert "Traceback" not in out.stderr, out.stderr
