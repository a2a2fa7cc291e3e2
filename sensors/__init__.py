"""Sensors: hardware and recordings turned into timestamped frames.

Importing this package never imports a hardware backend (cv2, depthai, serial); each driver
module imports its backend itself, when the config selects it.
"""

from sensors.base import (
    ColorImage,
    ContractError,
    DepthImage,
    Frame,
    PadSample,
    Payload,
    RecordingCorrupt,
    Sensor,
    SensorError,
    SensorNotOpen,
    SensorSpec,
    SensorState,
    SensorStatus,
    SensorUnavailable,
    frame_digest,
)
from sensors.clock import Clock, SimClock, WallClock

__all__ = [
    "Clock",
    "ColorImage",
    "ContractError",
    "DepthImage",
    "Frame",
    "PadSample",
    "Payload",
    "RecordingCorrupt",
    "Sensor",
    "SensorError",
    "SensorNotOpen",
    "SensorSpec",
    "SensorState",
    "SensorStatus",
    "SensorUnavailable",
    "SimClock",
    "WallClock",
    "frame_digest",
]
