"""Multidimensional keyframe sets: reading, checking, building and importing them, and evaluating a pose
at a point of the keyframe space Q = (Θx, Θz, Dx, Dz, B). Numpy only: no GL, no OpenCV.

Imports the layers to its left (``sim.motion``, ``sim.snapshot``); never ``render.gl``.
"""

from render.keyframes.keyframe_set import KeyframeError, KeyframeQuery, KeyframeSet, Pose, query_from_snapshot

__all__ = ["KeyframeError", "KeyframeQuery", "KeyframeSet", "Pose", "query_from_snapshot"]
