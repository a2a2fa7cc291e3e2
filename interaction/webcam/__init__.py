"""The webcam observer: colour frames → silhouettes, people, optical flow (and pose keypoints) → contactors.

Its calibration (:mod:`interaction.webcam.calibration`, the camera → stage-plane homography) and the
ArUco-board fit that makes it (:mod:`interaction.webcam.calibrate`) live here too. Importing this
package pulls in no OpenCV: ``WebcamObserver`` is imported from :mod:`interaction.webcam.observer`
on first use of the name.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from interaction.webcam.config import WebcamObserverConfig

if TYPE_CHECKING:
    from interaction.webcam.observer import WebcamObserver

__all__ = ["WebcamObserver", "WebcamObserverConfig"]


def __getattr__(name: str) -> Any:
    if name == "WebcamObserver":
        from interaction.webcam.observer import WebcamObserver

        return WebcamObserver
    raise AttributeError(f"module 'interaction.webcam' has no attribute {name!r}")
