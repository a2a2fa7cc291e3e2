"""The sensor contract: timestamped frames, their payloads, the Sensor protocol and its errors.

Everything a driver produces is a :class:`Frame`. A frame carries exactly one typed payload.
Drivers (live hardware, recordings, the virtual performer) all implement :class:`Sensor`, and
``sensors.testing.check_sensor`` is the conformance check every one of them must pass.
"""

from __future__ import annotations

import hashlib
from dataclasses import dataclass, field
from enum import StrEnum
from types import TracebackType
from typing import Literal, Protocol, Self, runtime_checkable

import numpy as np

# ---------------------------------------------------------------- payloads


@dataclass(frozen=True, slots=True, eq=False)
class ColorImage:
    """A colour image, uint8 BGR (OpenCV's order), shape (H, W, 3)."""

    bgr: np.ndarray

    @property
    def size(self) -> tuple[int, int]:
        """(width, height) in pixels."""
        return int(self.bgr.shape[1]), int(self.bgr.shape[0])


@dataclass(frozen=True, slots=True, eq=False)
class DepthImage:
    """A depth image in millimetres (uint16, 0 = no data), with the pinhole intrinsics of its camera.

    ``color`` is an optional BGR image aligned pixel for pixel with the depth.
    """

    depth_mm: np.ndarray
    fx: float
    fy: float
    cx: float
    cy: float
    color: np.ndarray | None = None

    @property
    def size(self) -> tuple[int, int]:
        return int(self.depth_mm.shape[1]), int(self.depth_mm.shape[0])


@dataclass(frozen=True, slots=True)
class PadSample:
    """One reading of every force pad on a board: calibrated newtons, and the raw counts kept."""

    newtons: tuple[float, ...]
    raw: tuple[int, ...]


Payload = ColorImage | DepthImage | PadSample
PayloadKind = Literal["color", "depth", "pads"]

PAYLOAD_KIND: dict[type, PayloadKind] = {ColorImage: "color", DepthImage: "depth", PadSample: "pads"}


# ---------------------------------------------------------------- frame


@dataclass(frozen=True, slots=True)
class Frame:
    """One timestamped reading of one sensor.

    ``t`` is in seconds on the loop clock (the sensor's own clock mapped onto it); ``seq`` counts
    the frames of this sensor from 0 and never goes back. Frames holding images compare by
    identity; use :func:`frame_digest` to compare contents.
    """

    sensor: str
    t: float
    seq: int
    payload: Payload

    @property
    def kind(self) -> PayloadKind:
        return PAYLOAD_KIND[type(self.payload)]


def frame_digest(frame: Frame) -> str:
    """A SHA-256 of everything in a frame (name, time, sequence and payload bytes)."""
    h = hashlib.sha256()
    h.update(f"{frame.sensor}|{frame.t!r}|{frame.seq}|{frame.kind}".encode())
    p = frame.payload
    if isinstance(p, ColorImage):
        h.update(repr(p.bgr.shape).encode())
        h.update(np.ascontiguousarray(p.bgr).tobytes())
    elif isinstance(p, DepthImage):
        h.update(repr((p.depth_mm.shape, p.fx, p.fy, p.cx, p.cy)).encode())
        h.update(np.ascontiguousarray(p.depth_mm).tobytes())
        if p.color is not None:
            h.update(np.ascontiguousarray(p.color).tobytes())
    else:
        h.update(repr((p.newtons, p.raw)).encode())
    return h.hexdigest()


# ---------------------------------------------------------------- spec and status


@dataclass(frozen=True, slots=True)
class SensorSpec:
    """What a sensor produces. After ``open()`` it reports what the device really gave."""

    name: str
    kind: PayloadKind
    rate_hz: float
    width: int | None = None  # images only
    height: int | None = None  # images only
    pads: int | None = None  # pads only


class SensorState(StrEnum):
    CLOSED = "closed"
    CONNECTED = "connected"
    RECONNECTING = "reconnecting"
    FAILED = "failed"
    ENDED = "ended"  # a recording or file that has no more frames


@dataclass(frozen=True, slots=True)
class SensorStatus:
    state: SensorState
    reason: str = ""
    frames: int = 0  # frames delivered
    dropped: int = 0  # frames lost (queue full, gaps in sequence)
    bad: int = 0  # bytes or messages that could not be decoded
    extra: dict[str, float] = field(default_factory=dict)


# ---------------------------------------------------------------- protocol


@runtime_checkable
class Sensor(Protocol):
    """The one contract of every driver, live or recorded.

    - ``open()`` connects; ``read`` before ``open`` raises :class:`SensorNotOpen`.
    - ``read(timeout)`` returns the next frame, or ``None`` if none came within ``timeout``
      seconds; it never blocks longer than asked.
    - ``close()`` is idempotent. The sensor is a context manager.
    """

    @property
    def spec(self) -> SensorSpec: ...

    @property
    def status(self) -> SensorStatus: ...

    def open(self) -> None: ...

    def read(self, timeout: float) -> Frame | None: ...

    def close(self) -> None: ...

    def __enter__(self) -> Sensor: ...

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None: ...


class SensorContext:
    """``with sensor:`` opens the sensor and closes it on the way out; mixed into every driver.

    The class supplies ``open()`` and ``close()``; ``__enter__`` returns the sensor itself.
    """

    def open(self) -> None:
        raise NotImplementedError(f"{type(self).__name__} must define open()")

    def close(self) -> None:
        raise NotImplementedError(f"{type(self).__name__} must define close()")

    def __enter__(self) -> Self:
        self.open()
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self.close()


# ---------------------------------------------------------------- errors


class SensorError(Exception):
    """Base of every sensor error. The message says what the user must fix."""


class SensorUnavailable(SensorError):
    """The configured device, port or file cannot be opened."""


class SensorNotOpen(SensorError):
    """``read`` was called before ``open`` (or after ``close``)."""


class RecordingCorrupt(SensorError):
    """A recording is damaged or is not a recording at all."""


class ContractError(AssertionError):
    """A sensor broke the contract (raised by ``sensors.testing.check_sensor``)."""
