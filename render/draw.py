"""The renderer: a WorldSnapshot (+ the people seen) → a BGR frame, headless through EGL or in a window.

Each character is ~18 capsules (64 triangles each, instanced in one draw call) posed by its
keyframe set at ``query_from_snapshot``, placed in its rigid body's frame (position = centre of
mass, orientation) and scaled to its height; coloured per character (shirt hue by its place in the
snapshot) and flashing red while a person pushes it. The people are translucent capsules/spheres
(their contactors) and, when given, a silhouette image blended over the frame. A blob shadow
under each figure, a floor with a metre grid and the playable stage marked, a back wall. The
camera stands on the audience side looking +y at the stage (z up), framing x ∈ [−3, 3].
"""

from __future__ import annotations

import ctypes
import math
import warnings
from collections.abc import Mapping
from types import ModuleType

import cv2
import numpy as np

from interaction.types import BodyObservation
from render import shaders
from render.glcontext import (
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
from render.keyframes import KeyframeSet, query_from_snapshot
from render.scene import (
    CAPSULE_FLOATS,
    CAPSULES,
    Camera,
    body_rotations,
    capsule_mesh,
    figure_capsules,
    figure_colours,
    people_capsules,
    shadow_blobs,
)
from render.skeleton_pose import com_fraction
from sim.snapshot import CharacterSnapshot, WorldSnapshot

__all__ = ["Renderer", "RendererUnavailable", "display_available"]

_SHADOW_FLOATS = 7
_STAGE = np.array(
    [  # floor (z = 0) and back wall (y = 8) as two quads
        (-15, -9, 0),
        (15, -9, 0),
        (15, 8, 0),
        (-15, -9, 0),
        (15, 8, 0),
        (-15, 8, 0),
        (-15, 8, 0),
        (15, 8, 0),
        (15, 8, 10),
        (-15, 8, 0),
        (15, 8, 10),
        (-15, 8, 10),
    ],
    dtype=np.float32,
)
_QUAD = np.array([(-1, -1), (1, -1), (-1, 1), (1, 1)], dtype=np.float32)  # triangle strip


class Renderer:
    """Draws snapshots into (H, W, 3) uint8 BGR frames. ``headless=False`` opens a window (needs a display;
    ``draw`` then also shows each frame there — a plain window for now, the kiosk comes later).

    ``samples``: multisample anti-aliasing, 0 = off; by default 0 headless (on llvmpipe 4× costs 2.5–3×
    the frame time, measured) and 4 in a window. ``com_fraction``: height of the sim body's centre
    of mass above its base as a fraction of its height (``CharacterSpec.com_height / height``), so the
    figure's feet meet the floor. ``flash_newtons``: a push of this force gives a full red flash.
    """

    def __init__(
        self,
        width: int = 1280,
        height: int = 720,
        *,
        headless: bool = True,
        samples: int | None = None,
        camera: Camera | None = None,
        stage_x: tuple[float, float] = (-3.0, 3.0),
        com_fraction: float = 0.5,
        flash_newtons: float = 150.0,
    ) -> None:
        for name, v in (("width", width), ("height", height)):
            if not isinstance(v, int) or v <= 0 or v > 8192:
                raise ValueError(f"{name}: expected a pixel count 1..8192, got {v!r}")
        if samples is None:
            samples = 0 if headless else 4
        if samples not in (0, 2, 4, 8):
            raise ValueError(f"samples: expected 0, 2, 4 or 8, got {samples!r}")
        if not 0.0 < com_fraction < 1.0:
            raise ValueError(f"com_fraction: expected a fraction in (0, 1), got {com_fraction!r}")
        self.width, self.height, self.headless = width, height, headless
        self.camera = camera or Camera()
        self.stage_x = stage_x
        self.com_fraction = com_fraction
        self.flash_newtons = flash_newtons
        tune_malloc()
        self._window, self._gl = open_context(headless, width, height)
        self._closed = False
        self._warned: set[str] = set()
        gl = self._gl
        self._fb = Framebuffer(gl, width, height, samples)
        self._background = Framebuffer(gl, width, height, samples)  # the stage, drawn once
        self._background_camera: Camera | None = None
        order = shaders.order_define(bgr=headless)  # a window shows RGB; read-back wants BGR
        self._stage_prog = compile_program(gl, shaders.STAGE_VS, shaders.STAGE_FS, order)
        self._shadow_prog = compile_program(gl, shaders.SHADOW_VS, shaders.SHADOW_FS, order)
        self._capsule_prog = compile_program(gl, shaders.CAPSULE_VS, shaders.CAPSULE_FS, order)
        self._overlay_prog = compile_program(gl, shaders.OVERLAY_VS, shaders.OVERLAY_FS, order)
        self._build_geometry(gl)
        self._texture = gen(gl, gl.glGenTextures)

    # ------------------------------------------------------------------ set-up

    def _build_geometry(self, gl: ModuleType) -> None:
        verts, tris = capsule_mesh(8)
        self._capsule_indices = int(tris.size)
        self._mesh_vbo = gen(gl, gl.glGenBuffers)
        upload(gl, gl.GL_ARRAY_BUFFER, self._mesh_vbo, verts, gl.GL_STATIC_DRAW)
        self._mesh_ibo = gen(gl, gl.glGenBuffers)
        self._capsule_vaos: list[
            tuple[int, int]
        ] = []  # (vao, instance vbo): opaque figures, translucent people
        for _ in range(2):
            vao = gen(gl, gl.glGenVertexArrays)
            gl.glBindVertexArray(vao)
            gl.glBindBuffer(gl.GL_ARRAY_BUFFER, self._mesh_vbo)
            attribute(gl, 0, 3, 4, 0, 0)
            attribute(gl, 1, 1, 4, 3, 0)
            gl.glBindBuffer(gl.GL_ELEMENT_ARRAY_BUFFER, self._mesh_ibo)  # element binding is VAO state
            inst = gen(gl, gl.glGenBuffers)
            gl.glBindBuffer(gl.GL_ARRAY_BUFFER, inst)
            for loc, size, off in ((2, 3, 0), (3, 3, 3), (4, 1, 6), (5, 4, 7), (6, 1, 11)):
                attribute(gl, loc, size, CAPSULE_FLOATS, off, 1)
            self._capsule_vaos.append((vao, inst))
        upload(gl, gl.GL_ELEMENT_ARRAY_BUFFER, self._mesh_ibo, tris, gl.GL_STATIC_DRAW)

        self._stage_vao = gen(gl, gl.glGenVertexArrays)
        gl.glBindVertexArray(self._stage_vao)
        vbo = gen(gl, gl.glGenBuffers)
        upload(gl, gl.GL_ARRAY_BUFFER, vbo, _STAGE, gl.GL_STATIC_DRAW)
        attribute(gl, 0, 3, 3, 0, 0)

        self._quad_vbo = gen(gl, gl.glGenBuffers)
        upload(gl, gl.GL_ARRAY_BUFFER, self._quad_vbo, _QUAD, gl.GL_STATIC_DRAW)
        self._shadow_vao = gen(gl, gl.glGenVertexArrays)
        gl.glBindVertexArray(self._shadow_vao)
        gl.glBindBuffer(gl.GL_ARRAY_BUFFER, self._quad_vbo)
        attribute(gl, 0, 2, 2, 0, 0)
        self._shadow_vbo = gen(gl, gl.glGenBuffers)
        gl.glBindBuffer(gl.GL_ARRAY_BUFFER, self._shadow_vbo)
        for loc, size, off in ((1, 2, 0), (2, 2, 2), (3, 2, 4), (4, 1, 6)):
            attribute(gl, loc, size, _SHADOW_FLOATS, off, 1)
        self._overlay_vao = gen(gl, gl.glGenVertexArrays)
        gl.glBindVertexArray(self._overlay_vao)
        gl.glBindBuffer(gl.GL_ARRAY_BUFFER, self._quad_vbo)
        attribute(gl, 0, 2, 2, 0, 0)
        gl.glBindVertexArray(0)

    # ------------------------------------------------------------------ per frame

    def draw(
        self,
        snapshot: WorldSnapshot,
        observation: BodyObservation | None,
        keyframes: Mapping[str, KeyframeSet] | KeyframeSet,
        *,
        silhouette: np.ndarray | None = None,
    ) -> np.ndarray:
        """The frame as a new (height, width, 3) uint8 BGR array.

        ``keyframes``: one set for every character, or a mapping from character name to set (key
        ``"*"`` for the rest). ``silhouette``: an (h, w) uint8 mask or (h, w, 3) BGR image in screen
        layout, stretched over the frame and blended at 35 %.
        """
        if self._closed:
            raise RuntimeError("render: draw() after close()")
        self._window.switch_to()
        chars = snapshot.characters
        a, b, radii, colours, blobs = self._figures(chars, keyframes)
        people = people_capsules(observation)
        gl = self._gl
        vp = self.camera.view_projection(self.width, self.height)
        if self._background_camera != self.camera:
            self._draw_stage(vp)
        self._fb.copy_from(self._background)
        self._fb.bind()
        gl.glEnable(gl.GL_DEPTH_TEST)
        gl.glDepthFunc(gl.GL_LESS)

        gl.glEnable(gl.GL_BLEND)
        gl.glBlendFunc(gl.GL_SRC_ALPHA, gl.GL_ONE_MINUS_SRC_ALPHA)
        gl.glDepthMask(gl.GL_FALSE)
        if len(blobs):
            gl.glUseProgram(self._shadow_prog)
            uniform_matrix(gl, self._shadow_prog, "view_proj", vp)
            upload(gl, gl.GL_ARRAY_BUFFER, self._shadow_vbo, blobs.astype(np.float32), gl.GL_STREAM_DRAW)
            gl.glBindVertexArray(self._shadow_vao)
            gl.glDrawArraysInstanced(gl.GL_TRIANGLE_STRIP, 0, 4, len(blobs))

        gl.glUseProgram(self._capsule_prog)
        uniform_matrix(gl, self._capsule_prog, "view_proj", vp)
        uniform(gl, self._capsule_prog, "eye", *self.camera.eye)
        if len(a):
            gl.glDisable(gl.GL_BLEND)
            gl.glDepthMask(gl.GL_TRUE)
            self._draw_capsules(0, np.concatenate([a, b, radii[:, None], colours], axis=1))
        if len(people):
            gl.glEnable(gl.GL_BLEND)
            gl.glDepthMask(gl.GL_FALSE)
            self._draw_capsules(1, people)
        gl.glDepthMask(gl.GL_TRUE)
        if silhouette is not None:
            self._overlay(silhouette)
        gl.glBindVertexArray(0)
        # headless shaders write BGRA (see shaders.order_define); a window renderer's frame is RGBA
        code = cv2.COLOR_BGRA2BGR if self.headless else cv2.COLOR_RGBA2BGR
        frame = cv2.cvtColor(self._fb.read(), code)
        if not self.headless:
            self.present()
        return frame

    def _draw_stage(self, vp: np.ndarray) -> None:
        """Floor and back wall into the background target (full-screen fragment work: ~10 ms on
        llvmpipe at 1280×720, so it is drawn once per camera and copied every frame)."""
        gl = self._gl
        self._background.bind()
        gl.glClearColor(0.0, 0.0, 0.0, 1.0)
        gl.glDepthMask(gl.GL_TRUE)
        gl.glClear(gl.GL_COLOR_BUFFER_BIT | gl.GL_DEPTH_BUFFER_BIT)
        gl.glEnable(gl.GL_DEPTH_TEST)
        gl.glDepthFunc(gl.GL_LESS)
        gl.glDisable(gl.GL_BLEND)
        gl.glUseProgram(self._stage_prog)
        uniform_matrix(gl, self._stage_prog, "view_proj", vp)
        uniform(gl, self._stage_prog, "stage_x", *self.stage_x)
        uniform(gl, self._stage_prog, "eye", *self.camera.eye)
        gl.glBindVertexArray(self._stage_vao)
        gl.glDrawArrays(gl.GL_TRIANGLES, 0, len(_STAGE))
        self._background_camera = self.camera

    def _draw_capsules(self, which: int, instances: np.ndarray) -> None:
        gl = self._gl
        vao, vbo = self._capsule_vaos[which]
        upload(gl, gl.GL_ARRAY_BUFFER, vbo, instances.astype(np.float32), gl.GL_STREAM_DRAW)
        gl.glBindVertexArray(vao)
        # closed meshes: dropping back faces changes no pixel (checked) and saves ~30 % of the
        # per-triangle work, which bounds llvmpipe here; GL_BACK as the mesh winds through the y-flip
        gl.glEnable(gl.GL_CULL_FACE)
        gl.glFrontFace(gl.GL_CCW)
        gl.glCullFace(gl.GL_BACK)
        gl.glDrawElementsInstanced(
            gl.GL_TRIANGLES, self._capsule_indices, gl.GL_UNSIGNED_INT, None, len(instances)
        )
        gl.glDisable(gl.GL_CULL_FACE)

    def _figures(
        self, chars: tuple[CharacterSnapshot, ...], keyframes: Mapping[str, KeyframeSet] | KeyframeSet
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Capsule ends, radii, colours (in snapshot order) and shadow blobs of all characters."""
        per = len(CAPSULES)
        n = len(chars)
        a, b = np.zeros((n, per, 3)), np.zeros((n, per, 3))
        radii = np.zeros((n, per))
        rots = body_rotations(np.array([c.orientation for c in chars], dtype=float).reshape(n, 4))
        self._check_frames(chars, rots)
        groups: dict[int, tuple[KeyframeSet, list[int]]] = {}
        for i, c in enumerate(chars):
            kset = self._set_for(c.name, keyframes)
            groups.setdefault(id(kset), (kset, []))[1].append(i)
        for kset, idx in groups.values():
            group = [chars[i] for i in idx]
            poses = kset.poses([query_from_snapshot(c) for c in group])
            lift = com_fraction() - self.com_fraction
            ga, gb, gr = figure_capsules(
                group, poses, kset.skeleton, kset.height, com_lift=lift, rotations=rots[idx]
            )
            a[idx], b[idx], radii[idx] = ga.reshape(-1, per, 3), gb.reshape(-1, per, 3), gr.reshape(-1, per)
        colours = figure_colours(chars, flash_newtons=self.flash_newtons)
        heights = np.array([c.height for c in chars], dtype=float)
        blobs = shadow_blobs(a.reshape(-1, 3), b.reshape(-1, 3), per, heights)
        return a.reshape(-1, 3), b.reshape(-1, 3), radii.reshape(-1), colours, blobs

    @staticmethod
    def _set_for(name: str, keyframes: Mapping[str, KeyframeSet] | KeyframeSet) -> KeyframeSet:
        if isinstance(keyframes, KeyframeSet):
            return keyframes
        found = keyframes.get(name, keyframes.get("*"))
        if found is None:
            raise KeyError(
                f"render: no keyframe set for character {name!r} (sets for: {', '.join(sorted(keyframes))})"
            )
        return found

    def _check_frames(self, chars: tuple[CharacterSnapshot, ...], rots: np.ndarray) -> None:
        """Warn once if an upright character's orientation faces away from its heading: the renderer
        assumes the sim's body frame (x forward, y left, z up)."""
        if "frame" in self._warned or not chars:
            return
        tilt = np.array([c.tilt for c in chars], dtype=float)
        heading = np.array([c.heading for c in chars], dtype=float)
        yaw = np.arctan2(rots[:, 1, 0], rots[:, 0, 0])  # skeleton x (forward) in stage axes
        off = np.abs(np.remainder(yaw - heading + math.pi, 2.0 * math.pi) - math.pi)
        bad = (np.abs(tilt).max(axis=1) < 0.3) & (off > 0.35)
        if np.any(bad):
            c = chars[int(np.argmax(bad))]
            yaw_c = float(yaw[int(np.argmax(bad))])
            self._warned.add("frame")
            warnings.warn(
                f"render: character {c.name!r}: orientation faces {math.degrees(yaw_c):.0f}° but heading is "
                f"{math.degrees(c.heading):.0f}°; the renderer assumes body axes x forward, y left, z up",
                stacklevel=3,
            )

    def _overlay(self, image: np.ndarray) -> None:
        gl = self._gl
        img = np.ascontiguousarray(image)
        if img.dtype != np.uint8 or img.ndim not in (2, 3) or (img.ndim == 3 and img.shape[2] != 3):
            raise ValueError(
                f"silhouette: expected an (h, w) uint8 mask or (h, w, 3) uint8 BGR image, got {img.dtype} "
                f"{img.shape}"
            )
        mask = img.ndim == 2
        gl.glActiveTexture(gl.GL_TEXTURE0)
        gl.glBindTexture(gl.GL_TEXTURE_2D, self._texture)
        gl.glPixelStorei(gl.GL_UNPACK_ALIGNMENT, 1)
        fmt, internal = (gl.GL_RED, gl.GL_R8) if mask else (gl.GL_RGB, gl.GL_RGB8)
        gl.glTexImage2D(
            gl.GL_TEXTURE_2D,
            0,
            internal,
            img.shape[1],
            img.shape[0],
            0,
            fmt,
            gl.GL_UNSIGNED_BYTE,
            img.ctypes.data_as(ctypes.c_void_p),
        )
        for p in (gl.GL_TEXTURE_MIN_FILTER, gl.GL_TEXTURE_MAG_FILTER):
            gl.glTexParameteri(gl.GL_TEXTURE_2D, p, gl.GL_LINEAR)
        for p in (gl.GL_TEXTURE_WRAP_S, gl.GL_TEXTURE_WRAP_T):
            gl.glTexParameteri(gl.GL_TEXTURE_2D, p, gl.GL_CLAMP_TO_EDGE)
        gl.glDisable(gl.GL_DEPTH_TEST)
        gl.glEnable(gl.GL_BLEND)
        gl.glUseProgram(self._overlay_prog)
        gl.glUniform1i(gl.glGetUniformLocation(self._overlay_prog, b"image"), 0)
        gl.glUniform1i(gl.glGetUniformLocation(self._overlay_prog, b"is_mask"), int(mask))
        uniform(gl, self._overlay_prog, "tint", 0.45, 0.82, 1.0)  # light blue
        uniform(gl, self._overlay_prog, "opacity", 0.35)
        gl.glBindVertexArray(self._overlay_vao)
        gl.glDrawArrays(gl.GL_TRIANGLE_STRIP, 0, 4)
        gl.glEnable(gl.GL_DEPTH_TEST)

    # ------------------------------------------------------------------ window and life cycle

    def present(self) -> None:
        """Window mode: show the last drawn frame (blit the offscreen target to the window) and flip;
        ``draw`` does this itself in window mode."""
        if self.headless:
            raise RuntimeError("render: present() needs a window renderer (headless=False)")
        gl = self._gl
        gl.glBindFramebuffer(gl.GL_READ_FRAMEBUFFER, self._fb.read_fbo)
        gl.glBindFramebuffer(gl.GL_DRAW_FRAMEBUFFER, 0)
        w, h = self._window.get_framebuffer_size()
        # the offscreen image is stored top row first; flip while blitting
        gl.glBlitFramebuffer(0, 0, self.width, self.height, 0, h, w, 0, gl.GL_COLOR_BUFFER_BIT, gl.GL_LINEAR)
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
        self._window.close()

    def __enter__(self) -> Renderer:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
