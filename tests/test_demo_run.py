"""The whole path, end to end, on the shipped recording: replay → observer → world → renderer → video."""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import cv2
import numpy as np
import pytest

from interaction.types import BodyObservation
from jostle.app import App, RunOptions
from jostle.cli import main
from jostle.config import JostleConfig, load_config
from jostle.summary import RunSummary
from sim.snapshot import WorldSnapshot

ROOT = Path(__file__).resolve().parent.parent
DEMO = ROOT / "configs" / "demo.toml"
SUMMARY_KEYS = {"characters", "sim_steps", "sim_seconds", "wall_seconds", "frames_rendered", "contacts",
                "pushes", "falls", "getups", "max_contact_force_n", "recording", "video", "seed"}


def _small_demo() -> JostleConfig:
    cfg = load_config(DEMO)
    return dataclasses.replace(cfg, render=dataclasses.replace(cfg.render, width=320, height=180))


def _run(out: Path | None, *, seed: int, duration: float, video: bool = False,
         keep: list[tuple[WorldSnapshot, BodyObservation, np.ndarray]] | None = None) -> RunSummary:
    app = App(_small_demo(), RunOptions(out_dir=out, seed=seed, duration_s=duration, video=video, progress=False))
    if keep is not None:
        def on_frame(snap: WorldSnapshot, obs: BodyObservation, image: np.ndarray | None) -> None:
            assert image is not None
            keep.append((snap, obs, image.copy()))

        app.on_frame = on_frame
    return app.run()


def test_demo_produces_pushes_and_real_pixels(tmp_path: Path) -> None:
    frames: list[tuple[WorldSnapshot, BodyObservation, np.ndarray]] = []
    s = _run(tmp_path, seed=7, duration=6.0, video=True, keep=frames)
    assert s.characters == 8  # six walkers and two critters
    assert s.frames_rendered == len(frames) == 180
    assert s.sim_seconds == pytest.approx(6.0, abs=1e-6)
    assert s.sim_steps == round(6.0 * 240)
    assert s.sensor_frames == 91  # frames at t = 0, 1/15, …, 6.0 s of a 15 fps recording
    assert s.observed_frames_with_people > 30  # the person enters at about 1.9 s
    assert s.pushes >= 1 and s.contacts >= s.pushes
    assert s.max_contact_force_n > 0

    # the summary file holds every figure, and the video holds every frame
    written = json.loads((tmp_path / "summary.json").read_text())
    assert SUMMARY_KEYS <= set(written)
    assert written["pushes"] == s.pushes and written["seed"] == 7
    cap = cv2.VideoCapture(str(tmp_path / "demo.mp4"))
    assert int(cap.get(cv2.CAP_PROP_FRAME_COUNT)) == 180
    ok, first = cap.read()
    assert ok and first.shape == (180, 320, 3)

    # real pixels: the characters' pixels differ from the same scene drawn without them
    from render.gl.renderer import Renderer
    from render.keyframes import KeyframeSet

    snap, obs, image = frames[-1]
    assert image.shape == (180, 320, 3) and image.dtype == np.uint8
    keyframes = KeyframeSet.load(_small_demo().render.keyframes)
    assert image.std() > 10, "the video frame is not blank"
    with Renderer(320, 180, headless=True) as renderer:
        drawn = renderer.draw(snap, obs, keyframes)
        again = renderer.draw(snap, obs, keyframes)
        empty = renderer.draw(dataclasses.replace(snap, characters=()), obs, keyframes)
    assert np.array_equal(drawn, again), "drawing is deterministic"
    changed = np.any(np.abs(drawn.astype(int) - empty.astype(int)) > 24, axis=2)
    assert changed.mean() > 0.005, f"characters cover only {changed.mean():.4f} of the frame"


def test_same_recording_and_seed_replay_to_the_same_trace() -> None:
    a = _run(None, seed=3, duration=5.0)
    b = _run(None, seed=3, duration=5.0)
    c = _run(None, seed=4, duration=5.0)
    assert a.trace_sha256 == b.trace_sha256 and len(a.trace_sha256) == 64
    assert (a.contacts, a.pushes, a.falls) == (b.contacts, b.pushes, b.falls)
    assert c.trace_sha256 != a.trace_sha256


def test_cli_run_prints_where_the_output_is(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "demo"
    code = main(["run", str(DEMO), "--headless", "--out", str(out), "--duration", "1", "--no-video", "--quiet"])
    captured = capsys.readouterr()
    assert code == 0, captured.err
    assert f"summary: {out / 'summary.json'}" in captured.out
    assert json.loads((out / "summary.json").read_text())["frames_rendered"] == 30


class _LateClock:
    """A live clock where each frame's work takes two frame times (a slow display)."""

    def __init__(self) -> None:
        self.t = 0.0

    def now(self) -> float:
        return self.t

    def sleep_until(self, t: float) -> None:
        self.t += 2.0 / 30.0  # the work done since the last sleep
        self.t = max(self.t, t)


def test_a_slow_loop_hands_the_world_all_the_time_that_passed() -> None:
    clock = _LateClock()
    app = App(_small_demo(), RunOptions(out_dir=None, duration_s=2.0, video=False, progress=False), clock=clock)
    s = app.run()
    assert s.frames_rendered < 40  # each frame took two frame times
    assert s.sim_seconds == pytest.approx(clock.t, abs=1e-6)  # simulated time kept up with the clock
