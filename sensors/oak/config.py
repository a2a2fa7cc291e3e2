"""``[sensors.<name>] type = "oak"``: a Luxonis OAK depth camera (depthai 3.x)."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

# StereoDepth.PresetMode members of depthai 3, in lower case (the config's spelling)
StereoPreset = Literal["default", "robotics", "high_detail", "accuracy", "density", "fast_accuracy",
                       "fast_density", "face"]
UsbSpeed = Literal["super", "high"]

STEREO_PRESETS: tuple[str, ...] = ("default", "robotics", "high_detail", "accuracy", "density", "fast_accuracy",
                                   "fast_density", "face")


def _positive_number(value: object) -> bool:
    return isinstance(value, int | float) and not isinstance(value, bool) and math.isfinite(value) and value > 0


def _whole(value: object, low: int) -> bool:
    return isinstance(value, int) and not isinstance(value, bool) and value >= low


@dataclass(frozen=True)
class OakConfig:
    """An OAK camera: stereo depth aligned to the colour camera (CAM_A), both at one size.

    - ``device``: which camera: its device id (``14442C10D13EABCE00``), IP address (PoE) or USB
      port name (``1.3``); "" = the first one found.
    - ``width`` / ``height`` / ``fps``: the output size of depth and colour, and their rate.
    - ``color``: deliver the colour image aligned with the depth (``DepthImage.color``).
    - ``preset``: the StereoDepth preset (``default``, ``robotics``, ``high_detail``, ...).
    - ``usb_speed``: ``"super"`` (USB3) or ``"high"`` (USB2: for long or flaky cables).
    - ``search_timeout_s``: the longest a device search may take (never depthai's ~11 s wait).
    - ``connect_timeout_s``: the longest ``open()`` waits for a found device to boot and start.
    - ``reconnect_attempts``: depthai's own reconnection attempts after a link drop (0 = off).
    - ``reconnect_s`` / ``reconnect_max_s``: our outer retry, when depthai's gives up: the first
      wait (a closed device reboots and is briefly unavailable) doubling up to the maximum.
    - ``give_up_after``: outer attempts before the sensor turns FAILED (0 = keep trying forever).
    - ``stall_s``: a connected camera that sends nothing for this long is reconnected.
    """

    device: str = ""
    width: int = 640
    height: int = 400
    fps: float = 30.0
    color: bool = True
    preset: StereoPreset = "default"
    usb_speed: UsbSpeed = "super"
    search_timeout_s: float = 3.0
    connect_timeout_s: float = 20.0
    reconnect_attempts: int = 3
    reconnect_s: float = 2.0
    reconnect_max_s: float = 30.0
    give_up_after: int = 0
    stall_s: float = 5.0

    def __post_init__(self) -> None:
        if not isinstance(self.device, str) or self.device != self.device.strip():
            raise ValueError(f"device: expected a device id, IP address or USB port name (\"\" = the first "
                             f"camera found), got {self.device!r}")
        for name in ("width", "height"):
            value = getattr(self, name)
            if not _whole(value, 1) or value % 2:
                raise ValueError(f"{name}: expected an even whole number of pixels > 0, got {value!r}")
        for name in ("fps", "search_timeout_s", "connect_timeout_s", "reconnect_s", "reconnect_max_s", "stall_s"):
            value = getattr(self, name)
            if not _positive_number(value):
                raise ValueError(f"{name}: expected a number > 0, got {value!r}")
        if not isinstance(self.color, bool):
            raise ValueError(f"color: expected true or false, got {self.color!r}")
        if self.preset not in STEREO_PRESETS:
            raise ValueError(f"preset: expected one of {', '.join(STEREO_PRESETS)}, got {self.preset!r}")
        if self.usb_speed not in ("super", "high"):
            raise ValueError(f"usb_speed: expected 'super' (USB3) or 'high' (USB2), got {self.usb_speed!r}")
        for name in ("reconnect_attempts", "give_up_after"):
            if not _whole(getattr(self, name), 0):
                raise ValueError(f"{name}: expected a whole number >= 0, got {getattr(self, name)!r}")
        if self.reconnect_max_s < self.reconnect_s:
            raise ValueError(f"reconnect_max_s: expected >= reconnect_s ({self.reconnect_s:g}), "
                             f"got {self.reconnect_max_s!r}")

    @property
    def size(self) -> tuple[int, int]:
        return self.width, self.height

    @property
    def label(self) -> str:
        """How messages name the camera: its id, or 'the first OAK found'."""
        return f"OAK {self.device}" if self.device else "the first OAK found"
