"""Point an installation config's sensors at a recording instead of hardware."""

from __future__ import annotations

import dataclasses
from pathlib import Path

from jostle.config import JostleConfig, SensorEntry
from jostle.configtree import ConfigError


def replace_sensors_with_recording(config: JostleConfig, recording: Path) -> JostleConfig:
    """Every sensor whose name is a channel of the recording replays that channel.

    With one sensor and one channel the names need not match. A sensor the recording does not
    hold is an error naming both sides (a replay never silently falls back to hardware).
    """
    from sensors.recording.info import describe_recording
    from sensors.recording.replay import ReplayConfig

    info = describe_recording(recording)
    topics = [c.topic for c in info.channels if c.kind in ("color", "depth", "pads")]
    if not topics:
        raise ConfigError(f"{recording}: holds no sensor channels")
    entries: list[SensorEntry] = []
    for e in config.sensors:
        if e.name in topics:
            channel = e.name
        elif len(config.sensors) == 1 and len(topics) == 1:
            channel = topics[0]
        else:
            raise ConfigError(
                f"{recording}: has no channel for sensor {e.name!r} of {config.path} "
                f"(channels: {', '.join(topics)})"
            )
        entries.append(SensorEntry(e.name, "replay", ReplayConfig(path=recording, channel=channel)))
    return dataclasses.replace(config, sensors=tuple(entries))
