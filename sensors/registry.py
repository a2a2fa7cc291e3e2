"""The one table of sensor types: ``type`` in a config → its config class and a driver loader.

A loader imports its driver module only when called, so importing this module never pulls in a
hardware backend (cv2, depthai, serial). Add a sensor type by adding a row here.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from sensors.base import Sensor
from sensors.clock import Clock
from sensors.faults import FaultyReplayConfig
from sensors.oak.config import OakConfig
from sensors.pads.config import PadsConfig
from sensors.recording.replay import ReplayConfig
from sensors.webcam.config import WebcamConfig


@dataclass(frozen=True, slots=True)
class SensorType:
    config: type  # the frozen config dataclass built from the [sensors.<name>] table
    loader: Callable[[Any, str, Clock], Sensor]  # (config, sensor name, clock) → an unopened Sensor
    description: str

    def load(self, config: object, name: str, clock: Clock) -> Sensor:
        """The unopened sensor for ``config`` (checked to be this type's config class)."""
        if not isinstance(config, self.config):
            raise TypeError(f"sensor {name!r}: expected a {self.config.__name__}, got {type(config).__name__}")
        return self.loader(config, name, clock)


def _load_webcam(config: WebcamConfig, name: str, clock: Clock) -> Sensor:
    from sensors.webcam.driver import WebcamSensor

    return WebcamSensor(config, clock, name)


def _load_pads(config: PadsConfig, name: str, clock: Clock) -> Sensor:
    from sensors.pads.driver import PadsSensor

    return PadsSensor(config, clock, name)


def _load_replay(config: ReplayConfig, name: str, clock: Clock) -> Sensor:
    from sensors.recording.replay import Replay

    return Replay(config.path, clock, channel=config.channel or None, name=name, loop=config.loop)


def _load_oak(config: OakConfig, name: str, clock: Clock) -> Sensor:
    from sensors.oak.driver import OakSensor

    return OakSensor(config, clock, name)


def _load_faulty_replay(config: FaultyReplayConfig, name: str, clock: Clock) -> Sensor:
    from sensors.faults import FaultySensor
    from sensors.recording.replay import Replay

    replay = Replay(config.path, clock, channel=config.channel or None, name=name, loop=config.loop)
    return FaultySensor(replay, config.schedule, clock)


SENSOR_TYPES: dict[str, SensorType] = {
    "webcam": SensorType(WebcamConfig, _load_webcam, "a camera, video file or stream URL through OpenCV"),
    "pads": SensorType(PadsConfig, _load_pads, "force pads on a serial port (binary COBS+CRC frames or CSV lines)"),
    "replay": SensorType(ReplayConfig, _load_replay, "one sensor channel of an MCAP recording, on the loop's clock"),
    "oak": SensorType(OakConfig, _load_oak, "a Luxonis OAK camera (depthai 3): stereo depth aligned to colour"),
    "faulty-replay": SensorType(FaultyReplayConfig, _load_faulty_replay,
                                "a replay that disconnects, fails or garbles frames on a schedule (tests recovery)"),
}
