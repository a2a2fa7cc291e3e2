"""The main loop rides out a sensor outage and stops loudly on a permanent failure (demo, headless)."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import pytest

from jostle.app import App, RunOptions
from jostle.config import JostleConfig, SensorEntry, load_config
from jostle.summary import RunSummary
from sensors.clock import SimClock
from sensors.faults import FaultyReplayConfig, SimulatedFailure
from sensors.recording.replay import Replay, ReplayConfig

ROOT = Path(__file__).resolve().parent.parent
SECONDS = 2.5


def _config(**faults: object) -> JostleConfig:
    cfg = load_config(ROOT / "configs" / "demo.toml")
    cfg = dataclasses.replace(cfg, render=dataclasses.replace(cfg.render, width=160, height=90))
    if not faults:
        return cfg
    entry = cfg.sensors[0]
    assert isinstance(entry.config, ReplayConfig)
    faulty = FaultyReplayConfig(path=entry.config.path, channel=entry.config.channel, **faults)  # type: ignore[arg-type]
    return dataclasses.replace(cfg, sensors=(SensorEntry(entry.name, "faulty-replay", faulty),))


def _run(cfg: JostleConfig) -> RunSummary:
    return App(cfg, RunOptions(out_dir=None, seed=7, duration_s=SECONDS, video=False, progress=False)).run()


def test_the_loop_rides_out_an_outage() -> None:
    cfg = _config(disconnect_at_s=0.81, down_for_s=0.8)
    entry = cfg.sensors[0]
    # what the outage takes away, counted on the recording itself
    clock = SimClock()
    replay = Replay(entry.config.path, clock, channel=entry.config.channel)
    replay.open()
    lost = 0
    while clock.now() <= SECONDS:
        while (frame := replay.read(0.0)) is not None:
            lost += 0.81 <= frame.t < 1.61
        clock.advance(1 / 30)
    replay.close()

    plain = _run(_config())
    faulty = _run(cfg)
    assert lost > 5
    assert faulty.stopped_because == plain.stopped_because == f"duration {SECONDS:g} s reached"
    assert faulty.sim_steps == plain.sim_steps
    assert faulty.sensor_frames == plain.sensor_frames - lost


def test_a_permanent_failure_stops_the_run_with_the_reason() -> None:
    with pytest.raises(SimulatedFailure, match=r"webcam: simulated fault: disconnected at 0\.5 s after open and never"):
        _run(_config(disconnect_at_s=0.5, down_for_s=0.5, fail=True))
