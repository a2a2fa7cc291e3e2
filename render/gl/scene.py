"""What the renderer draws, as numpy arrays: posed figures as capsule instances, their shadows, the
people, and where contacts land.

Stage frame (shared with sim/ and interaction/): metres, z up, x to the audience's right, y away
from the audience. The sim's body frame: x forward, y left, z up (identity = upright facing +x).
Keyframe poses are in the body frame with the skeleton's axes (x forward, y up, z right).
"""

from __future__ import annotations

import functools
import math
from collections.abc import Sequence

import numpy as np

from interaction.types import BodyObservation
from render.gl.style import Camera, Colours, rgb
from render.keyframes import Pose
from render.keyframes.skeletons import SHIRT, Figure
from sim.motion import quaternion as quat
from sim.snapshot import CharacterSnapshot, CharacterState

__all__ = ["CAPSULE_FLOATS", "Camera", "SHADOW_FLOATS", "body_rotations", "posed_capsules"]

# skeleton axes (x forward, y up, z right) → body axes (x forward, y left, z up)
SKELETON_TO_BODY = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]])
CAPSULE_FLOATS = 12  # one capsule instance: a(3) b(3) radius(1) rgba(4) glow(1)
SHADOW_FLOATS = 8  # one contact shadow: a(3) b(3) radius(1) strength(1)
BLOB_FLOATS = 7  # one figure's soft shadow: centre xy, half-axis u, half-axis v, strength


def body_rotations(orientations: np.ndarray) -> np.ndarray:
    """Rotation matrices (..., 3, 3) taking skeleton-axis vectors of a pose to stage vectors, from body
    orientations (..., 4) x y z w."""
    return quat.to_matrix(np.asarray(orientations, dtype=float)) @ SKELETON_TO_BODY


@functools.cache
def _levels(figure: Figure) -> tuple[tuple[np.ndarray, np.ndarray, np.ndarray], ...]:
    """Bones grouped by depth below the root: (bones, their parents, their rotation slot or −1)."""
    from sim.motion.mocap import JOINTS

    s = figure.skeleton
    depth = [0] * len(s.names)
    for b in range(1, len(s.names)):
        depth[b] = depth[s.parents[b]] + 1
    out = []
    for d in range(1, max(depth) + 1):
        bones = np.array([b for b in range(len(s.names)) if depth[b] == d])
        parents = np.array([s.parents[b] for b in bones])
        slots = np.array([1 + JOINTS.index(s.names[b]) if s.names[b] in JOINTS else -1 for b in bones])
        out.append((bones, parents, slots))
    return tuple(out)


def posed_capsules(
    figure: Figure,
    poses: Pose,
    positions: np.ndarray,
    rotations: np.ndarray,
    scale: np.ndarray,
    lift: np.ndarray,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Capsule ends a, b (N, C, 3) and radii (N, C) in stage metres for N posed figures.

    Each pose is scaled by ``scale``, placed with its body origin at ``positions`` (the centres of
    mass) and turned by ``rotations`` (``body_rotations``); ``lift`` (skeleton metres) moves the figure
    along the body's up axis so the feet meet the floor. Forward kinematics runs on rotation
    matrices, one batched product per depth of the skeleton.
    """
    n = len(positions)
    s = figure.skeleton
    local = quat.to_matrix(poses.rotations())  # (N, 1 + J, 3, 3)
    world_r = np.empty((n, len(s.names), 3, 3))
    world_p = np.empty((n, len(s.names), 3))
    root = poses.root_offset + lift[:, None] * np.array([0.0, 1.0, 0.0])
    world_r[:, 0] = rotations @ local[:, 0]
    world_p[:, 0] = positions + scale[:, None] * np.einsum("nij,nj->ni", rotations, root)
    offsets = s.offsets
    for bones, parents, slots in _levels(figure):
        pr = world_r[:, parents]  # (N, B, 3, 3)
        world_p[:, bones] = world_p[:, parents] + scale[:, None, None] * np.einsum("nbij,bj->nbi", pr, offsets[bones])
        rotated = slots >= 0
        world_r[:, bones] = pr
        if rotated.any():
            world_r[:, bones[rotated]] = pr[:, rotated] @ local[:, slots[rotated]]
    pa0, pa1 = world_p[:, figure.a_idx[:, 0]], world_p[:, figure.a_idx[:, 1]]
    pb0, pb1 = world_p[:, figure.b_idx[:, 0]], world_p[:, figure.b_idx[:, 1]]
    a = pa0 + figure.a_t[None, :, None] * (pa1 - pa0)
    b = pb0 + figure.b_t[None, :, None] * (pb1 - pb0)
    return a, b, scale[:, None] * figure.radii[None, :]


def character_colours(count: int) -> np.ndarray:
    """Shirt colours (count, 3) of the snapshot's characters in order: hues a golden-ratio turn apart,
    so any few characters get well-separated colours (the sim keeps its characters in a stable order)."""
    hue = (0.02 + np.arange(count) * 0.6180339887) % 1.0
    k = (np.array([5.0, 3.0, 1.0])[None, :] + hue[:, None] * 6.0) % 6.0  # HSV → RGB, saturation 0.7, value 0.88
    return 0.88 - 0.88 * 0.7 * np.clip(np.minimum(k, 4.0 - k), 0.0, 1.0)


def character_colour(index: int) -> np.ndarray:
    return character_colours(index + 1)[index]


def figure_colours(
    characters: Sequence[CharacterSnapshot], material: np.ndarray, colours: Colours, flash_newtons: float
) -> np.ndarray:
    """RGBA + glow (N, C, 5): shirt per character, trousers/skin/shoes shared; glow while pushed."""
    n = len(characters)
    shirt = character_colours(n)
    down = np.array([c.state in (CharacterState.LIE, CharacterState.BRAKE) for c in characters], dtype=bool)
    shirt[down] = 0.75 * shirt[down] + 0.25 * shirt[down].mean(axis=1, keepdims=True)
    shared = np.array([(0.0, 0.0, 0.0), rgb("trousers", colours.trousers), rgb("skin", colours.skin),
                       rgb("shoes", colours.shoes)])
    out = np.empty((n, len(material), 5))
    out[:, :, :3] = shared[material][None]
    out[:, material == SHIRT, :3] = shirt[:, None, :]
    out[:, :, 3] = 1.0
    force = np.array([c.contact_force_n for c in characters], dtype=float)
    out[:, :, 4] = np.where(force > 0, np.minimum(1.0, 0.35 + force / flash_newtons), 0.0)[:, None]
    return out


def contact_shadows(a: np.ndarray, b: np.ndarray, radii: np.ndarray, heights: np.ndarray) -> np.ndarray:
    """Soft contact shadows (M, SHADOW_FLOATS) for the capsules (N, C) whose lowest point is within a
    fifth of their figure's height of the floor; strength fades with that height."""
    low = np.minimum(a[..., 2], b[..., 2]) - radii
    reach = heights[:, None] / 5.0
    strength = np.clip(1.0 - low / reach, 0.0, 1.0) ** 2
    keep = strength > 0.05
    rows = np.concatenate([a[keep], b[keep], radii[keep][:, None], strength[keep][:, None]], axis=1)
    return rows.reshape(-1, SHADOW_FLOATS)


def shadow_blobs(a: np.ndarray, b: np.ndarray, heights: np.ndarray) -> np.ndarray:
    """One soft shadow (N, BLOB_FLOATS) per figure: centre xy, half-axis u (xy), half-axis v (xy),
    strength — an ellipse around its capsule ends projected on the floor, darker the lower it is."""
    n = len(heights)
    if n == 0:
        return np.zeros((0, BLOB_FLOATS))
    pts = np.concatenate([a, b], axis=1)[..., :2]
    centre = pts.mean(axis=1)
    d = pts - centre[:, None, :]
    sxx, syy, sxy = (d[..., 0] ** 2).mean(axis=1), (d[..., 1] ** 2).mean(axis=1), (d[..., 0] * d[..., 1]).mean(axis=1)
    mid, rad = 0.5 * (sxx + syy), np.sqrt((0.5 * (sxx - syy)) ** 2 + sxy**2)  # eigenvalues mid ± rad
    angle = 0.5 * np.arctan2(2.0 * sxy, sxx - syy)  # direction of the larger one
    major = np.stack([np.cos(angle), np.sin(angle)], axis=1)
    minor = np.stack([-major[:, 1], major[:, 0]], axis=1)
    margin = 0.06 * heights
    u = major * (1.5 * np.sqrt(mid + rad) + margin)[:, None]
    v = minor * (1.5 * np.sqrt(np.maximum(mid - rad, 0.0)) + margin)[:, None]
    low = np.minimum(a[..., 2].min(axis=1), b[..., 2].min(axis=1))
    strength = np.clip(1.0 - low / np.maximum(heights, 1e-6), 0.2, 1.0)
    return np.concatenate([centre, u, v, strength[:, None]], axis=1)


def people_capsules(observation: BodyObservation | None, colours: Colours, opacity: float) -> np.ndarray:
    """Capsule instances (M, CAPSULE_FLOATS) for the people: each contactor a translucent sphere or
    capsule along y in its person's colour; each impulse a short arrow ending where it hits."""
    if observation is None:
        return np.zeros((0, CAPSULE_FLOATS))
    palette = [rgb("people", c) for c in colours.people]
    flash = rgb("flash", colours.flash)
    rows = []
    for c in observation.contactors:
        p = np.array(c.position, dtype=float)
        half = np.array([0.0, c.half_depth, 0.0])
        rows.append([*(p - half), *(p + half), c.radius, *palette[c.person % len(palette)], opacity, 0.0])
    for imp in observation.impulses:
        p = np.array(imp.position, dtype=float)
        f = np.array(imp.force, dtype=float)
        mag = float(np.linalg.norm(f))
        if mag <= 0:
            continue
        tail = p - f / mag * float(np.clip(mag / 500.0, 0.15, 0.8))
        rows.append([*tail, *p, 0.035, *flash, 0.8, 0.0])
    return np.array(rows, dtype=float).reshape(-1, CAPSULE_FLOATS)


def closest_on_segments(p: np.ndarray, a: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """For a point p (3,) and segments a, b (C, 3): the closest point on each segment and its distance."""
    ab = b - a
    t = np.clip(np.einsum("ci,ci->c", p - a, ab) / np.maximum(np.einsum("ci,ci->c", ab, ab), 1e-12), 0.0, 1.0)
    q = a + t[:, None] * ab
    return q, np.linalg.norm(q - p, axis=1)


def contact_point(
    a: np.ndarray, b: np.ndarray, radii: np.ndarray, observation: BodyObservation | None
) -> np.ndarray | None:
    """Where the people touch one figure (capsules a, b (C, 3), radii (C,)): the point of its surface
    nearest to the nearest contactor (sampled along a webcam's depth capsules), or None."""
    if observation is None or not observation.contactors:
        return None
    best: tuple[float, np.ndarray] | None = None
    for c in observation.contactors:
        centre = np.array(c.position, dtype=float)
        for dy in np.linspace(-c.half_depth, c.half_depth, 5 if c.half_depth > 0 else 1):
            p = centre + np.array([0.0, dy, 0.0])
            q, d = closest_on_segments(p, a, b)
            i = int(np.argmin(d - radii))
            gap = float(d[i] - radii[i] - c.radius)
            if best is None or gap < best[0]:
                surface = q[i] + (p - q[i]) / max(float(d[i]), 1e-9) * radii[i]
                best = (gap, surface)
    return None if best is None else best[1]


def orientation_mismatch(chars: Sequence[CharacterSnapshot], rots: np.ndarray) -> str | None:
    """A message if an upright character's orientation faces away from its heading, else None: the
    renderer assumes the sim's body frame (x forward, y left, z up). ``rots``: (N, 3, 3) body rotations."""
    if not chars:
        return None
    tilt = np.array([c.tilt for c in chars], dtype=float)
    heading = np.array([c.heading for c in chars], dtype=float)
    yaw = np.arctan2(rots[:, 1, 0], rots[:, 0, 0])  # skeleton x (forward) in stage axes
    off = np.abs(np.remainder(yaw - heading + math.pi, 2.0 * math.pi) - math.pi)
    bad = (np.abs(tilt).max(axis=1) < 0.3) & (off > 0.35)
    if not np.any(bad):
        return None
    i = int(np.argmax(bad))
    return (
        f"render: character {chars[i].name!r}: orientation faces {math.degrees(float(yaw[i])):.0f}° but "
        f"heading is {math.degrees(chars[i].heading):.0f}°; the renderer assumes body axes x forward, "
        "y left, z up"
    )
