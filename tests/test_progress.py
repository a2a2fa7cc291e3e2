"""The progress line counts the simulated seconds the summary reports, also when frames come late."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import pytest

from jostle.app import App, RunOptions
from jostle.config import load_config
from jostle.progress import Progress
from sensors.clock import SimClock

ROOT = Path(__file__).resolve().parent.parent


def test_progress_shows_the_simulated_time_of_the_summary_when_the_loop_is_late() -> None:
    cfg = load_config(ROOT / "configs" / "demo.toml")
    cfg = dataclasses.replace(cfg, render=dataclasses.replace(cfg.render, width=160, height=90))
    clock = SimClock()
    app = App(cfg, RunOptions(out_dir=None, seed=1, duration_s=4.0, video=False, progress=False), clock=clock)
    # a slow frame (a slow observer or display): each takes twice its 1/30 s, so the next covers 2/30 s
    app.on_frame = lambda snap, obs, image: clock.advance(2.0 / 30)
    summary = app.run()
    assert app.progress is not None
    assert summary.sim_seconds == pytest.approx(4.0, abs=0.07)
    assert summary.frames_rendered <= 61  # about half the 120 frames of 4 s at 30 fps
    assert app.progress.n == pytest.approx(summary.sim_seconds, abs=1e-9)  # before: frames × 1/30 ≈ 2.0 s


def test_update_to_sets_the_count() -> None:
    bar = Progress(10.0, "t", "s", enabled=False)
    bar.update_to(2.5)
    bar.update_to(7.25)
    assert bar.n == 7.25
