"""What a run sets up from its config before the loop starts: its options, the characters placed on
the stage (deterministically from the seed), the simulated time it will cover, the files its sensors
play on their own timeline, and a builder for each observer."""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Literal

import numpy as np

from interaction.observers import Observer, observer_types
from jostle.config import JostleConfig, ObserverEntry
from sim.world import World

Mode = Literal["headless", "window", "kiosk"]
Speed = Literal["realtime", "max"]


@dataclass(frozen=True)
class RunOptions:
    mode: Mode = "headless"
    out_dir: Path | None = None
    seed: int | None = None
    speed: Speed = "max"
    duration_s: float | None = None  # overrides the config's [run] duration_s
    video: bool = True
    progress: bool = True


def place_characters(config: JostleConfig, world: World, seed: int) -> int:
    """Spread the configured characters over the stage, deterministically from the seed."""
    rng = np.random.default_rng([seed, 7])
    w = config.world
    total = sum(g.count for g in config.characters)
    n = 0
    for group in config.characters:
        for _ in range(group.count):
            frac = (n + 0.5) / max(total, 1)
            x = w.x_min + 0.5 + frac * (w.x_max - w.x_min - 1.0) + rng.uniform(-0.2, 0.2)
            y = rng.uniform(w.y_min * 0.5, w.y_max * 0.5)
            heading = float(rng.uniform(-np.pi, np.pi))
            world.add_character(group.spec, (float(x), float(y)), heading, intent=group.intent)
            n += 1
    return n


def expected_duration(config: JostleConfig, options: RunOptions) -> float | None:
    """Seconds of simulated time the run will cover, when it can be known in advance."""
    if options.duration_s:
        return options.duration_s
    if config.run.duration_s:
        return config.run.duration_s
    from sensors.recording.info import describe_recording
    from sensors.recording.replay import ReplayConfig

    longest = 0.0
    for entry in config.sensors:
        if isinstance(entry.config, ReplayConfig):
            longest = max(longest, describe_recording(entry.config.path).duration)
        elif (video := video_file(entry.config)) is not None:
            from sensors.webcam.driver import video_duration

            if (seconds := video_duration(video)) is None:
                return None
            longest = max(longest, seconds)
        else:
            return None  # a live sensor: runs until stopped
    return longest + config.run.tail_s


def observer_builder(ob: ObserverEntry, calibration: object, inline: bool = False) -> Callable[[], Observer]:
    """Builds the observer of ``ob`` afresh from its config (at start, and after a crash), with
    ``calibration`` (its file, or one loaded and fitted to the images: jostle.calibration_check);
    ``inline`` runs work an observer would do beside the loop in it (the webcam's ``pose_sync``):
    deterministic."""
    config = ob.config
    if inline and dataclasses.is_dataclass(config) and not isinstance(config, type) \
            and any(f.name == "pose_sync" for f in dataclasses.fields(config)):
        config = dataclasses.replace(config, pose_sync=True)
    return lambda: observer_types()[ob.type].build(config, calibration, ob.sensor)


def video_file(config: object) -> str | None:
    """The video file a webcam sensor plays (on its own timeline), None for a camera or stream."""
    from sensors.webcam.config import WebcamConfig

    return config.source if isinstance(config, WebcamConfig) and config.kind == "file" else None


def played_file(config: object) -> str | Path | None:
    """The file a sensor plays on its own timeline (a recording, a video file), None for a live one."""
    from sensors.recording.replay import ReplayConfig

    return config.path if isinstance(config, ReplayConfig) else video_file(config)


def plays_a_file(config: object) -> bool:
    return played_file(config) is not None
