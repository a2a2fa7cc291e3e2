"""Drawing the terrain people build: columns of unit cubes on the floor grid.

One instanced draw: a 12-triangle box per occupied column (its full height), the seams between the
stacked and neighbouring cubes drawn in the fragment shader (so a column of three looks like three
cubes for the price of one box); the instance buffer is uploaded again only when the heights change.
What it costs on llvmpipe: docs/notes/rendering-costs.md.

:class:`TerrainView` is what the renderer is given per frame (the heights in cubes, the cell size and
the grid's origin, and the cells where a hand is being held — drawn as a translucent cube growing on
top of the column as the hold nears the moment it places one); :func:`column_instances` turns it into
instance rows (pure numpy, testable without GL); :class:`TerrainLayer` owns the GL side.
"""

from __future__ import annotations

from dataclasses import dataclass
from types import ModuleType

import numpy as np

from render.gl.context import attribute, compile_program, gen, uniform, uniform_matrix, upload
from render.gl.shaders import _LIGHT, order_define

__all__ = ["COLUMN_FLOATS", "TerrainLayer", "TerrainView", "column_instances", "pending_instances"]

COLUMN_FLOATS = 9  # one column: x0, y0 (its corner), cell, cubes, rgba, base (cubes below it)
PENDING_RGB = (1.0, 0.88, 0.54)

CARDBOARD = np.array([(0.80, 0.64, 0.44), (0.74, 0.58, 0.39), (0.86, 0.71, 0.50)])  # by column parity / height


@dataclass(frozen=True, eq=False)
class TerrainView:
    """The cubes to draw: ``heights`` (nx, ny) in cubes, cell (ix, iy) with its corner at
    ``origin + (ix, iy)·cell``; ``pending``: (ix, iy, fraction 0..1) of the holds under way."""

    heights: np.ndarray
    cell: float
    origin: tuple[float, float]
    pending: tuple[tuple[int, int, float], ...] = ()


def column_instances(view: TerrainView) -> np.ndarray:
    """Instance rows (M, COLUMN_FLOATS) of the occupied columns, in (ix, iy) order."""
    h = np.asarray(view.heights)
    ix, iy = np.nonzero(h > 0)
    rows = np.zeros((len(ix), COLUMN_FLOATS), dtype=np.float32)
    rows[:, 0] = view.origin[0] + ix * view.cell
    rows[:, 1] = view.origin[1] + iy * view.cell
    rows[:, 2] = view.cell
    rows[:, 3] = h[ix, iy]
    rows[:, 4:7] = CARDBOARD[(ix + iy) % 2 + (h[ix, iy] > 1)]
    rows[:, 7] = 1.0
    return rows


def pending_instances(view: TerrainView) -> np.ndarray:
    """Instance rows of the holds under way: a cube on top of its column, as tall as the hold is far."""
    h = np.asarray(view.heights)
    rows = np.zeros((len(view.pending), COLUMN_FLOATS), dtype=np.float32)
    for k, (ix, iy, fraction) in enumerate(view.pending):
        f = float(np.clip(fraction, 0.0, 1.0))
        base = int(h[ix, iy]) if 0 <= ix < h.shape[0] and 0 <= iy < h.shape[1] else 0
        rows[k] = (view.origin[0] + ix * view.cell, view.origin[1] + iy * view.cell, view.cell, f,
                   *PENDING_RGB, 0.25 + 0.45 * f, base)
    return rows


def _unit_box() -> np.ndarray:
    """36 vertices (corner xyz in 0..1, normal xyz) of the unit box's 12 triangles, outward facing."""
    out: list[np.ndarray] = []
    for axis in range(3):
        for side in (0.0, 1.0):
            n = np.zeros(3)
            n[axis] = 1.0 if side else -1.0
            u, v = (axis + 1) % 3, (axis + 2) % 3
            quad = []
            for a, b in ((0, 0), (1, 0), (1, 1), (0, 1)):
                p = np.zeros(3)
                p[axis], p[u], p[v] = side, a, b
                quad.append(p)
            tris = [quad[0], quad[1], quad[2], quad[0], quad[2], quad[3]]
            if not side:
                tris = tris[::-1]
            out.extend(np.concatenate([p, n]) for p in tris)
    return np.array(out, dtype=np.float32)


COLUMN_VS = """
#version 330 core
layout(location = 0) in vec3 corner;      // unit box corner (0..1)
layout(location = 1) in vec3 normal;
layout(location = 2) in vec4 inst_column; // x0, y0, cell, cubes
layout(location = 3) in vec4 inst_colour;
layout(location = 4) in float inst_base;  // cubes under this one (a pending cube sits on its column)
uniform mat4 view_proj;
uniform vec2 origin;
out vec3 v_world;
out vec3 v_cells;                          // position in cube units from the grid's origin
flat out vec3 f_normal;
flat out vec4 f_colour;
void main() {
    float cell = inst_column.z;
    vec3 p = vec3(inst_column.xy + corner.xy * cell, (inst_base + corner.z * inst_column.w) * cell);
    v_world = p;
    v_cells = vec3((p.xy - origin) / cell, p.z / cell);
    f_normal = normal;
    f_colour = inst_colour;
    gl_Position = view_proj * vec4(p, 1.0);
}
"""

COLUMN_FS = (
    """
#version 330 core
in vec3 v_world;
in vec3 v_cells;
flat in vec3 f_normal;
flat in vec4 f_colour;
uniform vec3 eye;
out vec4 frag;
"""
    + _LIGHT
    + """
void main() {
    // seams: distance (in cube units) to the nearest cube edge along the two axes of this face
    vec3 g = abs(fract(v_cells - 0.5) - 0.5);
    vec3 w = fwidth(v_cells) * 1.5 + 0.012;
    vec3 line = 1.0 - smoothstep(vec3(0.0), w, g);
    line *= 1.0 - abs(f_normal);               // not along the face's own normal
    float seam = max(max(line.x, line.y), line.z);
    float diffuse = max(dot(f_normal, KEY_DIR), 0.0);
    float sky = 0.5 + 0.5 * f_normal.z;
    vec3 col = f_colour.rgb * (0.38 + 0.22 * sky + 0.5 * diffuse);
    col = mix(col, col * 0.45, 0.8 * seam);
    float dist = length(v_world - eye);
    col *= mix(1.0, 0.82, clamp((dist - 6.0) / 12.0, 0.0, 1.0));
    frag = vec4(ORDER(clamp(col, 0.0, 1.0)), f_colour.a);
}
"""
)


class TerrainLayer:
    """The cube columns on the GPU; ``draw`` uploads them again only when the heights change."""

    def __init__(self, gl: ModuleType, headless: bool) -> None:
        self._gl = gl
        self._prog = compile_program(gl, COLUMN_VS, COLUMN_FS, order_define(bgr=headless))
        self._box_vbo = gen(gl, gl.glGenBuffers)
        upload(gl, gl.GL_ARRAY_BUFFER, self._box_vbo, _unit_box(), gl.GL_STATIC_DRAW)
        self._columns = self._instanced()
        self._pending = self._instanced()
        self._shown: tuple[np.ndarray, float, tuple[float, float], tuple[float, ...]] | None = None  # in the buffer
        self._count = 0

    def _instanced(self) -> tuple[int, int]:
        """A VAO drawing the unit box once per row of its own instance buffer."""
        gl = self._gl
        vao = gen(gl, gl.glGenVertexArrays)
        gl.glBindVertexArray(vao)
        gl.glBindBuffer(gl.GL_ARRAY_BUFFER, self._box_vbo)
        attribute(gl, 0, 3, 6, 0, 0)
        attribute(gl, 1, 3, 6, 3, 0)
        vbo = gen(gl, gl.glGenBuffers)
        gl.glBindBuffer(gl.GL_ARRAY_BUFFER, vbo)
        attribute(gl, 2, 4, COLUMN_FLOATS, 0, 1)
        attribute(gl, 3, 4, COLUMN_FLOATS, 4, 1)
        attribute(gl, 4, 1, COLUMN_FLOATS, 8, 1)
        gl.glBindVertexArray(0)
        return vao, vbo

    def draw(self, view: TerrainView, view_proj: np.ndarray, eye: tuple[float, ...]) -> None:
        """Draw the columns (opaque) and then the pending cubes (blended) into the bound target, depth
        test on; leaves blending off and depth writes on."""
        gl = self._gl
        shown = self._shown
        if (shown is None or (shown[1], shown[2], shown[3]) != (view.cell, view.origin, tuple(eye))
                or not np.array_equal(shown[0], view.heights)):
            rows = column_instances(view)
            # nearest first: hidden faces then fail the depth test before they are shaded
            centre = rows[:, :2] + 0.5 * rows[:, 2:3]
            rows = rows[np.argsort(np.hypot(centre[:, 0] - eye[0], centre[:, 1] - eye[1]), kind="stable")]
            self._count = len(rows)
            if self._count:
                upload(gl, gl.GL_ARRAY_BUFFER, self._columns[1], rows, gl.GL_DYNAMIC_DRAW)
            self._shown = (np.array(view.heights, copy=True), view.cell, view.origin, tuple(eye))
        if not self._count and not view.pending:
            return
        gl.glUseProgram(self._prog)
        uniform_matrix(gl, self._prog, "view_proj", view_proj)
        uniform(gl, self._prog, "origin", float(view.origin[0]), float(view.origin[1]))
        uniform(gl, self._prog, "eye", *(float(v) for v in eye))
        # the boxes wind counter-clockwise seen from outside; the projection flips y (rows read top
        # first), which turns that clockwise on screen
        gl.glEnable(gl.GL_CULL_FACE)
        gl.glFrontFace(gl.GL_CW)
        if self._count:
            gl.glBindVertexArray(self._columns[0])
            gl.glDrawArraysInstanced(gl.GL_TRIANGLES, 0, 36, self._count)
        if view.pending:
            upload(gl, gl.GL_ARRAY_BUFFER, self._pending[1], pending_instances(view), gl.GL_STREAM_DRAW)
            gl.glEnable(gl.GL_BLEND)
            gl.glBlendFunc(gl.GL_SRC_ALPHA, gl.GL_ONE_MINUS_SRC_ALPHA)
            gl.glDepthMask(gl.GL_FALSE)
            gl.glBindVertexArray(self._pending[0])
            gl.glDrawArraysInstanced(gl.GL_TRIANGLES, 0, 36, len(view.pending))
            gl.glDepthMask(gl.GL_TRUE)
            gl.glDisable(gl.GL_BLEND)
        gl.glFrontFace(gl.GL_CCW)
        gl.glDisable(gl.GL_CULL_FACE)
        gl.glBindVertexArray(0)
