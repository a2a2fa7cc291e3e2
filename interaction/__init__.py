"""interaction: people's bodies seen by the sensors, as contactors and impulses in stage metres.

Importing this package pulls in no OpenCV: ``WebcamObserver`` (which needs cv2) is imported from
`interaction.webcam.observer` on first use of the name.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from interaction.types import BodyObservation, Contactor, Impulse, Vec3
from interaction.webcam.calibration import Calibration, CalibrationError
from interaction.webcam.config import WebcamObserverConfig

if TYPE_CHECKING:
    from interaction.webcam.observer import WebcamObserver

__all__ = [
    "BodyObservation",
    "Calibration",
    "CalibrationError",
    "Contactor",
    "Impulse",
    "Vec3",
    "WebcamObserver",
    "WebcamObserverConfig",
]


def __getattr__(name: str) -> Any:
    if name == "WebcamObserver":
        from interaction.webcam.observer import WebcamObserver

        return WebcamObserver
    raise AttributeError(f"module 'interaction' has no attribute {name!r}")
