"""The depth observer: depth frames → people on a floor grid → head, hands, feet and hull contactors.

Its calibration (:mod:`interaction.depth.calibration`, camera → stage rigid transform and floor
plane), the body parts and the shoe model behind the feet, and the terrain observer (boxes and
hands held still over floor cells, :mod:`interaction.depth.terrain_cells`) live here too. Importing
this package pulls in no OpenCV: ``DepthObserver`` is imported from :mod:`interaction.depth.observer`
on first use of the name.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from interaction.depth.config import DepthObserverConfig

if TYPE_CHECKING:
    from interaction.depth.observer import DepthObserver

__all__ = ["DepthObserver", "DepthObserverConfig"]


def __getattr__(name: str) -> Any:
    if name == "DepthObserver":
        from interaction.depth.observer import DepthObserver

        return DepthObserver
    raise AttributeError(f"module 'interaction.depth' has no attribute {name!r}")
