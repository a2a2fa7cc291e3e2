"""GLSL 3.30 sources for the renderer.

- the stage (floor with a grid and the playable area marked, back wall), drawn once per camera;
- soft shadows: one blob per figure and a contact shadow under every capsule near the floor;
- capsules as *impostors*: one camera-facing quad per capsule (2 triangles) bounding it, the capsule's
  surface and true depth found per fragment — on llvmpipe triangles, not fragments, are what a frame
  cannot afford (figures: docs/notes/rendering-costs.md);
- the silhouette of the people on the calibrated stage plane (textured through the inverse
  homography), the flashes where contacts land, and the HUD text.

Fragment colours pass through ``ORDER(rgb)``: ``.bgr`` for headless read-back (a GL_RGBA read is then
already in OpenCV's order), ``.rgb`` for a window (see ``order_define``).
"""

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
uniform vec3 c_floor, c_stage, c_grid, c_edge, c_wall_low, c_wall_high;
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
        c = mix(c_floor, c_stage, on_stage);
        c = mix(c, c_grid, 0.45 * grid_line(v_world.xy, 0.5, 1.0));
        c = mix(c, c_grid * 0.8, 0.7 * grid_line(v_world.xy, 1.0, 1.6));
        float edge = min(abs(v_world.x - stage_x.x), abs(v_world.x - stage_x.y));
        c = mix(c, c_edge, 1.0 - smoothstep(0.0, 2.0 * fwidth(v_world.x) + 0.01, edge));
    } else {  // back wall
        c = mix(c_wall_low, c_wall_high, clamp(v_world.z / 6.0, 0.0, 1.0));
        c = mix(c, c * 0.9, grid_line(v_world.xz, 1.0, 0.8) * 0.4);
    }
    float dist = length(v_world - eye);
    c *= mix(1.0, 0.82, clamp((dist - 6.0) / 12.0, 0.0, 1.0));
    frag = vec4(ORDER(c), 1.0);
}
"""

BLOB_VS = """
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

BLOB_FS = """
#version 330 core
in vec2 v_corner;
in float v_strength;
out vec4 frag;
void main() {
    float r2 = dot(v_corner, v_corner);
    if (r2 > 1.0) discard;
    frag = vec4(0.0, 0.0, 0.0, v_strength * 0.35 * (1.0 - smoothstep(0.1, 1.0, r2)));
}
"""

CONTACT_VS = """
#version 330 core
layout(location = 0) in vec2 corner;
layout(location = 1) in vec3 inst_a;
layout(location = 2) in vec3 inst_b;
layout(location = 3) in float inst_radius;
layout(location = 4) in float inst_strength;
uniform mat4 view_proj;
out vec2 v_floor;
flat out vec2 f_a;
flat out vec2 f_b;
flat out vec2 f_height;   // height of the capsule's bottom above the floor at a and at b
flat out float f_radius;
flat out float f_strength;
void main() {
    vec2 a = inst_a.xy, b = inst_b.xy;
    vec2 d = b - a;
    float len = length(d);
    vec2 e1 = len > 1e-5 ? d / len : vec2(1.0, 0.0);
    vec2 e2 = vec2(-e1.y, e1.x);
    vec2 h = max(vec2(inst_a.z, inst_b.z) - inst_radius, 0.0);
    float reach = inst_radius * 1.3 + 0.3 * max(h.x, h.y);   // penumbra widens with height
    vec2 p = 0.5 * (a + b) + corner.x * (0.5 * len + reach) * e1 + corner.y * reach * e2;
    v_floor = p;
    f_a = a; f_b = b; f_height = h; f_radius = inst_radius; f_strength = inst_strength;
    gl_Position = view_proj * vec4(p, 0.003, 1.0);
}
"""

CONTACT_FS = """
#version 330 core
in vec2 v_floor;
flat in vec2 f_a;
flat in vec2 f_b;
flat in vec2 f_height;
flat in float f_radius;
flat in float f_strength;
out vec4 frag;
void main() {
    vec2 ab = f_b - f_a;
    float t = clamp(dot(v_floor - f_a, ab) / max(dot(ab, ab), 1e-10), 0.0, 1.0);
    float d = length(v_floor - (f_a + t * ab));
    float h = mix(f_height.x, f_height.y, t);
    float inner = f_radius * (0.55 - 0.4 * clamp(h / (f_radius + 1e-4), 0.0, 1.0));
    float outer = f_radius * 1.3 + 0.3 * h;
    float occlusion = 1.0 - smoothstep(inner, outer, d);
    float fade = 1.0 / (1.0 + 4.0 * h / max(f_radius, 1e-3));
    frag = vec4(0.0, 0.0, 0.0, 0.55 * f_strength * occlusion * fade);
}
"""

CAPSULE_VS = """
#version 330 core
layout(location = 0) in vec2 corner;
layout(location = 1) in vec3 inst_a;
layout(location = 2) in vec3 inst_b;
layout(location = 3) in float inst_radius;
layout(location = 4) in vec4 inst_colour;
layout(location = 5) in float inst_glow;
uniform mat4 view_proj;
uniform vec3 eye;
uniform vec3 cam_fwd;         // the camera's unit forward vector
out vec2 v_uv;                // position on the quad: along the projected axis, across it (centre plane units)
flat out vec4 f_seg;          // u of the ends a and b on the quad, their depths along the camera's axis
flat out vec4 f_scale;        // world metres per quad unit at a and at b, radius (m), cos(view, camera axis)
flat out vec3 f_e1;
flat out vec3 f_e2;
flat out vec3 f_view;
flat out vec4 f_colour;
flat out float f_glow;
void main() {
    vec3 c = 0.5 * (inst_a + inst_b);
    vec3 v = normalize(c - eye);
    vec3 axis = inst_b - inst_a;
    vec3 across = axis - dot(axis, v) * v;
    float lp = length(across);
    vec3 any_perp = abs(v.z) < 0.9 ? vec3(0.0, 0.0, 1.0) : vec3(1.0, 0.0, 0.0);
    vec3 e1 = lp > 1e-6 ? across / lp : normalize(cross(v, any_perp));
    vec3 e2 = normalize(cross(v, e1));
    float dist = dot(c - eye, v);
    float da = dot(inst_a - eye, v);
    float db = dot(inst_b - eye, v);
    // the ends as seen on the centre plane (perspective), and how much bigger things look there
    float ua = dot(inst_a - eye, e1) * dist / da - dot(c - eye, e1);
    float ub = dot(inst_b - eye, e1) * dist / db - dot(c - eye, e1);
    float grow = dist / max(min(da, db) - inst_radius, 0.05 * dist) * 1.02;
    float hl = max(abs(ua), abs(ub)) + inst_radius * grow;
    float hw = inst_radius * grow;
    v_uv = vec2(corner.x * hl, corner.y * hw);
    vec3 p = c + v_uv.x * e1 + v_uv.y * e2;
    f_seg = vec4(ua, ub, dot(inst_a - eye, cam_fwd), dot(inst_b - eye, cam_fwd));
    f_scale = vec4(da / dist, db / dist, inst_radius, dot(v, cam_fwd));
    f_e1 = e1; f_e2 = e2; f_view = v;
    f_colour = inst_colour; f_glow = inst_glow;
    gl_Position = view_proj * vec4(p, 1.0);
}
"""

# The capsule seen from the eye is a stadium on its quad (exact for a parallel projection, within a
# few per cent at these distances): inside it the visible surface is the sphere around the nearest
# point of the axis, which gives the normal and the true depth (written, so capsules cut each other
# correctly at the joints). ~25 operations a fragment: llvmpipe's fill rate is what a frame is made of.
CAPSULE_FS = (
    """
#version 330 core
in vec2 v_uv;
flat in vec4 f_seg;
flat in vec4 f_scale;
flat in vec3 f_e1;
flat in vec3 f_e2;
flat in vec3 f_view;
flat in vec4 f_colour;
flat in float f_glow;
uniform vec2 depth_ab;
uniform vec3 glow_colour;
out vec4 frag;
"""
    + _LIGHT
    + """
void main() {
    float span = f_seg.y - f_seg.x;
    float t = abs(span) > 1e-7 ? clamp((v_uv.x - f_seg.x) / span, 0.0, 1.0) : 0.0;
    float k = mix(f_scale.x, f_scale.y, t);                // metres per quad unit there
    vec2 d = vec2(v_uv.x - mix(f_seg.x, f_seg.y, t), v_uv.y) * k;
    float r2 = f_scale.z * f_scale.z;
    float d2 = dot(d, d);
    if (d2 > r2) discard;
    float h = sqrt(r2 - d2);
    vec3 n = (d.x * f_e1 + d.y * f_e2 - h * f_view) / f_scale.z;
    gl_FragDepth = depth_ab.x - depth_ab.y / (mix(f_seg.z, f_seg.w, t) - h * f_scale.w);
    float diffuse = max(dot(n, KEY_DIR), 0.0);
    float sky = 0.5 + 0.5 * n.z;
    float facing = 1.0 - h / f_scale.z;
    float rim = facing * facing * facing;
    vec3 base = mix(f_colour.rgb, vec3(1.0, 0.12, 0.08), 0.6 * f_glow);
    vec3 col = base * (0.30 + 0.22 * sky + 0.62 * diffuse) + 0.18 * rim + 0.25 * f_glow * glow_colour;
    frag = vec4(ORDER(clamp(col, 0.0, 1.0)), f_colour.a);
}
"""
)

SILHOUETTE_VS = """
#version 330 core
layout(location = 0) in vec3 position;     // a corner of the camera image on the stage plane
uniform mat4 view_proj;
out vec3 v_world;
void main() {
    v_world = position;
    gl_Position = view_proj * vec4(position, 1.0);
}
"""

SILHOUETTE_FS = """
#version 330 core
in vec3 v_world;
uniform sampler2D image;
uniform mat3 stage_to_image;   // inverse homography: (x, z, 1) → (u·w, v·w, w), pixels
uniform vec2 image_size;
uniform vec3 tint;
uniform float opacity;
out vec4 frag;
void main() {
    vec3 h = stage_to_image * vec3(v_world.x, v_world.z, 1.0);
    vec2 uv = h.xy / h.z / image_size;
    if (h.z == 0.0 || any(lessThan(uv, vec2(0.0))) || any(greaterThan(uv, vec2(1.0)))) discard;
    float m = texture(image, uv).r;
    frag = vec4(ORDER(tint), opacity * m);
}
"""

FLASH_VS = """
#version 330 core
layout(location = 0) in vec2 corner;
layout(location = 1) in vec3 inst_centre;
layout(location = 2) in float inst_radius;
layout(location = 3) in float inst_strength;
uniform mat4 view_proj;
uniform vec3 eye;
out vec2 v_corner;
flat out float f_strength;
void main() {
    vec3 v = normalize(inst_centre - eye);
    vec3 e1 = normalize(cross(v, vec3(0.0, 0.0, 1.0)));
    vec3 e2 = cross(e1, v);
    vec3 p = inst_centre - 0.3 * inst_radius * v + inst_radius * (corner.x * e1 + corner.y * e2);
    v_corner = corner;
    f_strength = inst_strength;
    gl_Position = view_proj * vec4(p, 1.0);
}
"""

FLASH_FS = """
#version 330 core
in vec2 v_corner;
flat in float f_strength;
uniform vec3 colour;
out vec4 frag;
void main() {
    float r = length(v_corner);
    float ring = exp(-pow((r - 0.7) / 0.12, 2.0));
    float core = exp(-pow(r / 0.35, 2.0));
    float a = f_strength * clamp(ring + core, 0.0, 1.0);
    frag = vec4(ORDER(colour), a);
}
"""

OVERLAY_VS = """
#version 330 core
layout(location = 0) in vec2 corner;   // (-1..1)
uniform vec4 rect;                     // x0, y0, x1, y1 in normalised device coordinates
out vec2 v_uv;
void main() {
    v_uv = 0.5 * corner + 0.5;
    gl_Position = vec4(mix(rect.xy, rect.zw, v_uv), 0.0, 1.0);
}
"""

OVERLAY_FS = """
#version 330 core
in vec2 v_uv;
uniform sampler2D image;     // RGBA, row 0 at the top of the rectangle when flipped
uniform int flip;
out vec4 frag;
void main() {
    vec4 t = texture(image, vec2(v_uv.x, flip == 1 ? 1.0 - v_uv.y : v_uv.y));
    frag = vec4(ORDER(t.rgb), t.a);
}
"""
