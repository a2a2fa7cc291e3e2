"""``[sensors.<name>] type = "pads"``: a force-pad board on a serial port."""

from __future__ import annotations

import math
import re
from dataclasses import dataclass
from typing import Literal

from sensors.pads.protocol import MAX_PADS

Framing = Literal["binary", "csv"]
_WINDOWS_PORT = re.compile(r"COM\d+", re.IGNORECASE)


def _is_number(value: object) -> bool:
    return isinstance(value, int | float) and not isinstance(value, bool) and math.isfinite(value)


def _looks_like_port(value: object) -> bool:
    """A device path (/dev/ttyUSB0, ./ports/pads), a pyserial URL (loop://, socket://host:port), COM3."""
    if not isinstance(value, str) or not value.strip() or value != value.strip():
        return False
    return "/" in value or "://" in value or bool(_WINDOWS_PORT.fullmatch(value))


@dataclass(frozen=True)
class PadsConfig:
    """A serial force-pad board (the wire formats are in docs/pads-protocol.md).

    - ``port``: the device path (``/dev/ttyUSB0``, ``/dev/ttyACM0``, a stable
      ``/dev/serial/by-id/...`` link) or any pyserial URL (``loop://``, ``socket://host:port``,
      ``rfc2217://host:port``).
    - ``framing``: ``"binary"`` (COBS + CRC-16 frames, the reference firmware) or ``"csv"`` (text
      lines ``seq,raw0,raw1,...``, for hobby boards).
    - ``pads``: how many pads the board reports in each sample.
    - ``newtons_per_count``: the scale of each pad (one value per pad, or one value for all).
    - ``tare_samples``: at start (and after each reconnect) the first K samples are averaged as the
      zero of every pad and not delivered; 0 = no tare (newtons = counts × scale).
    - ``deadband_n``: forces smaller than this (in newtons, either sign) read as 0.
    - ``reconnect_s``: the wait between attempts to reopen a port that vanished.
    - ``max_bad_per_s``: more bad frames (or lines) than this within one second fails the sensor
      (FAILED, ``read`` raises) instead of spinning on a wrong baudrate or framing.
    - ``rate_hz``: the rate the board is expected to send at (the spec's rate; judges gaps).
    """

    port: str
    baudrate: int = 115200
    framing: Framing = "binary"
    pads: int = 4
    newtons_per_count: tuple[float, ...] = (1.0,)
    tare_samples: int = 50
    deadband_n: float = 0.0
    reconnect_s: float = 1.0
    max_bad_per_s: int = 50
    rate_hz: float = 80.0

    def __post_init__(self) -> None:
        if not _looks_like_port(self.port):
            raise ValueError(f"port: expected a path like /dev/ttyUSB0 or a pyserial URL, got {self.port!r}")
        if isinstance(self.baudrate, bool) or not isinstance(self.baudrate, int) or self.baudrate <= 0:
            raise ValueError(f"baudrate: expected a whole number of bits per second > 0 (e.g. 115200), "
                             f"got {self.baudrate!r}")
        if self.framing not in ("binary", "csv"):
            raise ValueError(f"framing: expected 'binary' or 'csv', got {self.framing!r}")
        if isinstance(self.pads, bool) or not isinstance(self.pads, int) or not 1 <= self.pads <= MAX_PADS:
            raise ValueError(f"pads: expected a whole number of pads 1..{MAX_PADS}, got {self.pads!r}")
        scale = self.newtons_per_count
        if not isinstance(scale, tuple) or len(scale) not in (1, self.pads):
            raise ValueError(f"newtons_per_count: expected one number, or one per pad ({self.pads}), got {scale!r}")
        if not all(_is_number(v) and v != 0 for v in scale):
            raise ValueError(f"newtons_per_count: expected non-zero numbers, got {scale!r}")
        for name in ("tare_samples", "max_bad_per_s"):
            value = getattr(self, name)
            low = 0 if name == "tare_samples" else 1
            if isinstance(value, bool) or not isinstance(value, int) or value < low:
                raise ValueError(f"{name}: expected a whole number >= {low}, got {value!r}")
        if not _is_number(self.deadband_n) or self.deadband_n < 0:
            raise ValueError(f"deadband_n: expected newtons >= 0, got {self.deadband_n!r}")
        for name in ("reconnect_s", "rate_hz"):
            value = getattr(self, name)
            if not _is_number(value) or value <= 0:
                raise ValueError(f"{name}: expected a number > 0, got {value!r}")

    @property
    def scales(self) -> tuple[float, ...]:
        """Newtons per count of every pad (the single value repeated when one is given)."""
        scale = tuple(float(v) for v in self.newtons_per_count)
        return scale * self.pads if len(scale) == 1 else scale
