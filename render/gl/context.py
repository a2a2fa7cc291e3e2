"""An OpenGL 3.3+ context from pyglet — headless through EGL (Mesa llvmpipe with no GPU) or a window —
and the raw-GL pieces the renderer builds on: shader programs, buffers, an offscreen framebuffer.

Headless recipe (DESIGN.md §2 render/): ``pyglet.options['headless'] = True`` and
``pyglet.options['debug_gl'] = False`` *before* ``pyglet.window`` is imported; an 8-bit RGBA config;
draw into our own framebuffer object; read back with ``glReadPixels(GL_RGBA)``. Shaders are
compiled through raw GL (pyglet 2.1's ShaderProgram trips on some attribute types).
"""

from __future__ import annotations

import ctypes
import ctypes.util
import os
import sys
from types import ModuleType
from typing import Any

import numpy as np


class RendererUnavailable(RuntimeError):
    """No OpenGL here for the requested mode; the message says what is missing and what to do."""


_malloc_tuned = False


def tune_malloc() -> bool:
    """Keep glibc from handing the GL driver's per-frame memory back to the OS (which costs llvmpipe
    much of its frame rate: docs/notes/rendering-costs.md). Raises M_TRIM_THRESHOLD / M_TOP_PAD /
    M_MMAP_THRESHOLD once per process; False where there is no glibc ``mallopt`` (nothing to tune)."""
    global _malloc_tuned
    if _malloc_tuned:
        return True
    name = ctypes.util.find_library("c")
    if not sys.platform.startswith("linux") or name is None:
        return False
    libc = ctypes.CDLL(name)
    mallopt = getattr(libc, "mallopt", None)
    if mallopt is None:
        return False
    m_trim_threshold, m_top_pad, m_mmap_threshold = -1, -2, -3
    ok = (
        mallopt(m_trim_threshold, 512 << 20)
        and mallopt(m_top_pad, 64 << 20)
        and mallopt(m_mmap_threshold, 32 << 20)
    )
    _malloc_tuned = bool(ok)
    return _malloc_tuned


def display_available() -> bool:
    """Whether a window could open here (an X11 or Wayland display is set); headless needs none."""
    return bool(os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY"))


def import_pyglet(headless: bool) -> tuple[ModuleType, ModuleType]:
    """(pyglet, pyglet.gl) with the headless option set before pyglet.window is first imported."""
    import pyglet

    if "pyglet.window" in sys.modules:
        if bool(pyglet.options["headless"]) != headless:
            mode = "headless" if pyglet.options["headless"] else "window"
            raise RendererUnavailable(
                f"render: pyglet is already set up for {mode} mode in this process; "
                "headless and window renderers cannot be mixed in one process"
            )
    else:
        pyglet.options["headless"] = headless
        pyglet.options["debug_gl"] = False
        if not headless and not display_available():
            raise RendererUnavailable(
                "render: no display for a window (DISPLAY is not set); use headless mode"
            )
    import pyglet.window  # noqa: F401  (the option above must be set first)
    from pyglet import gl

    return pyglet, gl


def open_context(headless: bool, width: int, height: int, fullscreen: bool = False) -> tuple[Any, ModuleType]:
    """A pyglet window (a 16×16 pbuffer when headless; the whole screen with the cursor hidden when
    ``fullscreen``) whose GL context is current, and pyglet.gl."""
    pyglet, gl = import_pyglet(headless)
    try:
        display = pyglet.display.get_display()
        screen = display.get_default_screen()
        config = screen.get_best_config(
            gl.Config(
                red_size=8, green_size=8, blue_size=8, alpha_size=8, depth_size=24, double_buffer=not headless
            )
        )
        if headless:
            window = pyglet.window.Window(16, 16, visible=False, config=config)
        elif fullscreen:
            window = pyglet.window.Window(caption="jostle", config=config, fullscreen=True, vsync=True)
            window.set_mouse_visible(False)
        else:
            window = pyglet.window.Window(width, height, caption="jostle", config=config, vsync=False,
                                          resizable=True)
    except (
        Exception
    ) as e:  # pyglet raises several unrelated types here (NoSuchDisplayException, GLException, …)
        what = "EGL (install libegl1 libgl1 libgl1-mesa-dri)" if headless else "a window"
        raise RendererUnavailable(
            f"render: cannot open an OpenGL context via {what}: {type(e).__name__}: {e}"
        ) from e
    window.switch_to()
    major, minor = gl.gl_info.get_version()
    if (major, minor) < (3, 3):
        window.close()
        raise RendererUnavailable(f"render: OpenGL 3.3 or newer is needed, this context has {major}.{minor}")
    return window, gl


def compile_program(gl: ModuleType, vertex: str, fragment: str, defines: str = "") -> int:
    """Link a program from GLSL sources (``defines`` go after each #version line); RendererUnavailable
    with the driver's log when it fails."""
    program = gl.glCreateProgram()
    for source, kind, label in (
        (vertex, gl.GL_VERTEX_SHADER, "vertex"),
        (fragment, gl.GL_FRAGMENT_SHADER, "fragment"),
    ):
        if defines:
            head, _, rest = source.strip().partition("\n")
            source = f"{head}\n{defines}\n{rest}"
        shader = gl.glCreateShader(kind)
        buf = ctypes.create_string_buffer(source.encode("utf-8"))
        ptr = ctypes.cast(
            ctypes.pointer(ctypes.cast(buf, ctypes.POINTER(gl.GLchar))),
            ctypes.POINTER(ctypes.POINTER(gl.GLchar)),
        )
        gl.glShaderSource(shader, 1, ptr, None)
        gl.glCompileShader(shader)
        status = gl.GLint()
        gl.glGetShaderiv(shader, gl.GL_COMPILE_STATUS, ctypes.byref(status))
        if not status.value:
            raise RendererUnavailable(f"render: {label} shader does not compile: {_log(gl, shader, False)}")
        gl.glAttachShader(program, shader)
        gl.glDeleteShader(shader)
    gl.glLinkProgram(program)
    status = gl.GLint()
    gl.glGetProgramiv(program, gl.GL_LINK_STATUS, ctypes.byref(status))
    if not status.value:
        raise RendererUnavailable(f"render: shader program does not link: {_log(gl, program, True)}")
    return int(program)


def _log(gl: ModuleType, obj: int, program: bool) -> str:
    buf = ctypes.create_string_buffer(4096)
    size = gl.GLsizei()
    (gl.glGetProgramInfoLog if program else gl.glGetShaderInfoLog)(obj, 4096, ctypes.byref(size), buf)
    return buf.value.decode("utf-8", "replace").strip().replace("\n", " | ")


def gen(gl: ModuleType, fn: Any) -> int:
    """One GL name from a glGen* function."""
    name = gl.GLuint()
    fn(1, ctypes.byref(name))
    return int(name.value)


def upload(gl: ModuleType, target: int, buffer: int, data: np.ndarray, usage: int) -> None:
    gl.glBindBuffer(target, buffer)
    arr = np.ascontiguousarray(data)
    gl.glBufferData(target, arr.nbytes, arr.ctypes.data_as(ctypes.c_void_p), usage)


def attribute(
    gl: ModuleType, location: int, size: int, stride_floats: int, offset_floats: int, divisor: int
) -> None:
    gl.glEnableVertexAttribArray(location)
    gl.glVertexAttribPointer(
        location, size, gl.GL_FLOAT, gl.GL_FALSE, stride_floats * 4, ctypes.c_void_p(offset_floats * 4)
    )
    gl.glVertexAttribDivisor(location, divisor)


def uniform_matrix(gl: ModuleType, program: int, name: str, m: np.ndarray) -> None:
    loc = gl.glGetUniformLocation(program, name.encode())
    data = (gl.GLfloat * 16)(*np.asarray(m, dtype=np.float32).ravel())
    gl.glUniformMatrix4fv(loc, 1, gl.GL_TRUE, data)  # numpy is row-major: transpose on upload


def uniform(gl: ModuleType, program: int, name: str, *values: float) -> None:
    loc = gl.glGetUniformLocation(program, name.encode())
    (gl.glUniform1f, gl.glUniform2f, gl.glUniform3f, gl.glUniform4f)[len(values) - 1](loc, *values)


class Framebuffer:
    """An offscreen colour (RGBA8) + depth target, optionally multisampled and resolved for read-back."""

    def __init__(self, gl: ModuleType, width: int, height: int, samples: int) -> None:
        self.gl, self.width, self.height, self.samples = gl, width, height, samples
        self._names: list[tuple[str, int]] = []
        self.draw_fbo = self._target(samples)
        self.read_fbo = self._target(0) if samples > 0 else self.draw_fbo
        self.pixels = np.empty((height, width, 4), dtype=np.uint8)

    def _target(self, samples: int) -> int:
        gl = self.gl
        fbo = gen(gl, gl.glGenFramebuffers)
        gl.glBindFramebuffer(gl.GL_FRAMEBUFFER, fbo)
        for fmt, attach in (
            (gl.GL_RGBA8, gl.GL_COLOR_ATTACHMENT0),
            (gl.GL_DEPTH_COMPONENT24, gl.GL_DEPTH_ATTACHMENT),
        ):
            rb = gen(gl, gl.glGenRenderbuffers)
            gl.glBindRenderbuffer(gl.GL_RENDERBUFFER, rb)
            if samples > 0:
                gl.glRenderbufferStorageMultisample(gl.GL_RENDERBUFFER, samples, fmt, self.width, self.height)
            else:
                gl.glRenderbufferStorage(gl.GL_RENDERBUFFER, fmt, self.width, self.height)
            gl.glFramebufferRenderbuffer(gl.GL_FRAMEBUFFER, attach, gl.GL_RENDERBUFFER, rb)
            self._names.append(("rb", rb))
        status = gl.glCheckFramebufferStatus(gl.GL_FRAMEBUFFER)
        if status != gl.GL_FRAMEBUFFER_COMPLETE:
            raise RendererUnavailable(
                f"render: offscreen framebuffer incomplete (status 0x{status:x}, {samples} samples)"
            )
        self._names.append(("fb", fbo))
        return fbo

    def copy_from(self, other: Framebuffer, depth: bool = True) -> None:
        """Copy colour (and depth) from a framebuffer of the same size and samples (the cached background)."""
        gl = self.gl
        mask = gl.GL_COLOR_BUFFER_BIT | (gl.GL_DEPTH_BUFFER_BIT if depth else 0)
        gl.glBindFramebuffer(gl.GL_READ_FRAMEBUFFER, other.draw_fbo)
        gl.glBindFramebuffer(gl.GL_DRAW_FRAMEBUFFER, self.draw_fbo)
        gl.glBlitFramebuffer(
            0,
            0,
            self.width,
            self.height,
            0,
            0,
            self.width,
            self.height,
            mask,
            gl.GL_NEAREST,
        )

    def scale_from(self, other: Framebuffer) -> None:
        """Colour from a framebuffer of another size, resolved and filtered (render_scale < 1)."""
        gl = self.gl
        other.resolve()
        gl.glBindFramebuffer(gl.GL_READ_FRAMEBUFFER, other.read_fbo)
        gl.glBindFramebuffer(gl.GL_DRAW_FRAMEBUFFER, self.draw_fbo)
        gl.glBlitFramebuffer(0, 0, other.width, other.height, 0, 0, self.width, self.height,
                             gl.GL_COLOR_BUFFER_BIT, gl.GL_LINEAR)

    def resolve(self) -> None:
        """Multisampled: resolve into the read-back target (nothing to do without multisampling)."""
        if self.samples > 0:
            gl = self.gl
            gl.glBindFramebuffer(gl.GL_READ_FRAMEBUFFER, self.draw_fbo)
            gl.glBindFramebuffer(gl.GL_DRAW_FRAMEBUFFER, self.read_fbo)
            gl.glBlitFramebuffer(0, 0, self.width, self.height, 0, 0, self.width, self.height,
                                 gl.GL_COLOR_BUFFER_BIT, gl.GL_NEAREST)

    def bind(self) -> None:
        self.gl.glBindFramebuffer(self.gl.GL_FRAMEBUFFER, self.draw_fbo)
        self.gl.glViewport(0, 0, self.width, self.height)

    def read(self) -> np.ndarray:
        """The frame as (H, W, 4) uint8, row 0 first as GL stores it (the shared buffer: copy to keep)."""
        gl = self.gl
        self.resolve()
        gl.glBindFramebuffer(gl.GL_READ_FRAMEBUFFER, self.read_fbo)
        gl.glPixelStorei(gl.GL_PACK_ALIGNMENT, 1)
        gl.glReadPixels(
            0,
            0,
            self.width,
            self.height,
            gl.GL_RGBA,
            gl.GL_UNSIGNED_BYTE,
            self.pixels.ctypes.data_as(ctypes.c_void_p),
        )
        return self.pixels

    def delete(self) -> None:
        gl = self.gl
        for kind, name in self._names:
            n = gl.GLuint(name)
            (gl.glDeleteRenderbuffers if kind == "rb" else gl.glDeleteFramebuffers)(1, ctypes.byref(n))
        self._names.clear()
