"""Fixtures several test files share."""

from __future__ import annotations

import itertools
import os
import shutil
import subprocess
import time
from collections.abc import Iterator
from typing import Any

import pytest

_NEXT_DISPLAY = itertools.count()


@pytest.fixture(scope="module")
def display() -> Iterator[str]:
    """A real X server (Xvfb, 800×600) for one test module; its DISPLAY name. Skips only where Xvfb is
    missing or cannot start (set-up installs it)."""
    xvfb = shutil.which("Xvfb")
    if xvfb is None:
        pytest.skip("Xvfb is not installed (apt-get install xvfb)")
    name = f":{120 + (os.getpid() + 13 * next(_NEXT_DISPLAY)) % 100}"
    proc = subprocess.Popen([xvfb, name, "-screen", "0", "800x600x24"], stdout=subprocess.DEVNULL,
                            stderr=subprocess.DEVNULL)
    time.sleep(1.0)
    if proc.poll() is not None:
        pytest.skip(f"Xvfb did not start on {name}")
    yield name
    proc.terminate()
    proc.wait(timeout=10)


@pytest.fixture(scope="module")
def skeleton() -> Any:
    """The DeepMimic humanoid as an ``ArticulatedSkeleton`` (articulated-character tests)."""
    from sim.articulated.skeleton import deepmimic_humanoid

    return deepmimic_humanoid()


@pytest.fixture()
def client() -> Iterator[int]:
    """A pybullet DIRECT client set up as the World sets its own (gravity, time step, solver)."""
    import pybullet as p

    from sim.config import WorldConfig
    from sim.physics import open_client

    c, _ = open_client(WorldConfig())
    yield c
    p.disconnect(c)
