"""What the OAK driver's thread needs from a connection, and its retry schedule.

A :class:`OakLink` is one live connection: a started depthai pipeline and the queue its frames
arrive on. ``sensors.oak.device`` makes them from real cameras; ``sensors.oak.host_pipeline``
makes them from a depthai pipeline that runs on the host alone (same messages, queues and Sync
node, no device), which is how everything above the link is tested here.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from enum import StrEnum
from typing import Any, Protocol

from sensors.oak.config import OakConfig
from sensors.oak.frames import Intrinsics
from sensors.oak.search import FoundDevice


class LinkHealth(StrEnum):
    RUNNING = "running"
    RECONNECTING = "reconnecting"  # depthai's own reconnection is at work
    FAILED = "failed"  # depthai gave up: the link is gone for good


# depthai's event names → health. Device.ReconnectionStatus (the device's reconnection callback)
# and DeviceState (the pipeline's device-state callback, depthai 3.12) both end up here.
HEALTH_OF_EVENT: dict[str, LinkHealth] = {
    "RECONNECTING": LinkHealth.RECONNECTING,
    "DISCONNECTED": LinkHealth.RECONNECTING,
    "RECONNECTED": LinkHealth.RUNNING,
    "RUNNING": LinkHealth.RUNNING,
    "RECONNECT_FAILED": LinkHealth.FAILED,
    "FAILED": LinkHealth.FAILED,
}


def health_of_event(event: Any) -> LinkHealth | None:
    """The health a depthai state event means (an enum member or its name); None if unknown."""
    name = str(getattr(event, "name", event)).split(".")[-1].upper()
    return HEALTH_OF_EVENT.get(name)


@dataclass(frozen=True, slots=True)
class LinkMessage:
    """One message from the link: a ``dai.MessageGroup`` ("depth", "color") or a lone depth
    ``ImgFrame``, and how old it was on arrival (host clock minus its synced timestamp)."""

    message: Any
    age_s: float


class OakLink(Protocol):
    """One live connection to a camera (or a host pipeline standing in for one)."""

    @property
    def device_id(self) -> str: ...

    @property
    def calibration(self) -> Intrinsics | None:
        """The colour camera's intrinsics at the output size, read at connect (the fallback)."""
        ...

    def read(self, timeout_s: float) -> LinkMessage | None:
        """The next message, or None within ``timeout_s``; raises when the link is broken
        (depthai's ``XLinkError``, ``MessageQueue.QueueException`` once the pipeline stopped)."""
        ...

    def health(self) -> tuple[LinkHealth, str]:
        """The latest state the device callbacks reported, and its detail."""
        ...

    def close(self) -> None: ...


Connector = Callable[[FoundDevice, OakConfig], OakLink]


class Backoff:
    """The outer retry schedule: waits of ``first_s``, doubling, at most ``max_s``; None once
    ``give_up_after`` attempts (> 0) have failed. ``reset()`` after a success."""

    def __init__(self, first_s: float, max_s: float, give_up_after: int = 0, factor: float = 2.0) -> None:
        if not 0 < first_s <= max_s:
            raise ValueError(f"first_s: expected 0 < first_s <= max_s, got {first_s}, {max_s}")
        if factor < 1:
            raise ValueError(f"factor: expected >= 1, got {factor}")
        self.first_s = first_s
        self.max_s = max_s
        self.give_up_after = give_up_after
        self.factor = factor
        self.attempts = 0

    def next_delay(self) -> float | None:
        """The wait before the next attempt (and count it), or None when it is time to give up."""
        if self.give_up_after and self.attempts >= self.give_up_after:
            return None
        delay = min(self.max_s, self.first_s * self.factor ** self.attempts)
        self.attempts += 1
        return delay

    def reset(self) -> None:
        self.attempts = 0
