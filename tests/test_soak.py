"""`jostle bench soak`, short: the demo looped on the free-running wall clock, drawn, measured."""

from __future__ import annotations

import math
import time
from pathlib import Path
from typing import Any

import pytest

from interaction.observers import Observer, ObserverType, observer_types
from interaction.types import BodyObservation
from jostle import run_setup
from jostle.bench.soak import FreeRunningClock, looped, rss_mb
from jostle.cli.bench import main_json
from jostle.config import load_config
from sensors.base import Frame
from sensors.recording.replay import ReplayConfig

ROOT = Path(__file__).resolve().parent.parent
KEYS = ("minutes", "frames", "rss_start_mb", "rss_end_mb", "rss_growth_pct", "fps_first_minute", "fps_last_minute",
        "errors", "fps_cpu_first_minute", "fps_cpu_last_minute")


def test_a_short_soak_returns_every_figure_with_sane_values(monkeypatch: pytest.MonkeyPatch) -> None:
    # one fault injected so the error count is seen to count: the observer raises once, at 2 s
    table = observer_types()
    real = table["webcam"]
    crashes = [0]

    def build(config: Any, calibration: Path | None, sensor: str) -> Observer:
        inner = real.build(config, calibration, sensor)

        class OnceCrashing:
            calibration = getattr(inner, "calibration", None)

            @property
            def silhouette(self) -> Any:
                return getattr(inner, "silhouette", None)

            def observe(self, frame: Frame) -> BodyObservation:
                if frame.t >= 2.0 and not crashes[0]:
                    crashes[0] += 1
                    raise RuntimeError("injected crash")
                return inner.observe(frame)

        return OnceCrashing()

    table["webcam"] = ObserverType(real.config, build, real.needs_calibration, real.description)
    monkeypatch.setattr(run_setup, "observer_types", lambda: table)
    minutes = 0.15
    started = time.perf_counter()
    figures = main_json("soak", ["--minutes", str(minutes), "--config", str(ROOT / "configs" / "demo.toml"),
                                 "--width", "320", "--height", "180", "--quiet"])
    wall = time.perf_counter() - started
    for key in KEYS:
        assert key in figures, key
    assert figures["errors"] == 1 and figures["observer_crashes"] == 1
    assert figures["error_messages"] == ["jostle.observers: observer 'webcam' crashed (RuntimeError: injected crash, "
                                         "1 in a row); rebuilding it in 1 s"]
    # ran for the time asked, on the wall clock (setup comes on top, so the call took longer)
    assert abs(figures["minutes"] - minutes) * 60 < 1.0
    assert wall >= minutes * 60
    assert figures["stopped_because"] == f"duration {minutes * 60:g} s reached"
    # every frame drawn was counted; the windows are inside the run and hold frames
    assert figures["frames"] > 20
    assert figures["warmup_s"] == minutes * 60 / 4
    for key in ("fps_first_minute", "fps_last_minute", "fps_cpu_first_minute", "fps_cpu_last_minute"):
        assert 0 < figures[key] < 10_000, key
    assert figures["fps_first_minute"] * figures["window_s"] < figures["frames"]
    # the wall clock drove the world: simulated time is the elapsed time (the world drops a little at most)
    assert abs(figures["sim_seconds"] + figures["dropped_sim_seconds"] - figures["minutes"] * 60) < 1.0
    # memory: a real process size, the growth computed from the two readings
    assert 50 < figures["rss_start_mb"] < 20_000 and 50 < figures["rss_end_mb"] < 20_000
    expected = 100 * (figures["rss_end_mb"] - figures["rss_start_mb"]) / figures["rss_start_mb"]
    assert math.isclose(figures["rss_growth_pct"], expected, abs_tol=0.1)
    assert figures["rss_max_mb"] >= figures["rss_end_mb"]


def test_looped_sets_every_replay_to_loop() -> None:
    cfg = looped(load_config(ROOT / "configs" / "demo.toml"))
    assert cfg.sensors and all(isinstance(e.config, ReplayConfig) and e.config.loop for e in cfg.sensors)


def test_the_free_running_clock_follows_real_time_and_never_sleeps() -> None:
    clock = FreeRunningClock()
    t = clock.now()
    began = time.monotonic()
    clock.sleep_until(t + 5.0)
    assert time.monotonic() - began < 0.5
    time.sleep(0.05)
    assert clock.now() - t >= 0.05


def test_rss_is_the_resident_size_the_kernel_reports() -> None:
    status = Path("/proc/self/status").read_text().splitlines()
    vm_rss_kb = next(int(line.split()[1]) for line in status if line.startswith("VmRSS:"))
    assert abs(rss_mb() - vm_rss_kb * 1024 / 1e6) < 5.0
