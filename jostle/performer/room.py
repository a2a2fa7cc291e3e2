"""A synthetic but plausible room behind the stage, ray-cast once per camera with numpy.

A box-shaped room (wooden floor, painted walls with a skirting board, a window and a picture,
a ceiling) holding a few pieces of furniture (sideboard, bookshelf, sofa), lit by one soft
directional light plus ambient, with darkened corners. Everything is seeded and deterministic.
Images are float32 BGR in [0, 255].
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from jostle.performer.camera import PinholeCamera


@dataclass(frozen=True)
class RoomImage:
    """The empty room seen by a camera."""

    bgr: np.ndarray  # (H, W, 3) float32, 0..255, before vignetting, light change and noise
    floor_index: np.ndarray  # (N,) flat indices of the pixels that see the bare floor
    floor_xy: np.ndarray  # (N, 2) stage (x, y) of the floor those pixels see
    vignette: np.ndarray  # (H, W, 1) float32 lens fall-off, 1 at the centre
    depth_m: np.ndarray  # (H, W) float32 distance of the surface seen along the optical axis


@dataclass(frozen=True)
class _Box:
    lo: tuple[float, float, float]
    hi: tuple[float, float, float]
    bgr: tuple[float, float, float]
    kind: str  # "plain" | "books" | "wood"


def _boxes(half_width: float, back_y: float) -> list[_Box]:
    w = half_width
    return [
        _Box((-w - 0.6, back_y - 0.45, 0.0), (-w + 1.2, back_y, 0.85), (60, 85, 120), "wood"),
        _Box((w - 1.2, back_y - 0.35, 0.0), (w + 0.2, back_y, 1.95), (70, 95, 125), "books"),
        _Box((-0.9, back_y - 0.9, 0.0), (1.1, back_y - 0.05, 0.42), (120, 105, 95), "plain"),  # sofa seat
        _Box((-0.9, back_y - 0.3, 0.42), (1.1, back_y - 0.05, 0.85), (112, 98, 90), "plain"),  # sofa back
    ]


def _smooth_noise(rng: np.random.Generator, a: np.ndarray, b: np.ndarray, waves: int = 6) -> np.ndarray:
    """Low-frequency texture: a sum of random plane waves over surface coordinates (a, b)."""
    out = np.zeros_like(a)
    for _ in range(waves):
        k = rng.uniform(0.5, 4.0)
        th = rng.uniform(0, 2 * np.pi)
        out += np.sin(k * (np.cos(th) * a + np.sin(th) * b) + rng.uniform(0, 2 * np.pi))
    return out / waves


def render_room(camera: PinholeCamera, half_width: float, seed: int) -> RoomImage:
    """Ray-cast the room for every pixel of ``camera``. Deterministic for a given seed."""
    rng = np.random.default_rng([seed, 7919])
    h, w = camera.height, camera.width
    d = camera.pixel_rays()
    c = camera.centre
    back_y, side_x, ceiling = 3.4, half_width + 2.3, 2.8
    inf = np.inf
    with np.errstate(divide="ignore", invalid="ignore"):
        t_floor = np.where(d[..., 2] < 0, -c[2] / d[..., 2], inf)
        t_ceil = np.where(d[..., 2] > 0, (ceiling - c[2]) / d[..., 2], inf)
        t_back = np.where(d[..., 1] > 0, (back_y - c[1]) / d[..., 1], inf)
        t_side = np.where(d[..., 0] > 0, (side_x - c[0]) / d[..., 0], (-side_x - c[0]) / d[..., 0])
        t_side = np.where(np.abs(d[..., 0]) > 1e-9, t_side, inf)
    shell_t = np.stack([t_floor, t_ceil, t_back, t_side])  # surface ids 0..3
    surface = np.argmin(shell_t, axis=0)
    t = np.min(shell_t, axis=0)
    normal = np.zeros((h, w, 3))
    normal[surface == 0] = (0, 0, 1)
    normal[surface == 1] = (0, 0, -1)
    normal[surface == 2] = (0, -1, 0)
    side = surface == 3
    normal[side, 0] = -np.sign(d[side, 0])

    # furniture: ray-box slabs
    box_id = np.full((h, w), -1)
    for i, box in enumerate(_boxes(half_width, back_y)):
        lo, hi = np.array(box.lo), np.array(box.hi)
        with np.errstate(divide="ignore", invalid="ignore"):
            t1 = (lo - c) / d
            t2 = (hi - c) / d
        near = np.minimum(t1, t2)
        far = np.maximum(t1, t2)
        t_in = np.max(near, axis=-1)
        t_out = np.min(far, axis=-1)
        hit = (t_in <= t_out) & (t_in > 0) & (t_in < t)
        axis = np.argmax(near, axis=-1)
        t = np.where(hit, t_in, t)
        box_id[hit] = i
        n = np.zeros((h, w, 3))
        for ax in range(3):
            sel = hit & (axis == ax)
            n[sel, ax] = -np.sign(d[sel, ax])
        normal[hit] = n[hit]
    p = c + d * t[..., None]
    x, y, z = p[..., 0], p[..., 1], p[..., 2]
    albedo = np.zeros((h, w, 3))

    # floor: planks running along x
    plank_w, plank_l = 0.16, 1.3
    plank = np.floor((y + 20.0) / plank_w).astype(int) % 64
    tone = rng.uniform(0.82, 1.12, 64)
    offset = rng.uniform(0, plank_l, 64)
    grain = 0.05 * np.sin(x * 23.0 + plank * 1.7) * np.sin(x * 3.1 + plank)
    seam = (((y + 20.0) / plank_w) % 1.0 < 0.06) | (((x + offset[plank]) / plank_l) % 1.0 < 0.012)
    wood = np.array([70.0, 118.0, 168.0])[None, None, :] * (tone[plank] + grain)[..., None]
    wood[seam] *= 0.6
    floor = surface == 0
    albedo[floor] = wood[floor]

    # walls: warm paint with faint texture, skirting board, window and picture on the back wall
    wall = (surface == 2) | (surface == 3)
    along = np.where(surface == 2, x, y)
    paint = np.array([178.0, 196.0, 208.0]) * (1.0 + 0.035 * _smooth_noise(rng, along, z))[..., None]
    albedo[wall] = paint[wall]
    skirting = wall & (z < 0.11)
    albedo[skirting] = (222, 226, 228)
    back = surface == 2
    win = back & (np.abs(x - (half_width * 0.45)) < 0.75) & (z > 1.0) & (z < 2.3)
    glass = np.array([238.0, 228.0, 205.0]) * (1.0 + 0.04 * np.sin(z * 9.0))[..., None]
    albedo[win] = glass[win]
    bars = win & ((np.abs(x - half_width * 0.45) < 0.025) | (np.abs(z - 1.65) < 0.025)
                  | (np.abs(np.abs(x - half_width * 0.45) - 0.75) < 0.05) | (z < 1.05) | (z > 2.25))
    albedo[bars] = (235, 238, 240)
    pic_x = -half_width * 0.35
    frame = back & (np.abs(x - pic_x) < 0.55) & (np.abs(z - 1.75) < 0.4)
    albedo[frame] = (40, 45, 52)
    canvas = back & (np.abs(x - pic_x) < 0.48) & (np.abs(z - 1.75) < 0.33)
    blotch = _smooth_noise(rng, x * 3.0, z * 3.0, waves=4)
    albedo[canvas] = np.stack([120 + 80 * blotch, 140 - 40 * blotch, 90 + 60 * np.abs(blotch)], axis=-1)[canvas]
    albedo[surface == 1] = (225, 228, 230)

    # furniture textures
    for i, box in enumerate(_boxes(half_width, back_y)):
        sel = box_id == i
        base = np.array(box.bgr, dtype=float)
        if box.kind == "books":
            shelf = ((z * 4.2) % 1.0) < 0.08
            book = np.floor(x / 0.07).astype(int) % 97
            grey = rng.uniform(70, 190, (97, 1))
            colours = np.clip(grey + rng.normal(0, 25, (97, 3)), 30, 230)
            col = np.where(shelf[..., None], base, colours[book] * (0.8 + 0.2 * (((z * 4.2) % 1.0) < 0.8))[..., None])
            albedo[sel] = col[sel]
        elif box.kind == "wood":
            g = 1.0 + 0.06 * np.sin(x * 31.0 + z * 3.0) + 0.04 * _smooth_noise(rng, x * 8, z * 8, 3)
            doors = (np.abs(((x - box.lo[0]) / 0.6) % 1.0 - 0.5) > 0.48) | (np.abs(z - 0.7) < 0.015)
            col = base * g[..., None]
            col[doors] *= 0.65
            albedo[sel] = col[sel]
        else:
            albedo[sel] = base * (1.0 + 0.03 * _smooth_noise(rng, x * 10, z * 10, 3))[sel][..., None]

    # light: soft directional key from the front left and above, ambient, distance fall-off
    light = np.array([-0.35, -0.55, 0.76])
    light /= np.linalg.norm(light)
    lambert = np.clip(normal @ light, 0.0, 1.0)
    shade = 0.72 + 0.38 * lambert
    shade = np.where(surface == 1, shade + 0.12, shade)  # the ceiling bounces the room's light
    shade *= 1.0 / (1.0 + 0.004 * t**2)
    # corners darken (a cheap ambient occlusion): distance to the nearest floor/wall/ceiling edge
    edge = np.minimum.reduce([z, ceiling - z, back_y - y, side_x - np.abs(x)])
    shade *= 1.0 - 0.25 * np.exp(-np.clip(edge, 0, None) / 0.25)
    shade = np.where(box_id >= 0, shade * (1.0 - 0.2 * np.exp(-z / 0.15)), shade)
    bgr = np.clip(albedo * shade[..., None], 0, 255).astype(np.float32)

    on_floor = (floor & (box_id < 0)).ravel()
    floor_index = np.flatnonzero(on_floor)
    floor_xy = np.stack([x.ravel(), y.ravel()], axis=-1)[on_floor]

    k = camera.intrinsics
    u, v = np.meshgrid(np.arange(w, dtype=float), np.arange(h, dtype=float))
    r2 = ((u - k[0, 2]) ** 2 + (v - k[1, 2]) ** 2) / (k[0, 0] ** 2)
    vignette = (1.0 / (1.0 + 0.35 * r2) ** 2).astype(np.float32)[..., None]
    depth_m = (t * (d @ camera.rotation[2])).astype(np.float32)
    return RoomImage(bgr, floor_index, floor_xy, vignette, depth_m)
