"""Textured overlays of the renderer: the people's silhouette (on the calibrated stage plane, through the
inverse homography, or stretched over the frame) and the HUD text."""

from __future__ import annotations

import ctypes
from types import ModuleType

import numpy as np

from interaction.calibration import Calibration
from render.effects import Hud
from render.glcontext import attribute, gen, uniform, uniform_matrix, upload
from render.style import RenderStyle, rgb


class Overlays:
    """GL objects for the overlays; ``prog`` holds the SILHOUETTE and OVERLAY programs, ``quad_vao`` a
    unit quad (triangle strip)."""

    def __init__(self, gl: ModuleType, prog: dict[str, int], quad_vao: int, style: RenderStyle) -> None:
        self.gl, self.prog, self.quad_vao, self.style = gl, prog, quad_vao, style
        self.silhouette_tex = gen(gl, gl.glGenTextures)
        self.hud_tex = gen(gl, gl.glGenTextures)
        self.silhouette_vbo = gen(gl, gl.glGenBuffers)
        self.silhouette_vao = gen(gl, gl.glGenVertexArrays)
        gl.glBindVertexArray(self.silhouette_vao)
        gl.glBindBuffer(gl.GL_ARRAY_BUFFER, self.silhouette_vbo)
        attribute(gl, 0, 3, 3, 0, 0)
        gl.glBindVertexArray(0)

    def texture(self, name: int, image: np.ndarray) -> None:
        """Upload an (h, w) or (h, w, 3|4) uint8 image into texture ``name`` (unit 0), linear, clamped."""
        gl = self.gl
        img = np.ascontiguousarray(image)
        gl.glActiveTexture(gl.GL_TEXTURE0)
        gl.glBindTexture(gl.GL_TEXTURE_2D, name)
        gl.glPixelStorei(gl.GL_UNPACK_ALIGNMENT, 1)
        fmt, internal = {1: (gl.GL_RED, gl.GL_R8), 3: (gl.GL_RGB, gl.GL_RGB8), 4: (gl.GL_RGBA, gl.GL_RGBA8)}[
            1 if img.ndim == 2 else img.shape[2]
        ]
        gl.glTexImage2D(gl.GL_TEXTURE_2D, 0, internal, img.shape[1], img.shape[0], 0, fmt, gl.GL_UNSIGNED_BYTE,
                        img.ctypes.data_as(ctypes.c_void_p))
        for p in (gl.GL_TEXTURE_MIN_FILTER, gl.GL_TEXTURE_MAG_FILTER):
            gl.glTexParameteri(gl.GL_TEXTURE_2D, p, gl.GL_LINEAR)
        for p in (gl.GL_TEXTURE_WRAP_S, gl.GL_TEXTURE_WRAP_T):
            gl.glTexParameteri(gl.GL_TEXTURE_2D, p, gl.GL_CLAMP_TO_EDGE)

    def silhouette(self, mask: np.ndarray, calibration: Calibration | None, vp: np.ndarray) -> None:
        """The people's mask: on the calibrated stage plane (depth-tested), or stretched over the frame."""
        gl = self.gl
        if mask.dtype != np.uint8 or mask.ndim != 2:
            raise ValueError(f"silhouette: expected an (h, w) uint8 mask, got {mask.dtype} {mask.shape}")
        h, w = mask.shape
        stage = None
        if calibration is not None:
            stage = calibration.image_to_stage(np.array([(0, 0), (w, 0), (0, h), (w, h)], dtype=float))
        self.texture(self.silhouette_tex, mask)
        prog = self.prog["SILHOUETTE"]
        gl.glUseProgram(prog)
        gl.glUniform1i(gl.glGetUniformLocation(prog, b"image"), 0)
        uniform(gl, prog, "tint", *rgb("silhouette", self.style.colours.silhouette))
        uniform(gl, prog, "opacity", self.style.look.silhouette_opacity)
        uniform(gl, prog, "image_size", float(w), float(h))
        if stage is None:  # draw in clip space: an identity "camera" and the plane x/z = NDC
            inv = np.array([[w / 2, 0, w / 2], [0, h / 2, h / 2], [0, 0, 1]], dtype=float)  # NDC −1 = row 0
            corners = np.array([(-1, 0, -1), (1, 0, -1), (-1, 0, 1), (1, 0, 1)], dtype=np.float32)
            flat = np.array([[1, 0, 0, 0], [0, 0, 1, 0], [0, 0, 0, 0], [0, 0, 0, 1]], dtype=float)
            gl.glDisable(gl.GL_DEPTH_TEST)
            uniform_matrix(gl, prog, "view_proj", flat)
        else:
            assert calibration is not None
            inv = np.linalg.inv(calibration.matrix)
            corners = stage.astype(np.float32)
            uniform_matrix(gl, prog, "view_proj", vp)
        loc = gl.glGetUniformLocation(prog, b"stage_to_image")
        gl.glUniformMatrix3fv(loc, 1, gl.GL_TRUE, (gl.GLfloat * 9)(*inv.astype(np.float32).ravel()))
        upload(gl, gl.GL_ARRAY_BUFFER, self.silhouette_vbo, corners, gl.GL_STREAM_DRAW)
        gl.glBindVertexArray(self.silhouette_vao)
        gl.glDrawArrays(gl.GL_TRIANGLE_STRIP, 0, 4)
        gl.glEnable(gl.GL_DEPTH_TEST)

    def hud(self, hud: Hud, width: int, height: int) -> None:
        """The HUD's text image in the top-left corner of a width × height target."""
        assert hud.image is not None
        gl = self.gl
        img = hud.image
        if hud.changed:
            self.texture(self.hud_tex, img)
        else:
            gl.glActiveTexture(gl.GL_TEXTURE0)
            gl.glBindTexture(gl.GL_TEXTURE_2D, self.hud_tex)
        prog = self.prog["OVERLAY"]
        gl.glUseProgram(prog)
        gl.glUniform1i(gl.glGetUniformLocation(prog, b"image"), 0)
        # the read-back image has row 0 at NDC y = −1 (the scene's projection flips y)
        x1 = -1.0 + 2.0 * (img.shape[1] + 8) / width
        y1 = -1.0 + 2.0 * (img.shape[0] + 8) / height
        x0, y0 = -1.0 + 16.0 / width, -1.0 + 16.0 / height
        uniform(gl, prog, "rect", x0, y0, x1, y1)
        gl.glUniform1i(gl.glGetUniformLocation(prog, b"flip"), 0)
        gl.glBindVertexArray(self.quad_vao)
        gl.glDrawArrays(gl.GL_TRIANGLE_STRIP, 0, 4)

