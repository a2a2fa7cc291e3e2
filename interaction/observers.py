"""The one table of observer types: ``type`` in an ``[observers.<name>]`` table → its config class and
how to build the observer.

The config classes are imported here (none needs OpenCV); a builder imports its observer module only
when called, as :mod:`sensors.registry` does for drivers. Add an observer kind by adding a row here.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Protocol

from interaction.depth.config import DepthObserverConfig
from interaction.pads.observer import PadsObserverConfig
from interaction.types import BodyObservation
from interaction.webcam.config import WebcamObserverConfig
from sensors.base import Frame


class Observer(Protocol):
    def observe(self, frame: Frame) -> BodyObservation: ...


@dataclass(frozen=True)
class ObserverType:
    config: type  # frozen config dataclass built from the table's other keys
    # (config, calibration: a file, one already loaded (checked against the image size), or None; sensor) → observer
    build: Callable[[Any, Any, str], Observer]
    needs_calibration: bool
    description: str


def _build_webcam(config: Any, calibration: object, sensor: str) -> Observer:
    from interaction.webcam.calibration import Calibration
    from interaction.webcam.floor_calibration import FloorCalibration, load_webcam_calibration
    from interaction.webcam.observer import WebcamObserver

    if isinstance(calibration, Path):
        calibration = load_webcam_calibration(calibration)  # an upright plane or the floor
    if not isinstance(config, WebcamObserverConfig) or not isinstance(calibration, Calibration | FloorCalibration):
        raise TypeError("webcam observer: expected a WebcamObserverConfig and a calibration (file)")
    return WebcamObserver(config, calibration)


def _build_pads(config: Any, calibration: Path | None, sensor: str) -> Observer:
    from interaction.pads.observer import PadsObserver

    if not isinstance(config, PadsObserverConfig):
        raise TypeError("pads observer: expected a PadsObserverConfig")
    return PadsObserver(config, sensor)


def _build_depth(config: Any, calibration: Path | None, sensor: str) -> Observer:
    from interaction.depth.calibration import DepthCalibration
    from interaction.depth.observer import DepthObserver

    if not isinstance(config, DepthObserverConfig) or calibration is None:
        raise TypeError("depth observer: expected a DepthObserverConfig and a calibration file")
    return DepthObserver(config, DepthCalibration.load(calibration))


OBSERVER_TYPES: dict[str, ObserverType] = {
    "webcam": ObserverType(WebcamObserverConfig, _build_webcam, True,
                           "silhouette, optical flow (and pose keypoints) → contactors, from colour frames"),
    "depth": ObserverType(DepthObserverConfig, _build_depth, True,
                          "depth frames → floor-grid people → head, hands, feet and body hull spheres"),
    "pads": ObserverType(PadsObserverConfig, _build_pads, False, "force pads → one impulse per hit"),
}


def observer_types() -> dict[str, ObserverType]:
    """A copy of the table (callers may change their copy: tests put wrapped builders in it)."""
    return dict(OBSERVER_TYPES)
