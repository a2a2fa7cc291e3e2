"""What the renderer draws, as numpy arrays: camera, capsule mesh, and per-character capsule instances.

Stage frame (shared with sim/ and interaction/): metres, z up, x to the audience's right, y away
from the audience. The sim's body frame: x forward, y left, z up (identity = upright facing +x).
Keyframe poses are in the body frame with the skeleton's axes (x forward, y up, z right).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from interaction.types import BodyObservation
from render import quaternion as quat
from render.keyframes import Pose
from render.mocap import HUMANOID, Skeleton
from sim.snapshot import CharacterSnapshot, CharacterState

# skeleton axes (x forward, y up, z right) → body axes (x forward, y left, z up)
SKELETON_TO_BODY = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]])

# ------------------------------------------------------------------------------ camera


@dataclass(frozen=True)
class Camera:
    """A perspective camera on the audience side looking +y at the stage."""

    eye: tuple[float, float, float] = (0.0, -8.2, 2.1)
    target: tuple[float, float, float] = (0.0, 0.0, 0.85)
    fov_y_deg: float = 30.0
    near: float = 0.1
    far: float = 60.0

    def view_projection(self, width: int, height: int, *, flip_y: bool = True) -> np.ndarray:
        """Row-major 4×4; ``flip_y`` puts the first image row at the top when read back with glReadPixels."""
        eye, target = np.array(self.eye), np.array(self.target)
        f = target - eye
        f /= np.linalg.norm(f)
        s = np.cross(f, [0.0, 0.0, 1.0])
        s /= np.linalg.norm(s)
        u = np.cross(s, f)
        view = np.eye(4)
        view[0, :3], view[1, :3], view[2, :3] = s, u, -f
        view[:3, 3] = -view[:3, :3] @ eye
        t = 1.0 / math.tan(math.radians(self.fov_y_deg) / 2.0)
        n, fa = self.near, self.far
        proj = np.zeros((4, 4))
        proj[0, 0] = t * height / width
        proj[1, 1] = -t if flip_y else t
        proj[2, 2] = (fa + n) / (n - fa)
        proj[2, 3] = 2.0 * fa * n / (n - fa)
        proj[3, 2] = -1.0
        return proj @ view


# ------------------------------------------------------------------------------ capsule mesh


def capsule_mesh(around: int = 8) -> tuple[np.ndarray, np.ndarray]:
    """A unit capsule: vertices (V, 4) = unit direction (x, y, z; y along the axis) and end (0 or 1),
    triangles (T, 3) uint32. ``around`` = 8 gives 64 triangles."""
    rings = [(1, 90.0), (1, 45.0), (1, 0.0), (0, 0.0), (0, -45.0), (0, -90.0)]
    verts: list[tuple[float, float, float, float]] = []
    starts = []
    for end, lat in rings:
        starts.append(len(verts))
        c, s = math.cos(math.radians(lat)), math.sin(math.radians(lat))
        if abs(lat) == 90.0:
            verts.append((0.0, s, 0.0, float(end)))
            continue
        for k in range(around):
            a = 2.0 * math.pi * k / around
            verts.append((c * math.cos(a), s, c * math.sin(a), float(end)))
    tris: list[tuple[int, int, int]] = []
    for r in range(len(rings) - 1):
        a0, b0 = starts[r], starts[r + 1]
        a_pole, b_pole = abs(rings[r][1]) == 90.0, abs(rings[r + 1][1]) == 90.0
        for k in range(around):
            k1 = (k + 1) % around
            if a_pole:
                tris.append((a0, b0 + k1, b0 + k))
            elif b_pole:
                tris.append((a0 + k, a0 + k1, b0))
            else:
                tris.append((a0 + k, a0 + k1, b0 + k1))
                tris.append((a0 + k, b0 + k1, b0 + k))
    return np.array(verts, dtype=np.float32), np.array(tris, dtype=np.uint32)


# ------------------------------------------------------------------------------ the figure

# points on the skeleton: (joint a, joint b, t) = a + t·(b − a)
_N = HUMANOID.names.index
POINTS: dict[str, tuple[int, int, float]] = {n: (_N(n), _N(n), 0.0) for n in HUMANOID.names}
POINTS |= {
    "head_low": (_N("neck"), _N("head_top"), 0.42),
    "head_high": (_N("neck"), _N("head_top"), 0.62),
    "neck_top": (_N("neck"), _N("head_top"), 0.25),
    "belly": (_N("root"), _N("chest"), 0.15),
    "right_hand": (_N("right_elbow"), _N("right_wrist"), 1.28),
    "left_hand": (_N("left_elbow"), _N("left_wrist"), 1.28),
    "right_heel": (_N("right_ankle"), _N("right_toe"), -0.25),
    "left_heel": (_N("left_ankle"), _N("left_toe"), -0.25),
}
SHIRT, TROUSERS, SKIN, SHOES = 0, 1, 2, 3
# (point a, point b, radius in skeleton metres, material)
CAPSULES: tuple[tuple[str, str, float, int], ...] = (
    ("right_hip", "left_hip", 0.085, TROUSERS),
    ("belly", "chest", 0.105, SHIRT),
    ("chest", "neck", 0.12, SHIRT),
    ("right_shoulder", "left_shoulder", 0.07, SHIRT),
    ("neck", "neck_top", 0.045, SKIN),
    ("head_low", "head_high", 0.098, SKIN),
    ("right_shoulder", "right_elbow", 0.05, SHIRT),
    ("left_shoulder", "left_elbow", 0.05, SHIRT),
    ("right_elbow", "right_wrist", 0.04, SKIN),
    ("left_elbow", "left_wrist", 0.04, SKIN),
    ("right_wrist", "right_hand", 0.045, SKIN),
    ("left_wrist", "left_hand", 0.045, SKIN),
    ("right_hip", "right_knee", 0.07, TROUSERS),
    ("left_hip", "left_knee", 0.07, TROUSERS),
    ("right_knee", "right_ankle", 0.055, TROUSERS),
    ("left_knee", "left_ankle", 0.055, TROUSERS),
    ("right_heel", "right_toe", 0.042, SHOES),
    ("left_heel", "left_toe", 0.042, SHOES),
)
_A_IDX = np.array([[POINTS[a][0], POINTS[a][1]] for a, _, _, _ in CAPSULES])
_A_T = np.array([POINTS[a][2] for a, _, _, _ in CAPSULES])
_B_IDX = np.array([[POINTS[b][0], POINTS[b][1]] for _, b, _, _ in CAPSULES])
_B_T = np.array([POINTS[b][2] for _, b, _, _ in CAPSULES])
RADII = np.array([r for _, _, r, _ in CAPSULES])
MATERIAL = np.array([m for _, _, _, m in CAPSULES])

TROUSER_RGB = (0.22, 0.24, 0.32)
SKIN_RGB = (0.93, 0.76, 0.62)
SHOE_RGB = (0.16, 0.14, 0.13)
PEOPLE = np.array([(0.35, 0.85, 1.0), (1.0, 0.85, 0.35), (0.7, 1.0, 0.5), (1.0, 0.55, 0.85)])


def character_colour(index: int) -> np.ndarray:
    """The shirt colour of the snapshot's ``index``-th character: hues a golden-ratio turn apart, so
    any few characters get well-separated colours (the sim keeps its characters in a stable order)."""
    hue = (0.02 + index * 0.6180339887) % 1.0
    k = (np.array([5.0, 3.0, 1.0]) + hue * 6.0) % 6.0  # HSV → RGB, saturation 0.7, value 0.88
    return 0.88 - 0.88 * 0.7 * np.clip(np.minimum(k, 4.0 - k), 0.0, 1.0)


def body_rotations(orientations: np.ndarray) -> np.ndarray:
    """Rotation matrices (..., 3, 3) taking skeleton-axis vectors of a pose to stage vectors, from body
    orientations (..., 4) x y z w."""
    return quat.to_matrix(np.asarray(orientations, dtype=float)) @ SKELETON_TO_BODY


def figure_capsules(
    characters: Sequence[CharacterSnapshot],
    poses: Pose,
    skeleton: Skeleton,
    set_height: float,
    *,
    com_lift: float,
    rotations: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Capsule ends a, b (N·C, 3) and radii (N·C,) in stage metres for N posed characters.

    Each pose is scaled by ``height / set_height``, placed with its body origin at the character's
    position (its centre of mass) and turned by its orientation; ``com_lift`` × height moves the
    figure along the body's up axis (the keyframe set's centre of mass height minus the sim body's,
    as fractions of the height) so the feet meet the floor. ``rotations``: the characters'
    ``body_rotations`` when already computed.
    """
    n = len(characters)
    pos, _ = skeleton.forward_kinematics(poses.root_offset, poses.root_rotation, poses.joint_rotations)
    a = pos[:, _A_IDX[:, 0]] + _A_T[None, :, None] * (pos[:, _A_IDX[:, 1]] - pos[:, _A_IDX[:, 0]])
    b = pos[:, _B_IDX[:, 0]] + _B_T[None, :, None] * (pos[:, _B_IDX[:, 1]] - pos[:, _B_IDX[:, 0]])
    heights = np.array([c.height for c in characters], dtype=float)
    scale = heights / set_height
    if rotations is None:
        rotations = body_rotations(np.array([c.orientation for c in characters], dtype=float).reshape(n, 4))
    rots = rotations
    lift = np.zeros((n, 1, 3))
    lift[:, 0, 1] = com_lift * heights / scale
    centres = np.array([c.position for c in characters], dtype=float).reshape(n, 1, 3)

    def place(p: np.ndarray) -> np.ndarray:
        return centres + scale[:, None, None] * np.einsum("nij,ncj->nci", rots, p + lift)

    radii = (scale[:, None] * RADII[None, :]).reshape(-1)
    return place(a).reshape(-1, 3), place(b).reshape(-1, 3), radii


def figure_colours(characters: Sequence[CharacterSnapshot], *, flash_newtons: float) -> np.ndarray:
    """RGBA + glow (N·C, 5): shirt per character, trousers/skin/shoes shared; glow while pushed."""
    out = np.zeros((len(characters), len(CAPSULES), 5))
    for i, c in enumerate(characters):
        shirt = character_colour(i)
        if c.state in (CharacterState.LIE, CharacterState.BRAKE):
            shirt = 0.75 * shirt + 0.25 * shirt.mean()
        rgb = np.array([shirt, TROUSER_RGB, SKIN_RGB, SHOE_RGB])[MATERIAL]
        glow = 0.0 if c.contact_force_n <= 0 else min(1.0, 0.35 + c.contact_force_n / flash_newtons)
        out[i, :, :3] = rgb
        out[i, :, 3] = 1.0
        out[i, :, 4] = glow
    return out.reshape(-1, 5)


def shadow_blobs(a: np.ndarray, b: np.ndarray, per_character: int, heights: np.ndarray) -> np.ndarray:
    """Blob shadows (N, 7): centre xy, half-axis u (xy), half-axis v (xy), strength — an ellipse
    around each figure's capsule ends projected on the floor."""
    n = len(heights)
    if n == 0:
        return np.zeros((0, 7))
    pts = np.concatenate([a.reshape(n, per_character, 3), b.reshape(n, per_character, 3)], axis=1)[..., :2]
    centre = pts.mean(axis=1)
    d = pts - centre[:, None, :]
    cov = np.einsum("npi,npj->nij", d, d) / pts.shape[1]
    evals, evecs = np.linalg.eigh(cov)
    margin = 0.12 * heights[:, None]
    half = 1.9 * np.sqrt(np.maximum(evals, 0.0)) + margin  # (N, 2)
    u = evecs[:, :, 1] * half[:, 1:2]
    v = evecs[:, :, 0] * half[:, 0:1]
    low = np.minimum(
        a.reshape(n, per_character, 3)[..., 2].min(axis=1), b.reshape(n, per_character, 3)[..., 2].min(axis=1)
    )
    strength = np.clip(1.0 - low / np.maximum(heights, 1e-6), 0.2, 1.0)
    return np.concatenate([centre, u, v, strength[:, None]], axis=1)


CAPSULE_FLOATS = 12  # one capsule instance: a(3) b(3) radius(1) rgba(4) glow(1)


def people_capsules(observation: BodyObservation | None) -> np.ndarray:
    """Capsule instances (M, CAPSULE_FLOATS) for the people: each contactor a translucent sphere or
    capsule along y in its person's colour; each impulse a short yellow arrow ending where it hits."""
    if observation is None:
        return np.zeros((0, CAPSULE_FLOATS))
    rows = []
    for c in observation.contactors:
        p = np.array(c.position, dtype=float)
        half = np.array([0.0, c.half_depth, 0.0])
        rgb = PEOPLE[c.person % len(PEOPLE)]
        rows.append([*(p - half), *(p + half), c.radius, *rgb, 0.35, 0.0])
    for imp in observation.impulses:
        p = np.array(imp.position, dtype=float)
        f = np.array(imp.force, dtype=float)
        mag = float(np.linalg.norm(f))
        if mag <= 0:
            continue
        tail = p - f / mag * float(np.clip(mag / 500.0, 0.15, 0.8))
        rows.append([*tail, *p, 0.035, 1.0, 0.85, 0.2, 0.8, 0.0])
    return np.array(rows, dtype=float).reshape(-1, CAPSULE_FLOATS)
