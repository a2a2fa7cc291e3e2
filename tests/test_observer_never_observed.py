"""A run whose observer produced nothing from the frames it was given fails: one line, exit status 1,
no traceback without --debug (a real process on the real clip; the crash injected into the observer)."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest
from video_source import CLIP_SIZE, calibration_for, video_config

from interaction.pads import PadsObserver, PadsObserverConfig
from jostle.observer_guard import ObserverGuard
from sensors.base import Frame, PadSample
from sensors.clock import SimClock

ROOT = Path(__file__).resolve().parent.parent
PADS = PadsObserverConfig(positions=(0.0, 0.0, 1.0), directions=(0.0, 1.0, 0.0))

# `jostle ARGS` with every webcam observer crashing on every frame (a bug, or input it cannot take)
CRASHING_JOSTLE = """
import sys
from interaction import observers
from jostle import run_setup
from jostle.cli import main

real = observers.observer_types()["webcam"]

class Crashing:
    def observe(self, frame):
        raise ValueError(f"cannot read frame {frame.seq}")

table = observers.observer_types()
table["webcam"] = observers.ObserverType(real.config, lambda config, calibration, sensor: Crashing(),
                                         real.needs_calibration, real.description)
run_setup.observer_types = lambda: table
sys.exit(main(sys.argv[1:]))
"""


def test_never_observed_names_an_observer_that_returned_nothing_for_its_frames() -> None:
    clock = SimClock()

    class Broken:
        def observe(self, frame: Frame) -> None:
            raise RuntimeError("broken")

    broken = ObserverGuard("floor", lambda: Broken(), clock)  # type: ignore[arg-type,return-value]
    fine = ObserverGuard("pads", lambda: PadsObserver(PADS), clock)
    idle = ObserverGuard("idle", lambda: PadsObserver(PADS), clock)
    for i in range(40):
        clock.advance(0.1)
        frame = Frame("pads", clock.now(), i, PadSample((0.0,), (0,)))
        broken.observe(frame)
        fine.observe(frame)
    assert broken.never_observed() == ("observer 'floor' produced nothing from the 40 frames of its sensor "
                                       "(crashes: 3, failed rebuilds: 0; last error: RuntimeError: broken)")
    assert broken.health().frames == 40 and broken.health().observations == 0
    assert fine.never_observed() is None and fine.health().observations == 40
    assert idle.never_observed() is None  # handed no frames: nothing to say


@pytest.mark.parametrize("debug", [False, True])
def test_a_run_whose_observer_crashed_on_every_frame_fails(tmp_path: Path, debug: bool) -> None:
    config = video_config(tmp_path, calibration_for(CLIP_SIZE, tmp_path))
    out = tmp_path / "out"
    args = [*(["--debug"] if debug else []), "run", str(config), "--headless", "--no-video", "--quiet",
            "--duration", "0.5", "--out", str(out)]
    done = subprocess.run([sys.executable, "-c", CRASHING_JOSTLE, *args], cwd=ROOT, capture_output=True,
                          text=True, timeout=120, env=dict(os.environ, PYTHONPATH=str(ROOT)))
    assert done.returncode == 1, done.stderr
    last = done.stderr.strip().splitlines()[-1]
    # the frames of the clip up to the first render frame at or after 0.5 s (8/15 s): 17
    assert last.startswith("jostle: error: observer 'cam' produced nothing from the 17 frames of its sensor (")
    assert "last error: ValueError: cannot read frame" in last and last.endswith("run with --debug for the traceback")
    assert ("Traceback" in done.stderr) is debug  # the crash's traceback only with --debug
    assert "internal error" not in done.stderr
    summary = json.loads((out / "summary.json").read_text())  # still written, saying why the run failed
    assert summary["failed"].startswith("observer 'cam' produced nothing") and summary["sensor_frames"] == 17
