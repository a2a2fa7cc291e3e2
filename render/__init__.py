"""render: snapshot → keyframe-space query → pose (multidimensional keyframe sets) → pixels.

Light imports only: ``import render`` pulls in numpy and the keyframe code, never pyglet or OpenCV.
``render.gl.renderer.Renderer`` (pyglet, EGL) and ``render.gl.video`` (OpenCV, Pillow) load when used.
"""

from render.keyframes import KeyframeError, KeyframeQuery, KeyframeSet, Pose, query_from_snapshot

__all__ = ["KeyframeError", "KeyframeQuery", "KeyframeSet", "Pose", "query_from_snapshot"]
