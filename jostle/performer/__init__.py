"""Synthetic sensors with ground truth: virtual performers (motion-captured people, 1 to 4 at once)
filmed by a virtual webcam and a virtual OAK depth camera and stepping on virtual force pads; used
to make the shipped demo recording and the test fixtures, and as ground truth for interaction tests.

- :class:`Performance` (``scene``): the people, shared by every sensor filming them.
- :class:`PerformerSensor` (webcam), :class:`PerformerDepth` (OAK), :class:`PerformerPads` (pads).
- :func:`record_performance` (``session``): all of them into one MCAP file, with the ``truth`` channel.
- :func:`read_truth`, :func:`read_cameras`, :func:`read_pad_layout` (``truth``): read such a file's
  ground truth back.
"""

from jostle.performer.camera import PinholeCamera, apply_homography
from jostle.performer.config import DepthCameraConfig, PerformerConfig
from jostle.performer.depth import DepthTruth, PerformerDepth
from jostle.performer.pads import (
    PadBoardConfig,
    PadLayout,
    PadPlacement,
    PerformerPads,
    default_pad_layout,
    load_pad_layout,
    pad_forces,
)
from jostle.performer.performer import PerformerSensor, PerformerTruth
from jostle.performer.scene import Performance, PersonState
from jostle.performer.session import SynthSensors, SynthSummary, record_performance
from jostle.performer.truth import PersonTruth, TruthFrame, read_cameras, read_pad_layout, read_truth

__all__ = [
    "DepthCameraConfig",
    "DepthTruth",
    "PadBoardConfig",
    "PadLayout",
    "PadPlacement",
    "Performance",
    "PerformerConfig",
    "PerformerDepth",
    "PerformerPads",
    "PerformerSensor",
    "PerformerTruth",
    "PersonState",
    "PersonTruth",
    "PinholeCamera",
    "SynthSensors",
    "SynthSummary",
    "TruthFrame",
    "apply_homography",
    "default_pad_layout",
    "load_pad_layout",
    "pad_forces",
    "read_cameras",
    "read_pad_layout",
    "read_truth",
    "record_performance",
]
