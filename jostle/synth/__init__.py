"""Synthetic sensors with ground truth: the virtual performer (a webcam filming a motion-captured
person in a room), used to make the shipped demo recording and as ground truth for interaction tests.
"""

from jostle.synth.camera import PinholeCamera, apply_homography
from jostle.synth.performer import PerformerConfig, PerformerSensor, PerformerTruth

__all__ = ["PerformerConfig", "PerformerSensor", "PerformerTruth", "PinholeCamera", "apply_homography"]
