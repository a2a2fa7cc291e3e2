"""interaction: people's bodies seen by the sensors, as contactors and impulses in stage metres.

The contracts are in :mod:`interaction.types`. One observer per payload kind, each in its room with
its calibration: :mod:`interaction.webcam`, :mod:`interaction.depth`, :mod:`interaction.pads`; the
table of them is :mod:`interaction.observers`. Importing this package pulls in no OpenCV.
"""

from __future__ import annotations

from interaction.types import BodyObservation, Contactor, Impulse, Vec3

__all__ = ["BodyObservation", "Contactor", "Impulse", "Vec3"]
