"""The renderer: a WorldSnapshot (+ the people seen) → a BGR frame, headless through EGL, in a window,
or full screen (kiosk).

Each character is 18 capsules posed by its keyframe set at its point of Q, placed in its rigid
body's frame (position = centre of mass, orientation) and scaled to its height (``render.gl.figures``);
shirts coloured per character, tinted red while pushed, with a flash where the contact lands.
Capsules are impostors (one quad each, ray-cast per fragment), all characters in one instanced draw.
Under each figure a soft shadow and a contact shadow under every limb near the floor. The people:
their contactors as translucent capsules and/or their silhouette drawn on the calibrated stage plane.
The stage (floor with grid, playable area, back wall) is drawn once per camera and copied; one upload
per kind of instance per frame; read back as GL_RGBA. Rendering never steps the sim: it draws the
snapshot given.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from types import ModuleType

import cv2
import numpy as np

from interaction.types import BodyObservation
from interaction.webcam.calibration import Calibration
from render.gl import shaders
from render.gl.context import (
    Framebuffer,
    RendererUnavailable,
    attribute,
    compile_program,
    display_available,
    gen,
    open_context,
    tune_malloc,
    uniform,
    uniform_matrix,
    upload,
)
from render.gl.effects import FLASH_FLOATS, Flashes, Hud
from render.gl.figures import Figures, Sets
from render.gl.overlays import Captions, Overlays
from render.gl.scene import (
    BLOB_FLOATS,
    CAPSULE_FLOATS,
    SHADOW_FLOATS,
    contact_point,
    contact_shadows,
    people_capsules,
    shadow_blobs,
)
from render.gl.style import Camera, RenderStyle, rgb
from render.gl.terrain import TerrainLayer, TerrainView
from render.gl.window_keys import WindowKeys
from sim.snapshot import WorldSnapshot

__all__ = ["Renderer", "RendererUnavailable", "display_available"]

_STAGE = np.array(  # floor (z = 0) and back wall (y = 8) as two quads
    [(-15, -9, 0), (15, -9, 0), (15, 8, 0), (-15, -9, 0), (15, 8, 0), (-15, 8, 0),
     (-15, 8, 0), (15, 8, 0), (15, 8, 10), (-15, 8, 0), (15, 8, 10), (-15, 8, 10)],
    dtype=np.float32,
)
_QUAD = np.array([(-1, -1), (1, -1), (-1, 1), (1, 1)], dtype=np.float32)  # triangle strip


class Renderer:
    """Draws snapshots into (H, W, 3) uint8 BGR frames.

    ``headless`` draws off screen (EGL); otherwise a window opens (``fullscreen``: the whole screen,
    cursor hidden — the kiosk) and ``draw`` also shows each frame there, letterboxed.
    ``style``: camera, colours and what is drawn (``render.gl.style``); ``camera``/``samples``/
    ``flash_newtons`` override it. ``com_fraction``: height of the sim body's centre of mass above its
    base over its height (``CharacterSpec.com_height / height``), so the figures' feet meet the floor;
    one for all, or by character name or kind (key ``"*"`` for the rest), or None: each snapshot's ``com_height``; see ``render.gl.figures``.
    """

    def __init__(
        self,
        width: int = 1280,
        height: int = 720,
        *,
        headless: bool = True,
        fullscreen: bool = False,
        samples: int | None = None,
        camera: Camera | None = None,
        style: RenderStyle | None = None,
        stage_x: tuple[float, float] = (-3.0, 3.0),
        com_fraction: float | Mapping[str, float] | None = 0.5,
        flash_newtons: float | None = None,
        exit_keys: str | None = None,
    ) -> None:
        for name, v in (("width", width), ("height", height)):
            if not isinstance(v, int) or v <= 0 or v > 8192:
                raise ValueError(f"{name}: expected a pixel count 1..8192, got {v!r}")
        self.style = style or RenderStyle()
        look = self.style.look
        if samples is None:
            samples = look.samples if look.samples >= 0 else (0 if headless else 4)
        if samples not in (0, 2, 4, 8):
            raise ValueError(f"samples: expected 0, 2, 4 or 8, got {samples!r}")
        self.figures = Figures(com_fraction, self.style.colours, flash_newtons or look.flash_newtons)
        self.width, self.height, self.headless = width, height, headless
        self.camera = camera or self.style.camera
        self.stage_x = stage_x
        self.flashes = Flashes(look.flash_s)
        self.hud = Hud(rgb("hud_text", self.style.colours.hud_text)) if look.hud else None
        tune_malloc()
        self._window, self._gl = open_context(headless, width, height, fullscreen and not headless)
        self._keys = None if headless else WindowKeys(self._window, exit_keys, kiosk=fullscreen)  # Esc: see there
        self._closed = False
        self._terrain: TerrainLayer | None = None  # made on the first frame with cubes to draw
        gl = self._gl
        # render_scale < 1 draws the scene smaller and scales it up (the HUD stays sharp): fragments are
        # what a frame costs on llvmpipe, so a crowd can trade sharpness for frame rate
        iw, ih = max(1, round(width * look.render_scale)), max(1, round(height * look.render_scale))
        self._fb = Framebuffer(gl, iw, ih, samples)
        self._background = Framebuffer(gl, iw, ih, samples)  # the stage, drawn once per camera
        self._out = Framebuffer(gl, width, height, 0) if (iw, ih) != (width, height) else self._fb
        self._background_camera: Camera | None = None
        order = shaders.order_define(bgr=headless)  # a window shows RGB; read-back wants BGR
        p = {name: compile_program(gl, getattr(shaders, f"{name}_VS"), getattr(shaders, f"{name}_FS"), order)
             for name in ("STAGE", "BLOB", "CONTACT", "CAPSULE", "SILHOUETTE", "FLASH", "OVERLAY")}
        self._prog = p
        self._build_geometry(gl)
        self._overlays = Overlays(gl, p, self._overlay_vao[0], self.style)

    # ------------------------------------------------------------------ set-up

    def _instanced(self, gl: ModuleType, layout: Sequence[tuple[int, int, int]], stride: int) -> tuple[int, int]:
        """A VAO drawing the unit quad once per instance of a buffer with ``layout`` (location, size, offset)."""
        vao = gen(gl, gl.glGenVertexArrays)
        gl.glBindVertexArray(vao)
        gl.glBindBuffer(gl.GL_ARRAY_BUFFER, self._quad_vbo)
        attribute(gl, 0, 2, 2, 0, 0)
        vbo = gen(gl, gl.glGenBuffers)
        gl.glBindBuffer(gl.GL_ARRAY_BUFFER, vbo)
        for loc, size, off in layout:
            attribute(gl, loc, size, stride, off, 1)
        gl.glBindVertexArray(0)
        return vao, vbo

    def _build_geometry(self, gl: ModuleType) -> None:
        self._quad_vbo = gen(gl, gl.glGenBuffers)
        upload(gl, gl.GL_ARRAY_BUFFER, self._quad_vbo, _QUAD, gl.GL_STATIC_DRAW)
        capsule = ((1, 3, 0), (2, 3, 3), (3, 1, 6), (4, 4, 7), (5, 1, 11))
        self._figures_vao = self._instanced(gl, capsule, CAPSULE_FLOATS)
        self._people_vao = self._instanced(gl, capsule, CAPSULE_FLOATS)
        self._contact_vao = self._instanced(gl, ((1, 3, 0), (2, 3, 3), (3, 1, 6), (4, 1, 7)), SHADOW_FLOATS)
        self._blob_vao = self._instanced(gl, ((1, 2, 0), (2, 2, 2), (3, 2, 4), (4, 1, 6)), BLOB_FLOATS)
        self._flash_vao = self._instanced(gl, ((1, 3, 0), (2, 1, 3), (3, 1, 4)), FLASH_FLOATS)
        self._overlay_vao = self._instanced(gl, (), 1)
        self._stage_vao = gen(gl, gl.glGenVertexArrays)
        gl.glBindVertexArray(self._stage_vao)
        vbo = gen(gl, gl.glGenBuffers)
        upload(gl, gl.GL_ARRAY_BUFFER, vbo, _STAGE, gl.GL_STATIC_DRAW)
        attribute(gl, 0, 3, 3, 0, 0)
        gl.glBindVertexArray(0)

    # ------------------------------------------------------------------ per frame

    def draw(
        self,
        snapshot: WorldSnapshot,
        observation: BodyObservation | None,
        keyframes: Sets,
        *,
        silhouette: np.ndarray | None = None,
        silhouette_calibration: Calibration | None = None,
        captions: Captions | None = None,
        terrain: TerrainView | None = None,
    ) -> np.ndarray:
        """The frame as a new (height, width, 3) uint8 BGR array.

        ``keyframes``: one set for every character, or a mapping from character name or kind (the
        spec's name, e.g. ``"critter"``) to set, key ``"*"`` for the rest. ``silhouette``: the people's mask (h, w) uint8 in camera pixels; with
        ``silhouette_calibration`` (the webcam's image → stage homography) it is drawn where the people
        stand, on the stage plane y = plane_y, behind characters in front of it; without, it is
        stretched over the whole frame.
        """
        if self._closed:
            raise RuntimeError("render: draw() after close()")
        self._window.switch_to()
        gl = self._gl
        vp = self.camera.view_projection(self.width, self.height)
        if self._background_camera != self.camera:
            self._draw_stage(vp)
        self._fb.copy_from(self._background, depth=False)
        self._fb.bind()
        gl.glDepthMask(gl.GL_TRUE)
        gl.glClear(gl.GL_DEPTH_BUFFER_BIT)  # nothing is ever behind the floor or the back wall
        gl.glFlush()  # llvmpipe copies the stage in its threads while the figures are posed here
        chars = snapshot.characters
        a, b, r, instances = self.figures.capsules(snapshot.t, chars, keyframes)
        gl.glEnable(gl.GL_DEPTH_TEST)
        gl.glDepthFunc(gl.GL_LESS)
        gl.glDisable(gl.GL_BLEND)
        self._draw_quads("CAPSULE", self._figures_vao, instances, vp)
        if terrain is not None:  # the cubes people build (render.gl.terrain)
            self._terrain = self._terrain or TerrainLayer(gl, self.headless)
            self._terrain.draw(terrain, vp, self.camera.eye)
        gl.glFlush()  # the figures are drawn while their shadows and contacts are worked out here
        heights = np.array([c.height for c in chars], dtype=float)
        contacts = {}
        for i, c in enumerate(chars):
            if c.contact_force_n > 0:
                p = contact_point(a[i], b[i], r[i], observation)
                contacts[i] = p if p is not None else np.array(c.position, dtype=float)
        self.flashes.update(snapshot.t, chars, contacts, observation)
        people = people_capsules(observation, self.style.colours, self.style.look.contactor_opacity)
        gl.glEnable(gl.GL_BLEND)
        gl.glBlendFunc(gl.GL_SRC_ALPHA, gl.GL_ONE_MINUS_SRC_ALPHA)
        gl.glDepthMask(gl.GL_FALSE)  # shadows lie on the floor behind whatever stands on it
        if self.style.look.shadows and len(chars):
            self._draw_quads("BLOB", self._blob_vao, shadow_blobs(a, b, heights), vp)
            self._draw_quads("CONTACT", self._contact_vao, contact_shadows(a, b, r, heights), vp)
        if silhouette is not None:
            self._overlays.silhouette(silhouette, silhouette_calibration, vp)
        self._draw_quads("CAPSULE", self._people_vao, people, vp)
        gl.glDisable(gl.GL_DEPTH_TEST)
        self._draw_quads("FLASH", self._flash_vao, self.flashes.instances(snapshot.t), vp)
        if self._out is not self._fb:
            self._out.scale_from(self._fb)
            self._out.bind()
        if self.hud is not None:
            self.hud.update(chars, observation)
            self._overlays.hud(self.hud, self.width, self.height)
        if captions is not None:  # the kiosk's call to action and diagnostics panel
            self._overlays.captions(captions, self.width, self.height)
        gl.glDepthMask(gl.GL_TRUE)
        gl.glBindVertexArray(0)
        # headless shaders write BGRA (see shaders.order_define); a window renderer's frame is RGBA
        frame = cv2.cvtColor(self._out.read(), cv2.COLOR_BGRA2BGR if self.headless else cv2.COLOR_RGBA2BGR)
        if not self.headless:
            self.present()
        return frame

    def _draw_quads(self, program: str, vao_vbo: tuple[int, int], rows: np.ndarray, vp: np.ndarray) -> None:
        if not len(rows):
            return
        gl = self._gl
        prog = self._prog[program]
        gl.glUseProgram(prog)
        uniform_matrix(gl, prog, "view_proj", vp)
        if program in ("CAPSULE", "FLASH"):
            uniform(gl, prog, "eye", *self.camera.eye)
        if program == "CAPSULE":
            uniform(gl, prog, "glow_colour", 1.0, 0.2, 0.1)
            cam = self.camera
            fwd = np.subtract(cam.target, cam.eye)
            uniform(gl, prog, "cam_fwd", *(fwd / np.linalg.norm(fwd)))
            far, near = cam.far, cam.near  # window depth of a point at view depth z: a − b / z
            uniform(gl, prog, "depth_ab", 0.5 * (far + near) / (far - near) + 0.5, far * near / (far - near))
        if program == "FLASH":
            uniform(gl, prog, "colour", *rgb("flash", self.style.colours.flash))
        vao, vbo = vao_vbo
        upload(gl, gl.GL_ARRAY_BUFFER, vbo, np.ascontiguousarray(rows, dtype=np.float32), gl.GL_STREAM_DRAW)
        gl.glBindVertexArray(vao)
        gl.glDrawArraysInstanced(gl.GL_TRIANGLE_STRIP, 0, 4, len(rows))

    def _draw_stage(self, vp: np.ndarray) -> None:
        """Floor and back wall into the background target (full-screen fragment work, dear on llvmpipe,
        so it is drawn once per camera and copied every frame)."""
        gl = self._gl
        self._background.bind()
        gl.glClearColor(*rgb("background", self.style.colours.background), 1.0)
        gl.glDepthMask(gl.GL_TRUE)
        gl.glClear(gl.GL_COLOR_BUFFER_BIT | gl.GL_DEPTH_BUFFER_BIT)
        gl.glEnable(gl.GL_DEPTH_TEST)
        gl.glDepthFunc(gl.GL_LESS)
        gl.glDisable(gl.GL_BLEND)
        prog = self._prog["STAGE"]
        gl.glUseProgram(prog)
        uniform_matrix(gl, prog, "view_proj", vp)
        uniform(gl, prog, "stage_x", *self.stage_x)
        uniform(gl, prog, "eye", *self.camera.eye)
        c = self.style.colours
        for name, value in (("c_floor", c.floor), ("c_stage", c.stage), ("c_grid", c.grid), ("c_edge", c.stage_edge),
                            ("c_wall_low", c.wall_low), ("c_wall_high", c.wall_high)):
            uniform(gl, prog, name, *rgb(name, value))
        gl.glBindVertexArray(self._stage_vao)
        gl.glDrawArrays(gl.GL_TRIANGLES, 0, len(_STAGE))
        self._background_camera = self.camera

    # ------------------------------------------------------------------ window and life cycle

    @property
    def should_close(self) -> bool:
        """A window or kiosk renderer whose window was closed (or Esc pressed): time to stop."""
        return bool(not self.headless and getattr(self._window, "has_exit", False))

    def take_keys(self) -> tuple[str, ...]:
        """Key combinations pressed in the window since the last call ("f1", "ctrl+shift+q"); none headless."""
        return () if self._keys is None else self._keys.take()

    def present(self) -> None:
        """Window mode: show the last drawn frame letterboxed in the window and handle its events;
        ``draw`` does this itself in window mode."""
        if self.headless:
            raise RuntimeError("render: present() needs a window renderer (headless=False)")
        gl = self._gl
        gl.glBindFramebuffer(gl.GL_READ_FRAMEBUFFER, self._out.read_fbo)
        gl.glBindFramebuffer(gl.GL_DRAW_FRAMEBUFFER, 0)
        w, h = self._window.get_framebuffer_size()
        k = min(w / self.width, h / self.height)
        dw, dh = int(self.width * k), int(self.height * k)
        x0, y0 = (w - dw) // 2, (h - dh) // 2
        gl.glClearColor(0.0, 0.0, 0.0, 1.0)
        gl.glClear(gl.GL_COLOR_BUFFER_BIT)
        # the offscreen image is stored top row first; flip while blitting
        gl.glBlitFramebuffer(0, 0, self.width, self.height, x0, y0 + dh, x0 + dw, y0, gl.GL_COLOR_BUFFER_BIT,
                             gl.GL_LINEAR)
        self._window.flip()
        self._window.dispatch_events()

    def close(self) -> None:
        """Release the GL objects and the context; closing twice is fine."""
        if self._closed:
            return
        self._closed = True
        self._window.switch_to()
        self._fb.delete()
        self._background.delete()
        if self._out is not self._fb:
            self._out.delete()
        self._window.close()

    def __enter__(self) -> Renderer:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
