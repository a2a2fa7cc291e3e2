"""What the OAK driver's thread needs from a connection.

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
