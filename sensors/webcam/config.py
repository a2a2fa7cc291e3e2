"""``[sensors.<name>] type = "webcam"``: a camera, a video file or a stream URL."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

SourceKind = Literal["device", "url", "file"]


def source_kind(source: str) -> SourceKind:
    """"0" or "/dev/video0" → device; anything with "://" → url (a live stream); else a video file."""
    if source.isdigit() or source.startswith("/dev/"):
        return "device"
    if "://" in source:
        return "url"
    return "file"


@dataclass(frozen=True)
class WebcamConfig:
    """``source``: a device index ("0"), a device path, a video file, or a stream URL.

    ``width``/``height``/``fps`` are requested from live cameras (the sensor's spec reports what the
    camera really gave); a video file keeps its own size and rate. ``reconnect_s`` is the wait
    between attempts to reopen a camera or stream that vanished.
    """

    source: str = "0"
    width: int = 640
    height: int = 480
    fps: float = 30.0
    reconnect_s: float = 2.0

    def __post_init__(self) -> None:
        if not isinstance(self.source, str) or not self.source.strip():
            raise ValueError(f'source: expected a device index like "0", a video file or a URL, got {self.source!r}')
        for name in ("width", "height"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int) or value <= 0:
                raise ValueError(f"{name}: expected a whole number of pixels > 0, got {value!r}")
        for name in ("fps", "reconnect_s"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value) or value <= 0:
                raise ValueError(f"{name}: expected a number > 0, got {value!r}")

    @property
    def kind(self) -> SourceKind:
        return source_kind(self.source)
