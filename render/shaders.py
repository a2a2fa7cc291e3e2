"""GLSL 3.30 sources for the renderer: the stage (floor grid, back wall), blob shadows, instanced
capsules, and the silhouette overlay. Fragment colours pass through ``ORDER(rgb)``: defined as
``.bgr`` for headless read-back (a GL_RGBA read is then already in OpenCV's order), ``.rgb`` for a
window (see ``order_define``)."""

from __future__ import annotations


def order_define(bgr: bool) -> str:
    return "#define ORDER(c) ((c).bgr)" if bgr else "#define ORDER(c) ((c).rgb)"


_LIGHT = """
const vec3 KEY_DIR = normalize(vec3(-0.45, -0.75, 0.85));  // toward the key light: audience side, left, up
"""

STAGE_VS = """
#version 330 core
layout(location = 0) in vec3 position;
uniform mat4 view_proj;
out vec3 v_world;
void main() {
    v_world = position;
    gl_Position = view_proj * vec4(position, 1.0);
}
"""

STAGE_FS = """
#version 330 core
in vec3 v_world;
uniform vec2 stage_x;      // playable stage, x range
uniform vec3 eye;
out vec4 frag;
float grid_line(vec2 p, float spacing, float width) {
    vec2 g = abs(fract(p / spacing - 0.5) - 0.5) * spacing;
    vec2 w = fwidth(p) * width;
    vec2 l = 1.0 - smoothstep(vec2(0.0), w, g);
    return max(l.x, l.y);
}
void main() {
    vec3 c;
    if (v_world.z < 1e-3) {  // floor
        float on_stage = step(stage_x.x, v_world.x) * step(v_world.x, stage_x.y);
        c = mix(vec3(0.50, 0.49, 0.47), vec3(0.62, 0.60, 0.56), on_stage);
        c = mix(c, vec3(0.35, 0.34, 0.33), 0.55 * grid_line(v_world.xy, 0.5, 1.0));
        c = mix(c, vec3(0.28, 0.27, 0.27), 0.75 * grid_line(v_world.xy, 1.0, 1.6));
        float edge = min(abs(v_world.x - stage_x.x), abs(v_world.x - stage_x.y));
        c = mix(c, vec3(0.85, 0.55, 0.25), 1.0 - smoothstep(0.0, 2.0 * fwidth(v_world.x) + 0.01, edge));
    } else {  // back wall
        float h = clamp(v_world.z / 6.0, 0.0, 1.0);
        c = mix(vec3(0.78, 0.80, 0.82), vec3(0.45, 0.58, 0.74), h);
        c = mix(c, c * 0.9, grid_line(v_world.xz, 1.0, 0.8) * 0.4);
    }
    float dist = length(v_world - eye);
    c *= mix(1.0, 0.82, clamp((dist - 6.0) / 12.0, 0.0, 1.0));
    frag = vec4(ORDER(c), 1.0);
}
"""

SHADOW_VS = """
#version 330 core
layout(location = 0) in vec2 corner;        // (-1..1, -1..1)
layout(location = 1) in vec2 inst_centre;
layout(location = 2) in vec2 inst_u;
layout(location = 3) in vec2 inst_v;
layout(location = 4) in float inst_strength;
uniform mat4 view_proj;
out vec2 v_corner;
out float v_strength;
void main() {
    v_corner = corner;
    v_strength = inst_strength;
    vec2 p = inst_centre + corner.x * inst_u + corner.y * inst_v;
    gl_Position = view_proj * vec4(p, 0.002, 1.0);
}
"""

SHADOW_FS = """
#version 330 core
in vec2 v_corner;
in float v_strength;
out vec4 frag;
void main() {
    float r2 = dot(v_corner, v_corner);
    float a = v_strength * 0.42 * (1.0 - smoothstep(0.15, 1.0, r2));
    frag = vec4(0.0, 0.0, 0.0, a);
}
"""

CAPSULE_VS = """
#version 330 core
layout(location = 0) in vec3 sphere_dir;   // unit direction; y along the capsule's axis
layout(location = 1) in float cap_end;     // 0: the hemisphere at a, 1: at b
layout(location = 2) in vec3 inst_a;
layout(location = 3) in vec3 inst_b;
layout(location = 4) in float inst_radius;
layout(location = 5) in vec4 inst_colour;
layout(location = 6) in float inst_glow;
uniform mat4 view_proj;
out vec3 v_normal;
out vec3 v_world;
out vec4 v_colour;
out float v_glow;
void main() {
    vec3 axis = inst_b - inst_a;
    float len = length(axis);
    vec3 d = len > 1e-6 ? axis / len : vec3(0.0, 0.0, 1.0);
    vec3 helper = abs(d.z) < 0.9 ? vec3(0.0, 0.0, 1.0) : vec3(1.0, 0.0, 0.0);
    vec3 u = normalize(cross(helper, d));
    vec3 w = cross(d, u);
    vec3 n = u * sphere_dir.x + d * sphere_dir.y + w * sphere_dir.z;
    vec3 p = mix(inst_a, inst_b, cap_end) + inst_radius * n;
    v_normal = n;
    v_world = p;
    v_colour = inst_colour;
    v_glow = inst_glow;
    gl_Position = view_proj * vec4(p, 1.0);
}
"""

CAPSULE_FS = (
    """
#version 330 core
in vec3 v_normal;
in vec3 v_world;
in vec4 v_colour;
in float v_glow;
uniform vec3 eye;
out vec4 frag;
"""
    + _LIGHT
    + """
void main() {
    vec3 n = normalize(v_normal);
    vec3 view = normalize(eye - v_world);
    float diffuse = max(dot(n, KEY_DIR), 0.0);
    float sky = 0.5 + 0.5 * n.z;
    float rim = pow(1.0 - max(dot(n, view), 0.0), 3.0);
    vec3 base = mix(v_colour.rgb, vec3(1.0, 0.12, 0.08), 0.6 * v_glow);
    vec3 c = base * (0.30 + 0.22 * sky + 0.62 * diffuse) + 0.18 * rim * vec3(1.0);
    c += 0.25 * v_glow * vec3(1.0, 0.2, 0.1);
    frag = vec4(ORDER(clamp(c, 0.0, 1.0)), v_colour.a);
}
"""
)

OVERLAY_VS = """
#version 330 core
layout(location = 0) in vec2 corner;  // full-screen triangle strip, (-1..1)
out vec2 v_uv;
void main() {
    v_uv = 0.5 * corner + 0.5;  // read-back row 0 is NDC y = -1 (the scene's projection flips y): image row 0
    gl_Position = vec4(corner, 0.0, 1.0);
}
"""

OVERLAY_FS = """
#version 330 core
in vec2 v_uv;
uniform sampler2D image;
uniform int is_mask;
uniform vec3 tint;       // RGB
uniform float opacity;
out vec4 frag;
void main() {
    vec4 t = texture(image, v_uv);
    if (is_mask == 1) {
        frag = vec4(ORDER(tint), opacity * t.r);
    } else {
        float a = max(max(t.r, t.g), t.b) > 0.0 ? opacity : 0.0;
        frag = vec4(ORDER(t.bgr), a);  // BGR bytes were uploaded as RGB: t.bgr is the image's RGB
    }
}
"""
