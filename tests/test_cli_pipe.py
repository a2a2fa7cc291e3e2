"""`jostle … | head -5`: a reader that closes the pipe early ends the command quietly, exit status 141
(128 + SIGPIPE, as `cat` or `grep` stopped by a closed pipe), tried on a real pipe in a real process."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
JOSTLE = "import sys; from jostle.cli import main; sys.exit(main())"


def _closed_early(*args: str) -> subprocess.CompletedProcess[bytes]:
    """Runs `jostle ARGS` with stdout a pipe whose reader is gone before the command writes a byte."""
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    child = subprocess.Popen([sys.executable, "-c", JOSTLE, *args], cwd=ROOT, env=env,
                             stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    assert child.stdout is not None and child.stderr is not None
    child.stdout.close()  # the reader quits at once (head -0): every write of the command meets a closed pipe
    err = child.stderr.read()
    return subprocess.CompletedProcess(child.args, child.wait(timeout=60), b"", err)


@pytest.mark.parametrize(("args", "status"), [
    (("info", "configs/recordings/demo.mcap"), 141),
    (("info", "configs/recordings/demo.mcap", "--json"), 141),
    (("--help",), 0),  # argparse drops its own write errors and exits 0; quiet all the same
])
def test_a_closed_pipe_ends_the_command_quietly(args: tuple[str, ...], status: int) -> None:
    done = _closed_early(*args)
    assert done.stderr == b"", done.stderr.decode()  # no "internal error: BrokenPipeError", no "Exception ignored"
    assert done.returncode == status


def test_an_open_pipe_still_gets_everything() -> None:
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    done = subprocess.run([sys.executable, "-c", JOSTLE, "info", "configs/recordings/demo.mcap"], cwd=ROOT,
                          env=env, capture_output=True, timeout=60)
    assert done.returncode == 0 and done.stderr == b""
    assert b"demo.mcap" in done.stdout
