"""Textured overlays of the renderer: the people's silhouette (on the calibrated stage plane, through the
inverse homography, or stretched over the frame), the HUD text, and the kiosk's captions: the call to
action of attract mode (large, centred, pulsing) and the diagnostics panel (top right)."""

from __future__ import annotations

import ctypes
from dataclasses import dataclass
from types import ModuleType

import cv2
import numpy as np

from interaction.webcam.calibration import Calibration
from render.gl.context import attribute, gen, uniform, uniform_matrix, upload
from render.gl.effects import Hud
from render.gl.style import RenderStyle, rgb


@dataclass(frozen=True)
class Captions:
    """Text drawn over the scene: ``call_to_action`` at ``strength`` (0: not drawn, 1: full), and the
    ``diagnostics`` panel's lines (empty: no panel). ASCII only (OpenCV's Hershey font)."""

    call_to_action: str = ""
    strength: float = 0.0
    diagnostics: tuple[str, ...] = ()


def call_to_action_image(text: str, height: int) -> np.ndarray:
    """``text`` large, white with a dark outline, on a transparent RGBA image (row 0 at the top); the
    letters are about height / 10 pixels tall."""
    font, scale = cv2.FONT_HERSHEY_DUPLEX, max(0.5, height / 260.0)
    thick = max(1, round(scale * 1.6))
    outline = thick + max(2, round(scale * 2))
    (w, h), base = cv2.getTextSize(text, font, scale, outline)
    pad = outline + 4
    img = np.zeros((h + base + 2 * pad, w + 2 * pad, 4), np.uint8)
    org = (pad, pad + h)
    cv2.putText(img, text, org, font, scale, (20, 20, 30, 200), outline, cv2.LINE_AA)
    cv2.putText(img, text, org, font, scale, (255, 255, 255, 255), thick, cv2.LINE_AA)
    return img


def panel_image(lines: tuple[str, ...], colour: tuple[int, int, int]) -> np.ndarray:
    """Lines of small text on a dark translucent panel, RGBA, row 0 at the top."""
    font, scale, thick = cv2.FONT_HERSHEY_SIMPLEX, 0.42, 1
    sizes = [cv2.getTextSize(line or " ", font, scale, thick)[0] for line in lines]
    line_h = max(s[1] for s in sizes) + 8
    img = np.zeros((line_h * len(lines) + 10, max(s[0] for s in sizes) + 16, 4), np.uint8)
    img[..., 3] = 180
    for i, line in enumerate(lines):
        bad = line.startswith("!")
        cv2.putText(img, line, (8, 4 + line_h * (i + 1) - 5), font, scale,
                    ((255, 120, 90, 255) if bad else (*colour, 255)), thick, cv2.LINE_AA)
    return img


class Overlays:
    """GL objects for the overlays; ``prog`` holds the SILHOUETTE and OVERLAY programs, ``quad_vao`` a
    unit quad (triangle strip)."""

    def __init__(self, gl: ModuleType, prog: dict[str, int], quad_vao: int, style: RenderStyle) -> None:
        self.gl, self.prog, self.quad_vao, self.style = gl, prog, quad_vao, style
        self.silhouette_tex = gen(gl, gl.glGenTextures)
        self.hud_tex = gen(gl, gl.glGenTextures)
        self.cta_tex = gen(gl, gl.glGenTextures)
        self.panel_tex = gen(gl, gl.glGenTextures)
        self._cta: tuple[str, int, int] | None = None  # (text, height, alpha level) in cta_tex
        self._cta_image: tuple[str, int, np.ndarray] | None = None
        self._panel: tuple[str, ...] | None = None
        self._panel_size = (0, 0)
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


    def _place(self, texture: int, x: float, y: float, w: int, h: int, width: int, height: int) -> None:
        """Draw ``texture`` (row 0 at its top) as a w × h pixel rectangle whose top-left corner is at
        pixel (x, y) of a width × height target (row 0 at the top of the read-back image)."""
        gl = self.gl
        gl.glActiveTexture(gl.GL_TEXTURE0)
        gl.glBindTexture(gl.GL_TEXTURE_2D, texture)
        prog = self.prog["OVERLAY"]
        gl.glUseProgram(prog)
        gl.glUniform1i(gl.glGetUniformLocation(prog, b"image"), 0)
        uniform(gl, prog, "rect", -1.0 + 2.0 * x / width, -1.0 + 2.0 * y / height,
                -1.0 + 2.0 * (x + w) / width, -1.0 + 2.0 * (y + h) / height)
        gl.glUniform1i(gl.glGetUniformLocation(prog, b"flip"), 0)
        gl.glBindVertexArray(self.quad_vao)
        gl.glDrawArrays(gl.GL_TRIANGLE_STRIP, 0, 4)

    def captions(self, captions: Captions, width: int, height: int) -> None:
        """The call to action (centred, in the lower third) and the diagnostics panel (top right)."""
        strength = min(1.0, max(0.0, float(captions.strength)))
        if captions.call_to_action and strength > 0.0:
            level = max(1, round(strength * 32))  # the alpha is baked in: re-upload at most 32 levels
            key = (captions.call_to_action, height, level)
            if self._cta_image is None or self._cta_image[:2] != key[:2]:
                self._cta_image = (key[0], key[1], call_to_action_image(key[0], height))
            img = self._cta_image[2]
            if self._cta != key:
                faded = img.copy()
                faded[..., 3] = (img[..., 3].astype(np.float32) * (level / 32)).astype(np.uint8)
                self.texture(self.cta_tex, faded)
                self._cta = key
            w, h = min(img.shape[1], width), img.shape[0]
            self._place(self.cta_tex, (width - w) / 2, height * 0.78 - h / 2, w, h, width, height)
        if captions.diagnostics:
            if self._panel != captions.diagnostics:
                colour = tuple(int(255 * c) for c in rgb("hud_text", self.style.colours.hud_text))
                img = panel_image(captions.diagnostics, (colour[0], colour[1], colour[2]))
                self.texture(self.panel_tex, img)
                self._panel, self._panel_size = captions.diagnostics, (img.shape[1], img.shape[0])
            w, h = self._panel_size
            self._place(self.panel_tex, max(0.0, width - w - 16.0), 16.0, w, h, width, height)
