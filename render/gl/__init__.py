"""Drawing: snapshots posed by their keyframe sets → pixels through OpenGL (pyglet; headless via EGL, a
window or the kiosk), and the frames out to video. May import ``render.keyframes``, never the reverse.

Nothing is imported here, so ``render.gl.style`` (plain dataclasses) loads without pyglet or OpenCV.
"""
