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
from sensors.replay import ReplayConfig
from sensors.webcam.config import WebcamConfig


@dataclass(frozen=True, slots=True)
class SensorType:
    config: type  # the frozen config dataclass built from the [sensors.<name>] table
    loader: Callable[[Any, str, Clock], Sensor]  # (config, sensor name, clock) → an unopened Sensor
    description: str


def _load_webcam(config: Any, name: str, clock: Clock) -> Sensor:
    if not isinstance(config, WebcamConfig):
        raise TypeError(f"webcam sensor {name!r}: expected a WebcamConfig, got {type(config).__name__}")
    from sensors.webcam.driver import WebcamSensor

    return WebcamSensor(config, clock, name)


def _load_pads(config: Any, name: str, clock: Clock) -> Sensor:
    if not isinstance(config, PadsConfig):
        raise TypeError(f"pads sensor {name!r}: expected a PadsConfig, got {type(config).__name__}")
    from sensors.pads.driver import PadsSensor

    return PadsSensor(config, clock, name)


def _load_replay(config: Any, name: str, clock: Clock) -> Sensor:
    if not isinstance(config, ReplayConfig):
        raise TypeError(f"replay sensor {name!r}: expected a ReplayConfig, got {type(config).__name__}")
    from sensors.replay import Replay

    return Replay(config.path, clock, channel=config.channel or None, name=name, loop=config.loop)


def _load_oak(config: Any, name: str, clock: Clock) -> Sensor:
    if not isinstance(config, OakConfig):
        raise TypeError(f"oak sensor {name!r}: expected an OakConfig, got {type(config).__name__}")
    from sensors.oak.driver import OakSensor

    return OakSensor(config, clock, name)


def _load_faulty_replay(config: Any, name: str, clock: Clock) -> Sensor:
    if not isinstance(config, FaultyReplayConfig):
        raise TypeError(f"faulty-replay sensor {name!r}: expected a FaultyReplayConfig, got {type(config).__name__}")
    from sensors.faults import FaultySensor
    from sensors.replay import Replay

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
