"""The one table of observer types: ``type`` in an ``[observers.<name>]`` table → its config class and
how to build it. Add an observer kind by adding a row here."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Protocol

from interaction.types import BodyObservation
from sensors.base import Frame


class Observer(Protocol):
    def observe(self, frame: Frame) -> BodyObservation: ...


@dataclass(frozen=True)
class ObserverType:
    config: type  # frozen config dataclass built from the table's other keys
    build: Callable[[Any, Path | None, str], Observer]  # (config, calibration file or None, sensor) → observer
    needs_calibration: bool
    description: str


def _webcam_config() -> type:
    from interaction.webcam.config import WebcamObserverConfig

    return WebcamObserverConfig


def _build_webcam(config: Any, calibration: Path | None, sensor: str) -> Observer:
    from interaction.webcam.calibration import Calibration
    from interaction.webcam.config import WebcamObserverConfig
    from interaction.webcam.observer import WebcamObserver

    if not isinstance(config, WebcamObserverConfig) or calibration is None:
        raise TypeError("webcam observer: expected a WebcamObserverConfig and a calibration file")
    return WebcamObserver(config, Calibration.load(calibration))


def _pads_config() -> type:
    from interaction.pads.observer import PadsObserverConfig

    return PadsObserverConfig


def _build_pads(config: Any, calibration: Path | None, sensor: str) -> Observer:
    from interaction.pads.observer import PadsObserver, PadsObserverConfig

    if not isinstance(config, PadsObserverConfig):
        raise TypeError("pads observer: expected a PadsObserverConfig")
    return PadsObserver(config, sensor)


def _depth_config() -> type:
    from interaction.depth.observer import DepthObserverConfig

    return DepthObserverConfig


def _build_depth(config: Any, calibration: Path | None, sensor: str) -> Observer:
    from interaction.depth.calibration import DepthCalibration
    from interaction.depth.observer import DepthObserver, DepthObserverConfig

    if not isinstance(config, DepthObserverConfig) or calibration is None:
        raise TypeError("depth observer: expected a DepthObserverConfig and a calibration file")
    return DepthObserver(config, DepthCalibration.load(calibration))


def observer_types() -> dict[str, ObserverType]:
    """The table (built on call: the config classes live in modules that import OpenCV)."""
    return {
        "webcam": ObserverType(_webcam_config(), _build_webcam, True,
                               "silhouette, optical flow (and pose keypoints) → contactors, from colour frames"),
        "depth": ObserverType(_depth_config(), _build_depth, True,
                              "depth frames → floor-grid people → head, hands, feet and body hull spheres"),
        "pads": ObserverType(_pads_config(), _build_pads, False, "force pads → one impulse per hit"),
    }
